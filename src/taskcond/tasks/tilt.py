"""PT5 Tilt (paper Table I): tilt a held object as if pouring, rotating the hand about its horizontal axis
across the fingers.

Initial state: the object held 10 cm above where it stood. Success: ``gripper grasping A`` and A's axis
tilted at least :data:`MIN_TILT` rad from vertical.
"""

from __future__ import annotations

import numpy as np
import pybullet as p
from scipy.spatial.transform import Rotation

from taskcond.conditions import GripperState, Predicate
from taskcond.envs.kitchen import KitchenEnv
from taskcond.tasks.base import PrimitiveTask
from taskcond.tasks.groundtruth import GroundTruth
from taskcond.tasks.motion_plan import Waypoint
from taskcond.tasks.motions import CLOSED, current, grasp_of

OBJECTS = ("bottle", "mug")
MIN_TILT = 1.0
"""Smallest tilt (rad, ≈57°) that counts as success."""
TILT = 1.4
"""Tilt (rad) the oracle turns the hand by."""


def tilt_angle(env: KitchenEnv, name: str) -> float:
    """Angle (rad) between a free object's z axis and world z."""
    _, orn = p.getBasePositionAndOrientation(env.scene.bodies[name], physicsClientId=env.scene.client)
    z = np.array(p.getMatrixFromQuaternion(orn)).reshape(3, 3)[:, 2]
    return float(np.arccos(np.clip(z[2], -1.0, 1.0)))


class Tilt(PrimitiveTask):
    primitive_id = "tilt"
    max_steps = 150

    def setup(self, env: KitchenEnv, rng: np.random.Generator) -> None:
        env.hold(self.objects[0], 0.10, grasp_of(env.scene, self.objects[0]))

    def post_conditions(self) -> tuple[Predicate, ...]:
        return (GripperState(self.objects[0]),)

    def extra_success(self, env: KitchenEnv, judge: GroundTruth) -> bool:
        return tilt_angle(env, self.objects[0]) >= MIN_TILT

    def waypoints(self, env: KitchenEnv) -> list[Waypoint]:
        pos, orn, _ = current(env)
        tilted = (Rotation.from_quat(orn) * Rotation.from_euler("x", TILT)).as_quat()
        return [Waypoint(pos, tilted, CLOSED, 2.0), Waypoint(pos, tilted, CLOSED, 0.5)]
