"""robosuite's tasks in the condition vocabulary: each robosuite environment as the primitive task names
that do it, a scripted oracle per primitive (robosuite ships no scripted experts), and robosuite's own
``_check_success`` as the judge. The registry is :data:`TASKS`; ids are robosuite's environment names.

An oracle plans from the true state of the scene when its primitive starts (MuJoCo's poses, never the
perceived ones) and yields end-effector commands, one per control step: (position (3,) m, orientation (4,)
xyzw, gripper 0 open … 1 closed), world frame. Every primitive but opening the door (a level hand,
:func:`level`, :func:`open_door`) keeps the hand pointing down (:func:`down`); a grasp turns it about the
vertical so that the fingers close across an elongated object's narrow side (:func:`across`; the cereal
box is 10 cm long, more than the Panda's 8 cm opening), the primitives after it keep the heading the hand
has. A ring (the square nut) is held across a wall (:func:`grasp_ring`) and carried turned to line up with
the square peg (:func:`carry_ring`).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

from taskcond.conditions import ContainerState, Relation
from taskcond.primitives import parse_task
from taskcond.worlds.robosuite.scene import CLOSING, RINGS, ROUND, RobosuiteScene

Command = tuple[np.ndarray, np.ndarray, float]
"""One control step's end-effector command: position (3,) m, orientation (4,) xyzw, gripper 0–1."""

SPEED = 0.2
"""Oracle hand speed, m/s."""
HOLD = 12
"""Control steps the oracle holds still where the gripper closes or opens."""
LIFT = 0.22
"""Height (m) a grasp lifts its object by; a release rises as much (robosuite's PickPlace counts an object
placed only once the hand is 7 cm away from it). More than the tallest object robosuite places (the cereal
box, 15 cm): a skill demonstrated alone then carries its object over the others (at 15 cm the bread
grazed the cereal's top and knocked it over)."""
ABOVE = 0.10
"""Height (m) above an object's top where a grasp's descent starts."""
GRIP_DEPTH = 0.035
"""Depth (m) below an object's top at which the fingertips close ..."""
GRIP_FLOOR = 0.015
"""... or this height (m) above its bottom if that is higher: a short object (the cube) is held over most
of its height, so that 5 mm of perception noise on its height leaves the pads on it."""
CLEARANCE = 0.06
"""Clearance (m) of a carried object above what it is carried over."""
DROP = 0.02
"""Height (m) above its place at which a carried object is let go."""
CARRIES = (Relation.INSIDE, Relation.ABOVE)
"""The relations a carry oracle places its object in with another: into a bin, on top of a cube."""
RING_GRIP = np.array([0.0, 0.045, 0.0])
"""Where the hand holds a ring (:data:`~taskcond.worlds.robosuite.scene.RINGS`), m, in the ring's frame:
across its wall at +y, or the wall at −y half a turn away (robosuite's SquareNut: an 8.75 cm square ring of
2.1 cm walls whose middles lie 3.325 cm from the centre, the handle on the +x wall), the fingers closing
along y, the hand 1.2 cm outside the wall's middle: coming down there, the open inner finger clears the far
wall (over the wall's middle it brushed the far wall's top, and the learned approach ended at the
standstill above the ring instead of at the grip); closing, it slides the ring onto the outer finger.
Tried before: the +x wall's middle (the handle is in the outer finger's way), near a corner across a wall
(the inner finger landed on the next wall) and across a corner (the opened inner finger kept the nut
hanging on it)."""
RING_DEPTH = 0.008
"""Depth (m) below a ring's top (2 cm high) at which the hand (the end-effector site) closes on it: the
fingers reach 8 mm below the site, so they stop 4 mm above the table (at 2 mm they touched it, which the
LLM's conditions do not allow, and Alg. 2 moved the grasp away)."""
FINAL_SPEED = 0.05
"""Speed (m/s) of the hand's last 10 cm onto what it grasps, from a standstill before it, for a ring and the
door's lever: slow, so that the arm, which lags its commands, is there when the fingers close (at
:data:`SPEED` it was 1.8 cm high over the ring, 2.5 cm short of the lever), and so that the learned
approach (one DMP piece, up to the standstill at the grip), which reaches its goal only at its end, comes
in only after it has arrived in front. Tried for the ring: the descent as a DMP piece of its own, from the
standstill above; it starts where the lagging hand is, and 4 of 10 grasps closed 1 cm high and 2 cm
aside."""
LEVER_GRIP = 0.125
"""Distance (m) from the latch's axis along the door's lever (15 cm long) at which the hand holds it: far
enough out that the hand's housing (7 cm either side of the fingers along the lever) clears the latch's
boss, which stands 1 cm proud of the lever round the axis (at 10 cm the hand stopped 2.5 cm short)."""
LEVER_TURN = np.radians(85.0)
"""Turn (rad) of the door's lever that unlatches the door: the latch frees it from about 1.25 rad
(measured by holding the latch at fixed angles and pushing the door: at 1.2 rad it stuck at 0.1 rad of
opening, from 1.25 rad it opened to the hinge's stop); the hand, holding the lever by friction, turns it
about 1.45 rad by this."""
DOOR_PULL = 0.40
"""Turn (rad) of the hand about the door's hinge: the hinge's stop (robosuite counts 0.3 rad as open)."""
TURN_STEPS = 40
"""Control steps of turning the lever, and of pulling the door, each (2 s at 20 Hz)."""


@dataclass(frozen=True)
class RobosuiteTask:
    """One robosuite environment as a task.

    Attributes:
        id: robosuite's environment name (``Lift``, ``PickPlaceCan``).
        steps: the primitive task names that do it, in order.
        description: one line.
    """

    id: str
    steps: tuple[str, ...]
    description: str

    @property
    def kind(self) -> str:
        return "primitive" if len(self.steps) == 1 else "long-horizon"


def _pick_place(obj: str) -> tuple[str, ...]:
    return (f"grasp {obj}", f"move {obj} into {obj} bin", f"release {obj}")


SINGLE_OBJECTS = {
    "PickPlaceMilk": "milk",
    "PickPlaceBread": "bread",
    "PickPlaceCereal": "cereal",
    "PickPlaceCan": "can",
}
"""robosuite's single-object PickPlace environments and their object."""
TALLEST_FIRST = ("cereal", "milk", "can", "bread")
"""The four-object PickPlace's objects in the order they are put away: the tallest first (robosuite's
boxes: cereal 15 cm, milk 14.4 cm, can 8 cm, bread 4.8 cm). A hand coming straight down onto an object
sweeps the space above it down to its grip, a few centimetres below the object's top; a neighbour taller
than that is in its way. Taken tallest first, every object left beside the one grasped is lower than it
(in robosuite's order, milk, bread, cereal, can, the hand descending on the bread met the top of the
cereal box standing beside it and knocked it over)."""

TASKS: dict[str, RobosuiteTask] = {
    t.id: t
    for t in (
        RobosuiteTask("Lift", ("grasp cube",), "lift the cube"),
        RobosuiteTask(
            "Stack",
            ("grasp red cube", "move red cube on top of green cube", "release red cube"),
            "stack the red cube on the green cube",
        ),
        *(
            RobosuiteTask(env, _pick_place(obj), f"put the {obj} into its bin")
            for env, obj in SINGLE_OBJECTS.items()
        ),
        RobosuiteTask(
            "PickPlace",
            tuple(s for obj in TALLEST_FIRST for s in _pick_place(obj)),
            "put each of the four objects into its bin",
        ),
        RobosuiteTask("Door", ("open door",), "open the door"),
        RobosuiteTask(
            "NutAssemblySquare",
            ("grasp square nut", "move square nut on top of square peg", "release square nut"),
            "put the square nut onto the square peg",
        ),
    )
}
"""The supported robosuite environments, by robosuite's name."""


class UnknownRobosuiteTaskError(KeyError):
    """An id that is not in :data:`TASKS`; the message lists the valid ones."""

    def __str__(self) -> str:
        return str(self.args[0])


def get_task(task_id: str) -> RobosuiteTask:
    """The task of robosuite's environment ``task_id``.

    Raises:
        UnknownRobosuiteTaskError: not a supported environment.
    """
    try:
        return TASKS[task_id]
    except KeyError:
        raise UnknownRobosuiteTaskError(
            f"unknown robosuite task {task_id!r}; valid: {', '.join(TASKS)}"
        ) from None


# ------------------------------------------------------------------------------------------- oracles
def hand(closing: np.ndarray, pointing: np.ndarray) -> np.ndarray:
    """The hand pointing along ``pointing`` (3,) (the end-effector site's z) with its fingers closing along
    ``closing`` (3,), perpendicular to it (the site's :data:`~taskcond.worlds.robosuite.scene.CLOSING`
    axis), xyzw (4,)."""
    z = pointing / np.linalg.norm(pointing)
    c = closing / np.linalg.norm(closing)
    site_z = np.array([0.0, 0.0, 1.0])
    world = np.column_stack([c, np.cross(z, c), z])
    site = np.column_stack([CLOSING, np.cross(site_z, CLOSING), site_z])
    return Rotation.from_matrix(world @ site.T).as_quat()


def closing_axis(quat: np.ndarray) -> np.ndarray:
    """The world axis (3,) along which the hand at orientation ``quat`` (4,) xyzw closes its fingers."""
    return Rotation.from_quat(quat).apply(CLOSING)


DOWN = np.array([0.0, 0.0, -1.0])
"""World −z: where a hand pointing down points."""


def down(scene: RobosuiteScene) -> np.ndarray:
    """The hand pointing straight down, its fingers' closing axis (:func:`closing_axis`) the horizontal
    part of the current pose's: the current pose without its tilt, xyzw (4,)."""
    closing = closing_axis(scene.ee_pose()[1])
    return hand(np.array([closing[0], closing[1], 0.0]), DOWN)


def across(scene: RobosuiteScene, obj: str, quat: np.ndarray) -> np.ndarray:
    """The hand pointing down (``quat`` (4,) xyzw, pointing down) turned about the vertical by the least
    turn that makes its fingers close (:func:`closing_axis`) along the shorter of the object's own
    horizontal axes (:meth:`~RobosuiteScene.axes`, :meth:`~RobosuiteScene.half_size`) for an elongated
    section (:meth:`~RobosuiteScene.elongated`: the cereal box); ``quat`` for a round or square one. xyzw
    (4,)."""
    if obj in ROUND or not scene.elongated(obj):
        return quat
    axes, half = scene.axes(obj), scene.half_size(obj)
    narrow = axes[:, 0] if half[0] <= half[1] else axes[:, 1]
    closing = np.array([narrow[0], narrow[1], 0.0])
    return hand(closing if closing @ closing_axis(quat) >= 0.0 else -closing, DOWN)


def _line(start: np.ndarray, goal: np.ndarray, speed: float = SPEED, dt: float = 0.05) -> list[np.ndarray]:
    """Positions (3,) m, one per control step, from ``start`` (exclusive) to ``goal`` (inclusive)."""
    n = max(1, int(np.ceil(np.linalg.norm(goal - start) / (speed * dt))))
    return [start + (goal - start) * (k / n) for k in range(1, n + 1)]


def _path(
    waypoints: list[tuple[np.ndarray, float]], start: np.ndarray, quat: np.ndarray
) -> Iterator[Command]:
    """Straight lines through ``waypoints`` (position (3,) m, gripper), each end held :data:`HOLD` steps
    where the gripper command changes."""
    here, grip = start, waypoints[0][1]
    for point, gripper in waypoints:
        if gripper != grip:
            for _ in range(HOLD):
                yield here, quat, gripper
            grip = gripper
        for position in _line(here, point):
            yield position, quat, gripper
        here = point
    for _ in range(3):
        yield here, quat, grip


def grasp(scene: RobosuiteScene, obj: str, quat: np.ndarray) -> Iterator[Command]:
    """Above the object (turning the hand :func:`across` it), straight down to :data:`GRIP_DEPTH` below its
    top (:data:`GRIP_FLOOR` above its bottom at least), close, lift :data:`LIFT`."""
    quat = across(scene, obj, quat)
    here, _ = scene.ee_pose()
    lower, upper = scene.box(obj)
    centre = (lower + upper) / 2
    grip = np.array([centre[0], centre[1], max(lower[2] + GRIP_FLOOR, upper[2] - GRIP_DEPTH)])
    above = np.array([*grip[:2], upper[2] + ABOVE])
    yield from _path(
        [(np.array([*here[:2], max(here[2], above[2])]), 0.0), (above, 0.0), (grip, 0.0)], here, quat
    )
    yield from _close_and_lift(grip, quat)


def _close_and_lift(grip: np.ndarray, quat: np.ndarray) -> Iterator[Command]:
    """Hold still at ``grip`` (3,) m with the hand open (:data:`HOLD` steps), close, lift :data:`LIFT`; the
    hand at ``quat`` (4,) xyzw. The standstill ends the learned grasp's approach there
    (:func:`~taskcond.execution.skills.split_points`): its DMP piece then ends holding still at the grip, and
    the arm, which lags its commands by 1.5-2.5 cm on a descent, arrives before the closing piece starts
    where the hand is. Without it, the milk's grasp closed 1.3 cm below its top instead of 3.5 cm, on the
    gable roof of its carton (the top 2.6 cm narrow to a ridge along its own y): turned a quarter turn, the
    fingers closed across the roof's slopes, lifted it by the fingers' rims and not their pads, and
    robosuite's ``_check_grasp`` (both pads on the object) said not held."""
    for _ in range(HOLD):
        yield grip, quat, 0.0
    yield from _path([(grip, 0.0), (grip, 1.0), (grip + np.array([0.0, 0.0, LIFT]), 1.0)], grip, quat)


def _turned(quat: np.ndarray, angle: float) -> np.ndarray:
    """``quat`` (4,) xyzw turned by ``angle`` rad about the world's vertical."""
    return (Rotation.from_rotvec([0.0, 0.0, angle]) * Rotation.from_quat(quat)).as_quat()


def grasp_ring(scene: RobosuiteScene, obj: str, quat: np.ndarray) -> Iterator[Command]:
    """Grasp a ring (:data:`~taskcond.worlds.robosuite.scene.RINGS`, the square nut) at :data:`RING_GRIP`,
    of the points its symmetry makes of it the one nearest the hand, the hand pointing down with its
    fingers closing towards the ring's centre (:func:`closing_axis`) in whichever of its two ways is
    nearer ``quat`` (4,) xyzw: turned on its way to :data:`ABOVE` over the grip, still there, down at
    :data:`FINAL_SPEED` to :data:`RING_DEPTH` below the top, still there, close, lift :data:`LIFT`."""
    here, _ = scene.ee_pose()
    centre, period = scene.centre(obj), scene.yaw_period(obj)
    angles = scene.yaw(obj) + period * np.arange(round(2 * np.pi / period))
    points = [centre + Rotation.from_rotvec([0.0, 0.0, a]).apply(RING_GRIP) for a in angles]
    k = int(np.argmin([np.linalg.norm((p - here)[:2]) for p in points]))
    normal = Rotation.from_rotvec([0.0, 0.0, angles[k]]).apply(RING_GRIP / np.linalg.norm(RING_GRIP))
    held = hand(normal if normal @ closing_axis(quat) >= 0.0 else -normal, DOWN)
    grip = np.array([*points[k][:2], scene.box(obj)[1][2] - RING_DEPTH])
    above = grip + np.array([0.0, 0.0, ABOVE])
    high = np.array([*here[:2], max(here[2], above[2])])
    yield from _path([(high, 0.0)], here, quat)
    yield from _turning(high, above, quat, held, 0.0)
    for position in _line(above, grip, FINAL_SPEED):
        yield position, held, 0.0
    yield from _close_and_lift(grip, held)


def _turning(
    start: np.ndarray, goal: np.ndarray, quat: np.ndarray, end: np.ndarray, gripper: float
) -> Iterator[Command]:
    """A straight line from ``start`` to ``goal`` (3,) m at :data:`SPEED` with the hand turning from ``quat``
    to ``end`` (4,) xyzw on the way (turned at once, the arm of a large turn was thrown into its joint
    limits and lost the pose), then :data:`HOLD` steps at the end."""
    line = _line(start, goal)
    turns = Slerp([0.0, 1.0], Rotation.from_quat([quat, end]))(np.linspace(0.0, 1.0, len(line) + 1)[1:])
    for position, orientation in zip(line, turns.as_quat(), strict=True):
        yield position, orientation, gripper
    for _ in range(HOLD):
        yield goal, end, gripper


def carry_ring(scene: RobosuiteScene, obj: str, place: str) -> Iterator[Command]:
    """Carry the held ring ``obj`` up and across, turning it by the least turn that brings its heading to
    0 or π (its sides then lie along the world's axes, as robosuite's square peg's do, and the hand
    holding it across its ±y walls closes along world y, as the arm starts: turned to ±π/2 instead, the
    arm reaching out to the peg lost its pose in 3 of 10 runs), until its centre is above the centre of
    ``place``'s box, hold, and lower it until its bottom is :data:`DROP` above the place's top."""
    here, quat = scene.ee_pose()
    turn = -float((scene.yaw(obj) + np.pi / 2) % np.pi - np.pi / 2)
    lever = Rotation.from_rotvec([0.0, 0.0, turn]).apply(here - scene.centre(obj))
    hand_above_bottom = here[2] - scene.box(obj)[0][2]
    p_lower, p_upper = scene.box(place)
    target = (p_lower + p_upper) / 2 + lever
    high = max(here[2], p_upper[2] + hand_above_bottom + CLEARANCE)
    end = _turned(quat, turn)
    top, over = np.array([*here[:2], high]), np.array([*target[:2], high])
    yield from _path([(top, 1.0)], here, quat)
    yield from _turning(top, over, quat, end, 1.0)
    yield from _path([(np.array([*target[:2], p_upper[2] + DROP + hand_above_bottom]), 1.0)], over, end)


def release(scene: RobosuiteScene, obj: str, quat: np.ndarray) -> Iterator[Command]:
    """Open where the hand is, then rise :data:`LIFT`."""
    here, _ = scene.ee_pose()
    yield from _path([(here, 1.0), (here, 0.0), (here + np.array([0.0, 0.0, LIFT]), 0.0)], here, quat)


def carry(scene: RobosuiteScene, obj: str, place: str, quat: np.ndarray, inside: bool) -> Iterator[Command]:
    """Carry the held ``obj`` up, across to above ``place``, hold still there (:data:`HOLD` steps) and go
    straight down until its bottom is :data:`DROP` above the place's floor (``inside``: a bin's bottom) or
    top. The standstill ends the skill's approach there (:func:`~taskcond.execution.skills.split_points`):
    learned from it, the way across is one DMP piece aimed at the place from wherever the carry starts and
    the descent another, straight down; without it the one warped piece of a carry started elsewhere than
    demonstrated came down over the target bin's divider (BENCHMARKS.md, seed 1001)."""
    here, _ = scene.ee_pose()
    lower, _ = scene.box(obj)
    hand_above_bottom = here[2] - lower[2]
    p_lower, p_upper = scene.box(place)
    target = (p_lower + p_upper) / 2
    floor = p_lower[2] if inside else p_upper[2]
    high = max(here[2], p_upper[2] + hand_above_bottom + CLEARANCE)
    over = np.array([*target[:2], high])
    yield from _path([(np.array([*here[:2], high]), 1.0), (over, 1.0)], here, quat)
    for _ in range(HOLD):
        yield over, quat, 1.0
    yield from _path([(np.array([*target[:2], floor + DROP + hand_above_bottom]), 1.0)], over, quat)


def level(outward: np.ndarray) -> np.ndarray:
    """The hand level, pointing horizontally against ``outward`` (3,) (at a door's panel) with its fingers
    closing vertically (:func:`closing_axis` world −z), xyzw (4,)."""
    return hand(DOWN, -np.array([outward[0], outward[1], 0.0]))


def _arc(
    here: np.ndarray, quat: np.ndarray, centre: np.ndarray, axis: np.ndarray, angle: float, gripper: float
) -> list[Command]:
    """:data:`TURN_STEPS` poses of the hand (position ``here`` (3,) m, orientation ``quat`` (4,) xyzw)
    turned rigidly by up to ``angle`` rad about the line through ``centre`` (3,) along ``axis`` (3,)."""
    out = []
    for k in range(1, TURN_STEPS + 1):
        turn = Rotation.from_rotvec(axis * angle * k / TURN_STEPS)
        out.append((centre + turn.apply(here - centre), (turn * Rotation.from_quat(quat)).as_quat(), gripper))
    return out


def open_door(scene: RobosuiteScene, quat: np.ndarray) -> Iterator[Command]:
    """Open robosuite's latched door (:meth:`~RobosuiteScene.door`): the hand turns level (:func:`level`)
    on its way to :data:`ABOVE` in front of the lever, :data:`LEVER_GRIP` out along it, comes in at
    :data:`FINAL_SPEED`, holds still and closes on it; turns the lever's free end up by :data:`LEVER_TURN`
    about the latch's axis (up, not down: pressed down, the Panda's last joint met its limit); pulls the
    door open by :data:`DOOR_PULL` about the hinge, turns the lever back, lets go and backs off along the
    panel's normal. ``quat`` is unused: the hand's heading is the door's."""
    door = scene.door()
    if door is None:
        raise ValueError("no door in this scene")
    here, _ = scene.ee_pose()
    level_hand = level(door.outward)
    grip = door.latch + LEVER_GRIP * door.lever
    lift = 1.0 if np.cross(door.latch_axis, door.lever)[2] > 0 else -1.0
    front = grip + ABOVE * door.outward
    yield from _path([(front, 0.0)], here, level_hand)
    for position in _line(front, grip, FINAL_SPEED):
        yield position, level_hand, 0.0
    for gripper in (0.0, 1.0):
        for _ in range(HOLD):
            yield grip, level_hand, gripper
    steps = _arc(grip, level_hand, door.latch, door.latch_axis, lift * LEVER_TURN, 1.0)
    pulled, turned = steps[-1][0], steps[-1][1]
    steps += _arc(pulled, turned, door.hinge, door.hinge_axis, DOOR_PULL, 1.0)
    swing = Rotation.from_rotvec(door.hinge_axis * DOOR_PULL)
    latch = door.hinge + swing.apply(door.latch - door.hinge)
    steps += _arc(*steps[-1][:2], latch, swing.apply(door.latch_axis), -lift * LEVER_TURN, 1.0)
    yield from steps
    end, end_quat, _ = steps[-1]
    yield from _path([(end, 1.0), (end, 0.0), (end + ABOVE * swing.apply(door.outward), 0.0)], end, end_quat)


def oracle(scene: RobosuiteScene, task_name: str, quat: np.ndarray) -> Iterator[Command]:
    """The scripted commands of one primitive task from the scene's current state, chosen by what the
    primitive achieves (:attr:`~taskcond.primitives.Primitive.achieves`), never by its id: a grasp
    (:attr:`~taskcond.primitives.Primitive.grasps`), a let-go
    (:attr:`~taskcond.primitives.Primitive.lets_go`), a carry that places its object inside or above
    another (:attr:`~taskcond.primitives.Primitive.places`). ``quat`` (4,) xyzw is the hand pointing down
    (:func:`down`) at the task's start: a grasp turns it across its object, the other primitives keep the
    hand's current heading.

    Raises:
        ValueError: a primitive no oracle here performs (its effect is none of these).
    """
    task = parse_task(task_name)
    primitive = task.primitive
    if primitive.grasps:
        if task.objects[0] in RINGS:
            return grasp_ring(scene, task.objects[0], quat)
        return grasp(scene, task.objects[0], quat)
    if primitive.lets_go:
        return release(scene, task.objects[0], down(scene))
    if primitive.places is Relation.ABOVE and task.objects[0] in RINGS:
        return carry_ring(scene, *task.objects)
    if primitive.places in CARRIES and len(task.objects) == 2:
        return carry(scene, *task.objects, down(scene), inside=primitive.places is Relation.INSIDE)
    if primitive.effect(*task.objects) == ContainerState("door", True):
        return open_door(scene, quat)
    raise ValueError(
        f"no robosuite oracle for {task.name!r}; oracles: a grasp, a let-go, a carry placing an object "
        f"{' or '.join(str(r) for r in CARRIES)} another, opening the door"
    )


__all__ = [
    "SINGLE_OBJECTS",
    "TALLEST_FIRST",
    "TASKS",
    "Command",
    "RobosuiteTask",
    "UnknownRobosuiteTaskError",
    "closing_axis",
    "down",
    "get_task",
    "oracle",
]
