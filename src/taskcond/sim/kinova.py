"""A Kinova Gen3 7-DoF arm with a two-finger parallel gripper for PyBullet, generated from Kinova's published
kinematics (no Kinova model ships with ``pybullet_data``; the paper's suite has "two 7 DoF robots Franka and
Kinova").

Sources:
    * Kinematics: Kinova Gen3 Ultra lightweight robot User Guide (Kinova Robotics), chapter on the arm's
      kinematics, classic DH parameters of the 7 DoF spherical-wrist arm. Base to frame 0: α = π, all else
      0. Frames 1..7: a_i = 0; α_i = π/2 for i = 1..6, α_7 = π;
      d = -(0.1564+0.1284), -(0.0054+0.0064), -(0.2104+0.2104), -(0.0064+0.0064), -(0.2084+0.1059), 0,
      -(0.1059+0.0615) m; θ_i = q_i + offset with offsets 0, π, π, π, π, π, π. Frame 7 is Kinova's tool
      frame (the flange of the interface module, z pointing out of the arm). Each d is printed as a sum of
      the two housings that meet at an actuator; the split tells which link carries which length.
    * Joint limits, efforts, velocities and link masses: ``Kinovarobotics/ros_kortex``,
      ``kortex_description/arms/gen3/7dof/urdf/GEN3_URDF_V12.urdf`` (joints 2, 4, 6 limited to ±2.41, ±2.66,
      ±2.23 rad; joints 1, 3, 5, 7 continuous). Its joint origins agree with the DH table above to 0.4 mm.
    * Home pose: Kinova's factory "Home" (0°, 15°, 180°, 230°, 0°, 55°, 90°) with joint 6 at -35° instead of
      55°, which turns the gripper from pointing forward to pointing straight down, the tabletop grasp pose.

The arm's geometry is primitive shapes (cylinders along the actuator axes, spheres at the elbows); inertias
are those of the solid primitives at the published link masses. The gripper is not Kinova's (their Robotiq
2F-85 has a linkage); it is a simple prismatic two-finger hand of the same 85 mm stroke. Its fingers are
coupled by a PyBullet gear constraint because PyBullet ignores URDF ``<mimic>``.

Frames: everything is in metres and radians; poses are in the PyBullet world frame unless a name says
``base``: the robot base frame is the centre of the bottom of the base, z up, x forward. Quaternions are
PyBullet's ``(x, y, z, w)``.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import Literal
from xml.sax.saxutils import quoteattr

import numpy as np
import pybullet as p
from numpy.typing import ArrayLike
from scipy.spatial.transform import Rotation

from taskcond.sim.arm import IKResult
from taskcond.sim.assets import write_urdf
from taskcond.sim.description import GripperSpec

# ----------------------------------------------------------------------------------------------------------
# Published kinematics


@dataclass(frozen=True)
class DHRow:
    """One row of a classic (distal) DH table: ``T = Rz(q + theta_offset) Tz(d) Tx(a) Rx(alpha)``."""

    d: float
    a: float
    alpha: float
    theta_offset: float


GEN3_BASE_TO_FRAME0 = DHRow(d=0.0, a=0.0, alpha=math.pi, theta_offset=0.0)
"""Base frame (z up) to DH frame 0 (z down along joint 1), Kinova User Guide."""

GEN3_HOUSINGS: tuple[tuple[float, float], ...] = (
    (0.1564, 0.1284),
    (0.0054, 0.0064),
    (0.2104, 0.2104),
    (0.0064, 0.0064),
    (0.2084, 0.1059),
    (0.0, 0.0),
    (0.1059, 0.0615),
)
"""Per DH row i: (length carried by link i-1, length carried by link i) along joint i's axis, metres; the
Kinova User Guide prints each ``d_i`` as minus this sum. Link 0 is the base."""

GEN3_DH: tuple[DHRow, ...] = tuple(
    DHRow(
        d=-(proximal + distal),
        a=0.0,
        alpha=math.pi if i == 6 else math.pi / 2,
        theta_offset=0.0 if i == 0 else math.pi,
    )
    for i, (proximal, distal) in enumerate(GEN3_HOUSINGS)
)
"""Kinova Gen3 7-DoF spherical wrist, classic DH, rows 1..7 (Kinova User Guide)."""


@dataclass(frozen=True)
class JointSpec:
    """A revolute arm joint. ``lower``/``upper`` are ``None`` for continuous joints (rad, N·m, rad/s)."""

    name: str
    lower: float | None
    upper: float | None
    effort: float
    velocity: float


GEN3_JOINTS: tuple[JointSpec, ...] = (
    JointSpec("joint_1", None, None, 39.0, 0.8727),
    JointSpec("joint_2", -2.41, 2.41, 39.0, 0.8727),
    JointSpec("joint_3", None, None, 39.0, 0.8727),
    JointSpec("joint_4", -2.66, 2.66, 39.0, 0.8727),
    JointSpec("joint_5", None, None, 9.0, 0.8727),
    JointSpec("joint_6", -2.23, 2.23, 9.0, 0.8727),
    JointSpec("joint_7", None, None, 9.0, 0.8727),
)
"""Limits, efforts and velocities from kortex_description ``GEN3_URDF_V12.urdf``."""

GEN3_LINK_MASSES: tuple[float, ...] = (1.697, 1.3773, 1.1636, 1.1636, 0.9302, 0.6781, 0.6781, 0.5006)
"""kg, base then links 1..7 (bracelet without vision module), kortex_description ``GEN3_URDF_V12.urdf``."""

GEN3_LINK_NAMES: tuple[str, ...] = (
    "base_link",
    "shoulder_link",
    "half_arm_1_link",
    "half_arm_2_link",
    "forearm_link",
    "spherical_wrist_1_link",
    "spherical_wrist_2_link",
    "bracelet_link",
)

GEN3_HOME = np.radians([0.0, 15.0, 180.0, 230.0 - 360.0, 0.0, -35.0, 90.0])
GEN3_HOME.setflags(write=False)
"""Home joint positions (7,), rad: Kinova's Home with the gripper pointing down (see module docstring)."""

ACTUATOR_RADII: tuple[float, ...] = (0.05, 0.045, 0.045, 0.045, 0.04, 0.035, 0.035)
"""Radius (m) of the housing along each joint axis 1..7 (large actuators on joints 1-4, small on 5-7);
approximate, from the Gen3 specification drawings' 90-100 mm and 70 mm diameters."""


@dataclass(frozen=True)
class GripperGeometry:
    """The parallel gripper mounted on Kinova's tool frame (frame 7, z out of the flange); metres, kg, N.

    The palm is a box from the flange to ``palm_size[2]``; each finger is a box of ``finger_size`` (x, y
    thickness, z length) whose inner face sits ``q`` from the centre plane, ``q`` being its joint position in
    ``[0, max_opening / 2]``. The tool centre point is on the tool z axis between the finger pads,
    ``tcp_from_tip`` back from the fingertips.
    """

    palm_size: tuple[float, float, float] = (0.05, 0.11, 0.06)
    palm_mass: float = 0.6
    finger_size: tuple[float, float, float] = (0.03, 0.015, 0.055)
    finger_mass: float = 0.05
    max_opening: float = 0.085
    finger_force: float = 40.0
    finger_velocity: float = 0.15
    finger_friction: float = 1.5
    tcp_from_tip: float = 0.02

    @property
    def tcp_offset(self) -> float:
        """Distance (m) from the tool frame to the tool centre point along the tool z axis."""
        return self.palm_size[2] + self.finger_size[2] - self.tcp_from_tip


GEN3_GRIPPER = GripperGeometry()
"""The geometry of the Gen3's two-finger gripper that the URDF builder and the arm's kinematics use."""


# ----------------------------------------------------------------------------------------------------------
# Forward kinematics


def dh_transform(row: DHRow, q: float) -> np.ndarray:
    """Homogeneous transform (4, 4) of one classic DH row at joint position ``q`` (rad)."""
    theta = q + row.theta_offset
    ct, st = math.cos(theta), math.sin(theta)
    ca, sa = math.cos(row.alpha), math.sin(row.alpha)
    return np.array(
        [
            [ct, -st * ca, st * sa, row.a * ct],
            [st, ct * ca, -ct * sa, row.a * st],
            [0.0, sa, ca, row.d],
            [0.0, 0.0, 0.0, 1.0],
        ]
    )


def forward_kinematics(q: ArrayLike, tcp_offset: float = 0.0) -> np.ndarray:
    """Pose (4, 4) of Kinova's tool frame, moved ``tcp_offset`` m along its z axis, in the robot base frame.

    Args:
        q: joint positions (7,), rad.
        tcp_offset: 0 for the tool frame (flange); ``GEN3_GRIPPER.tcp_offset`` for the gripper's tool
            centre point.
    """
    q = np.asarray(q, dtype=float)
    if q.shape != (7,):
        raise ValueError(f"expected 7 joint positions, got shape {q.shape}")
    pose = dh_transform(GEN3_BASE_TO_FRAME0, 0.0)
    for row, qi in zip(GEN3_DH, q, strict=True):
        pose = pose @ dh_transform(row, qi)
    tool = np.eye(4)
    tool[2, 3] = tcp_offset
    return pose @ tool


def _rot_z(theta: float) -> np.ndarray:
    pose = np.eye(4)
    pose[:2, :2] = [[math.cos(theta), -math.sin(theta)], [math.sin(theta), math.cos(theta)]]
    return pose


def _translation(x: float, y: float, z: float) -> np.ndarray:
    pose = np.eye(4)
    pose[:3, 3] = (x, y, z)
    return pose


GEN3_SHOULDER_HEIGHT = -GEN3_DH[0].d
"""Height (m) of the shoulder (joint 2 centre, on the joint 1 axis) above the base frame."""

GEN3_SHOULDER_TO_FLANGE = sum(abs(row.d) + abs(row.a) for row in GEN3_DH[1:])
"""Upper bound (m) on the distance from the shoulder to the tool frame: the length of the straight arm."""


# ----------------------------------------------------------------------------------------------------------
# URDF generation


@dataclass(frozen=True)
class Solid:
    """A solid primitive in a link's frame. ``size``: cylinder (radius, length along its z), sphere
    (radius,), box (x, y, z) full extents; ``pose`` (4, 4) places its centre."""

    kind: Literal["cylinder", "sphere", "box"]
    size: tuple[float, ...]
    pose: np.ndarray

    def volume(self) -> float:
        if self.kind == "cylinder":
            radius, length = self.size
            return math.pi * radius**2 * length
        if self.kind == "sphere":
            return 4.0 / 3.0 * math.pi * self.size[0] ** 3
        return float(np.prod(self.size))

    def central_inertia(self, mass: float) -> np.ndarray:
        """Inertia tensor (3, 3), kg·m², of the solid about its centre, in its own axes."""
        if self.kind == "cylinder":
            r, h = self.size
            side = mass * (3 * r**2 + h**2) / 12
            return np.diag([side, side, mass * r**2 / 2])
        if self.kind == "sphere":
            return np.eye(3) * 0.4 * mass * self.size[0] ** 2
        x, y, z = self.size
        return np.diag([y**2 + z**2, x**2 + z**2, x**2 + y**2]) * mass / 12

    def geometry_xml(self) -> str:
        if self.kind == "cylinder":
            return f'<cylinder radius="{self.size[0]:.6g}" length="{self.size[1]:.6g}"/>'
        if self.kind == "sphere":
            return f'<sphere radius="{self.size[0]:.6g}"/>'
        return '<box size="{:.6g} {:.6g} {:.6g}"/>'.format(*self.size)


@dataclass(frozen=True)
class LinkSpec:
    """A URDF link of uniform density: its total mass (kg) is shared among its shapes by volume. A link
    without shapes is a frame marker (e.g. the tool centre point) with a token inertia."""

    name: str
    mass: float
    shapes: tuple[Solid, ...] = ()
    rgba: tuple[float, float, float, float] = (0.75, 0.75, 0.78, 1.0)
    lateral_friction: float | None = None

    def inertial(self) -> tuple[np.ndarray, np.ndarray]:
        """Centre of mass (3,) and inertia tensor about it (3, 3) in the link frame."""
        if not self.shapes:
            return np.zeros(3), np.eye(3) * 1e-6
        volumes = np.array([s.volume() for s in self.shapes])
        masses = self.mass * volumes / volumes.sum()
        centres = np.array([s.pose[:3, 3] for s in self.shapes])
        com = masses @ centres / self.mass
        inertia = np.zeros((3, 3))
        for shape, m, c in zip(self.shapes, masses, centres, strict=True):
            rot = shape.pose[:3, :3]
            r = c - com
            inertia += rot @ shape.central_inertia(m) @ rot.T + m * (r @ r * np.eye(3) - np.outer(r, r))
        return com, inertia


INERTIA_ENTRIES = {"ixx": (0, 0), "ixy": (0, 1), "ixz": (0, 2), "iyy": (1, 1), "iyz": (1, 2), "izz": (2, 2)}


def _origin_xml(pose: np.ndarray) -> str:
    x, y, z = pose[:3, 3]
    roll, pitch, yaw = Rotation.from_matrix(pose[:3, :3]).as_euler("xyz")
    return f'<origin xyz="{x:.9g} {y:.9g} {z:.9g}" rpy="{roll:.9g} {pitch:.9g} {yaw:.9g}"/>'


def _link_xml(link: LinkSpec) -> str:
    com, inertia = link.inertial()
    lines = [
        f"  <link name={quoteattr(link.name)}>",
        "    <inertial>",
        f"      {_origin_xml(_translation(*com))}",
        f'      <mass value="{link.mass:.6g}"/>',
        "      <inertia "
        + " ".join(f'{k}="{inertia[i, j]:.6g}"' for k, (i, j) in INERTIA_ENTRIES.items())
        + "/>",
        "    </inertial>",
    ]
    if link.lateral_friction is not None:
        lines.append(f'    <contact><lateral_friction value="{link.lateral_friction:g}"/></contact>')
    rgba = " ".join(f"{c:g}" for c in link.rgba)
    for shape in link.shapes:
        origin, geometry = _origin_xml(shape.pose), shape.geometry_xml()
        lines += [
            f"    <visual>{origin}<geometry>{geometry}</geometry>",
            f'      <material name=""><color rgba="{rgba}"/></material></visual>',
            f"    <collision>{origin}<geometry>{geometry}</geometry></collision>",
        ]
    lines.append("  </link>")
    return "\n".join(lines)


@dataclass(frozen=True)
class JointXml:
    """A URDF joint; ``origin`` (4, 4) is the child frame in the parent frame at zero joint position."""

    name: str
    kind: Literal["revolute", "continuous", "prismatic", "fixed"]
    parent: str
    child: str
    origin: np.ndarray
    axis: tuple[float, float, float] = (0.0, 0.0, 1.0)
    limits: tuple[float, float] | None = None
    effort: float = 0.0
    velocity: float = 0.0

    def xml(self) -> str:
        lines = [
            f"  <joint name={quoteattr(self.name)} type={quoteattr(self.kind)}>",
            f"    <parent link={quoteattr(self.parent)}/>",
            f"    <child link={quoteattr(self.child)}/>",
            f"    {_origin_xml(self.origin)}",
        ]
        if self.kind != "fixed":
            lines.append('    <axis xyz="{:g} {:g} {:g}"/>'.format(*self.axis))
            bounds = (
                "" if self.limits is None else f'lower="{self.limits[0]:.9g}" upper="{self.limits[1]:.9g}" '
            )
            lines.append(f'    <limit {bounds}effort="{self.effort:g}" velocity="{self.velocity:g}"/>')
        lines.append("  </joint>")
        return "\n".join(lines)


def _axis_segment(origin: np.ndarray, start: float, end: float, radius: float) -> Solid:
    """Cylinder on the z axis of frame ``origin`` (4, 4) between z = ``start`` and z = ``end``."""
    return Solid("cylinder", (radius, abs(end - start)), origin @ _translation(0.0, 0.0, (start + end) / 2))


TOOL_LINK = "tool_frame"
TCP_LINK = "tcp_link"
FINGER_LINKS = ("left_finger_link", "right_finger_link")
FINGER_JOINTS = ("left_finger_joint", "right_finger_joint")


@dataclass
class _UrdfBuilder:
    links: list[LinkSpec] = field(default_factory=list)
    joints: list[JointXml] = field(default_factory=list)

    def xml(self) -> str:
        body = [_link_xml(link) for link in self.links] + [joint.xml() for joint in self.joints]
        return '<?xml version="1.0"?>\n<robot name="kinova_gen3_7dof">\n' + "\n".join(body) + "\n</robot>\n"


def gen3_urdf(gripper: GripperGeometry = GEN3_GRIPPER) -> str:
    """The URDF text of the Gen3 7-DoF arm with the parallel gripper.

    Link frames: link ``i`` (1..7) is DH frame ``i-1`` turned by joint ``i``, so joint ``i`` is its z axis;
    ``tool_frame`` is DH frame 7 (Kinova's tool frame); ``tcp_link`` is the tool centre point, ``tcp_offset``
    along the tool z axis. Joints 1..7 are named ``joint_1``..``joint_7``, the fingers ``left_finger_joint``
    (moves along +y of the tool frame) and ``right_finger_joint`` (along -y).
    """
    builder = _UrdfBuilder()
    # Joint i's origin in link i-1: the rest of DH row i-1 after its rotation, then joint i's theta offset.
    origins = [dh_transform(GEN3_BASE_TO_FRAME0, 0.0) @ _rot_z(GEN3_DH[0].theta_offset)]
    for row, next_row in itertools.pairwise(GEN3_DH):
        origins.append(dh_transform(row, -row.theta_offset) @ _rot_z(next_row.theta_offset))
    tool_origin = dh_transform(GEN3_DH[-1], -GEN3_DH[-1].theta_offset)

    shapes: list[list[Solid]] = [[] for _ in GEN3_LINK_NAMES]
    for i, ((proximal, distal), row, radius) in enumerate(
        zip(GEN3_HOUSINGS, GEN3_DH, ACTUATOR_RADII, strict=True)
    ):
        sign = math.copysign(1.0, row.d)
        # The proximal housing belongs to link i (before joint i+1), placed through joint i+1's origin; it
        # is symmetric about that joint's axis, so the joint's rotation does not move it.
        if proximal > 0:
            shapes[i].append(_axis_segment(origins[i], 0.0, sign * proximal, radius))
        if distal > 0:
            shapes[i + 1].append(_axis_segment(np.eye(4), sign * proximal, row.d, radius))
        if i > 0:  # the actuator housing where the arm bends, centred on DH frame i-1 = link i+1's origin
            shapes[i + 1].append(Solid("sphere", (radius,), np.eye(4)))
    for name, mass, link_shapes in zip(GEN3_LINK_NAMES, GEN3_LINK_MASSES, shapes, strict=True):
        builder.links.append(LinkSpec(name, mass, tuple(link_shapes), rgba=(0.2, 0.2, 0.22, 1.0)))
    for spec, parent, child, origin in zip(
        GEN3_JOINTS, GEN3_LINK_NAMES[:-1], GEN3_LINK_NAMES[1:], origins, strict=True
    ):
        limited = spec.lower is not None and spec.upper is not None
        builder.joints.append(
            JointXml(
                spec.name,
                "revolute" if limited else "continuous",
                parent,
                child,
                origin,
                limits=(spec.lower, spec.upper) if limited else None,
                effort=spec.effort,
                velocity=spec.velocity,
            )
        )

    px, py, pz = gripper.palm_size
    fx, fy, fz = gripper.finger_size
    builder.links.append(LinkSpec(TOOL_LINK, 1e-3))
    builder.joints.append(JointXml("tool_joint", "fixed", GEN3_LINK_NAMES[-1], TOOL_LINK, tool_origin))
    builder.links.append(
        LinkSpec(
            "gripper_palm_link", gripper.palm_mass, (Solid("box", (px, py, pz), _translation(0, 0, pz / 2)),)
        )
    )
    builder.joints.append(JointXml("gripper_mount_joint", "fixed", TOOL_LINK, "gripper_palm_link", np.eye(4)))
    for name, link, side in zip(FINGER_JOINTS, FINGER_LINKS, (1.0, -1.0), strict=True):
        finger = Solid("box", (fx, fy, fz), _translation(0.0, side * fy / 2, fz / 2))
        builder.links.append(
            LinkSpec(link, gripper.finger_mass, (finger,), (0.1, 0.1, 0.1, 1.0), gripper.finger_friction)
        )
        builder.joints.append(
            JointXml(
                name,
                "prismatic",
                "gripper_palm_link",
                link,
                _translation(0.0, 0.0, pz),
                axis=(0.0, side, 0.0),
                limits=(0.0, gripper.max_opening / 2),
                effort=gripper.finger_force,
                velocity=gripper.finger_velocity,
            )
        )
    builder.links.append(LinkSpec(TCP_LINK, 1e-3))
    builder.joints.append(
        JointXml("tcp_joint", "fixed", TOOL_LINK, TCP_LINK, _translation(0, 0, gripper.tcp_offset))
    )
    return builder.xml()


def gen3_urdf_path(gripper: GripperGeometry = GEN3_GRIPPER) -> Path:
    """Write :func:`gen3_urdf` beside the suite's other generated assets (through
    :func:`~taskcond.sim.assets.write_urdf`, named by a hash of the text, so a changed model never reuses a
    stale file) and return its absolute path."""
    return write_urdf("kinova_gen3", gen3_urdf(gripper)).resolve()


# ----------------------------------------------------------------------------------------------------------
# Controller


class KinovaArm:
    """A Kinova Gen3 7-DoF arm with the parallel gripper, loaded into a PyBullet client; an
    :class:`~taskcond.sim.arm.Arm`.

    Joint commands use PyBullet position control at the published efforts and velocities. :meth:`step` and
    the methods whose name says ``move`` step the simulation (``p.stepSimulation`` on the arm's client, which
    moves the whole world); the others only set motor targets or read state (IK restores what it touches).

    Args:
        client: PyBullet physics client id.
        base_position: world position (3,) of the robot base frame (centre of the base's bottom), m.
        base_orientation: world orientation of the base frame, quaternion (x, y, z, w).
        gripper: the gripper's geometry (the URDF is generated for it).
    """

    position_tolerance = 1e-3
    """m: IK answers farther than this from the target are failures."""
    orientation_tolerance = 1e-2
    """rad: IK answers turned more than this from the target orientation are failures."""
    ik_rounds = 20
    """Rounds of PyBullet's IK (100 iterations each), each from the previous answer clamped into the limits;
    IK stops early once ten times inside both tolerances."""

    def __init__(
        self,
        client: int,
        base_position: ArrayLike = (0.0, 0.0, 0.0),
        base_orientation: ArrayLike = (0.0, 0.0, 0.0, 1.0),
        gripper: GripperGeometry = GEN3_GRIPPER,
    ) -> None:
        self.client = client
        self.gripper = gripper
        self.reach = GEN3_SHOULDER_TO_FLANGE + gripper.tcp_offset
        """Upper bound (m) on the distance from the shoulder to the tool centre point."""
        self.base_position = np.asarray(base_position, dtype=float)
        self.base_orientation = np.asarray(base_orientation, dtype=float)
        self.base_pose = np.eye(4)
        self.base_pose[:3, :3] = Rotation.from_quat(self.base_orientation).as_matrix()
        self.base_pose[:3, 3] = self.base_position
        self.body_id = p.loadURDF(
            str(gen3_urdf_path(gripper)),
            self.base_position.tolist(),
            self.base_orientation.tolist(),
            useFixedBase=True,
            physicsClientId=client,
        )
        joints = {}
        links = {}
        for index in range(p.getNumJoints(self.body_id, physicsClientId=client)):
            info = p.getJointInfo(self.body_id, index, physicsClientId=client)
            joints[info[1].decode()] = index
            links[info[12].decode()] = index
        self.arm_joints = tuple(joints[spec.name] for spec in GEN3_JOINTS)
        self.finger_joints: tuple[int, int] = (joints[FINGER_JOINTS[0]], joints[FINGER_JOINTS[1]])
        self.finger_links: tuple[int, int] = (links[FINGER_LINKS[0]], links[FINGER_LINKS[1]])
        self.tool_link = links[TOOL_LINK]
        self.ee_link = links[TCP_LINK]
        self.lower = np.array([-np.inf if s.lower is None else s.lower for s in GEN3_JOINTS])
        self.upper = np.array([np.inf if s.upper is None else s.upper for s in GEN3_JOINTS])
        self.continuous = np.array([s.lower is None for s in GEN3_JOINTS])
        self.shoulder = (self.base_pose @ np.array([0.0, 0.0, GEN3_SHOULDER_HEIGHT, 1.0]))[:3]
        # URDF <mimic> is ignored by PyBullet: the right finger follows the left through a gear constraint,
        # and only the left finger has a motor.
        self._gear = p.createConstraint(
            self.body_id,
            self.finger_joints[0],
            self.body_id,
            self.finger_joints[1],
            p.JOINT_GEAR,
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 0.0],
            [0.0, 0.0, 0.0],
            physicsClientId=client,
        )
        p.changeConstraint(
            self._gear, gearRatio=-1.0, erp=0.2, maxForce=gripper.finger_force, physicsClientId=client
        )
        p.setJointMotorControl2(
            self.body_id, self.finger_joints[1], p.VELOCITY_CONTROL, force=0.0, physicsClientId=client
        )
        self.gripper_closed = False
        """Whether the last gripper command was (more than half way) closed."""
        self.reset_home()

    # -- state -------------------------------------------------------------------------------------------

    def joint_positions(self) -> np.ndarray:
        """Current arm joint positions (7,), rad."""
        states = p.getJointStates(self.body_id, self.arm_joints, physicsClientId=self.client)
        return np.array([s[0] for s in states])

    def forward_kinematics(self, q: ArrayLike) -> np.ndarray:
        """World pose (4, 4) of the tool centre point at joint positions ``q`` (7,), from the DH table."""
        return self.base_pose @ forward_kinematics(q, self.gripper.tcp_offset)

    def ee_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """World position (3,) and quaternion (4,) of the tool centre point link, as PyBullet has it."""
        state = p.getLinkState(
            self.body_id, self.ee_link, computeForwardKinematics=True, physicsClientId=self.client
        )
        return np.array(state[4]), np.array(state[5])

    def within_limits(self, q: ArrayLike) -> bool:
        """Whether joint positions ``q`` (7,) respect the limits of joints 2, 4 and 6."""
        q = np.asarray(q, dtype=float)
        return bool(np.all(q >= self.lower) and np.all(q <= self.upper))

    # -- joint control -----------------------------------------------------------------------------------

    def reset_home(self) -> None:
        """Teleport to :data:`GEN3_HOME` with the gripper open, and hold there."""
        for index, value in zip(self.arm_joints, GEN3_HOME, strict=True):
            p.resetJointState(self.body_id, index, value, physicsClientId=self.client)
        for index in self.finger_joints:
            p.resetJointState(self.body_id, index, self.gripper.max_opening / 2, physicsClientId=self.client)
        self.set_joint_targets(GEN3_HOME)
        self.open_gripper()

    def set_joint_targets(self, q: ArrayLike) -> None:
        """Command arm joint positions ``q`` (7,), rad, at the published efforts and speeds.

        Raises:
            ValueError: ``q`` is outside the limits of joints 2, 4 or 6.
        """
        q = np.asarray(q, dtype=float)
        if not self.within_limits(q):
            raise ValueError(
                f"joint target {np.round(q, 3).tolist()} is outside the Kinova Gen3 joint limits"
            )
        for index, value, spec in zip(self.arm_joints, q, GEN3_JOINTS, strict=True):
            p.setJointMotorControl2(
                self.body_id,
                index,
                p.POSITION_CONTROL,
                targetPosition=float(value),
                force=spec.effort,
                maxVelocity=spec.velocity,
                physicsClientId=self.client,
            )

    def step(self, steps: int = 1) -> None:
        """Advance the simulation ``steps`` steps."""
        for _ in range(steps):
            p.stepSimulation(physicsClientId=self.client)

    def move_joints(self, q: ArrayLike, max_steps: int = 1200, tolerance: float = 1e-3) -> bool:
        """Drive the arm to joint positions ``q`` (7,), stepping until every joint is within ``tolerance``
        rad or ``max_steps`` have run; returns whether it arrived."""
        target = np.asarray(q, dtype=float)
        self.set_joint_targets(target)
        for _ in range(max_steps):
            self.step()
            if np.all(np.abs(self.joint_positions() - target) < tolerance):
                return True
        return False

    # -- Cartesian control -------------------------------------------------------------------------------

    def _check_reach(self, position: np.ndarray) -> None:
        distance = float(np.linalg.norm(position - self.shoulder))
        if distance > self.reach:
            raise ValueError(
                f"target {np.round(position, 3).tolist()} is {distance:.3f} m from the Kinova Gen3 shoulder, "
                f"beyond its reach of {self.reach:.3f} m"
            )

    def solve_ik(
        self, position: ArrayLike, orientation: ArrayLike | None = None, seed: ArrayLike | None = None
    ) -> IKResult:
        """Joint positions putting the tool centre point at a world pose, by PyBullet's IK.

        Plain (not null-space) IK, 100 iterations per round, started from ``seed`` (default: the current
        joints) and restarted from its own answer up to :attr:`ik_rounds` times; the best answer is returned
        and the arm's state restored. Errors are measured with the DH forward kinematics; a solution that is
        not ``success`` (out of limits, or too far off) is still returned, for the caller to judge. Its
        continuous joints are within π of the seed, its limited ones in (-π, π].

        Args:
            position: world position (3,), m.
            orientation: world quaternion (x, y, z, w) of the tool centre point, or ``None`` for any.
            seed: joint positions (7,) to start from.

        Raises:
            ValueError: the position is beyond the arm's reach (one line, giving the reach).
        """
        target = np.asarray(position, dtype=float)
        self._check_reach(target)
        target_rotation = None if orientation is None else Rotation.from_quat(np.asarray(orientation, float))
        saved = p.getJointStates(self.body_id, self.arm_joints, physicsClientId=self.client)
        start = np.array([s[0] for s in saved]) if seed is None else np.asarray(seed, dtype=float)
        best = self._ik_result(start, start, target, target_rotation)
        q = start
        try:
            for _ in range(self.ik_rounds):
                for index, value in zip(self.arm_joints, q, strict=True):
                    p.resetJointState(self.body_id, index, value, physicsClientId=self.client)
                kwargs = {} if orientation is None else {"targetOrientation": list(orientation)}
                solution = p.calculateInverseKinematics(
                    self.body_id,
                    self.ee_link,
                    target.tolist(),
                    maxNumIterations=100,
                    residualThreshold=1e-6,
                    physicsClientId=self.client,
                    **kwargs,
                )
                result = self._ik_result(
                    np.array(solution[: len(self.arm_joints)]), start, target, target_rotation
                )
                if (not result.success, result.position_error) < (not best.success, best.position_error):
                    best = result
                if (
                    result.success
                    and result.position_error < self.position_tolerance / 10
                    and result.orientation_error < self.orientation_tolerance / 10
                ):
                    break
                q = np.clip(result.q, self.lower, self.upper)  # restart inside the limits
        finally:
            for index, (value, velocity, *_rest) in zip(self.arm_joints, saved, strict=True):
                p.resetJointState(self.body_id, index, value, velocity, physicsClientId=self.client)
        return best

    def _ik_result(
        self, q: np.ndarray, seed: np.ndarray, target: np.ndarray, rotation: Rotation | None
    ) -> IKResult:
        # Angles 2π apart are the same pose: continuous joints go nearest the seed, limited ones (all within
        # ±π) into (-π, π], where their limits are.
        q = np.where(
            self.continuous,
            seed + (q - seed + np.pi) % (2 * np.pi) - np.pi,
            -((np.pi - q) % (2 * np.pi)) + np.pi,
        )
        return IKResult(
            q,
            within_limits=self.within_limits(q),
            measure=partial(self._ik_errors, target, rotation),
            position_tolerance=self.position_tolerance,
            orientation_tolerance=self.orientation_tolerance,
        )

    def _ik_errors(self, target: np.ndarray, rotation: Rotation | None, q: np.ndarray) -> tuple[float, float]:
        """Position (m) and orientation (rad) errors of the tool centre point at ``q`` (DH forward kinematics)
        against the target."""
        pose = self.forward_kinematics(q)
        position_error = float(np.linalg.norm(pose[:3, 3] - target))
        orientation_error = (
            0.0
            if rotation is None
            else float((rotation.inv() * Rotation.from_matrix(pose[:3, :3])).magnitude())
        )
        return position_error, orientation_error

    def reachable(self, position: ArrayLike, orientation: ArrayLike | None = None) -> bool:
        """Whether IK finds joint positions within limits for this world pose (see :meth:`solve_ik`)."""
        try:
            return self.solve_ik(position, orientation).success
        except ValueError:
            return False

    def move_to(
        self, position: ArrayLike, orientation: ArrayLike | None = None, max_steps: int = 1200
    ) -> IKResult:
        """Solve IK for a world pose of the tool centre point and drive there (see :meth:`move_joints`).

        Raises:
            ValueError: the pose is out of reach or IK finds no solution within the joint limits.
        """
        result = self.solve_ik(position, orientation)
        if not result.success:
            raise ValueError(
                f"no Kinova Gen3 joint solution for {np.round(np.asarray(position, float), 3).tolist()}: "
                f"IK is {result.position_error * 1000:.1f} mm and {result.orientation_error:.3f} rad off"
                f"{'' if result.within_limits else ', outside the joint limits'}"
            )
        self.move_joints(result.q, max_steps=max_steps)
        return result

    # -- gripper -----------------------------------------------------------------------------------------

    def set_gripper(self, opening: float, force: float | None = None) -> None:
        """Command the distance (m) between the finger pads, in ``[0, max_opening]``, pushing with at most
        ``force`` N (default: the gripper's rated force)."""
        half = float(np.clip(opening, 0.0, self.gripper.max_opening)) / 2
        self.gripper_closed = half < self.gripper.max_opening / 4
        p.setJointMotorControl2(
            self.body_id,
            self.finger_joints[0],
            p.POSITION_CONTROL,
            targetPosition=half,
            force=self.gripper.finger_force if force is None else force,
            maxVelocity=self.gripper.finger_velocity,
            physicsClientId=self.client,
        )

    def open_gripper(self) -> None:
        """Command the gripper fully open (non-blocking)."""
        self.set_gripper(self.gripper.max_opening)

    def close_gripper(self, force: float | None = None) -> None:
        """Command the gripper shut, squeezing with at most ``force`` N (non-blocking)."""
        self.set_gripper(0.0, force)

    def gripper_opening(self) -> float:
        """Current distance (m) between the finger pads."""
        states = p.getJointStates(self.body_id, self.finger_joints, physicsClientId=self.client)
        return float(states[0][0] + states[1][0])

    def gripper_spec(self, name: str = "gripper") -> GripperSpec:
        """The gripper as the scene description names it: this body, its finger links and tool-centre link."""
        return GripperSpec(
            body_id=self.body_id, finger_links=self.finger_links, ee_link=self.ee_link, name=name
        )
