"""PT4 Close (paper Table I): close an open drawer (push its handle), the box (push the lid from behind
until it falls shut) or the microwave (swing the door back by its handle).

Initial state: the container open (drawers and box fully, the microwave door at 1.1 rad). Success:
``A closed`` (joint within 8 % of its range from closed).
"""

from __future__ import annotations

import numpy as np

from taskcond.conditions import ContainerState, Predicate
from taskcond.envs.kitchen import KitchenEnv
from taskcond.tasks.base import PrimitiveTask
from taskcond.tasks.motion_plan import Waypoint
from taskcond.tasks.motions import door_motion, drawer_motion, lid_close

OBJECTS = ("top drawer", "bottom drawer", "box", "microwave")
DOOR_START = 1.1
"""Microwave door angle (rad) at the start of ``close microwave``."""


class Close(PrimitiveTask):
    primitive_id = "close"
    max_steps = 400

    def fixed_joints(self, env: KitchenEnv) -> dict[str, float]:
        """The container open: drawers and box fully, the microwave door at :data:`DOOR_START`."""
        target = self.objects[0]
        joint = env.scene.joints[target]
        return {target: DOOR_START / joint.open_position if target == "microwave" else 1.0}

    def setup(self, env: KitchenEnv, rng: np.random.Generator) -> None:
        for name, fraction in self.fixed_joints(env).items():
            env.scene.set_joint(name, fraction)

    def post_conditions(self) -> tuple[Predicate, ...]:
        return (ContainerState(self.objects[0], False),)

    def waypoints(self, env: KitchenEnv) -> list[Waypoint]:
        target = self.objects[0]
        if target == "box":
            return lid_close(env)
        if target == "microwave":
            return door_motion(env, -0.05)
        return drawer_motion(env, target, -0.05)
