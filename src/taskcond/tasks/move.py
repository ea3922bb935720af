"""PT7 Move A to position (paper Table I): carry a held object to a goal position.

Initial state: the object held 8 cm above where it stood; the goal (observation ``target``) is its centre
of mass shifted by a seeded random offset. Success: ``gripper grasping A`` and A's centre of mass within
:data:`TOLERANCE` m of the goal.
"""

from __future__ import annotations

import numpy as np

from taskcond.conditions import GripperState, Predicate
from taskcond.tasks.base import PrimitiveTask
from taskcond.tasks.env import KitchenEnv
from taskcond.tasks.skills import CLOSED, GRASPS, current
from taskcond.tasks.trajectory import Waypoint

OBJECTS = ("bottle", "bowl", "mug")
TOLERANCE = 0.03
OFFSET_LOW = np.array([-0.08, -0.10, 0.03])
OFFSET_HIGH = np.array([0.05, 0.10, 0.12])
"""Bounds (m) of the goal offset from the object's start."""


class Move(PrimitiveTask):
    primitive_id = "move"
    max_steps = 200

    def setup(self, env: KitchenEnv, rng: np.random.Generator) -> None:
        env.hold(self.objects[0], 0.08, GRASPS[self.objects[0]])
        env.target = env.truth.com(self.objects[0]) + rng.uniform(OFFSET_LOW, OFFSET_HIGH)

    def post_conditions(self) -> tuple[Predicate, ...]:
        return (GripperState(self.objects[0]),)

    def extra_success(self, env: KitchenEnv) -> bool:
        return bool(np.linalg.norm(env.truth.com(self.objects[0]) - env.target) <= TOLERANCE)

    def waypoints(self, env: KitchenEnv) -> list[Waypoint]:
        pos, orn, _ = current(env)
        goal = env.target + (pos - env.truth.com(self.objects[0]))
        return [Waypoint(goal, orn, CLOSED), Waypoint(goal, orn, CLOSED, 0.5)]
