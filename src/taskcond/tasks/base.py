"""Task definitions of the suite (paper §IV, Table I): what a task is, how it sets up its initial state, how
its success is checked and how its scripted oracle plans.

A :class:`Task` owns no simulator; :class:`taskcond.envs.kitchen.KitchenEnv` calls it through the
protocol :class:`taskcond.envs.protocol.Task`. Primitive tasks live in one module per primitive family,
long-horizon tasks in :mod:`taskcond.tasks.long_horizon`.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING, Literal

import numpy as np

from taskcond.conditions import Predicate
from taskcond.primitives import PRIMITIVES
from taskcond.tasks.groundtruth import GroundTruth
from taskcond.tasks.motion_plan import MotionPlan, Waypoint

if TYPE_CHECKING:
    from taskcond.envs.kitchen import KitchenEnv
    from taskcond.sim.scene import KitchenScene, SceneConfig


@dataclass(frozen=True)
class TaskInfo:
    """A registry entry.

    Attributes:
        id: registry id, e.g. ``"grasp-bottle"``, ``"move_into-bottle-box"``, ``"LHT1"``.
        kind: ``"primitive"`` or ``"long-horizon"``.
        primitive: the primitive id of :data:`taskcond.primitives.PRIMITIVES` for a primitive task; for a
            long-horizon task the primitive task names in order (``("grasp bottle", ...)``).
        objects: condition names of the objects the task acts on, in task-name order.
        task_name: canonical task name (``"move bottle into box"``) or the long-horizon description.
    """

    id: str
    kind: Literal["primitive", "long-horizon"]
    primitive: str | tuple[str, ...]
    objects: tuple[str, ...]
    task_name: str


class Task:
    """Base class of every task: an initial state, post-conditions and an oracle.

    Subclasses set :attr:`info`, and override :meth:`setup`, :meth:`post_conditions`, :meth:`plans` and,
    for checks the vocabulary cannot express, :meth:`extra_success`.
    """

    info: TaskInfo
    max_steps: int = 400
    """Episode length in control steps before truncation."""

    def scene_config(self, config: SceneConfig | None) -> SceneConfig | None:
        """The scene this task needs, given the caller's ``config`` (``None`` = the default kitchen).

        Single-arm tasks return it unchanged; dual-arm and cloth tasks add the Kinova and the cloth
        (:func:`taskcond.sim.scene.dual_arm_config`)."""
        return config

    def ground_truth(self, scene: KitchenScene) -> GroundTruth:
        """The judge of the task's conditions on ``scene``, which the environment keeps as ``env.truth``."""
        return GroundTruth(scene)

    def setup(self, env: KitchenEnv, rng: np.random.Generator) -> None:
        """Bring the freshly randomized scene into the task's initial state (reset time only)."""

    def setup_after_random(self, env: KitchenEnv, rng: np.random.Generator) -> None:
        """The task's set-up after a random start (:class:`taskcond.tasks.free.RandomStart`): by
        default :meth:`setup` (an object the task starts holding is grasped where it now stands)."""
        self.setup(env, rng)

    def fixed_joints(self, env: KitchenEnv) -> dict[str, float]:
        """Container name → open fraction that a random start (:class:`taskcond.tasks.free.
        RandomStart`) must keep: the container states the task assumes at its start and its oracle's
        demonstration showed (``open box`` needs the box closed). The others are drawn at random."""
        return {}

    def post_conditions(self) -> tuple[Predicate, ...]:
        """Conditions that mark success, in the vocabulary of :mod:`taskcond.conditions`; the same for the
        task's lifetime (:meth:`success` asks once)."""
        return ()

    @cached_property
    def _success_conditions(self) -> tuple[Predicate, ...]:
        """:meth:`post_conditions`, built once (:meth:`success` runs at every control step)."""
        return self.post_conditions()

    def extra_success(self, env: KitchenEnv, judge: GroundTruth) -> bool:
        """Success criteria outside the vocabulary (lifted, tilted, at the target), asked of ``judge``, the
        judge of :meth:`success` (bound to the step's reading when the step judges)."""
        return True

    def success(self, env: KitchenEnv, truth: GroundTruth | None = None) -> bool:
        """Ground-truth success: every post-condition holds by ``truth`` (``None``: ``env.truth``, which
        reads the simulator now; :meth:`KitchenEnv.step <taskcond.envs.kitchen.KitchenEnv.step>` passes one
        bound to the step's reading) and :meth:`extra_success`."""
        judge = env.truth if truth is None else truth
        return all(map(judge.holds, self._success_conditions)) and self.extra_success(env, judge)

    def plans(self, env: KitchenEnv) -> Iterator[MotionPlan]:
        """The scripted oracle: end-effector trajectories to execute one after the other, each planned
        from the state the previous one left (a primitive task yields one, or a few when it
        reacts to what happened, as a release whose fingers stayed jammed)."""
        raise NotImplementedError


class PrimitiveTask(Task):
    """A primitive task on given objects; subclasses set :attr:`primitive_id` and :meth:`waypoints`."""

    primitive_id: str = ""

    def __init__(self, *objects: str) -> None:
        prim = PRIMITIVES[self.primitive_id]
        self.objects = objects
        self.info = TaskInfo(
            id="-".join((self.primitive_id, *(o.replace(" ", "_") for o in objects))),
            kind="primitive",
            primitive=self.primitive_id,
            objects=objects,
            task_name=prim.task_name(*objects),
        )

    def waypoints(self, env: KitchenEnv) -> list[Waypoint]:
        """The oracle's waypoints, planned from the current state."""
        raise NotImplementedError

    def plans(self, env: KitchenEnv) -> Iterator[MotionPlan]:
        from taskcond.tasks.motions import plan

        yield plan(env, self.waypoints(env))
