"""PT2 Release (paper Table I): let go of a held object just above the counter.

Initial state: the object is held 3 cm above where it stands. Success: ``gripper not grasping`` and the
object resting within 2 cm of the counter.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from taskcond.conditions import GripperState, Predicate
from taskcond.envs.kitchen import KitchenEnv
from taskcond.tasks.base import PrimitiveTask
from taskcond.tasks.groundtruth import GroundTruth
from taskcond.tasks.motion_plan import MotionPlan
from taskcond.tasks.motions import grasp_of, release_plans

OBJECTS = ("bottle", "bowl", "mug", "toothpaste", "spatula")


class Release(PrimitiveTask):
    primitive_id = "release"
    max_steps = 120

    def setup(self, env: KitchenEnv, rng: np.random.Generator) -> None:
        env.hold(self.objects[0], 0.03, grasp_of(env.scene, self.objects[0]))

    def post_conditions(self) -> tuple[Predicate, ...]:
        return (GripperState(None),)

    def extra_success(self, env: KitchenEnv, judge: GroundTruth) -> bool:
        return bool(env.scene.aabb(self.objects[0])[0][2] <= 0.02)

    def plans(self, env: KitchenEnv) -> Iterator[MotionPlan]:
        yield from release_plans(env)
