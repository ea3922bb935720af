"""PT10 Move A in front of B (paper Table I): carry a held object to the counter in front of B (between
the robot and B's front face).

Initial state: A held 3 cm above where it stood. Success: ``A in front of B``.
"""

from __future__ import annotations

import numpy as np

from taskcond.conditions import Predicate, Relation, SpatialRelation
from taskcond.envs.kitchen import KitchenEnv
from taskcond.tasks.base import PrimitiveTask
from taskcond.tasks.motion_plan import Waypoint
from taskcond.tasks.motions import bottom_to_com, carry, grasp_of

PAIRS = (("bottle", "microwave"), ("mug", "box"), ("bowl", "cabinet"))
FRONT_GAP = 0.09
"""Gap (m) the oracle leaves between A and B's front face."""


class MoveInFront(PrimitiveTask):
    primitive_id = "move_in_front"
    max_steps = 300

    def fixed_joints(self, env: KitchenEnv) -> dict[str, float]:
        """A random start keeps B closed, and the drawers when B is the cabinet: an open door, lid or drawer
        stands where A goes, and moves B's front face."""
        b = self.objects[1]
        if b == "cabinet":
            return {name: 0.0 for name in env.scene.joints if name.endswith("drawer")}
        return {b: 0.0} if b in env.scene.joints else {}

    def setup(self, env: KitchenEnv, rng: np.random.Generator) -> None:
        env.hold(self.objects[0], 0.03, grasp_of(env.scene, self.objects[0]))

    def post_conditions(self) -> tuple[Predicate, ...]:
        return (SpatialRelation(self.objects[0], Relation.IN_FRONT_OF, self.objects[1]),)

    def waypoints(self, env: KitchenEnv) -> list[Waypoint]:
        a, b = self.objects
        alo, ahi = env.scene.aabb(a)
        blo, bhi = env.scene.aabb(b)
        half = (ahi[0] - alo[0]) / 2
        goal = np.array([blo[0] - FRONT_GAP - half, (blo[1] + bhi[1]) / 2, 0.012 + bottom_to_com(env, a)])
        return carry(env, a, goal, clearance=0.08)
