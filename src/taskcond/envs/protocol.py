"""What :class:`~taskcond.envs.kitchen.KitchenEnv` needs of a task: the :class:`Task` protocol it is typed
against. The tasks of the suite (:class:`taskcond.tasks.base.Task`) implement it; the environment layer
never imports them (ravens and robosuite keep environment and task apart the same way).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol

if TYPE_CHECKING:
    import numpy as np

    from taskcond.conditions import Predicate
    from taskcond.envs.kitchen import KitchenEnv
    from taskcond.envs.reader import Reading
    from taskcond.sim.scene import KitchenScene, SceneConfig


class Judge(Protocol):
    """Evaluates conditions of :mod:`taskcond.conditions` on a scene
    (:class:`taskcond.tasks.groundtruth.GroundTruth`)."""

    def holds(self, pred: Predicate) -> bool:
        """Whether ``pred`` holds in the current simulator state."""
        ...

    def at(self, reading: Reading) -> Judge:
        """The same judge taking the simulator state from ``reading`` where it has it (nothing has moved
        since it was read)."""
        ...


class Task(Protocol):
    """A task as the environment uses it: the scene it needs, its judge, its initial state, its success and
    its episode length."""

    max_steps: int
    """Episode length in control steps before truncation."""

    def scene_config(self, config: SceneConfig | None) -> SceneConfig | None:
        """The scene this task needs, given the caller's ``config`` (``None`` = the default kitchen)."""
        ...

    def ground_truth(self, scene: KitchenScene) -> Judge:
        """The judge of the task's conditions on ``scene`` (the environment's :attr:`~KitchenEnv.truth`)."""
        ...

    def setup(self, env: KitchenEnv, rng: np.random.Generator) -> None:
        """Bring the freshly randomized scene into the task's initial state (reset time only)."""
        ...

    def success(self, env: KitchenEnv, truth: Judge | None = None) -> bool:
        """Whether the task has succeeded, asking ``truth`` (the step passes ``env.truth`` at its reading;
        ``None``: ``env.truth``, reading the simulator now)."""
        ...


__all__ = ["Judge", "Task"]
