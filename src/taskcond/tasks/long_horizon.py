"""Long-horizon tasks of the paper's Table I: LHT1-LHT4 and the novel-object variants LHT1*, LHT2*. LHT4
("Grasp the spatula and place it onto the cloth, then fold the cloth") runs in the dual-arm scene.

A long-horizon task is a sequence of primitive tasks; its oracle runs each primitive's oracle in turn,
planned from the state the previous one left. Success is checked on the final conditions.
"""

from __future__ import annotations

import math
from collections.abc import Iterator

import numpy as np

from taskcond.conditions import (
    KINOVA_GRIPPER,
    ContainerState,
    GripperState,
    Predicate,
    Relation,
    SpatialRelation,
)
from taskcond.envs.kitchen import KitchenEnv
from taskcond.sim.scene import SceneConfig, dual_arm_config
from taskcond.tasks.base import PrimitiveTask, Task, TaskInfo
from taskcond.tasks.close import Close
from taskcond.tasks.dual_arm import DualArmMotionPlan
from taskcond.tasks.fold import Fold, MoveOntoCloth, folded
from taskcond.tasks.grasp import Grasp
from taskcond.tasks.groundtruth import GroundTruth
from taskcond.tasks.motion_plan import MotionPlan
from taskcond.tasks.move_into import MoveInto
from taskcond.tasks.move_on_top import MoveOnTop
from taskcond.tasks.open import Open
from taskcond.tasks.release import Release


class LongHorizonTask(Task):
    """A sequence of primitive tasks from an initial container state to final conditions.

    Args:
        task_id: registry id (``"LHT1"``).
        description: the paper's wording.
        steps: the primitive tasks in order.
        initial_open: container name → open fraction at reset (others closed).
        final: conditions that mark success.
    """

    def __init__(
        self,
        task_id: str,
        description: str,
        steps: tuple[PrimitiveTask, ...],
        initial_open: dict[str, float],
        final: tuple[Predicate, ...],
    ) -> None:
        objects: list[str] = []
        for step in steps:
            objects.extend(o for o in step.objects if o not in objects)
        self.steps = steps
        self.initial_open = initial_open
        self.final = final
        self.max_steps = sum(s.max_steps for s in steps)
        self.info = TaskInfo(
            task_id, "long-horizon", tuple(s.info.task_name for s in steps), tuple(objects), description
        )

    def setup(self, env: KitchenEnv, rng: np.random.Generator) -> None:
        for name, fraction in self.initial_open.items():
            env.scene.set_joint(name, fraction)

    def setup_after_random(self, env: KitchenEnv, rng: np.random.Generator) -> None:
        """Nothing: the set-up only opens containers, which a random start draws instead (the task's own
        steps, repaired by the planner, must deal with them)."""

    def post_conditions(self) -> tuple[Predicate, ...]:
        return self.final

    def plans(self, env: KitchenEnv) -> Iterator[MotionPlan]:
        for step in self.steps:
            yield from step.plans(env)


def _inside(a: str, b: str) -> SpatialRelation:
    return SpatialRelation(a, Relation.INSIDE, b)


def _put_into_closed(task_id: str, obj: str, description: str) -> LongHorizonTask:
    return LongHorizonTask(
        task_id,
        description,
        (Grasp(obj), MoveInto(obj, "box"), Release(obj), Close("box")),
        {"box": 1.0},
        (_inside(obj, "box"), ContainerState("box", False), GripperState(None)),
    )


BOWL_BESIDE_DRAWER_YAW = math.pi / 2
"""Grasp yaw (rad) of the bowl once a drawer is out: fingers closing along world x, so that the hand's long
side does not reach over the pulled-out drawer next to the bowl (MoveInto turns it back across the drawer)."""


def _drawer_swap(task_id: str, target: str, other: str, description: str) -> LongHorizonTask:
    return LongHorizonTask(
        task_id,
        description,
        (
            Close(other),
            Open(target),
            Grasp("bowl", yaw_offset=BOWL_BESIDE_DRAWER_YAW),
            MoveInto("bowl", target),
            Release("bowl"),
            Close(target),
        ),
        {other: 1.0},
        (_inside("bowl", target), ContainerState(target, False), ContainerState(other, False)),
    )


class ClothLongHorizonTask(LongHorizonTask):
    """LHT4 (paper Table I): grasp the spatula (Franka), place it onto the half of the cloth the fold
    covers, release it, fold the cloth with both arms.

    Every trajectory is dual-arm (the Kinova holds still during the Franka's steps). Success: the cloth is
    folded over the spatula (:func:`taskcond.tasks.fold.folded`, the moved edge's miss measured in the
    xy-plane: the spatula, 39 mm tall on the cloth, holds the top layer up), neither gripper holds anything,
    and the spatula lies inside the fold: its centre over the xy bounding box of the cloth's nodes, its
    lowest point less than :data:`SPATULA_ON_CLOTH_HEIGHT` m above the table and not below the median height
    of the bottom layer's nodes under it (it rests on the cloth), and the top layer's highest node over it
    higher than its top (it is covered).
    """

    def scene_config(self, config: SceneConfig | None) -> SceneConfig | None:
        return dual_arm_config(config)

    def extra_success(self, env: KitchenEnv, judge: GroundTruth) -> bool:
        spec = env.scene.config.cloth
        if env.scene.cloth is None or spec is None or not folded(env, horizontal=True):
            return False
        nodes = env.scene.cloth_nodes()
        lo, hi = env.scene.aabb("spatula")
        centre = (lo + hi) / 2
        over = bool(
            np.all(centre[:2] >= nodes[:, :2].min(axis=0)) and np.all(centre[:2] <= nodes[:, :2].max(axis=0))
        )
        n = spec.resolution
        layers = nodes.reshape(n, n, 3)  # the fold lays rows i < n / 2 (the -x half) over the others
        top, bottom = layers[: n // 2].reshape(-1, 3), layers[n - n // 2 :].reshape(-1, 3)
        top, bottom = top[_within(top, lo, hi)], bottom[_within(bottom, lo, hi)]
        if not over or lo[2] > SPATULA_ON_CLOTH_HEIGHT or top.size == 0 or bottom.size == 0:
            return False
        return bool(lo[2] >= np.median(bottom[:, 2]) and top[:, 2].max() > hi[2])

    def plans(self, env: KitchenEnv) -> Iterator[DualArmMotionPlan]:  # type: ignore[override]
        for step in self.steps:
            for trajectory in step.plans(env):
                yield (
                    trajectory
                    if isinstance(trajectory, DualArmMotionPlan)
                    else DualArmMotionPlan.hold(env, trajectory)
                )


SPATULA_ON_CLOTH_HEIGHT = 0.02
"""LHT4: metres above the table the spatula's lowest point may be (it lies on the cloth's bottom layer)."""


def _within(points: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Mask (k,) of the ``points`` (k, 3) whose xy lies within the xy of the box ``lo`` .. ``hi`` (m)."""
    return np.all((points[:, :2] >= lo[:2]) & (points[:, :2] <= hi[:2]), axis=1)


def lht4() -> ClothLongHorizonTask:
    """LHT4: spatula onto the cloth, then fold the cloth."""
    return ClothLongHorizonTask(
        "LHT4",
        "Grasp the spatula and place it onto the cloth, then fold the cloth.",
        (Grasp("spatula"), MoveOntoCloth("spatula"), Release("spatula"), Fold("cloth")),
        {},
        (GripperState(None), GripperState(None, KINOVA_GRIPPER)),
    )


def long_horizon_tasks() -> list[LongHorizonTask]:
    """LHT1, LHT2, LHT3, LHT4, LHT1*, LHT2* (paper Table I)."""
    return [
        _put_into_closed("LHT1", "bottle", "Pick up a bottle, put the bottle into the box, close the box."),
        _drawer_swap(
            "LHT2",
            "bottom drawer",
            "top drawer",
            "To put the bowl into the bottom drawer of the cabinet, first close the top drawer, then "
            "open the bottom drawer, put the bowl into the bottom drawer and then close the drawer.",
        ),
        LongHorizonTask(
            "LHT3",
            "Hold a mug up, place it on the table, and put toothpaste into the mug.",
            (
                Grasp("mug"),
                MoveOnTop("mug", "table"),
                Release("mug"),
                Grasp("toothpaste"),
                MoveInto("toothpaste", "mug"),
                Release("toothpaste"),
            ),
            {},
            (
                SpatialRelation("mug", Relation.ABOVE, "table"),
                _inside("toothpaste", "mug"),
                GripperState(None),
            ),
        ),
        lht4(),
        _put_into_closed("LHT1*", "bowl", "Pick up a bowl, put the bowl into the box, and close the box."),
        _drawer_swap(
            "LHT2*",
            "top drawer",
            "bottom drawer",
            "To put the bowl into the upper drawer of the cabinet, first close the bottom drawer, then "
            "open the upper drawer, put the bowl into the upper drawer and then close the drawer.",
        ),
    ]
