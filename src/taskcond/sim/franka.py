"""The Franka Panda arm of the task suite (paper §III-E, §IV): position control, Cartesian↔joint conversion
with PyBullet's inverse kinematics, and a parallel gripper whose fingers are coupled by a gear constraint
(PyBullet ignores the URDF ``mimic`` tag).

Units: metres, radians, newtons. Poses are in the world frame; quaternions are ``(x, y, z, w)``. The
end-effector point is the ``panda_grasptarget`` link, about 1 cm above the fingertips, between the pads.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import partial

import numpy as np
import pybullet as p
import pybullet_data
from numpy.typing import ArrayLike

from taskcond.sim.arm import IKResult, command_gripper
from taskcond.sim.description import GripperSpec

ARM_JOINTS = (0, 1, 2, 3, 4, 5, 6)
FINGER_JOINTS = (9, 10)
EE_LINK = 11
HAND_LINK = 8
HOME = (0.0, -0.3, 0.0, -2.3, 0.0, 2.0, 0.785)
"""Joint positions (rad) of the start pose: gripper pointing down in front of the robot."""
FORWARD_SEED = (0.0, 0.3, 0.0, -2.0, 0.0, 2.3, 0.785)
ARM_FORCES = (87.0, 87.0, 87.0, 87.0, 12.0, 12.0, 12.0)
"""Maximum torque (N·m) of each arm joint's position motor (all seven are revolute)."""
ARM_GAINS = (0.1,) * 7
"""Position gain of each arm joint's position motor (PyBullet's ``positionGains``)."""
FINGER_FORCE = 40.0
"""Force (N) of each finger's position motor; the grasp force on an object."""
FINGER_OPEN = 0.04
"""Finger joint position (m) of the open gripper; the opening between the pads is twice this."""
IK_DAMPING = (1e-3,) * 9
"""Damping of PyBullet's damped least squares IK per degree of freedom (the 7 arm joints and the 2 fingers,
whose Jacobian columns are zero). PyBullet's default, :data:`PYBULLET_IK_DAMPING`, converges slowly and
misses more targets; smaller damping overshoots at the edge of the reach (BENCHMARKS.md, "IK setting")."""
PYBULLET_IK_DAMPING = (0.5,) * 9
"""PyBullet's IK damping when ``jointDamping`` is not given (measured: identical solutions)."""
IK_MAX_ITERATIONS = 20
"""Iteration cap of :meth:`Franka.solve_ik`; most calls stop earlier at :data:`IK_RESIDUAL` (BENCHMARKS.md,
"IK setting")."""
IK_POSITION_TOLERANCE = 1e-3
"""m: an IK answer farther than this from the target is no ``success`` (the Kinova's tolerance)."""
IK_ORIENTATION_TOLERANCE = 1e-2
"""rad: an IK answer turned more than this from the target orientation is no ``success``."""
IK_RESIDUAL = 1e-5
"""Position error (m) at which PyBullet's IK stops iterating (it checks the position only)."""

TOP_DOWN = (1.0, 0.0, 0.0, 0.0)
"""End-effector orientation (xyzw) pointing straight down, fingers closing along world y."""


def top_down(yaw: float = 0.0) -> tuple[float, float, float, float]:
    """Downward-pointing gripper rotated by ``yaw`` (rad) about world z; fingers close along the rotated y."""
    q = p.multiplyTransforms((0, 0, 0), p.getQuaternionFromEuler((0, 0, yaw)), (0, 0, 0), TOP_DOWN)[1]
    return (q[0], q[1], q[2], q[3])


def forward(yaw: float = 0.0) -> tuple[float, float, float, float]:
    """Gripper pointing horizontally along world +x rotated by ``yaw`` (rad) about z; fingers close along
    the horizontal axis perpendicular to it (world y for ``yaw=0``)."""
    q = p.getQuaternionFromEuler((0.0, np.pi / 2, yaw))
    return (q[0], q[1], q[2], q[3])


@dataclass(frozen=True)
class EEPose:
    """End-effector pose: ``position`` (3,) m and ``orientation`` (4,) xyzw quaternion, world frame."""

    position: np.ndarray
    orientation: np.ndarray


class Franka:
    """A fixed-base Panda loaded from ``pybullet_data`` at ``base_position`` in client ``client``; an
    :class:`~taskcond.sim.arm.Arm`."""

    def __init__(self, client: int, base_position: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> None:
        self.client = client
        self.body = p.loadURDF(
            f"{pybullet_data.getDataPath()}/franka_panda/panda.urdf",
            base_position,
            useFixedBase=True,
            flags=p.URDF_USE_INERTIA_FROM_FILE,
            physicsClientId=client,
        )
        info = [p.getJointInfo(self.body, j, physicsClientId=client) for j in ARM_JOINTS]
        self.lower = np.array([i[8] for i in info])
        self.upper = np.array([i[9] for i in info])
        self._limits = [(i[8], i[9]) for i in info]
        """Per arm joint, its (lower, upper) limit (rad) as floats, for :meth:`solve_ik`'s clipping."""
        gear = p.createConstraint(
            self.body,
            FINGER_JOINTS[0],
            self.body,
            FINGER_JOINTS[1],
            p.JOINT_GEAR,
            (1, 0, 0),
            (0, 0, 0),
            (0, 0, 0),
            physicsClientId=client,
        )
        p.changeConstraint(gear, gearRatio=-1, erp=0.1, maxForce=50, physicsClientId=client)
        for link in FINGER_JOINTS:
            p.changeDynamics(
                self.body,
                link,
                lateralFriction=1.5,
                spinningFriction=0.003,
                frictionAnchor=True,
                physicsClientId=client,
            )
        base_dynamics = p.getDynamicsInfo(self.body, -1, physicsClientId=client)
        self._ik_bias: tuple[float, float, float] = base_dynamics[3]
        """Position (m) of the base's centre of mass in its link frame, subtracted from IK targets."""
        self.gripper_closed = False
        self._arm_targets: list[float] | None = None
        """Arm joint targets (rad) last sent to the motors by :meth:`set_joint_targets`."""
        self._finger_target: float | None = None
        """Finger joint target (m) last sent to the motors by :meth:`open_gripper`/:meth:`close_gripper`."""
        self.reset(HOME)

    @property
    def spec(self) -> GripperSpec:
        return GripperSpec(body_id=self.body, finger_links=FINGER_JOINTS, ee_link=EE_LINK)

    # ---------------------------------------------------------------------------------------- state
    def joint_positions(self) -> np.ndarray:
        """Arm joint positions (7,) rad."""
        states = p.getJointStates(self.body, ARM_JOINTS, physicsClientId=self.client)
        return np.array([s[0] for s in states])

    def finger_width(self) -> float:
        """Opening between the finger pads (m)."""
        states = p.getJointStates(self.body, FINGER_JOINTS, physicsClientId=self.client)
        return float(states[0][0] + states[1][0])

    def ee_pose(self) -> EEPose:
        position, orientation = self.ee_frame()
        return EEPose(np.array(position), np.array(orientation))

    def ee_frame(self) -> tuple[tuple[float, float, float], tuple[float, float, float, float]]:
        """End-effector position (m) and quaternion (xyzw), world frame, as PyBullet reports them (forward
        kinematics of the current joints); :meth:`ee_pose` as tuples."""
        # positional: (body, link, computeLinkVelocity, computeForwardKinematics, physicsClientId)
        state = p.getLinkState(self.body, EE_LINK, 0, 1, self.client)
        return state[4], state[5]

    def reset(self, q: tuple[float, ...] | np.ndarray, finger: float = FINGER_OPEN) -> None:
        """Set the arm to ``q`` (7,) rad and the fingers to ``finger`` m at rest (episode reset only) and
        hold it with the motors."""
        for j, v in zip(ARM_JOINTS, q, strict=True):
            p.resetJointState(self.body, j, float(v), physicsClientId=self.client)
        for j in FINGER_JOINTS:
            p.resetJointState(self.body, j, finger, physicsClientId=self.client)
        self.set_joint_targets(q)
        command_gripper(self, closed=finger < FINGER_OPEN / 2)

    # ------------------------------------------------------------------------------------- control
    def solve_ik(
        self,
        position: ArrayLike,
        orientation: ArrayLike | None = None,
        seed: ArrayLike | None = None,
        damping: tuple[float, ...] = IK_DAMPING,
        max_iterations: int = IK_MAX_ITERATIONS,
    ) -> IKResult:
        """Joint positions (7,) rad putting the end effector at ``position`` (3,) m with ``orientation``
        (4,) xyzw (``None``: any), world frame (:meth:`taskcond.sim.arm.Arm.solve_ik`); damped least squares
        IK (``damping`` per degree of freedom, at most ``max_iterations`` iterations; the defaults are the
        measured :data:`IK_DAMPING` and :data:`IK_MAX_ITERATIONS`) started from ``seed`` (default the current
        joints), clipped to the joint limits, so always ``within_limits``. PyBullet's IK measures targets
        from the base's centre of mass, not its link frame, so the target is shifted by that offset. The
        errors are measured with PyBullet's forward kinematics (:meth:`fk`) when first read. Never raises:
        the Panda has no reach check."""
        seed = self.joint_positions() if seed is None else np.asarray(seed, dtype=float)
        x, y, z = position  # type: ignore[misc]
        bx, by, bz = self._ik_bias
        turn = {} if orientation is None else {"targetOrientation": tuple(map(float, orientation))}  # type: ignore[arg-type]
        q = p.calculateInverseKinematics(
            self.body,
            EE_LINK,
            (float(x) - bx, float(y) - by, float(z) - bz),
            currentPositions=(*seed.tolist(), 0.0, 0.0),
            jointDamping=damping,
            maxNumIterations=max_iterations,
            residualThreshold=IK_RESIDUAL,
            physicsClientId=self.client,
            **turn,
        )
        # np.minimum(np.maximum(q, lower), upper) in Python floats (NaN passes through, as in numpy)
        clipped = np.array(
            [lo if v < lo else hi if v > hi else v for v, (lo, hi) in zip(q[:7], self._limits, strict=True)]
        )
        return IKResult(
            clipped,
            within_limits=True,
            measure=partial(self._ik_errors, np.asarray(position, dtype=float), orientation),
            position_tolerance=IK_POSITION_TOLERANCE,
            orientation_tolerance=IK_ORIENTATION_TOLERANCE,
        )

    def _ik_errors(
        self, target: np.ndarray, orientation: ArrayLike | None, q: np.ndarray
    ) -> tuple[float, float]:
        """Position (m) and orientation (rad) errors of the end effector at ``q`` against the target."""
        pose = self.fk(q)
        position_error = float(np.linalg.norm(pose.position - target))
        if orientation is None:
            return position_error, 0.0
        want = np.asarray(orientation, dtype=float)
        cosine = abs(float(np.dot(pose.orientation, want))) / (
            float(np.linalg.norm(pose.orientation)) * float(np.linalg.norm(want))
        )
        return position_error, 2 * math.acos(min(1.0, cosine))

    def fk(self, q: np.ndarray) -> EEPose:
        """End-effector pose for joints ``q`` (7,), computed by resetting the joints and restoring them with
        their velocities (no physics step in between)."""
        states = p.getJointStates(self.body, ARM_JOINTS, physicsClientId=self.client)
        for j, v in zip(ARM_JOINTS, q, strict=True):
            p.resetJointState(self.body, j, float(v), physicsClientId=self.client)
        pose = self.ee_pose()
        for j, s in zip(ARM_JOINTS, states, strict=True):
            p.resetJointState(self.body, j, s[0], s[1], physicsClientId=self.client)
        return pose

    def clearance(self, qs: Sequence[np.ndarray], bodies: Sequence[tuple[int, int]], within: float) -> float:
        """Least distance (m, negative for penetration, at most ``within``) between the arm's links and
        the ``bodies`` (body id, link index or -1 for every link) over the joint configurations ``qs``
        (each (7,) rad), by resetting the joints to each and restoring them with their velocities at the
        end (no physics step in between)."""
        states = p.getJointStates(self.body, ARM_JOINTS, physicsClientId=self.client)
        least = within
        try:
            for q in qs:
                for j, v in zip(ARM_JOINTS, q, strict=True):
                    p.resetJointState(self.body, j, float(v), physicsClientId=self.client)
                for body, link in bodies:
                    extra = {} if link < 0 else {"linkIndexB": link}
                    for point in p.getClosestPoints(
                        self.body, body, within, physicsClientId=self.client, **extra
                    ):
                        least = min(least, float(point[8]))
        finally:
            for j, st in zip(ARM_JOINTS, states, strict=True):
                p.resetJointState(self.body, j, st[0], st[1], physicsClientId=self.client)
        return least

    def set_joint_targets(self, q: ArrayLike) -> None:
        """Position targets of the arm joints ``q`` (7,) rad (:meth:`taskcond.sim.arm.Arm.set_joint_targets`).
        Bullet keeps a motor's settings until they are set again, so targets equal to the last ones sent are
        not sent again.

        Raises:
            ValueError: ``q`` is outside the joint limits.
        """
        targets = np.asarray(q, dtype=float).tolist()
        if targets == self._arm_targets:
            return
        if any(v < lo or v > hi for v, (lo, hi) in zip(targets, self._limits, strict=True)):
            raise ValueError(
                f"joint target {np.round(targets, 3).tolist()} is outside the Franka Panda joint limits"
            )
        p.setJointMotorControlArray(
            self.body,
            ARM_JOINTS,
            p.POSITION_CONTROL,
            targetPositions=targets,
            forces=ARM_FORCES,
            positionGains=ARM_GAINS,
            physicsClientId=self.client,
        )
        self._arm_targets = targets

    def open_gripper(self) -> None:
        """Command the fingers open to :data:`FINGER_OPEN` (non-blocking)."""
        self._command_fingers(closed=False)

    def close_gripper(self) -> None:
        """Command the finger pads pushed together with :data:`FINGER_FORCE` (non-blocking)."""
        self._command_fingers(closed=True)

    def _command_fingers(self, closed: bool) -> None:
        self.gripper_closed = closed
        target = 0.0 if closed else FINGER_OPEN
        if target == self._finger_target:
            return
        self._finger_target = target
        p.setJointMotorControlArray(
            self.body,
            FINGER_JOINTS,
            p.POSITION_CONTROL,
            targetPositions=[target, target],
            forces=[FINGER_FORCE, FINGER_FORCE],
            positionGains=[0.05, 0.05],
            physicsClientId=self.client,
        )
