"""The arm protocol of the simulator: what the environment asks of an arm, whichever arm it is (the Franka
Panda of :mod:`taskcond.sim.franka`, the Kinova Gen3 of :mod:`taskcond.sim.kinova`).

Units: metres, radians; poses in the PyBullet world frame, quaternions ``(x, y, z, w)``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property
from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike

IKErrors = Callable[[np.ndarray], tuple[float, float]]
"""Position error (m) and orientation error (rad, 0 when no orientation was asked) of joint positions (7,)
against the target an IK call was given."""


@dataclass(frozen=True)
class IKResult:
    """An inverse-kinematics answer. Its errors are measured when first read (an arm whose forward kinematics
    costs simulator calls pays them only for the callers that look), then kept.

    Attributes:
        q: joint positions (7,), rad.
        within_limits: ``q`` respects the arm's joint limits.
        measure: the errors of joint positions against the target (:data:`IKErrors`).
        position_tolerance: m; an answer farther from the target is no ``success``.
        orientation_tolerance: rad; an answer turned more from the target orientation is no ``success``.
    """

    q: np.ndarray
    within_limits: bool
    measure: IKErrors
    position_tolerance: float
    orientation_tolerance: float

    @cached_property
    def errors(self) -> tuple[float, float]:
        """Position error (m) and orientation error (rad) of :attr:`q`."""
        return self.measure(self.q)

    @property
    def position_error(self) -> float:
        """Distance (m) between the target and the end effector at :attr:`q`."""
        return self.errors[0]

    @property
    def orientation_error(self) -> float:
        """Angle (rad) between the target and achieved orientations; 0 if none was asked."""
        return self.errors[1]

    @property
    def success(self) -> bool:
        """Within the joint limits and both errors within the tolerances."""
        return (
            self.within_limits
            and self.position_error <= self.position_tolerance
            and self.orientation_error <= self.orientation_tolerance
        )


@runtime_checkable
class Arm(Protocol):
    """A position-controlled arm with a parallel gripper in a PyBullet client.

    Attributes:
        lower: joint lower limits (7,), rad (``-inf`` for a continuous joint).
        upper: joint upper limits (7,), rad (``inf`` for a continuous joint).
        gripper_closed: whether the last gripper command closed it.
    """

    lower: np.ndarray
    upper: np.ndarray
    gripper_closed: bool

    def joint_positions(self) -> np.ndarray:
        """Current arm joint positions (7,), rad."""
        ...

    def solve_ik(
        self, position: ArrayLike, orientation: ArrayLike | None = None, seed: ArrayLike | None = None
    ) -> IKResult:
        """Joint positions putting the end effector at ``position`` (3,) with ``orientation`` (4,) (``None``:
        any), started from ``seed`` (7,) (default: the current joints); the arm's state is left as it was.
        An answer that misses (``not success``) is still returned, for the caller to judge.

        Raises:
            ValueError: the arm knows the position to be beyond its reach (one line, giving the reach).
        """
        ...

    def set_joint_targets(self, q: ArrayLike) -> None:
        """Command arm joint positions ``q`` (7,), rad (non-blocking).

        Raises:
            ValueError: ``q`` is outside the joint limits.
        """
        ...

    def open_gripper(self) -> None:
        """Command the gripper fully open (non-blocking)."""
        ...

    def close_gripper(self) -> None:
        """Command the gripper shut (non-blocking)."""
        ...


def command_gripper(arm: Arm, closed: bool) -> None:
    """Command ``arm``'s gripper closed or open (non-blocking)."""
    if closed:
        arm.close_gripper()
    else:
        arm.open_gripper()
