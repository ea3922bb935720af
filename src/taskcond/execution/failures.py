"""Why a run of the executor stops (:class:`ExecutionError`), and every failure kind an episode records
(:class:`FailureKind`)."""

from __future__ import annotations

from enum import StrEnum


class FailureKind(StrEnum):
    """Short failure class of a run or an episode, for statistics (the ``failure`` of a results record)."""

    UNSATISFIABLE = "unsatisfiable"
    """A pre-condition that no primitive achieves, or that stays unmet, or too deep a recursion (Alg. 1)."""
    CYCLE = "cycle"
    """Satisfying a pre-condition would raise a task already on the stack (Alg. 1)."""
    TIMEOUT = "timeout"
    """A top-level primitive spent its time budget."""
    UNREACHABLE = "unreachable"
    """A goal out of the arm's reach."""
    NO_SKILL = "no_skill"
    """No skill of the library fits the task, or it moves more arms than the robot has."""
    NOT_PERCEIVED = "not_perceived"
    """The target is not perceived."""
    CONDITION = "condition"
    """The condition source failed (an LLM error, malformed output)."""
    SIMULATION = "simulation"
    """The world failed to step."""
    BAD_TASK = "bad_task"
    """A malformed task name, or one the world cannot afford."""
    FALLEN = "fallen"
    """The object to grasp lies on its side."""
    IMPOSSIBLE = "impossible"
    """The planner found that the plan cannot be done; nothing moved (an episode's kind)."""
    NOT_SUCCEEDED = "not_succeeded"
    """The run completed but the success check failed (an episode's kind)."""
    DECOMPOSITION = "decomposition"
    """The LLM gave no valid plan for an instruction (an episode's kind)."""


class ExecutionError(RuntimeError):
    """Execution cannot continue; the message is the one-line reason and :attr:`kind` its class."""

    def __init__(self, reason: str, kind: FailureKind) -> None:
        super().__init__(reason)
        self.kind = kind
