"""The condition source of each method (:func:`make_source`), and the novel-primitive episodes' sources
(paper §V, Table IV).
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterable
from dataclasses import replace

import numpy as np

from taskcond.application.plans import plan_run
from taskcond.execution.executor import METHODS, ConditionSource, SourceKind
from taskcond.execution.skills import SkillLibrary
from taskcond.execution.sources import EnvConditions, GroundedConditions, LLMConditions
from taskcond.generator import ConditionGenerator
from taskcond.llm.base import LLMError
from taskcond.primitives import parse_task
from taskcond.results import Job
from taskcond.tasks.registry import get_task

NOVEL_METHODS = ("llm", "llm+demo")
"""Methods a novel-primitive episode can run: the ones whose conditions come from the LLM."""


NOVEL_PRIMITIVE_STREAM = 20
"""Second word of the seed of the left-out primitive's draw (:func:`left_out_primitive`), so that it is
independent of the other draws seeded by the episode's seed (reset, perception noise)."""


def left_out_primitive(task_id: str, seed: int) -> str:
    """The primitive left out of the LLM's examples in the novel-primitive episode ``seed`` of the
    long-horizon task ``task_id`` (paper §V, Table IV "generalize to novel primitive tasks": "a randomly
    selected unseen primitive task"): drawn uniformly from the task's distinct primitives, in the order
    they first appear, by a generator seeded with the episode's seed and :data:`NOVEL_PRIMITIVE_STREAM`.

    Raises:
        ValueError: ``task_id`` is not a long-horizon task of the suite.
    """
    info = get_task(task_id).info
    if info.kind != "long-horizon":
        raise ValueError(f"{task_id} is a primitive task; novel-primitive episodes are long-horizon tasks")
    primitives = list(dict.fromkeys(parse_task(name).primitive.id for name in info.primitive))
    rng = np.random.default_rng([seed, NOVEL_PRIMITIVE_STREAM])
    return primitives[int(rng.integers(len(primitives)))]


def novel_primitive_source(source: ConditionSource, task_id: str, seed: int) -> tuple[ConditionSource, str]:
    """The condition source of the novel-primitive episode ``seed`` of ``task_id``, and the primitive it
    leaves out (:func:`left_out_primitive`): ``source`` (LLM conditions, grounded or not) with that
    primitive's examples left out of every prompt and the examples of its own tasks shuffled by the
    episode's seed, so that each episode draws its own generalization (cached per draw).

    Raises:
        ValueError: ``source`` does not ask the LLM; ``task_id`` is not long-horizon.
    """
    if not isinstance(source, LLMConditions | GroundedConditions):
        raise ValueError(
            f"novel-primitive episodes need LLM conditions (method {' or '.join(NOVEL_METHODS)}), not "
            f"{source.name}"
        )
    primitive = left_out_primitive(task_id, seed)
    return source.leaving_out(primitive, seed), primitive


def _generator(llm: str | None, cache: bool, threads: int | None) -> ConditionGenerator:
    """The condition generator of the ``--llm`` spec ``llm`` (default: $TASKCOND_LLM, the config file, else
    embedded; an embedded model on ``threads`` CPU threads, None: every core), its answers cached unless
    ``cache`` is off."""
    from taskcond.llm.config import LLMConfig

    config = replace(LLMConfig.load(llm), threads=threads)
    if not cache:
        config = replace(config, cache=False)
    return ConditionGenerator.from_config(config)


SourceFactory = Callable[[SkillLibrary, str | None, bool, int | None], ConditionSource | None]
"""Builds a condition source from the skill library, the ``--llm`` spec, whether answers are cached, and
the embedded model's CPU threads."""

SOURCES: dict[SourceKind, SourceFactory] = {
    SourceKind.LLM: lambda library, llm, cache, threads: LLMConditions(_generator(llm, cache, threads)),
    SourceKind.LLM_DEMO: lambda library, llm, cache, threads: GroundedConditions(
        _generator(llm, cache, threads), library
    ),
    SourceKind.ENV: lambda library, llm, cache, threads: EnvConditions(library),
    SourceKind.NONE: lambda library, llm, cache, threads: None,
}
"""The one registry from a condition source to its factory."""


def make_source(
    method: SourceKind,
    library: SkillLibrary,
    llm: str | None = None,
    cache: bool = True,
    threads: int | None = None,
) -> ConditionSource | None:
    """The condition source of ``method`` (:data:`SOURCES`): None (DMP only), FromEnv, the LLM of ``llm``
    (the ``--llm`` spec; default: $TASKCOND_LLM, the config file, else embedded; an embedded model on
    ``threads`` CPU threads, None: every core), or that LLM grounded in the library's demonstrations
    (``llm+demo``)."""
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}; valid: {', '.join(METHODS)}")
    return SOURCES[SourceKind(method)](library, llm, cache, threads)


Progress = Callable[[list, str, str], Iterable]
"""Wraps the items a loop goes through with a progress display: ``(items, description, unit)``."""


def prefetch_conditions(
    jobs: list[Job],
    library: SkillLibrary | None,
    llm: str | None,
    steps: dict[tuple[str, str, int], tuple[str, ...]] | None = None,
    novel_primitive: bool = False,
    progress: Progress = lambda items, desc, unit: items,
) -> None:
    """Ask each LLM condition source (llm, llm+demo) of ``jobs`` once for every condition the jobs will
    need, so that the workers find the answers in the LLM's cache. A job's steps are ``steps[job.key]``
    (instructions, decomposed beforehand) or its suite task's plan; with ``novel_primitive``, each
    episode's own draw of the examples (:func:`novel_primitive_source`), a draw without an answer left to
    fail its episode.

    Raises:
        LLMError, TaskNameError, ConditionError, ValueError: the first source or condition that fails.
    """
    for method in [m for m in ("llm", "llm+demo") if any(j.method == m for j in jobs)]:
        source = make_source(method, library, llm)  # type: ignore[arg-type]
        mine = [j for j in jobs if j.method == method]
        if novel_primitive:  # one draw per episode
            for job in progress(mine, "conditions", "episode"):
                drawn, _ = novel_primitive_source(source, job.task, job.seed)  # type: ignore[arg-type]
                for name in plan_run(job.task).steps:
                    with contextlib.suppress(LLMError):
                        drawn.condition(name)
            continue
        names = {
            s for j in mine for s in (steps.get(j.key, ()) if steps is not None else plan_run(j.task).steps)
        }
        for name in progress(sorted(names), "conditions", "task"):
            source.condition(name)  # type: ignore[union-attr]
