"""Dual-arm end-effector trajectories (paper §IV: "dual-arm manipulation tasks, e.g., folding the cloth"): a
Franka trajectory and a Kinova trajectory sampled at the same control times, executed together by the (16,)
actions of :class:`taskcond.envs.kitchen.KitchenEnv`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from taskcond.tasks.motion_plan import MotionPlan, Waypoint

if TYPE_CHECKING:
    from taskcond.envs.kitchen import KitchenEnv


@dataclass(frozen=True)
class DualArmMotionPlan:
    """Two end-effector trajectories of equal length and timing.

    Attributes:
        franka: the Franka's end-effector (``panda_grasptarget``) trajectory, world frame.
        kinova: the Kinova's tool-centre-point trajectory, world frame.
    """

    franka: MotionPlan
    kinova: MotionPlan

    def __post_init__(self) -> None:
        if len(self.franka) != len(self.kinova):
            raise ValueError(f"arm trajectories differ in length: {len(self.franka)} and {len(self.kinova)}")

    @property
    def times(self) -> np.ndarray:
        """(n,) seconds from the start."""
        return self.franka.times

    def __len__(self) -> int:
        return len(self.franka)

    def action(self, i: int) -> np.ndarray:
        """Environment action (16,) of sample ``i``: the Franka's (8,) then the Kinova's (8,)."""
        return np.concatenate([self.franka.action(i), self.kinova.action(i)])

    @staticmethod
    def concatenate(parts: list[DualArmMotionPlan]) -> DualArmMotionPlan:
        """Join dual-arm trajectories end to end (times continue)."""
        return DualArmMotionPlan(
            MotionPlan.concatenate([t.franka for t in parts]),
            MotionPlan.concatenate([t.kinova for t in parts]),
        )

    @staticmethod
    def hold(env: KitchenEnv, franka: MotionPlan) -> DualArmMotionPlan:
        """``franka`` with the Kinova holding its current tool pose and gripper state throughout."""
        assert env.kinova is not None
        position, orientation = env.kinova.ee_pose()
        n = len(franka)
        kinova = MotionPlan(
            franka.times.copy(),
            np.tile(position, (n, 1)),
            np.tile(orientation, (n, 1)),
            np.full(n, 1.0 if env.kinova.gripper_closed else 0.0),
        )
        return DualArmMotionPlan(franka, kinova)

    @staticmethod
    def from_waypoints(
        env: KitchenEnv, franka: list[Waypoint], kinova: list[Waypoint], durations: list[float]
    ) -> DualArmMotionPlan:
        """Both arms through their waypoints in lockstep, starting at their current poses: segment ``k``
        of both lasts ``durations[k]`` s (the waypoints' own durations are ignored).

        Raises:
            ValueError: the scene has no Kinova, or the lists differ in length.
        """
        if env.kinova is None:
            raise ValueError("a dual-arm trajectory needs the Kinova in the scene (SceneConfig.kinova)")
        if not len(franka) == len(kinova) == len(durations):
            raise ValueError(
                f"{len(franka)} Franka and {len(kinova)} Kinova waypoints for {len(durations)} durations"
            )

        def timed(wps: list[Waypoint]) -> list[Waypoint]:
            return [
                Waypoint(w.position, w.orientation, w.gripper, d) for w, d in zip(wps, durations, strict=True)
            ]

        ee = env.robot.ee_pose()
        k_position, k_orientation = env.kinova.ee_pose()
        return DualArmMotionPlan(
            MotionPlan.from_waypoints(ee.position, ee.orientation, timed(franka), env.dt),
            MotionPlan.from_waypoints(k_position, k_orientation, timed(kinova), env.dt),
        )


__all__ = ["DualArmMotionPlan"]
