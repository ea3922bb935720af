"""Motion plans of the scripted oracles: end-effector trajectories, the demonstrations a DMP is later
fitted to (paper §III-E). A motion plan is sampled at the environment's control rate. (A DMP's own
rollout is :class:`taskcond.dmp.Trajectory`.)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

SPEED = 0.2
"""Default Cartesian speed (m/s) of oracle motions."""


@dataclass(frozen=True)
class Waypoint:
    """Reach ``position`` (3,) m with ``orientation`` (4,) xyzw (world frame) and gripper command
    ``gripper`` (0 open, 1 closed) over ``duration`` s; ``None`` duration = distance / :data:`SPEED`
    (at least 0.3 s)."""

    position: np.ndarray
    orientation: np.ndarray
    gripper: float
    duration: float | None = None


@dataclass(frozen=True)
class MotionPlan:
    """An oracle's end-effector trajectory.

    Attributes:
        times: (n,) seconds from the start.
        positions: (n, 3) metres, world frame.
        orientations: (n, 4) quaternions xyzw, world frame.
        gripper: (n,) commands, 0 open and 1 closed.
    """

    times: np.ndarray
    positions: np.ndarray
    orientations: np.ndarray
    gripper: np.ndarray

    def __len__(self) -> int:
        return len(self.times)

    def action(self, i: int) -> np.ndarray:
        """Environment action (8,) of sample ``i``: position, quaternion xyzw, gripper."""
        return np.concatenate([self.positions[i], self.orientations[i], [self.gripper[i]]])

    @staticmethod
    def concatenate(parts: list[MotionPlan]) -> MotionPlan:
        """Join trajectories end to end (times continue)."""
        times, offset = [], 0.0
        for part in parts:
            times.append(part.times + offset)
            offset += part.times[-1] + (part.times[1] - part.times[0] if len(part) > 1 else 0.0)
        return MotionPlan(
            np.concatenate(times),
            np.concatenate([t.positions for t in parts]),
            np.concatenate([t.orientations for t in parts]),
            np.concatenate([t.gripper for t in parts]),
        )

    @staticmethod
    def from_waypoints(
        start: np.ndarray, start_orientation: np.ndarray, waypoints: list[Waypoint], dt: float
    ) -> MotionPlan:
        """Sample straight-line, smooth-step-timed segments through ``waypoints`` every ``dt`` s, starting at
        ``start`` (3,) / ``start_orientation`` (4,); orientations are slerped."""
        pos, orn = np.asarray(start, float), np.asarray(start_orientation, float)
        ps, qs, gs = [], [], []
        for wp in waypoints:
            goal, goal_q = np.asarray(wp.position, float), np.asarray(wp.orientation, float)
            angle = Rotation.from_quat(orn).inv() * Rotation.from_quat(goal_q)
            duration = wp.duration
            if duration is None:
                duration = max(0.3, np.linalg.norm(goal - pos) / SPEED, angle.magnitude() / 1.0)
            n = max(1, round(duration / dt))
            s = np.arange(1, n + 1) / n
            s = s * s * (3 - 2 * s)
            ps.append(pos + s[:, None] * (goal - pos))
            qs.append(Slerp([0, 1], Rotation.from_quat([orn, goal_q]))(s).as_quat())
            gs.append(np.full(n, wp.gripper))
            pos, orn = goal, goal_q
        positions = np.concatenate(ps)
        return MotionPlan(np.arange(len(positions)) * dt, positions, np.concatenate(qs), np.concatenate(gs))
