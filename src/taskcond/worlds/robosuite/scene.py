"""robosuite's environments seen in the condition vocabulary: which MuJoCo bodies are which named object,
their boxes (from the geoms), their contacts, grasps and container states. Knows no task.

Every environment is robosuite's own (``suite.make(name, robots="Panda")``) with its operational-space
controller (OSC_POSE, robosuite's default for the Panda) switched to absolute end-effector poses in the
world frame, which is what :meth:`taskcond.execution.world.World.step` commands. Frames: robosuite's world
frame, metres, z up; the Panda's base at x ≈ −0.56 m facing +x, so ``in front of`` (towards the robot,
world −x) means what it means in the kitchen (:data:`taskcond.relations.FRONT`).

Names (:data:`OBJECT_NAMES`, :func:`fixtures`): robosuite's objects by their vocabulary names (``cubeA`` is
the ``red cube``), the table, PickPlace's start bin and the four quarters of its target bin as containers
(``milk bin`` ... ``can bin``: robosuite's success check wants each object in its own quarter), the pegs
of NutAssembly and the door of Door. Every geom of the robot is the ``gripper`` in contacts, as in the
kitchen.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from taskcond.worlds.robosuite import require_robosuite

CONTROL_FREQ = 20
"""Control steps per second (robosuite's default): one :meth:`RobosuiteScene.step` is 1/20 s."""
CAMERA = "frontview"
"""robosuite camera of the videos."""
VIDEO_SIZE = (320, 240)
"""Width and height (pixels) of video frames."""

OBJECT_NAMES = {
    "cube": "cube",
    "cubeA": "red cube",
    "cubeB": "green cube",
    "Milk": "milk",
    "Bread": "bread",
    "Cereal": "cereal",
    "Can": "can",
    "SquareNut": "square nut",
    "RoundNut": "round nut",
}
"""robosuite object name → name in the condition vocabulary, for every free object of the supported
environments."""
ROUND = frozenset({"can", "round nut"})
"""Free objects that look the same turned about their vertical axis."""
CUBE_LIKE = 1.25
"""A free object whose box edges (in its own frame) differ by less than this factor (the cubes, the bread:
0.040 × 0.048 × 0.048 m) stands on any face: it is upright whichever of its axes is vertical."""
BIN_QUARTERS = ("milk bin", "bread bin", "cereal bin", "can bin")
"""PickPlace's target bin in quarters, in robosuite's object order (Milk, Bread, Cereal, Can): quarter i
is where robosuite's ``not_in_bin(pos, i)`` wants object i."""
BIN_DEPTH = 0.1
"""Height (m) of a target-bin quarter's box above the bin's reference height (robosuite's ``not_in_bin``
counts an object within 0.1 m above it)."""
DOOR_OPEN = 0.3
"""Door hinge angle (rad) from which the door is open: robosuite's Door success threshold."""
DOOR_CLOSED = 0.05
"""Door hinge angle (rad) up to which it is closed."""
CONTACT_DISTANCE = 0.002
"""MuJoCo contacts with a larger distance (m; within the geoms' margins) are not touches."""
LYING = np.cos(np.radians(45.0))
"""A free object whose own z axis has a smaller world-z component (tilted more than 45°) lies."""
RINGS = {"square nut": np.pi}
"""Free objects that are held and placed by a ring, and the turn (rad) about the ring's centre (the object's
body origin) after which the ring and the walls a hand holds it by look the same: the square nut's ring,
held across its ±y walls, turned by half a turn (its handle on the +x wall then points the other way,
which neither the hold nor the peg minds). Their centre is the ring's (:meth:`RobosuiteScene.centre`),
their heading's period this (:meth:`RobosuiteScene.yaw_period`)."""
CLOSING = np.array([1.0, 0.0, 0.0])
"""The axis (3,) along which robosuite's Panda closes its fingers, in the end-effector site's frame (z from
the hand towards the fingertips): the pads sit at ±4.2 cm along the site's x, and the hand's housing
(0.21 × 0.06 m from above) is long along it too (measured from MuJoCo's geoms). The one definition every
hand pose here is built from (:mod:`taskcond.worlds.robosuite.tasks`,
:data:`taskcond.worlds.robosuite.world.HAND_POINTS`)."""
FAR = 5.0
"""A free object farther than this (m) from the origin is not in the scene: robosuite parks the objects a
single-object PickPlace or NutAssembly does not use at (10, 10, 10)."""


@dataclass(frozen=True, eq=False)
class Entity:
    """One named thing of the scene.

    Attributes:
        name: vocabulary name.
        kind: ``object`` (free), ``container`` (has an inside: bins), ``door`` (hinged), ``fixture``.
        geoms: MuJoCo geom ids whose collision shapes make its box; empty for a bin quarter (its box is
            computed, :attr:`box`).
        body: MuJoCo body id whose pose is the object's (free objects), or -1.
        box: a fixed box (lower (3,), upper (3,)) m, world frame, for a bin quarter; None otherwise.
    """

    name: str
    kind: str
    geoms: tuple[int, ...] = ()
    body: int = -1
    box: tuple[np.ndarray, np.ndarray] | None = None


@dataclass(frozen=True, eq=False)
class Touching:
    """Two named things in contact at ``position`` (3,) m, world frame."""

    a: str
    b: str
    position: np.ndarray


@dataclass(frozen=True, eq=False)
class Door:
    """robosuite's Door at one moment, world frame: a panel on a vertical hinge, latched shut until its
    lever is turned about the latch's axis (the panel's normal) by about 1.25 rad (measured; robosuite's
    latch joint stops at ±1.57 rad and springs back).

    Attributes:
        hinge: (3,) m, a point of the hinge's axis.
        hinge_axis: (3,) unit; the door opens turning positively about it (robosuite's hinge angle).
        latch: (3,) m, the point of the latch's axis level with the lever's middle (the lever's root).
        latch_axis: (3,) unit, normal to the panel.
        lever: (3,) unit, from the latch's axis along the lever to its free end.
        outward: (3,) unit, the panel's normal on the lever's side (the side the door opens to).
    """

    hinge: np.ndarray
    hinge_axis: np.ndarray
    latch: np.ndarray
    latch_axis: np.ndarray
    lever: np.ndarray
    outward: np.ndarray


def controller_config() -> dict[str, Any]:
    """robosuite's default Panda controller (OSC_POSE) taking absolute world-frame poses: each action is
    (position (3,) m, rotation vector (3,) rad, gripper −1 open … 1 closed)."""
    from robosuite.controllers import load_composite_controller_config

    config = load_composite_controller_config(robot="Panda")
    arm = config["body_parts"]["right"]
    arm["input_type"] = "absolute"
    arm["input_ref_frame"] = "world"
    return config


def renderer_error() -> str | None:
    """Why MuJoCo cannot render offscreen here (no EGL or OSMesa for ``MUJOCO_GL``), or None if it can."""
    require_robosuite()
    import mujoco

    try:
        context = mujoco.GLContext(16, 16)
        context.make_current()
        context.free()
    except Exception as exc:  # any GL back end's failure means no video, never a failed run
        return f"{type(exc).__name__}: {' '.join(str(exc).split())[:120]}"
    return None


def make_env(env_name: str, video: bool = False) -> Any:
    """robosuite's environment ``env_name`` with the Panda and :func:`controller_config`, no time limit;
    an offscreen renderer only for ``video``."""
    require_robosuite()
    import robosuite

    return robosuite.make(
        env_name,
        robots="Panda",
        controller_configs=controller_config(),
        has_renderer=False,
        has_offscreen_renderer=video,
        use_camera_obs=False,
        control_freq=CONTROL_FREQ,
        horizon=10**7,
        ignore_done=True,
    )


class RobosuiteScene:
    """A reset robosuite environment in the condition vocabulary.

    Args:
        env: a robosuite environment made by :func:`make_env`, already reset.
    """

    def __init__(self, env: Any) -> None:
        self.env = env
        self.sim = env.sim
        self.model = env.sim.model
        self.robot = env.robots[0]
        self.gripper_model = self.robot.gripper["right"]
        self.site = self.robot.eef_site_id["right"]
        self.entities = self._entities()
        self._owner = self._geom_owners()
        self.fingers = tuple(
            self.model.geom_name2id(g)
            for group in ("left_fingerpad", "right_fingerpad", "left_finger", "right_finger")
            for g in self.gripper_model.important_geoms[group]
        )
        self.steps = 0

    # ------------------------------------------------------------------------------------------ names
    def _entities(self) -> dict[str, Entity]:
        out: dict[str, Entity] = {}
        model, env = self.model, self.env
        for obj in env.model.mujoco_objects:
            body = model.body_name2id(obj.root_body)
            if obj.name == "Door":
                out["door frame"] = Entity("door frame", "fixture", self._body_geoms("Door_frame", False))
                panel = model.body_name2id("Door_door")  # its pose is the panel's, swung with the hinge
                out["door"] = Entity("door", "door", self._body_geoms("Door_door"), panel)
                continue
            name = OBJECT_NAMES.get(obj.name)
            if name is None or np.linalg.norm(self.sim.data.body_xpos[body]) > FAR:
                continue
            geoms = tuple(model.geom_name2id(g) for g in obj.contact_geoms)
            out[name] = Entity(name, "object", geoms, body)
        for body_name, name, kind in (
            ("table", "table", "fixture"),
            ("bin1", "start bin", "container"),
            ("peg1", "square peg", "fixture"),
            ("peg2", "round peg", "fixture"),
        ):
            if body_name in self._body_names():
                out[name] = Entity(name, kind, self._body_geoms(body_name))
        if "bin2" in self._body_names():
            out["target bin"] = Entity("target bin", "fixture", self._body_geoms("bin2"))
            for k, quarter in enumerate(BIN_QUARTERS):
                out[quarter] = Entity(quarter, "container", box=self._quarter(k))
        return out

    def _body_names(self) -> list[str]:
        return [self.model.body_id2name(i) for i in range(self.model.nbody)]

    def _body_geoms(self, body_name: str, subtree: bool = True) -> tuple[int, ...]:
        """Collision geoms of a body (and of its descendants when ``subtree``)."""
        root = self.model.body_name2id(body_name)
        bodies = {root}
        if subtree:
            for b in range(self.model.nbody):
                parent = b
                while parent not in (0, root):
                    parent = int(self.model.body_parentid[parent])
                if parent == root:
                    bodies.add(b)
        return tuple(
            g
            for g in range(self.model.ngeom)
            if int(self.model.geom_bodyid[g]) in bodies and self._collides(g)
        )

    def _collides(self, geom: int) -> bool:
        return bool(self.model.geom_contype[geom] or self.model.geom_conaffinity[geom])

    def _quarter(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        """Box of quarter ``k`` of the target bin, as robosuite's ``PickPlace.not_in_bin`` draws it."""
        env = self.env
        x0, y0, z0 = env.bin2_pos
        if k in (0, 2):
            x0 -= env.bin_size[0] / 2
        if k < 2:
            y0 -= env.bin_size[1] / 2
        lower = np.array([x0, y0, z0])
        return lower, lower + np.array([env.bin_size[0] / 2, env.bin_size[1] / 2, BIN_DEPTH])

    def _geom_owners(self) -> dict[int, str]:
        """Name owning each geom (the robot's all ``gripper``; a target-bin geom is resolved per contact)."""
        owner: dict[int, str] = {}
        for entity in self.entities.values():
            for g in entity.geoms:
                owner[g] = entity.name
        if "door" in self.entities:  # the handle and latch hang below the door body
            for g in self._body_geoms("Door_door"):
                owner[g] = "door"
        for g in range(self.model.ngeom):
            body = self.model.body_id2name(int(self.model.geom_bodyid[g]))
            if body.startswith(("robot0_", "gripper0_")):
                owner[g] = "gripper"
        return owner

    @property
    def objects(self) -> tuple[str, ...]:
        """Names of everything that can appear in conditions (the robot's gripper not included)."""
        return tuple(n for n in self.entities if n != "target bin")

    @property
    def free(self) -> tuple[str, ...]:
        """The free objects (what a grasp can pick up)."""
        return tuple(e.name for e in self.entities.values() if e.kind == "object")

    @property
    def containers(self) -> tuple[str, ...]:
        """Open containers (bins), always ``open``."""
        return tuple(e.name for e in self.entities.values() if e.kind == "container")

    # ------------------------------------------------------------------------------------- geometry
    def geom_box(self, geom: int) -> tuple[np.ndarray, np.ndarray]:
        """World-frame axis-aligned box (lower, upper) (3,) m of one geom: the corners of MuJoCo's local
        bounding box (``geom_aabb``) turned by the geom's pose."""
        centre, half = self.model.geom_aabb[geom, :3], self.model.geom_aabb[geom, 3:]
        rot = self.sim.data.geom_xmat[geom].reshape(3, 3)
        middle = self.sim.data.geom_xpos[geom] + rot @ centre
        extent = np.abs(rot) @ half
        return middle - extent, middle + extent

    def box(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """Ground-truth box (lower (3,), upper (3,)) m, world frame, of a named thing."""
        entity = self.entities[name]
        if entity.box is not None:
            return entity.box
        boxes = [self.geom_box(g) for g in entity.geoms]
        return np.min([b[0] for b in boxes], axis=0), np.max([b[1] for b in boxes], axis=0)

    def gripper_box(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The fingers' box (lower, upper) and the grasp point (the end-effector site), each (3,) m."""
        boxes = [self.geom_box(g) for g in self.fingers]
        lower, upper = np.min([b[0] for b in boxes], axis=0), np.max([b[1] for b in boxes], axis=0)
        return lower, upper, self.ee_pose()[0]

    def ee_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """End-effector site (between the fingertips): position (3,) m and orientation (4,) xyzw."""
        position = np.array(self.sim.data.site_xpos[self.site])
        rotation = Rotation.from_matrix(self.sim.data.site_xmat[self.site].reshape(3, 3))
        return position, rotation.as_quat()

    def pose(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """Position (3,) m and orientation (4,) xyzw of a free object's body."""
        body = self.entities[name].body
        wxyz = self.sim.data.body_xquat[body]
        return np.array(self.sim.data.body_xpos[body]), np.array([*wxyz[1:], wxyz[0]])

    def lying(self) -> frozenset[str]:
        """The free objects tilted more than 45° (:data:`LYING`) from standing: their own z axis, or for a
        cube-like one (:data:`CUBE_LIKE`) every one of its axes (turned onto another face, it stands)."""
        out = []
        for name in self.free:
            axes = self.axes(name)  # columns: the object's own axes
            up = np.abs(axes[2]) if self._cube_like(name) else axes[2, 2:]
            if up.max() < LYING:
                out.append(name)
        return frozenset(out)

    def _cube_like(self, name: str) -> bool:
        """Whether the object's own box (:meth:`half_size`) is cube-like."""
        half = self.half_size(name)
        return bool(half.max() < CUBE_LIKE * half.min())

    def half_size(self, name: str) -> np.ndarray:
        """Half the edges (3,) m of a free object's own box along its own axes (:meth:`axes`): the largest
        of MuJoCo's local ``geom_aabb`` of its geoms."""
        return np.max([self.model.geom_aabb[g, 3:] for g in self.entities[name].geoms], axis=0)

    def axes(self, name: str) -> np.ndarray:
        """The axes of a free object's own box (:meth:`half_size`), world frame, as the columns of a (3, 3)
        rotation: its first geom's frame, which is not always its body's (the cereal's box geom is turned
        90° about the body's z: its 3 cm side lies along the body's y)."""
        return np.array(self.sim.data.geom_xmat[self.entities[name].geoms[0]]).reshape(3, 3)

    def yaw_period(self, name: str) -> float:
        """The turn (rad) about its vertical after which a free object, or the door, looks the same: the
        door's a whole turn; a ring's (:data:`RINGS`); else its box's, π/2 for a section whose sides
        differ by less than :data:`CUBE_LIKE`, π otherwise."""
        if name == "door":
            return 2 * np.pi
        if name in RINGS:
            return RINGS[name]
        return np.pi if self.elongated(name) else np.pi / 2

    def centre(self, name: str) -> np.ndarray:
        """Centre (3,) m, world frame, of a named thing: a ring's (:data:`RINGS`) or the door's, its body
        origin (the ring's centre; the panel's, about which a turn of the door is a turn of its lever),
        else its box's (the door's box, its lever sticking out, shifted 2.5 cm with the door's turn)."""
        if name in RINGS or name == "door":
            return self.pose(name)[0]
        lower, upper = self.box(name)
        return (lower + upper) / 2

    def elongated(self, name: str) -> bool:
        """Whether a free object's horizontal section has sides differing by :data:`CUBE_LIKE` or more."""
        half = self.half_size(name)
        return bool(max(half[0], half[1]) >= CUBE_LIKE * min(half[0], half[1]))

    def yaw(self, name: str) -> float:
        """Heading (rad) of a free object about the world's vertical: the angle from world x of the
        horizontal part of its own x axis."""
        axes = Rotation.from_quat(self.pose(name)[1]).as_matrix()
        return float(np.arctan2(axes[1, 0], axes[0, 0]))

    # ------------------------------------------------------------------------------------- contacts
    def touches(self) -> list[Touching]:
        """Named pairs in contact after the last step, each at the mean of its contact points; a
        target-bin geom counts as the quarter its contact lies in."""
        merged: dict[tuple[str, str], list[np.ndarray]] = {}
        data = self.sim.data
        for i in range(data.ncon):
            contact = data.contact[i]
            if contact.dist > CONTACT_DISTANCE:
                continue
            position = np.array(contact.pos)
            a = self._name_at(int(contact.geom1), position)
            b = self._name_at(int(contact.geom2), position)
            if a is None or b is None or a == b:
                continue
            merged.setdefault((min(a, b), max(a, b)), []).append(position)
        return [Touching(a, b, np.mean(v, axis=0)) for (a, b), v in merged.items()]

    def _name_at(self, geom: int, position: np.ndarray) -> str | None:
        name = self._owner.get(geom)
        if name != "target bin":
            return name
        for quarter in BIN_QUARTERS:
            lower, upper = self.entities[quarter].box  # type: ignore[misc]
            if np.all(position[:2] >= lower[:2]) and np.all(position[:2] <= upper[:2]):
                return quarter
        return None

    def grasped(self) -> str | None:
        """The free object both finger pads touch (robosuite's own ``_check_grasp``), or None."""
        for name in self.free:
            geoms = [self.model.geom_id2name(g) for g in self.entities[name].geoms]
            if self.env._check_grasp(gripper=self.gripper_model, object_geoms=geoms):
                return name
        return None

    def door_angle(self) -> float | None:
        """The door's hinge angle (rad), or None without a door."""
        if "door" not in self.entities:
            return None
        return float(self.sim.data.qpos[self.env.hinge_qpos_addr])

    def door(self) -> Door | None:
        """The door's hinge, latch and lever now (:class:`Door`), or None without a door."""
        if "door" not in self.entities:
            return None
        data = self.sim.data
        hinge, latch = (self.model.joint_name2id(j) for j in self.env.door.joints[:2])
        lever = self.model.geom_name2id(f"{self.env.door.naming_prefix}handle")
        point, axis = np.array(data.xanchor[latch]), np.array(data.xaxis[latch])
        centre = np.array(data.geom_xpos[lever])
        along = centre - point
        out = float(along @ axis)
        along = along - out * axis
        return Door(
            hinge=np.array(data.xanchor[hinge]),
            hinge_axis=np.array(data.xaxis[hinge]),
            latch=point + out * axis,
            latch_axis=axis,
            lever=along / np.linalg.norm(along),
            outward=axis if out > 0 else -axis,
        )

    # --------------------------------------------------------------------------------------- control
    def step(self, position: np.ndarray, orientation: np.ndarray, gripper: float) -> str | None:
        """One control step of the OSC towards the end-effector pose (position (3,) m, orientation (4,)
        xyzw, world frame) with the gripper command (0 open … 1 closed); a failure reason or None."""
        rotvec = Rotation.from_quat(orientation).as_rotvec()
        action = np.concatenate([position, rotvec, [2.0 * float(np.clip(gripper, 0.0, 1.0)) - 1.0]])
        self.env.step(action)
        self.steps += 1
        if not np.all(np.isfinite(self.sim.data.qpos)):
            return "MuJoCo state is not finite"
        return None

    def render(self) -> np.ndarray:
        """One RGB frame (H, W, 3) uint8 of :data:`CAMERA`."""
        width, height = VIDEO_SIZE
        frame = self.sim.render(camera_name=CAMERA, width=width, height=height)
        return np.ascontiguousarray(frame[::-1])

    def success(self) -> bool:
        """robosuite's own success check of the environment (``_check_success``)."""
        return bool(self.env._check_success())


SETTLE_STEPS = 10
"""Control steps the arm holds its start pose after a reset, so that the objects robosuite places a little
above their support come to rest before the episode's clock starts."""


def reset(env: Any, seed: int) -> RobosuiteScene:
    """Reset ``env`` to the initial state robosuite's placement initializer draws for ``seed`` and let it
    settle (:data:`SETTLE_STEPS`); the episode's clock starts after that.

    robosuite 1.5.1's samplers draw from NumPy's global generator, so it is seeded here; the same seed gives
    the same start."""
    np.random.seed(seed)
    env.reset()
    scene = RobosuiteScene(env)
    position, orientation = scene.ee_pose()
    for _ in range(SETTLE_STEPS):
        scene.step(position, orientation, 0.0)
    scene.steps = 0
    return scene


__all__ = [
    "BIN_QUARTERS",
    "CONTROL_FREQ",
    "DOOR_OPEN",
    "OBJECT_NAMES",
    "RINGS",
    "ROUND",
    "Door",
    "RobosuiteScene",
    "Touching",
    "controller_config",
    "make_env",
    "renderer_error",
    "reset",
]
