"""PT1 Grasp (paper Table I): pick a free object up from the counter.

Success: ``gripper grasping A`` and A lifted at least :data:`LIFT` m off the counter.
"""

from __future__ import annotations

import numpy as np

from taskcond.conditions import GripperState, Predicate
from taskcond.envs.kitchen import KitchenEnv
from taskcond.tasks.base import PrimitiveTask
from taskcond.tasks.groundtruth import GroundTruth
from taskcond.tasks.motion_plan import Waypoint
from taskcond.tasks.motions import pick

LIFT = 0.03
"""Metres the grasped object's lowest point must be above the counter."""
OBJECTS = ("bottle", "bowl", "mug", "toothpaste", "spatula")


class Grasp(PrimitiveTask):
    """``yaw_offset`` (rad): the oracle's grasp yaw relative to the object, replacing the object's default
    (:func:`taskcond.tasks.motions.grasp_of`)."""

    primitive_id = "grasp"
    max_steps = 300

    def __init__(self, *objects: str, yaw_offset: float | None = None) -> None:
        super().__init__(*objects)
        self.yaw_offset = yaw_offset

    def post_conditions(self) -> tuple[Predicate, ...]:
        return (GripperState(self.objects[0]),)

    def extra_success(self, env: KitchenEnv, judge: GroundTruth) -> bool:
        return bool(env.scene.aabb(self.objects[0])[0][2] >= LIFT)

    def setup(self, env: KitchenEnv, rng: np.random.Generator) -> None:
        """The arm starts at home with the gripper open."""

    def waypoints(self, env: KitchenEnv) -> list[Waypoint]:
        return pick(env, self.objects[0], yaw_offset=self.yaw_offset)
