"""PT8 Move A on top of B (paper Table I): carry a held object over B and lower it onto B's top.

Initial state: A held 5 cm above where it stood, B (the closed box or the counter) in place. Success:
``A above B`` with A's lowest point at most :data:`GAP` m above B's top.
"""

from __future__ import annotations

import numpy as np

from taskcond.conditions import Predicate, Relation, SpatialRelation
from taskcond.envs.kitchen import KitchenEnv
from taskcond.tasks.base import PrimitiveTask
from taskcond.tasks.groundtruth import GroundTruth
from taskcond.tasks.motion_plan import Waypoint
from taskcond.tasks.motions import bottom_to_com, carry, grasp_of

PAIRS = (("bottle", "box"), ("bowl", "box"), ("toothpaste", "box"), ("spatula", "box"), ("mug", "table"))
GAP = 0.03
DROP = 0.012
"""Height (m) of A's lowest point above B's top where the oracle stops."""


class MoveOnTop(PrimitiveTask):
    primitive_id = "move_on_top"
    max_steps = 300

    def fixed_joints(self, env: KitchenEnv) -> dict[str, float]:
        """A random start keeps B closed when it is a container (an open lid is no top to stand on)."""
        b = self.objects[1]
        return {b: 0.0} if b in env.scene.joints else {}

    def setup(self, env: KitchenEnv, rng: np.random.Generator) -> None:
        env.hold(self.objects[0], 0.05, grasp_of(env.scene, self.objects[0]))

    def post_conditions(self) -> tuple[Predicate, ...]:
        return (SpatialRelation(self.objects[0], Relation.ABOVE, self.objects[1]),)

    def extra_success(self, env: KitchenEnv, judge: GroundTruth) -> bool:
        return judge.height_over(*self.objects) <= GAP

    def waypoints(self, env: KitchenEnv) -> list[Waypoint]:
        a, b = self.objects
        lo, hi = env.scene.aabb(b)
        com = env.truth.com(a)
        xy = com[:2] if b == "table" else (lo[:2] + hi[:2]) / 2
        goal = np.array([xy[0], xy[1], hi[2] + DROP + bottom_to_com(env, a)])
        return carry(env, a, goal, clearance=hi[2] + 0.05)
