"""PT7 Move A to position (paper Table I): carry a held object to a goal position.

Initial state: the object held 8 cm above where it stood; the goal (observation ``target``) is its centre
of mass shifted by a seeded random offset, redrawn while A would there overlap another body (a goal inside
the box wall cannot be reached). Success: ``gripper grasping A`` and A's centre of mass within
:data:`TOLERANCE` m of the goal.
"""

from __future__ import annotations

import numpy as np
import pybullet as p

from taskcond.conditions import GripperState, Predicate
from taskcond.envs.kitchen import KitchenEnv
from taskcond.tasks.base import PrimitiveTask
from taskcond.tasks.groundtruth import GroundTruth
from taskcond.tasks.motion_plan import Waypoint
from taskcond.tasks.motions import CLOSED, current, grasp_of

OBJECTS = ("bottle", "bowl", "mug")
TOLERANCE = 0.03
OFFSET_LOW = np.array([-0.08, -0.10, 0.03])
OFFSET_HIGH = np.array([0.05, 0.10, 0.12])
"""Bounds (m) of the goal offset from the object's start."""
CLEARANCE = 0.01
"""Metres by which A's bounding box at the goal must stay clear of every other body's."""
DRAWS = 100
"""Goal draws before giving up."""


def free_goal(env: KitchenEnv, name: str, rng: np.random.Generator) -> np.ndarray:
    """A goal centre of mass (3,) m, world, for the held ``name``: its current one plus a uniform offset in
    [:data:`OFFSET_LOW`, :data:`OFFSET_HIGH`], where its bounding box (as held now, grown by
    :data:`CLEARANCE`) overlaps no body but itself and the robot."""
    com = env.truth.com(name)
    lo, hi = env.scene.aabb(name)
    own = {env.scene.bodies[name], env.robot.body}
    for _ in range(DRAWS):
        goal = com + rng.uniform(OFFSET_LOW, OFFSET_HIGH)
        shift = goal - com
        hits = p.getOverlappingObjects(
            (lo + shift - CLEARANCE).tolist(),
            (hi + shift + CLEARANCE).tolist(),
            physicsClientId=env.scene.client,
        )
        if not any(body not in own for body, _ in hits or ()):
            return goal
    raise RuntimeError(f"no free goal for {name} in {DRAWS} draws")


class Move(PrimitiveTask):
    primitive_id = "move"
    max_steps = 200

    def setup(self, env: KitchenEnv, rng: np.random.Generator) -> None:
        env.hold(self.objects[0], 0.08, grasp_of(env.scene, self.objects[0]))
        env.target = free_goal(env, self.objects[0], rng)

    def post_conditions(self) -> tuple[Predicate, ...]:
        return (GripperState(self.objects[0]),)

    def extra_success(self, env: KitchenEnv, judge: GroundTruth) -> bool:
        return bool(np.linalg.norm(judge.com(self.objects[0]) - env.target) <= TOLERANCE)

    def waypoints(self, env: KitchenEnv) -> list[Waypoint]:
        pos, orn, _ = current(env)
        goal = env.target + (pos - env.truth.com(self.objects[0]))
        return [Waypoint(goal, orn, CLOSED), Waypoint(goal, orn, CLOSED, 0.5)]
