"""The application's choices: the plan repair (:class:`Planner`) and the methods an evaluation compares
(:class:`EvalMethod`)."""

from __future__ import annotations

from enum import StrEnum


class Planner(StrEnum):
    """Whether the plan is repaired before the arm moves (``--planner``)."""

    CONDITIONS = "conditions"
    """The look-ahead planner repairs the plan before execution (beyond the paper)."""
    NONE = "none"
    """The plan runs as given; Alg. 1 alone satisfies pre-conditions (the paper's behaviour)."""


class EvalMethod(StrEnum):
    """What an evaluation runs (``--method`` of ``taskcond eval``): the executor with each condition source
    (:class:`~taskcond.execution.executor.SourceKind`) or the paper's image-based baseline."""

    LLM = "llm"
    LLM_DEMO = "llm+demo"
    ENV = "env"
    NONE = "none"
    IMAGE_IL = "image-il"
    """The paper's image-based imitation-learning baseline (:mod:`taskcond.il`), not the executor."""
