"""The executor's :class:`~taskcond.execution.world.World` over a robosuite environment: the second
implementation of the protocol, next to :class:`taskcond.worlds.kitchen.KitchenWorld`.

Environment information (§III-A.2) is made as in the kitchen: the ground-truth box of every named thing
(here from MuJoCo's geoms, :meth:`~taskcond.worlds.robosuite.scene.RobosuiteScene.box`) with the same
Gaussian noise on each coordinate of its centre and corners (:func:`taskcond.sim.perception._add_noise`),
the gripper's box exact (a robot knows its hand); the heading (yaw) of every upright free object with an
elongated section (the cereal box; a square one, the milk's, turned a grasp by up to 45° and missed in the
four-object scene), exact (no noise model of orientation: the kitchen perceives none); a ring's (the square
nut's, :data:`~taskcond.worlds.robosuite.scene.RINGS`) centre and heading those of its ring; the door's
centre and heading its panel's (robosuite turns the door by up to 0.25 rad); the spatial
relations by the one definition of :mod:`taskcond.relations`; ``gripper grasping X`` by robosuite's own
``_check_grasp`` (both finger pads on X); bins always ``open``; the door ``open`` from robosuite's success
angle (0.3 rad) on, ``closed`` below 0.05 rad.
"""

from __future__ import annotations

import time

import numpy as np
from scipy.spatial.transform import Rotation

from taskcond.conditions import ContainerState, GripperState, Predicate, Relation, SpatialRelation
from taskcond.execution.config import PANDA_HAND, Hand
from taskcond.execution.world import Observation, Touch
from taskcond.primitives import get_primitive
from taskcond.sim.perception import ObjectBox, _add_noise, spatial_relations
from taskcond.sim.recording import VideoRecorder
from taskcond.worlds.robosuite.scene import CLOSING, DOOR_CLOSED, DOOR_OPEN, RINGS, ROUND, RobosuiteScene

REACH = 0.95
"""Reach (m) of the Panda's end effector from its shoulder (as :data:`taskcond.worlds.kitchen.REACH`)."""
SHOULDER_HEIGHT = 0.333
"""Height (m) of the Panda's shoulder (joint 2) above its base."""
VIDEO_EVERY = 2
"""Record every n-th control step."""
SWEEP_WITHIN = 0.05
"""Distance (m) up to which :meth:`RobosuiteWorld.sweep` measures the hand's clearance."""
_ACROSS = np.cross([0.0, 0.0, 1.0], CLOSING)
HAND_POINTS = np.array(
    [c * CLOSING + [0.0, 0.0, -0.02] for c in (-0.068, -0.04, 0.0, 0.04, 0.068)]
    + [
        c * CLOSING + a * _ACROSS + [0.0, 0.0, -0.03]
        for c in (-0.1, -0.05, 0.0, 0.05, 0.1)
        for a in (-0.03, 0.03)
    ]
)
"""Points (m) of the Panda hand in the end-effector site's frame (z from the hand towards the
fingertips), measured from its collision geoms: the open fingers, out to 6.8 cm either side along their
closing axis (:data:`~taskcond.worlds.robosuite.scene.CLOSING`), and the bottom of the housing, which is
0.21 m long along that axis and 6 cm wide across it, 2.6 cm above the site."""
HAND = Hand(
    housing=PANDA_HAND.housing, opening=PANDA_HAND.opening, closing=tuple(CLOSING), round_carry_holds=True
)
"""robosuite's Panda hand for the executor: the kitchen's, closing along the site's x; a round object
carried keeps the hand's heading (:attr:`~taskcond.execution.config.Hand.round_carry_holds`)."""


class RobosuiteWorld:
    """A reset robosuite scene seen through the environment-information layer.

    Args:
        scene: the scene, already reset.
        noise_sigma: Gaussian noise (m) on every perceived centre and box coordinate.
        seed: seed of the perception noise.
        recorder: video of every :data:`VIDEO_EVERY`-th control step, if given.
    """

    def __init__(
        self,
        scene: RobosuiteScene,
        noise_sigma: float = 0.0,
        seed: int | None = None,
        recorder: VideoRecorder | None = None,
    ) -> None:
        self.scene = scene
        self.dt = 1.0 / scene.env.control_freq
        self.noise_sigma = noise_sigma
        self.recorder = recorder
        self._rng = np.random.default_rng(seed)
        self._observed: tuple[int, Observation] | None = None
        self.env_seconds = 0.0
        """Wall-clock seconds spent inside robosuite's step (controller and physics)."""
        base = np.array(scene.robot.base_pos, float)
        self._shoulder = base + np.array([0.0, 0.0, SHOULDER_HEIGHT])

    @property
    def time(self) -> float:
        return self.scene.steps * self.dt

    @property
    def objects(self) -> tuple[str, ...]:
        return self.scene.objects

    @property
    def arms(self) -> tuple[str, ...]:
        return ("gripper",)

    @property
    def ground(self) -> tuple[str, ...]:
        return ("table",) if "table" in self.scene.entities else ()

    def observe(self) -> Observation:
        """Environment information now; the same observation (same noise draw) until the next step."""
        if self._observed is None or self._observed[0] != self.scene.steps:
            self._observed = (self.scene.steps, self._perceive())
        return self._observed[1]

    def _perceive(self) -> Observation:
        boxes = {}
        for name in self.scene.objects:
            lower, upper = self.scene.box(name)
            box = ObjectBox(name, self.scene.centre(name), lower, upper)
            boxes[name] = _add_noise(box, self.noise_sigma, self._rng) if self.noise_sigma > 0 else box
        lower, upper, centre = self.scene.gripper_box()
        boxes["gripper"] = ObjectBox("gripper", centre, lower, upper)
        predicates: set[Predicate] = set(spatial_relations(boxes, grippers=("gripper",)))
        predicates.add(GripperState(self.scene.grasped(), "gripper"))
        predicates.update(ContainerState(c, True) for c in self.scene.containers)
        lying = self.scene.lying()
        headed = [
            n
            for n in self.scene.free
            if n not in ROUND and n not in lying and (self.scene.elongated(n) or n in RINGS)
        ] + [n for n in self.scene.entities if self.scene.entities[n].kind == "door"]
        angle = self.scene.door_angle()
        if angle is not None and (angle >= DOOR_OPEN or angle <= DOOR_CLOSED):
            predicates.add(ContainerState("door", angle >= DOOR_OPEN))
        return Observation(
            predicates=frozenset(predicates),
            centers={name: box.center for name, box in boxes.items()},
            touches=self.touches(),
            boxes={name: (box.lower, box.upper) for name, box in boxes.items()},
            round=ROUND & set(self.scene.free),
            lying=lying,
            yaws={n: self.scene.yaw(n) for n in headed},
            yaw_periods={n: self.scene.yaw_period(n) for n in headed},
        )

    def touches(self) -> tuple[Touch, ...]:
        return tuple(Touch(t.a, t.b, t.position) for t in self.scene.touches())

    def locate(self, name: str, observation: Observation) -> np.ndarray | None:
        """The perceived centre (no goal position: no robosuite task moves to one)."""
        return observation.centers.get(name)

    def affords(self, primitive: str, objects: tuple[str, ...]) -> str | None:
        unknown = [o for o in objects if o not in self.scene.objects]
        if unknown:
            return f"{', '.join(map(repr, unknown))} not in the scene (objects: {', '.join(self.objects)})"
        free = self.scene.free
        prim = get_primitive(primitive)
        if prim.sets_container:
            if objects[0] != "door" or "door" not in self.scene.entities:
                return f"{objects[0]!r} has no door, lid or drawer to {primitive}"
            return None
        if primitive == "fold":
            return f"{objects[0]!r} cannot be folded"
        if 0 in prim.movable and objects[0] not in free:
            return f"{objects[0]!r} cannot be picked up (free objects: {', '.join(free) or 'none'})"
        into = prim.effect(*objects) if prim.places is Relation.INSIDE else None
        if isinstance(into, SpatialRelation) and into.reference not in self.scene.containers:
            return f"{into.reference!r} is not a container (containers: {', '.join(self.scene.containers)})"
        return None

    def reach_error(self, position: np.ndarray, orientation: np.ndarray | None = None) -> str | None:
        """:meth:`World.reach_error` by distance only: the operational-space controller holds any
        orientation it reaches."""
        distance = float(np.linalg.norm(np.asarray(position, float)[:3] - self._shoulder))
        if distance > REACH:
            return f"{distance:.2f} m from the Panda's shoulder, beyond its reach of {REACH} m"
        return None

    def wound(self, positions: np.ndarray, orientations: np.ndarray) -> bool:
        """Never: robosuite's operational-space controller drives the hand in task space, with no IK answer
        seeded by the last to wind up."""
        return False

    def follows(self, positions: np.ndarray, orientations: np.ndarray) -> bool:
        """Always: robosuite's operational-space controller drives the hand in task space."""
        return True

    def unwind(self, gripper: float) -> str | None:
        """Nothing to do (:meth:`wound` is never true)."""
        return None

    def sweep(self, positions: np.ndarray, orientations: np.ndarray, ignore: tuple[str, ...]) -> float:
        """Least distance (m) between the hand's points (:data:`HAND_POINTS`) at each pose and the true
        boxes of everything but ``ignore`` and the ground, each of its collision geoms' own (a bin's walls
        and floor, not the box round the whole bin, inside which a grasp in the bin always is), at most
        :data:`SWEEP_WITHIN`; an approximation of the kitchen's arm clearance by the hand alone (what
        passes near a grasp)."""
        skip = {*ignore, *self.ground, "target bin"}
        boxes = [
            box
            for name in self.scene.objects
            if name not in skip
            for box in (
                [self.scene.geom_box(g) for g in self.scene.entities[name].geoms]
                if self.scene.entities[name].geoms
                else [self.scene.box(name)]
            )
        ]
        if not boxes:
            return SWEEP_WITHIN
        lower = np.array([b[0] for b in boxes])
        upper = np.array([b[1] for b in boxes])
        points = _hand_points(np.asarray(positions, float), np.asarray(orientations, float))
        outside = np.maximum(np.maximum(lower[None] - points[:, None], points[:, None] - upper[None]), 0.0)
        distance = np.linalg.norm(outside, axis=2)
        inside = np.all((points[:, None] > lower[None]) & (points[:, None] < upper[None]), axis=2)
        depth = np.min(np.minimum(points[:, None] - lower[None], upper[None] - points[:, None]), axis=2)
        signed = np.where(inside, -depth, distance)
        return float(min(signed.min(), SWEEP_WITHIN))

    def ee_pose(self, arms: int = 1) -> tuple[np.ndarray, np.ndarray]:
        return self.scene.ee_pose()

    def step(self, position: np.ndarray, orientation: np.ndarray, gripper: float) -> str | None:
        start = time.perf_counter()
        reason = self.scene.step(np.asarray(position, float)[:3], np.asarray(orientation, float)[:4], gripper)
        self.env_seconds += time.perf_counter() - start
        if self.recorder is not None and self.scene.steps % VIDEO_EVERY == 0:
            self.recorder.add(self.scene.render())
        return reason


def _hand_points(positions: np.ndarray, orientations: np.ndarray) -> np.ndarray:
    """(m·p, 3) world positions of :data:`HAND_POINTS` at m poses (positions (m, 3), orientations (m, 4))."""
    rotations = Rotation.from_quat(orientations).as_matrix()  # (m, 3, 3)
    return (positions[:, None, :] + np.einsum("mij,pj->mpi", rotations, HAND_POINTS)).reshape(-1, 3)


__all__ = ["HAND", "REACH", "RobosuiteWorld"]
