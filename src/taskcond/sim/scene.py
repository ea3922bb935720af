"""The kitchen scene of the task suite (paper §IV, Fig. 4): a counter with a Franka Panda, a cabinet with a
top and a bottom drawer, a box with a hinged lid, a microwave, a bottle, a bowl, a mug, a toothpaste tube,
a spatula and two distractors.

World frame: z up, metres; the counter top is the plane z = 0 and the robot base sits on it at the origin,
facing +x. The cabinet stands on the robot's left (+y), the microwave on its right (-y), the box in front
and the free objects between the robot and the furniture (see ``reference-scene.png``).

Articulated objects have PyBullet's default joint motors replaced by a weak velocity motor with target 0,
which acts as joint friction; drawers, lid and door only move when the gripper pushes or pulls them.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from itertools import chain
from operator import itemgetter
from typing import Literal

import numpy as np
import pybullet as p

from taskcond.conditions import GRIPPER, KINOVA_GRIPPER
from taskcond.sim.assets import (
    AssetSpec,
    BlockSpec,
    BottleSpec,
    BoxSpec,
    CabinetSpec,
    Interior,
    MeshSpec,
    MicrowaveSpec,
    SpatulaSpec,
    TableSpec,
    VesselSpec,
    build_asset,
)
from taskcond.sim.cloth import ClothGrips, ClothSpec, GripperHandle, cloth_nodes, load_cloth
from taskcond.sim.description import ContainerJoint, GripperSpec, NamedBody, SceneDescription
from taskcond.sim.franka import EE_LINK, FINGER_JOINTS, Franka
from taskcond.sim.kinova import KinovaArm

PHYSICS_HZ = 240
"""Physics steps per second."""
FramePose = tuple[tuple[float, float, float], tuple[float, float, float, float]]
"""A pose as PyBullet returns it: position (m) and quaternion (xyzw)."""
_POSITION = itemgetter(0)
"""Item 0 of a ``p.getJointStates`` entry: the joint position (m or rad)."""
TABLE = "table"
"""The body everything else stands on."""
LYING = float(np.cos(np.radians(45.0)))
"""A free object whose upright axis has a world-z component below this (tilted more than 45°) lies: it fell
over (:meth:`KitchenScene.lying`)."""


@dataclass(frozen=True)
class Placement:
    """Nominal pose of a free object on the counter: ``xy`` (m, world) and ``yaw`` (rad about z)."""

    xy: tuple[float, float]
    yaw: float = 0.0


Role = Literal["graspable", "container", "surface", "vessel"]
ROLES: tuple[Role, ...] = ("graspable", "container", "surface", "vessel")
"""What an object of the scene affords beside its name: the hand can grasp it (and carry it, as every free
object), it has an interior things go into, things can be put on top of it, or it holds a liquid and can be
tilted to pour. An object that is not free (:attr:`SceneConfig.free_objects`) is fixed: things can be put in
front of it."""
SUITE_ROLES: dict[str, frozenset[Role]] = {
    "table": frozenset({"surface"}),
    "cabinet": frozenset({"surface"}),
    "top drawer": frozenset({"container"}),
    "bottom drawer": frozenset({"container"}),
    "box": frozenset({"container", "surface"}),
    "microwave": frozenset({"container", "surface"}),
    "bottle": frozenset({"graspable", "vessel"}),
    "bowl": frozenset({"graspable", "container", "vessel"}),
    "mug": frozenset({"graspable", "container", "vessel"}),
    "toothpaste": frozenset({"graspable"}),
    "spatula": frozenset({"graspable"}),
    "cube": frozenset({"graspable"}),
    "can": frozenset({"graspable", "vessel"}),
    "cloth": frozenset({"graspable", "surface"}),
}
"""The roles of the suite's objects (the cloth's in the dual-arm scene): the one role table, which a declared
object joins with its own (:attr:`SceneConfig.roles`)."""


@dataclass(frozen=True)
class DeclaredObject:
    """An object a user declared (``--objects``, :func:`taskcond.sim.objects.load_objects`), kept in the scene
    exactly like the suite's objects: its spec and nominal placement join :attr:`SceneConfig.free_objects`,
    its roles :attr:`SceneConfig.roles`, its aliases :func:`scene_aliases`.

    Attributes:
        name: canonical name (conditions, instructions).
        aliases: other words for it.
        spec: the asset (:class:`~taskcond.sim.assets.SolidSpec`, :class:`~taskcond.sim.assets.MeshSpec`,
            or a suite spec kind: bottle, vessel, block).
        placement: nominal pose of a task start.
        roles: :data:`ROLES` it has.
        source: the declaration file and entry it came from.
    """

    name: str
    aliases: tuple[str, ...]
    spec: AssetSpec
    placement: Placement
    roles: frozenset[Role]
    source: str


DECLARED: dict[str, DeclaredObject] = {}
"""The declared objects of this process by name (:func:`taskcond.sim.objects.register_object`); every
:class:`SceneConfig` made after a declaration has them."""


def suite_objects() -> dict[str, tuple[AssetSpec, Placement]]:
    """The suite's free objects: spec and nominal placement by name."""
    return {
        "bottle": (BottleSpec(), Placement((0.40, -0.02))),
        "bowl": (VesselSpec(), Placement((0.42, 0.19))),
        "mug": (
            VesselSpec(outer_radius=0.04, height=0.09, handle=True, mass=0.3, rgba=(0.8, 0.25, 0.2, 1.0)),
            Placement((0.34, -0.26)),
        ),
        "toothpaste": (BlockSpec(), Placement((0.30, 0.11))),
        "spatula": (SpatulaSpec(), Placement((0.24, -0.07))),
        "cube": (BlockSpec((0.04, 0.04, 0.04), 0.1, (0.85, 0.15, 0.15, 1.0)), Placement((0.22, 0.32))),
        "can": (
            BottleSpec(
                radius=0.03,
                height=0.09,
                neck_radius=0.028,
                neck_height=0.01,
                mass=0.2,
                rgba=(0.2, 0.3, 0.8, 1.0),
            ),
            Placement((0.20, -0.45)),
        ),
    }


def _free_objects() -> dict[str, tuple[AssetSpec, Placement]]:
    """The suite's free objects and then the declared ones (:data:`DECLARED`)."""
    return suite_objects() | {d.name: (d.spec, d.placement) for d in DECLARED.values()}


def _roles() -> dict[str, frozenset[Role]]:
    return SUITE_ROLES | {d.name: d.roles for d in DECLARED.values()}


def suite_config() -> SceneConfig:
    """The kitchen with the suite's objects only, whatever is declared: the scene of the oracle
    demonstrations the skill library learns from."""
    return SceneConfig(free_objects=suite_objects(), roles=dict(SUITE_ROLES))


@dataclass(frozen=True)
class SceneConfig:
    """Every parameter of the kitchen. Replace a spec (``dataclasses.replace``) for a novel object.

    ``free_objects`` maps a condition name to its spec and nominal placement (the suite's
    :func:`suite_objects`, then the declared :data:`DECLARED`); ``position_noise`` (m) and
    ``yaw_noise`` (rad) are the half-widths of the uniform perturbation applied at each seeded reset.
    """

    table: TableSpec = field(default_factory=TableSpec)
    cabinet: CabinetSpec = field(default_factory=CabinetSpec)
    cabinet_origin: tuple[float, float] = (0.62, 0.40)
    box: BoxSpec = field(default_factory=BoxSpec)
    box_origin: tuple[float, float] = (0.58, -0.13)
    microwave: MicrowaveSpec = field(default_factory=MicrowaveSpec)
    microwave_origin: tuple[float, float] = (0.55, -0.56)
    free_objects: dict[str, tuple[AssetSpec, Placement]] = field(default_factory=_free_objects)
    roles: dict[str, frozenset[Role]] = field(default_factory=_roles)
    """Every object's :data:`ROLES` by name (the suite's :data:`SUITE_ROLES` and the declared objects')."""
    position_noise: float = 0.02
    yaw_noise: float = 0.25
    kinova: bool = False
    """Load the Kinova Gen3 beside the Franka (dual-arm tasks)."""
    kinova_base: tuple[float, float, float] = (0.0, 0.62, 0.0)
    """World position (m) of the Kinova's base frame (centre of the base's bottom), facing +x like the
    Franka: on the Franka's left, in front of nothing the single-arm tasks use."""
    cloth: ClothSpec | None = None
    """The cloth (a soft body; its presence makes the client a deformable world), or ``None``."""
    cloth_center: tuple[float, float] = (0.36, 0.26)
    """Nominal world xy (m) of the cloth's centre, between the two arms; perturbed by ``position_noise``."""

    @property
    def repeatable_in_process(self) -> bool:
        """Whether an episode in this scene simulates alike wherever it runs in a process. Not with a
        self-colliding cloth: Bullet's soft-body self-collision shuffles its repulsion contacts with one
        random state per process (a static seed in ``btSoftBody.h``, advanced by each step of any soft body
        and never reset), so such an episode is repeatable only as the first soft-body simulation of a
        fresh process (:func:`taskcond.application.evaluate.run_jobs` gives it one)."""
        return self.cloth is None or not self.cloth.self_collision


DUAL_ARM_CABINET_SHIFT = 0.075
"""Metres the cabinet stands farther back (+x) in the dual-arm scene than in the kitchen. Laying the cloth's
far edge, the Kinova's hand reaches x = 0.56 m at the cabinet's side of the cloth, where the drawer handles
stood (their bars at x = 0.56-0.57 m); 7.5 cm back, they are clear of it and the cabinet still stands on the
table (its back 4 mm inside the table's edge)."""


def dual_arm_config(base: SceneConfig | None = None, cloth: ClothSpec | None = None) -> SceneConfig:
    """The scene of the dual-arm and cloth tasks (PT6 Fold, grasp cloth, LHT4): ``base`` (default kitchen)
    with the Kinova and the cloth, the cabinet :data:`DUAL_ARM_CABINET_SHIFT` farther back, and without the
    free objects whose nominal placement lies on the cloth or within 16 cm of it (bowl, toothpaste, cube
    and bottle in the default kitchen), so that nothing stands where the spatula is carried onto the cloth
    (BENCHMARKS.md, "Cloth, dual-arm fold, LHT4")."""
    base = base or SceneConfig()
    spec = cloth or base.cloth or ClothSpec()
    half = spec.size / 2 + 0.16
    cx, cy = base.cloth_center
    free = {
        name: (asset, place)
        for name, (asset, place) in base.free_objects.items()
        if abs(place.xy[0] - cx) > half or abs(place.xy[1] - cy) > half
    }
    cabinet = (base.cabinet_origin[0] + DUAL_ARM_CABINET_SHIFT, base.cabinet_origin[1])
    return replace(base, kinova=True, cloth=spec, free_objects=free, cabinet_origin=cabinet)


DRAWERS = ("bottom drawer", "top drawer")
ARTICULATED = ("top drawer", "bottom drawer", "box", "microwave")
"""Container names with a joint."""
JOINT_FRICTION = {"bottom drawer": 3.0, "top drawer": 3.0, "box": 0.01, "microwave": 0.3}
"""Force (N) or torque (N m) of the zero-velocity motor that acts as each container joint's friction."""
STOP_SLACK = 0.05
"""How far (m or rad) past a container joint's limit :meth:`KitchenScene.keep_at_stops` lets it go: more than
the demonstrations press a lid or door past it (at most 0.01 rad) or a weight on a closed lid presses it
down (0.04 rad), so that those are as PyBullet leaves them."""
STOP_REACHED = 0.005
"""How near (m or rad) to the limit :meth:`KitchenScene.keep_at_stops` drives a joint back."""
STOP_FORCE = 5.0
"""Force (N) or torque (N m) with which :meth:`KitchenScene.keep_at_stops` drives a joint back to a limit."""
STOP_SPEED = 0.2
"""Speed (m/s or rad/s) at most of a joint :meth:`KitchenScene.keep_at_stops` drives back to a limit, slow
enough that the joint's friction stops it there."""
ALIASES = {
    "upper drawer": "top drawer",
    "lower drawer": "bottom drawer",
    "microwave oven": "microwave",
    "lunch box": "box",
    "lunchbox": "box",
    "cup": "mug",
    "tube of toothpaste": "toothpaste",
    "toothpaste tube": "toothpaste",
    "tin can": "can",
    "tin": "can",
}
"""Other words an instruction may use for a scene object (alias → the object's name), read before the
LLM decomposes it: the embedded model took "the upper drawer" for the bottom drawer."""


def scene_aliases() -> dict[str, str]:
    """:data:`ALIASES` and the declared objects' aliases (:data:`DECLARED`)."""
    return ALIASES | {alias: d.name for d in DECLARED.values() for alias in d.aliases}


@dataclass(frozen=True)
class WorldInterior:
    """A container's interior in the world frame: ``center`` (3,) m, ``half_extents`` (3,) m along the axes
    of ``rotation`` (3, 3); ``round`` means a vertical cylinder of radius ``half_extents[0]``."""

    center: np.ndarray
    half_extents: np.ndarray
    rotation: np.ndarray
    round: bool


class KitchenScene:
    """The kitchen in one PyBullet client: builds every body and keeps their ids and interiors.

    With ``config.kinova`` the Kinova Gen3 (:attr:`kinova`) stands at ``config.kinova_base`` facing +x;
    with ``config.cloth`` the client is a deformable world (reset with ``RESET_USE_DEFORMABLE_WORLD`` before
    anything is loaded) and the cloth lies flat at ``config.cloth_center`` (:attr:`cloth`, a soft body,
    named ``"cloth"``; :attr:`grips` holds the soft-body anchors of the grippers on it). Both are off by
    default, so that the single-arm tasks keep PyBullet's rigid-body world and their speed.

    Gripper names (conditions, perception): ``"gripper"`` is the Franka's, ``"kinova gripper"`` the Kinova's
    (:data:`KINOVA_GRIPPER`); any name ending in ``gripper`` is a gripper (``conditions.is_gripper``),
    so the single-arm vocabulary is unchanged.

    Args:
        config: layout and object parameters.
        gui: open PyBullet's GUI instead of the headless ``DIRECT`` mode.
    """

    def __init__(self, config: SceneConfig | None = None, gui: bool = False) -> None:
        self.config = config or SceneConfig()
        self.client = p.connect(p.GUI if gui else p.DIRECT)
        if self.config.cloth is not None:
            p.resetSimulation(p.RESET_USE_DEFORMABLE_WORLD, physicsClientId=self.client)
        p.setGravity(0, 0, -9.81, physicsClientId=self.client)
        p.setTimeStep(1.0 / PHYSICS_HZ, physicsClientId=self.client)
        p.setPhysicsEngineParameter(numSolverIterations=50, physicsClientId=self.client)
        if gui:
            p.configureDebugVisualizer(p.COV_ENABLE_GUI, 0, physicsClientId=self.client)
        cfg = self.config
        self.bodies: dict[str, int] = {}
        self._inertial_inverse: dict[int, FramePose] = {}
        self._fixed_interiors: dict[str, WorldInterior] = {}
        self.links: dict[str, int] = {}
        self.interiors: dict[str, Interior] = {}
        self.joints: dict[str, ContainerJoint] = {}
        self.specs: dict[str, AssetSpec] = {}
        self.upright: dict[str, tuple[float, float, float, float]] = {}
        """Quaternion (xyzw) that stands a file object (:class:`MeshSpec`) upright; the others stand upright
        unturned."""
        self._bottom: dict[str, np.ndarray] = {}
        """A file object's base-frame position (3,) m relative to the bottom centre of its bounding box,
        standing upright at yaw 0."""

        self._load(TABLE, cfg.table, (*cfg.table.center, 0.0), fixed=True)
        self._load("cabinet", cfg.cabinet, (*cfg.cabinet_origin, 0.0), fixed=True)
        self._load("box", cfg.box, (*cfg.box_origin, 0.0), fixed=True)
        self._load("microwave", cfg.microwave, (*cfg.microwave_origin, 0.0), fixed=True)
        cab = self.bodies["cabinet"]
        for link, (name, _) in enumerate(cfg.cabinet.drawer_links):
            self.bodies[name], self.links[name] = cab, link
            self.joints[name] = ContainerJoint(name, cab, link, 0.0, cfg.cabinet.travel, 0.5)
        self.links["box"] = -1
        self.joints["box"] = ContainerJoint("box", self.bodies["box"], 0, 0.0, cfg.box.open_angle, 0.5)
        self.links["microwave"] = -1
        self.joints["microwave"] = ContainerJoint(
            "microwave", self.bodies["microwave"], 0, 0.0, cfg.microwave.open_angle, 0.5
        )
        self._container_reads = self._plan_container_reads()
        self._container_ranges = [r for _, _, ranges in self._container_reads for r in ranges]
        """Closed position and range (m or rad) of each container joint, in :data:`ARTICULATED` order."""
        self._past_stop: set[str] = set()
        """Containers whose joint :meth:`keep_at_stops` is driving back to a limit."""
        for name, joint in self.joints.items():
            self._joint_motor(name, None)
            p.changeDynamics(
                joint.body_id, joint.joint_index, lateralFriction=0.6, physicsClientId=self.client
            )

        for name, (spec, place) in cfg.free_objects.items():
            self._load(name, spec, (*place.xy, 0.0), fixed=False)
            self.links[name] = -1
            p.changeDynamics(
                self.bodies[name],
                -1,
                lateralFriction=1.0,
                spinningFriction=0.002,
                rollingFriction=0.0001,
                restitution=0.0,
                activationState=p.ACTIVATION_STATE_ENABLE_SLEEPING,
                physicsClientId=self.client,
            )
            if name in self.upright:  # a file object stands on the table by its bounding box
                self.place(name, place.xy, place.yaw)
        self.robot = Franka(self.client)
        self.free_objects = tuple(cfg.free_objects)
        self.kinova: KinovaArm | None = None
        if cfg.kinova:
            self.kinova = KinovaArm(self.client, cfg.kinova_base)
        self.cloth: int | None = None
        self.grips: ClothGrips | None = None
        if cfg.cloth is not None:
            self.cloth = load_cloth(self.client, cfg.cloth, (*cfg.cloth_center, cfg.cloth.collision_margin))
            self.bodies["cloth"] = self.cloth
            self.links["cloth"] = -1
            self.specs["cloth"] = cfg.cloth  # type: ignore[assignment]
            self.grips = ClothGrips(self.client, self.cloth, cfg.cloth, self._grip_handles())
            # The free objects collide with the cloth; one resting on it (the spatula of LHT4) blows the
            # soft contact up within a second at one sub-step per 240 Hz step, and is stable from two.
            p.setPhysicsEngineParameter(numSubSteps=cfg.cloth.substeps, physicsClientId=self.client)

    def _plan_container_reads(self) -> list[tuple[int, tuple[int, ...], tuple[tuple[float, float], ...]]]:
        """The joint queries of :meth:`open_fractions`: per body, in :data:`ARTICULATED` order, its container
        joints and each one's closed position and range (open minus closed position, m or rad)."""
        groups: dict[int, list[ContainerJoint]] = {}
        for name in ARTICULATED:
            joint = self.joints[name]
            groups.setdefault(joint.body_id, []).append(joint)
        order = [j.name for joints in groups.values() for j in joints]
        if order != list(ARTICULATED):
            raise ValueError(f"ARTICULATED lists a body's containers apart: {ARTICULATED}")
        return [
            (
                body,
                tuple(j.joint_index for j in joints),
                tuple((j.closed_position, j.open_position - j.closed_position) for j in joints),
            )
            for body, joints in groups.items()
        ]

    def _grip_handles(self) -> list[GripperHandle]:
        robot = self.robot
        handles = [
            GripperHandle(
                GRIPPER, robot.body, FINGER_JOINTS, EE_LINK, lambda: robot.gripper_closed, robot.finger_width
            )
        ]
        if self.kinova is not None:
            arm = self.kinova
            handles.append(
                GripperHandle(
                    KINOVA_GRIPPER,
                    arm.body_id,
                    arm.finger_links,
                    arm.ee_link,
                    lambda: arm.gripper_closed,
                    arm.gripper_opening,
                )
            )
        return handles

    @property
    def grippers(self) -> list[GripperSpec]:
        """Every gripper of the scene: the Franka's ``"gripper"``, then the Kinova's ``"kinova gripper"``."""
        specs = [self.robot.spec]
        if self.kinova is not None:
            specs.append(self.kinova.gripper_spec(KINOVA_GRIPPER))
        return specs

    def cloth_nodes(self) -> np.ndarray:
        """(n*n, 3) world positions (m) of the cloth's simulation-mesh nodes (see :mod:`taskcond.sim.cloth`).

        Raises:
            ValueError: the scene has no cloth.
        """
        if self.cloth is None:
            raise ValueError("the scene has no cloth (SceneConfig.cloth is None; use dual_arm_config)")
        return cloth_nodes(self.client, self.cloth)

    def place_cloth(self, xy: tuple[float, float] | np.ndarray, yaw: float = 0.0) -> None:
        """Lay the cloth flat and at rest with its centre at ``xy`` (m) turned ``yaw`` rad (reset only).

        PyBullet can set a soft body's node positions but not its node velocities, so the cloth is removed
        and loaded again (8 ms at 15 × 15); PyBullet reuses the freed body id, which is checked. Every anchor
        is removed first.
        """
        if self.cloth is None or self.grips is None or self.config.cloth is None:
            raise ValueError("the scene has no cloth (SceneConfig.cloth is None; use dual_arm_config)")
        self.grips.release_all()
        p.removeBody(self.cloth, physicsClientId=self.client)
        spec = self.config.cloth
        body = load_cloth(self.client, spec, (float(xy[0]), float(xy[1]), spec.collision_margin), yaw)
        if body != self.cloth:
            raise RuntimeError(f"PyBullet gave the reloaded cloth body id {body}, not {self.cloth}")
        self.grips.reset_contacts()

    def _load(self, name: str, spec: AssetSpec, position: tuple[float, float, float], fixed: bool) -> None:
        asset = build_asset(name.replace(" ", "_"), spec)
        client = self.client
        if not isinstance(spec, MeshSpec):
            body = p.loadURDF(str(asset.path), position, useFixedBase=fixed, physicsClientId=client)
        else:
            self.upright[name] = p.getQuaternionFromEuler(spec.rpy)
            body = p.loadURDF(
                str(asset.path),
                position,
                self.upright[name],
                useFixedBase=fixed,
                globalScaling=spec.scale if spec.is_urdf else 1.0,
                physicsClientId=client,
            )
            if spec.mass is not None:
                p.changeDynamics(body, -1, mass=spec.mass, physicsClientId=client)
            if spec.rgba is not None:
                for link in range(-1, p.getNumJoints(body, physicsClientId=client)):
                    p.changeVisualShape(body, link, rgbaColor=spec.rgba, physicsClientId=client)
        self.bodies[name] = body
        self.specs[name] = spec
        if isinstance(spec, MeshSpec):
            lo, hi = self.aabb(name)
            self._bottom[name] = self.pose(name)[0] - np.array([*(lo[:2] + hi[:2]) / 2, lo[2]])
        for key, interior in asset.interiors.items():
            self.interiors[key.replace("_", " ")] = interior

    # ----------------------------------------------------------------------------------- description
    def description(self) -> SceneDescription:
        """The :class:`SceneDescription` read by the environment-information layer (§III-A.2)."""
        roles = self.config.roles
        kinds = {TABLE: "furniture", "cabinet": "furniture"} | {
            name: "container" for name in self.bodies if "container" in roles.get(name, ())
        }
        bodies = [
            NamedBody(n, self.bodies[n], self.links.get(n, -1), kinds.get(n, "object"))  # type: ignore[arg-type]
            for n in self.bodies
        ]
        bodies.append(NamedBody("robot", self.robot.body, -1, "robot"))
        if self.kinova is not None:
            bodies.append(NamedBody("kinova", self.kinova.body_id, -1, "robot"))
        soft = [self.cloth] if self.cloth is not None else []
        return SceneDescription(self.client, bodies, list(self.joints.values()), self.grippers, soft)

    # ----------------------------------------------------------------------------------------- state
    def pose(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """World pose of a named body or link frame: position (3,) m and quaternion (4,) xyzw."""
        body, link = self.bodies[name], self.links.get(name, -1)
        if link < 0:
            pos, orn = p.getBasePositionAndOrientation(body, physicsClientId=self.client)
            pos, orn = self.base_frame(body, pos, orn)
        else:
            state = p.getLinkState(body, link, computeForwardKinematics=True, physicsClientId=self.client)
            pos, orn = state[4], state[5]
        return np.array(pos), np.array(orn)

    def base_frame(
        self, body: int, com_position: Sequence[float], com_orientation: Sequence[float]
    ) -> FramePose:
        """World pose (position m, quaternion xyzw) of ``body``'s URDF base-link frame, given the pose of its
        centre-of-mass frame as ``p.getBasePositionAndOrientation`` reports it (the offset is constant per
        body and cached)."""
        inv = self.com_to_base(body)
        return p.multiplyTransforms(com_position, com_orientation, inv[0], inv[1])

    def com_to_base(self, body: int) -> FramePose:
        """Pose (position m, quaternion xyzw) of ``body``'s URDF base-link frame in its centre-of-mass frame:
        the transform :meth:`base_frame` applies (constant per body, cached)."""
        inv = self._inertial_inverse.get(body)
        if inv is None:
            local = p.getDynamicsInfo(body, -1, physicsClientId=self.client)[3]
            inv = self._inertial_inverse[body] = p.invertTransform(local, (0, 0, 0, 1))
        return inv

    def aabb(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """World axis-aligned bounding box (min (3,), max (3,)) of a named body or link."""
        lo, hi = p.getAABB(self.bodies[name], self.links.get(name, -1), physicsClientId=self.client)
        return np.array(lo), np.array(hi)

    def joint_position(self, container: str) -> float:
        """Joint position of an articulated container (m or rad)."""
        j = self.joints[container]
        return float(p.getJointState(j.body_id, j.joint_index, physicsClientId=self.client)[0])

    def open_fraction(self, container: str) -> float:
        """How far open a container is: 0 closed, 1 fully open."""
        j = self.joints[container]
        return (self.joint_position(container) - j.closed_position) / (j.open_position - j.closed_position)

    @property
    def articulated_bodies(self) -> tuple[int, ...]:
        """Body ids of the containers of :data:`ARTICULATED`, each once, in the order of
        :meth:`container_joint_positions`."""
        return tuple(body for body, _, _ in self._container_reads)

    def container_joint_positions(self) -> list[tuple[float, ...]]:
        """Positions (m or rad) of the container joints, one tuple per :attr:`articulated_bodies` entry (the
        cabinet's two drawers together, in :data:`ARTICULATED` order), from one joint query per body."""
        client = self.client
        return [
            tuple(map(_POSITION, p.getJointStates(body, joint_indices, client)))
            for body, joint_indices, _ in self._container_reads
        ]

    def keep_at_stops(self, positions: list[tuple[float, ...]]) -> None:
        """Drive each container joint pushed more than :data:`STOP_SLACK` past a limit back to it, as a stop
        would; PyBullet's joint-limit constraint stops a joint at its limit but never brings back one pushed
        past it (a hand shoved the box's lid 0.3 rad past its stop, and it stayed there: BENCHMARKS.md, "lids
        back on their stops"). The joint's friction motor gives way to a position motor of at most
        :data:`STOP_FORCE` towards the limit, compliant so that a hand still pressing is not thrown off,
        until the joint is within :data:`STOP_REACHED` of it. Once per control step, from the joint
        ``positions`` :meth:`container_joint_positions` returned."""
        flat = [q for qs in positions for q in qs]
        for name, q, (closed, span) in zip(ARTICULATED, flat, self._container_ranges, strict=True):
            lower, upper = sorted((closed, closed + span))
            stop = min(max(q, lower), upper)
            if name in self._past_stop and abs(q - stop) <= STOP_REACHED:
                self._past_stop.discard(name)
                self._joint_motor(name, None)
            elif name not in self._past_stop and abs(q - stop) > STOP_SLACK:
                self._past_stop.add(name)
                self._joint_motor(name, stop)

    def _joint_motor(self, name: str, stop: float | None) -> None:
        """A container joint's motor: its friction (:data:`JOINT_FRICTION`), or with ``stop`` (m or rad) a
        position motor towards it (:meth:`keep_at_stops`)."""
        joint = self.joints[name]
        if stop is None:
            mode = {"controlMode": p.VELOCITY_CONTROL, "targetVelocity": 0, "force": JOINT_FRICTION[name]}
        else:
            mode = {"controlMode": p.POSITION_CONTROL, "targetPosition": stop, "force": STOP_FORCE}
            mode["maxVelocity"] = STOP_SPEED
        p.setJointMotorControl2(joint.body_id, joint.joint_index, **mode, physicsClientId=self.client)

    def open_fractions(self, positions: list[tuple[float, ...]] | None = None) -> list[float]:
        """:meth:`open_fraction` of every container of :data:`ARTICULATED`, in that order, from the joint
        ``positions`` :meth:`container_joint_positions` returned (read now if not given)."""
        if positions is None:
            positions = self.container_joint_positions()
        return [
            (q - closed) / span
            for q, (closed, span) in zip(chain.from_iterable(positions), self._container_ranges, strict=True)
        ]

    def interior(self, container: str) -> WorldInterior:
        """A container's interior volume in the world frame, following its link (drawer, vessel). The interior
        of a fixed body's base (box, microwave) never moves: it is computed once, with read-only arrays."""
        fixed = self._fixed_interiors.get(container)
        if fixed is not None:
            return fixed
        it = self.interiors[container]
        body = self.bodies[container]
        on_base = self.links[container] < 0
        if on_base:
            pos, orn = self.pose(container)
        else:
            link = self.links[container]
            state = p.getLinkState(body, link, computeForwardKinematics=True, physicsClientId=self.client)
            pos, orn = state[4], state[5]
        rot = np.array(p.getMatrixFromQuaternion(orn)).reshape(3, 3)
        interior = WorldInterior(
            np.asarray(pos) + rot @ np.array(it.center), np.array(it.half_extents), rot, it.round
        )
        if on_base and container not in self.free_objects:
            for array in (interior.center, interior.half_extents, interior.rotation):
                array.setflags(write=False)
            self._fixed_interiors[container] = interior
        return interior

    def set_joint(self, container: str, fraction: float) -> None:
        """Put a container at ``fraction`` of its range, at rest, with its friction motor (reset only)."""
        j = self.joints[container]
        q = j.closed_position + fraction * (j.open_position - j.closed_position)
        p.resetJointState(j.body_id, j.joint_index, q, 0.0, physicsClientId=self.client)
        if container in self._past_stop:
            self._past_stop.discard(container)
            self._joint_motor(container, None)

    def place(self, name: str, xy: tuple[float, float] | np.ndarray, yaw: float, z: float = 0.0) -> None:
        """Put a free object's bottom-centre frame at ``(x, y, z)`` with ``yaw``, upright, at rest (reset
        only); a file object's by the bottom centre of its bounding box."""
        body = self.bodies[name]
        local = p.getDynamicsInfo(body, -1, physicsClientId=self.client)[3]
        turn = p.getQuaternionFromEuler((0, 0, yaw))
        base = np.array([float(xy[0]), float(xy[1]), z + 0.0005])
        orn = turn
        if name in self.upright:
            orn = p.multiplyTransforms((0, 0, 0), turn, (0, 0, 0), self.upright[name])[1]
            base = base + np.array(p.multiplyTransforms((0, 0, 0), turn, self._bottom[name], (0, 0, 0, 1))[0])
        pos, _ = p.multiplyTransforms(base, orn, local, (0, 0, 0, 1))
        p.resetBasePositionAndOrientation(body, pos, orn, physicsClientId=self.client)
        p.resetBaseVelocity(body, (0, 0, 0), (0, 0, 0), physicsClientId=self.client)

    def lying(self) -> tuple[str, ...]:
        """The free objects tilted more than 45° from upright (:data:`LYING`), from their poses: the one
        definition of an object that fell over (the executor's perception and an episode's ``fallen``). A
        cube stands on any face: it lies only when none of its axes is within 45° of vertical."""
        out = []
        for name in self.free_objects:
            axes = p.getMatrixFromQuaternion(self._upright_orientation(name))  # row 2: world z of each axis
            up = max(abs(a) for a in axes[6:9]) if self._cube(name) else axes[8]
            if up < LYING:
                out.append(name)
        return tuple(out)

    def _upright_orientation(self, name: str) -> tuple[float, ...]:
        """A free object's orientation (xyzw) relative to how it stands upright: its pose's, or for a
        declared model whose file stands it otherwise, the pose's turned back by its ``upright`` rotation."""
        orn = self.pose(name)[1]
        upright = self.upright.get(name)
        if upright is not None:
            orn = p.multiplyTransforms((0, 0, 0), orn, (0, 0, 0), p.invertTransform((0, 0, 0), upright)[1])[1]
        return tuple(orn)

    def _cube(self, name: str) -> bool:
        """A block whose three sides are equal (within a millimetre): turned onto another face, it stands."""
        spec = self.specs[name]
        return isinstance(spec, BlockSpec) and max(spec.size) - min(spec.size) < 1e-3

    def yaw(self, name: str) -> float:
        return float(p.getEulerFromQuaternion(self.pose(name)[1])[2])

    def close(self) -> None:
        if p.isConnected(self.client):
            p.disconnect(self.client)
