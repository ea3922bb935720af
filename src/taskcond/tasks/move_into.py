"""PT9 Move A into B (paper Table I): carry a held object over an open container and lower it in.

Initial state: B open (box lid, drawer fully out), A held 5 cm above where it stood (beside a drawer, with
the fingers closing along world x, see :data:`BESIDE_DRAWER_YAW`). Success: ``A inside B`` (A's centre of
mass in B's interior).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from taskcond.conditions import Predicate, Relation, SpatialRelation
from taskcond.envs.kitchen import KitchenEnv
from taskcond.sim.franka import top_down
from taskcond.tasks.base import PrimitiveTask
from taskcond.tasks.motion_plan import Waypoint
from taskcond.tasks.motions import bottom_to_com, carry, current, grasp_of, nearest_grip

PAIRS = (
    ("bottle", "box"),
    ("bowl", "box"),
    ("bowl", "top drawer"),
    ("bowl", "bottom drawer"),
    ("toothpaste", "mug"),
)
FLOOR_GAP = 0.02
"""Height (m) of A's lowest point above B's floor where the oracle stops."""
FRONT_CLEARANCE = 0.025
"""Gap (m) the oracle leaves between A and the inner face of a drawer's front panel (the drawer link's
origin, :class:`~taskcond.sim.assets.CabinetSpec`)."""
BESIDE_DRAWER_YAW = math.pi / 2
"""Grasp yaw (rad, relative to A) of the held A when B is a drawer: fingers closing along world x, so that
the hand's long side (20 cm across the fingers) is not under or against the pulled-out drawer beside A."""


def into_goal(env: KitchenEnv, a: str, b: str) -> tuple[np.ndarray, float]:
    """Goal centre of mass (3,) of A inside B and the rim height (m) to clear on the way. In a drawer the
    goal is just behind its front panel, so that the hand stays clear of the cabinet and the drawer
    above."""
    inner = env.scene.interior(b)
    floor = inner.center[2] - inner.half_extents[2]
    rim = inner.center[2] + inner.half_extents[2]
    xy = inner.center[:2]
    if b.endswith("drawer"):
        front, _ = env.scene.pose(b)
        lo, hi = env.scene.aabb(a)
        xy = np.array([front[0] + FRONT_CLEARANCE + (hi[0] - lo[0]) / 2, xy[1]])
    goal = np.array([xy[0], xy[1], floor + FLOOR_GAP + bottom_to_com(env, a)])
    return goal, rim


class MoveInto(PrimitiveTask):
    primitive_id = "move_into"
    max_steps = 300

    def fixed_joints(self, env: KitchenEnv) -> dict[str, float]:
        """A random start keeps B open (fully), and when B is a drawer the other drawer closed: an open top
        drawer covers the bottom one, an open bottom drawer stands under the hand going into the top one."""
        b = self.objects[1]
        if b not in env.scene.joints:
            return {}
        others = (
            [n for n in env.scene.joints if n.endswith("drawer") and n != b] if b.endswith("drawer") else []
        )
        return {b: 1.0, **dict.fromkeys(others, 0.0)}

    def setup(self, env: KitchenEnv, rng: np.random.Generator) -> None:
        b = self.objects[1]
        if b in env.scene.joints:
            env.scene.set_joint(b, 1.0)
        grasp = grasp_of(env.scene, self.objects[0])
        if b.endswith("drawer"):
            grasp = replace(grasp, yaw_offset=BESIDE_DRAWER_YAW)
        env.hold(self.objects[0], 0.05, grasp)

    def post_conditions(self) -> tuple[Predicate, ...]:
        return (SpatialRelation(self.objects[0], Relation.INSIDE, self.objects[1]),)

    def waypoints(self, env: KitchenEnv) -> list[Waypoint]:
        a, b = self.objects
        goal, rim = into_goal(env, a, b)
        orientation = None
        if b.endswith("drawer"):
            # fingers across the drawer (world y): the hand's long side then stays clear of the front
            # panel and of the cabinet behind the pulled-out drawer
            orientation = nearest_grip(np.array(top_down()), current(env)[1])
        return carry(env, a, goal, clearance=rim + 0.04, orientation=orientation)
