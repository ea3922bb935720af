"""Motion building blocks of the scripted oracles (paper §IV): grasp poses of the free objects and
waypoint sequences for picking, carrying, handle pulling and lid pushing.

Every function reads the current simulator state (ground truth) and returns waypoints in the world frame
(metres, xyzw quaternions) that :func:`plan` turns into a :class:`MotionPlan` starting at the current
end-effector pose.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, TypeVar

import numpy as np
from scipy.spatial.transform import Rotation

from taskcond.sim.assets import BoxSpec, CabinetSpec, MicrowaveSpec, VesselSpec, to_world
from taskcond.sim.franka import forward, top_down
from taskcond.sim.scene import KitchenScene
from taskcond.tasks.motion_plan import MotionPlan, Waypoint

if TYPE_CHECKING:
    from taskcond.envs.kitchen import KitchenEnv

SpecT = TypeVar("SpecT", BoxSpec, CabinetSpec, MicrowaveSpec)

OPEN, CLOSED = 0.0, 1.0
SAFE_Z = 0.30
"""Height (m) of free-space transit moves."""
GRIP_TIME = 0.6
"""Seconds given to the fingers to close or open."""


@dataclass(frozen=True)
class GraspPose:
    """Top-down grasp of a free object: end-effector ``height`` (m) above the object's bottom-centre frame
    and ``along`` (m) along the object's own x axis from it, gripper yaw = object yaw + ``yaw_offset``
    (rad), object ``width`` (m) between the pads. A ``round`` object (a vessel held by its wall) is held
    on the same side in the world frame whatever its yaw: the world x axis takes the place of its own, so
    the hand-to-object offset does not turn with the object's random yaw."""

    height: float
    yaw_offset: float
    width: float
    along: float = 0.0
    round: bool = False

    def pose(self, scene: KitchenScene, name: str) -> tuple[np.ndarray, np.ndarray]:
        """End-effector position (3,) and orientation (4,) grasping ``name`` where it is now."""
        pos, _ = scene.pose(name)
        yaw = 0.0 if self.round else scene.yaw(name)
        offset = np.array([self.along * math.cos(yaw), self.along * math.sin(yaw), self.height])
        grip_yaw = (yaw + self.yaw_offset + math.pi / 2) % math.pi - math.pi / 2
        return pos + offset, np.array(top_down(grip_yaw))


VESSEL_GRIP_DEPTH = 0.01
"""How far (m) below a vessel's rim the end-effector point is when it holds the wall."""

GRASPS: dict[str, GraspPose] = {
    # the upper body, palm (3.5 cm above the end-effector point) clear of the neck's top at 0.13 m
    "bottle": GraspPose(0.10, 0.0, 0.06),
    # near the top, so that with the tube standing in the mug the fingertips open above the mug's rim
    "toothpaste": GraspPose(0.085, math.pi / 2, 0.022),
    # on the handle 3.5 cm towards the blade: near the centre of mass (2.3 cm), and far enough from the
    # robot base for the hand to reach it low down (at 0.24 m in front of the base the elbow is at its limit)
    "spatula": GraspPose(0.018, 0.0, 0.022, along=0.035),
    "can": GraspPose(0.06, 0.0, 0.06),
    "cube": GraspPose(0.025, 0.0, 0.04),
}
"""Grasp of each free object of the default scene that is not a vessel (see :func:`grasp_of`)."""


def vessel_grasp(spec: VesselSpec) -> GraspPose:
    """Grasp of a vessel (bowl, mug) by the middle of its wall on the world -x side, nearest the robot,
    :data:`VESSEL_GRIP_DEPTH` below the rim: one finger inside, one outside (an open hand, 8 cm, clears a
    6 mm wall by 3.7 cm on each side, around a whole 6.8 cm bowl by 6 mm only). Lengths are rounded to the
    micrometre, the resolution the hand-written grasps had."""
    return GraspPose(
        round(spec.height - VESSEL_GRIP_DEPTH, 6),
        math.pi / 2,
        spec.wall,
        along=-round(spec.wall_radius, 6),
        round=True,
    )


def grasp_of(scene: KitchenScene, name: str) -> GraspPose:
    """The grasp of free object ``name`` in ``scene``: from its own spec for a vessel (so a resized bowl
    is held by its own wall), else :data:`GRASPS`."""
    spec = scene.config.free_objects[name][0]
    return vessel_grasp(spec) if isinstance(spec, VesselSpec) else GRASPS[name]


def plan(env: KitchenEnv, waypoints: list[Waypoint]) -> MotionPlan:
    """MotionPlan from the current end-effector pose (and gripper state) through ``waypoints``."""
    ee = env.robot.ee_pose()
    return MotionPlan.from_waypoints(ee.position, ee.orientation, waypoints, env.dt)


def current(env: KitchenEnv) -> tuple[np.ndarray, np.ndarray, float]:
    ee = env.robot.ee_pose()
    return ee.position, ee.orientation, CLOSED if env.robot.gripper_closed else OPEN


def transit(
    env: KitchenEnv,
    goal: np.ndarray,
    orientation: np.ndarray,
    gripper: float,
    z: float = SAFE_Z,
    rise_orientation: np.ndarray | None = None,
) -> list[Waypoint]:
    """Rise to ``z`` (or stay higher), turning to ``rise_orientation`` if given, travel over ``goal``
    turning to ``orientation``, go down to it."""
    pos, orn, _ = current(env)
    top = max(z, float(pos[2]))
    return [
        Waypoint(
            np.array([pos[0], pos[1], top]), orn if rise_orientation is None else rise_orientation, gripper
        ),
        Waypoint(np.array([goal[0], goal[1], top]), orientation, gripper),
        Waypoint(np.asarray(goal, float), orientation, gripper),
    ]


def nearest_grip(orientation: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """Of ``orientation`` (4,) and the same grip turned half a turn about the hand's approach axis (the
    parallel gripper is symmetric), the one closer to ``reference`` (4,). Turning from a horizontal hand
    (drawer handle) to a top-down grasp is then a 90-degree pitch, not a half turn that winds the wrist into
    its joint limits."""
    flipped = (Rotation.from_quat(orientation) * Rotation.from_euler("z", math.pi)).as_quat()
    return flipped if abs(np.dot(flipped, reference)) > abs(np.dot(orientation, reference)) else orientation


def downward(orientation: np.ndarray) -> np.ndarray | None:
    """For a hand not pointing down (after a drawer handle), the top-down orientation reached from
    ``orientation`` (4,) by pitching the hand down about its finger axis; ``None`` if it already points
    down. Turning to it first keeps the wrist away from its joint limits when the hand then turns about
    the vertical to a grasp yaw."""
    rot = Rotation.from_quat(orientation).as_matrix()
    if rot[2, 2] < -0.9:
        return None
    fingers = rot[:, 1]
    return np.array(top_down(math.atan2(fingers[0], -fingers[1])))


def pick(env: KitchenEnv, name: str, lift: float = 0.12, yaw_offset: float | None = None) -> list[Waypoint]:
    """Open, come from above, close on ``name`` and lift it by ``lift`` m; ``yaw_offset`` (rad) replaces
    the grasp's own (round objects can be taken at any yaw)."""
    grasp = grasp_of(env.scene, name)
    if yaw_offset is not None:
        grasp = replace(grasp, yaw_offset=yaw_offset)
    ee, orn = grasp.pose(env.scene, name)
    hand = current(env)[1]
    level = downward(hand)
    orn = nearest_grip(orn, hand if level is None else level)
    above = ee + np.array([0, 0, 0.12])
    return [
        *transit(env, above, orn, OPEN, z=max(SAFE_Z, above[2]), rise_orientation=level),
        Waypoint(ee, orn, OPEN, 0.9),
        Waypoint(ee, orn, CLOSED, GRIP_TIME),
        Waypoint(ee + np.array([0, 0, lift]), orn, CLOSED, 1.0),
    ]


FREED_WIDTH = 0.05
"""Opening (m) between the pads, after :func:`release_plans` opened them, below which the fingers are jammed
on the object (fully open: 0.08)."""
REGRIPS = 2
"""Times :func:`release_plans` grips again and reopens jammed fingers before it rises anyway."""


def release_plans(env: KitchenEnv, rise: float = 0.10) -> Iterator[MotionPlan]:
    """Open the fingers where the hand is; while they stay jammed on the object (opening below
    :data:`FREED_WIDTH`, at most :data:`REGRIPS` times) close them again, which presses the object's wall
    flat between the pads, and reopen; then move up by ``rise`` m. (A vessel turning in the opening hand
    can wedge its wall across the pads: BENCHMARKS.md, "LHT2* mended".)"""
    pos, orn, _ = current(env)
    yield plan(env, [Waypoint(pos, orn, OPEN, GRIP_TIME)])
    for _ in range(REGRIPS):
        if env.robot.finger_width() >= FREED_WIDTH:
            break
        yield plan(env, [Waypoint(pos, orn, CLOSED, GRIP_TIME), Waypoint(pos, orn, OPEN, GRIP_TIME)])
    yield plan(env, [Waypoint(pos + np.array([0, 0, rise]), orn, OPEN, 0.8)])


def carry(
    env: KitchenEnv, name: str, com_goal: np.ndarray, clearance: float, orientation: np.ndarray | None = None
) -> list[Waypoint]:
    """Move the held ``name`` so that its centre of mass reaches ``com_goal`` (3,), travelling with its
    lowest point at least ``clearance`` m high; the hand keeps the measured hand-to-object offset and its
    orientation, or turns to ``orientation`` (4,) on the way (the offset turning with it)."""
    pos, orn, _ = current(env)
    com = env.truth.com(name)
    offset = pos - com
    below = com[2] - env.scene.aabb(name)[0][2]
    travel_z = max(clearance + below + offset[2], float(pos[2]))
    end = orn if orientation is None else np.asarray(orientation, float)
    turn = Rotation.from_quat(end) * Rotation.from_quat(orn).inv()
    goal = np.asarray(com_goal, float) + turn.apply(offset)
    return [
        Waypoint(np.array([pos[0], pos[1], travel_z]), orn, CLOSED),
        Waypoint(np.array([goal[0], goal[1], travel_z]), end, CLOSED),
        Waypoint(goal, end, CLOSED, max(0.6, (travel_z - goal[2]) / 0.12)),
        Waypoint(goal, end, CLOSED, 0.3),
    ]


def bottom_to_com(env: KitchenEnv, name: str) -> float:
    """Height (m) of a free object's centre of mass above its lowest point, as it is held now."""
    return float(env.truth.com(name)[2] - env.scene.aabb(name)[0][2])


# ----------------------------------------------------------------------------------------- furniture
LIP_REACH_BELOW = 0.014
"""Depth (m) below the lip's underside of the end-effector point (between the closed fingertips) that lifts
the lid: the fingertips' upper faces then bear on the lip."""
LID_PUSH_INSET = 0.01
"""Distance (m) behind the lid's front edge where :func:`lid_close`'s downward fingertips push it."""
LID_PUSH_HEIGHT = 0.035
"""Height (m) above the lid's top face of the end-effector point that pushes it (fingertips on the lid)."""
FIN_PINCH_DEPTH = 0.014
"""Depth (m) below the microwave fin's top edge where :func:`door_motion` pinches it."""


def _spec(scene: KitchenScene, name: str, kind: type[SpecT]) -> SpecT:
    spec = scene.specs[name]
    if not isinstance(spec, kind):
        raise TypeError(f"{name!r} is a {type(spec).__name__}, not a {kind.__name__}")
    return spec


def drawer_handle(scene: KitchenScene, drawer: str) -> np.ndarray:
    """World centre (3,) of a drawer's handle bar."""
    return to_world(scene.pose(drawer), _spec(scene, "cabinet", CabinetSpec).handle_center)


def drawer_motion(env: KitchenEnv, drawer: str, to_fraction: float) -> list[Waypoint]:
    """Grasp a drawer's handle with the hand pointing +x, slide it to ``to_fraction`` of its travel,
    let go and back off."""
    spec = _spec(env.scene, "cabinet", CabinetSpec)
    handle = drawer_handle(env.scene, drawer)
    orn = np.array(forward())
    pre = handle - np.array([0.12, 0, 0])
    travel = (to_fraction - env.scene.open_fraction(drawer)) * spec.travel
    goal = handle - np.array([travel, 0, 0])
    back = goal - np.array([0.10, 0, 0])
    return [
        *transit(env, pre, orn, OPEN),
        Waypoint(handle, orn, OPEN, 1.0),
        Waypoint(handle, orn, CLOSED, GRIP_TIME),
        Waypoint(goal, orn, CLOSED, max(1.0, abs(travel) / 0.12)),
        Waypoint(goal, orn, OPEN, GRIP_TIME),
        Waypoint(back, orn, OPEN, 0.8),
    ]


def lid_open(env: KitchenEnv) -> list[Waypoint]:
    """Slide the closed fingertips (hand pointing +x) under the lid's lip and lift it along its arc past
    vertical to its stop (:attr:`BoxSpec.open_angle`, the hinge's limit), where gravity holds it."""
    spec = _spec(env.scene, "box", BoxSpec)
    frame = env.scene.pose("box")
    lip_x, _, lip_z = spec.lip_center
    under = np.array([lip_x, 0.0, lip_z - spec.lip[2] / 2 - LIP_REACH_BELOW])
    orn = np.array(forward())
    start = spec.hinge.to_world(frame, 0.0, under)
    arc = [
        Waypoint(spec.hinge.to_world(frame, a, under), orn, CLOSED, 0.12)
        for a in np.linspace(0.05, spec.open_angle, 24)
    ]
    end = arc[-1].position
    return [
        *transit(env, start - np.array([0.10, 0, 0]), orn, CLOSED),
        Waypoint(start, orn, CLOSED, 0.8),
        *arc,
        Waypoint(end - np.array([0.12, 0, 0]), orn, CLOSED, 0.8),
    ]


def lid_close(env: KitchenEnv, to_angle: float = 0.6) -> list[Waypoint]:
    """Push the open lid from behind with the downward fingertips along its arc until gravity shuts it."""
    spec = _spec(env.scene, "box", BoxSpec)
    frame = env.scene.pose("box")
    angle = env.scene.joint_position("box")
    orn = np.array(top_down())
    front_x, _, top_z = spec.lid_front_top
    contact = np.array([front_x + LID_PUSH_INSET, 0.0, top_z + LID_PUSH_HEIGHT])
    first = spec.hinge.to_world(frame, angle, contact)
    arc = [
        Waypoint(spec.hinge.to_world(frame, a, contact), orn, CLOSED, 0.12)
        for a in np.linspace(angle, to_angle, 20)
    ]
    up = arc[-1].position + np.array([-0.05, 0, 0.10])
    over = spec.hinge.axis_in_world(frame)[0][2] + spec.size[0] + 0.10
    return [
        *transit(env, first + np.array([0, 0, 0.10]), orn, CLOSED, z=over),
        Waypoint(first, orn, CLOSED, 0.8),
        *arc,
        Waypoint(up, orn, CLOSED, 0.8),
    ]


def door_motion(env: KitchenEnv, to_angle: float) -> list[Waypoint]:
    """Pinch the microwave door's fin from above (fingers across the door), swing the door about its
    hinge to ``to_angle`` rad turning the hand with it, then let go and rise."""
    spec = _spec(env.scene, "microwave", MicrowaveSpec)
    frame = env.scene.pose("microwave")
    angle = env.scene.joint_position("microwave")
    fin_x, fin_y, fin_z = spec.fin_center
    local = np.array([fin_x, fin_y, fin_z + spec.fin[2] / 2 - FIN_PINCH_DEPTH])
    grip = spec.hinge.to_world(frame, angle, local)
    above = np.array([0, 0, 0.10])
    n = max(2, round(abs(to_angle - angle) / 0.05))
    arc = [
        Waypoint(spec.hinge.to_world(frame, a, local), np.array(top_down(math.pi / 2 + a)), CLOSED, 0.12)
        for a in np.linspace(angle, to_angle, n)[1:]
    ]
    end, end_orn = arc[-1].position, arc[-1].orientation
    orn = np.array(top_down(math.pi / 2 + angle))
    return [
        *transit(env, grip + above, orn, OPEN),
        Waypoint(grip, orn, OPEN, 0.8),
        Waypoint(grip, orn, CLOSED, GRIP_TIME),
        *arc,
        Waypoint(end, end_orn, OPEN, GRIP_TIME),
        Waypoint(end + above, end_orn, OPEN, 0.8),
    ]
