"""PT3 Open (paper Table I): open a drawer (pull its handle), the box (lift the lid by its lip) or the
microwave (swing the door by the fin on its top edge).

Initial state: every container closed. Success: ``A open`` (joint past half of its range).
"""

from __future__ import annotations

from taskcond.conditions import ContainerState, Predicate
from taskcond.envs.kitchen import KitchenEnv
from taskcond.tasks.base import PrimitiveTask
from taskcond.tasks.motion_plan import Waypoint
from taskcond.tasks.motions import door_motion, drawer_motion, lid_open

OBJECTS = ("top drawer", "bottom drawer", "box", "microwave")
DOOR_OPEN = 1.25
"""Angle (rad) the oracle swings the microwave door to."""


class Open(PrimitiveTask):
    primitive_id = "open"
    max_steps = 400

    def fixed_joints(self, env: KitchenEnv) -> dict[str, float]:
        """A random start keeps the container closed (an open one has nothing to open)."""
        return {self.objects[0]: 0.0}

    def post_conditions(self) -> tuple[Predicate, ...]:
        return (ContainerState(self.objects[0], True),)

    def waypoints(self, env: KitchenEnv) -> list[Waypoint]:
        target = self.objects[0]
        if target == "box":
            return lid_open(env)
        if target == "microwave":
            return door_motion(env, DOOR_OPEN)
        return drawer_motion(env, target, 0.95)
