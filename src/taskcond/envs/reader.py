"""What :class:`~taskcond.envs.kitchen.KitchenEnv` reads of the simulator after each control step, and the
blow-up check on it.

:class:`StepReader` reads the state once per control step (:class:`Reading`); the observation, the blow-up
check (:class:`BlowupMonitor`) and the task's success judge all take that one reading instead of asking
PyBullet again. The judge gets it as an argument (``truth.at(reading)``,
:meth:`taskcond.tasks.groundtruth.GroundTruth.at`), so what it sees does not depend on call order.

Both components skip work whose result cannot have changed, bit for bit: the free objects' base-link poses
are recomputed only for objects whose centre-of-mass pose changed, the containers' open fractions only when
their joints changed, and the deep-penetration check reads only the contacts of the bodies that moved
(:meth:`BlowupMonitor.moved_bodies`). BENCHMARKS.md ("Simulation throughput") has the measurements.

Bullet keeps state across a reset that no pose or velocity shows: persistent contact points (whose impulses
warm-start the solver), the order of overlapping pairs, and sleeping (a free object asleep at the end of one
episode stayed asleep, hovering where :meth:`~taskcond.sim.scene.KitchenScene.place` put it 0.5 mm above the
counter). :meth:`BlowupMonitor.reset` therefore parks the free objects far apart and out of reach with
sleeping disabled and runs one physics step, which drops their contacts and wakes them; the environment's
client orders pairs deterministically (``deterministicOverlappingPairs``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from itertools import compress, repeat
from operator import itemgetter, ne, or_
from typing import Any, NamedTuple

import numpy as np
import pybullet as p

from taskcond.sim.franka import ARM_JOINTS, FINGER_JOINTS
from taskcond.sim.scene import FramePose, KitchenScene

WORKSPACE = (np.array([-0.4, -1.0, -0.2]), np.array([1.1, 1.0, 1.5]))
"""Bounds (min, max) in metres of where free objects may be; leaving them ends the episode."""
_WORKSPACE_BOUNDS = tuple(zip(WORKSPACE[0].tolist(), WORKSPACE[1].tolist(), strict=True))
"""(min, max) per world axis of :data:`WORKSPACE`, as floats for the per-step check."""
ROBOT_JOINTS = (*ARM_JOINTS, *FINGER_JOINTS)
"""Franka joints read once per control step: the arm's seven, then the two fingers."""
ARM_DOFS = len(ARM_JOINTS)
PENETRATION = 0.03
"""Contact depth (m) counted as a simulation blow-up."""
BODY_QUERIES = 3
"""Most contact queries per body (``p.getContactPoints(bodyA=...)``) the deep-penetration check makes
(:meth:`BlowupMonitor.moved_bodies`); with more bodies to query it asks for every contact point at once."""
_DEEPER_THAN_PENETRATION = (-PENETRATION).__gt__
"""Whether a contact distance (m, negative inside) is below ``-PENETRATION``: ``False`` for NaN, as ``<``."""
_FIRST = itemgetter(0)
"""Item 0 of a ``p.getJointStates`` entry: the joint position (m or rad)."""
_CONTACT_DISTANCE = itemgetter(8)
"""Item 8 of a ``p.getContactPoints`` tuple: the contact distance (m, negative when penetrating)."""
PARKING = (100.0, 0.0, 100.0)
"""World position (m) of the first free object parked at reset (:meth:`BlowupMonitor.reset`); the others
follow :data:`PARKING_SPACING` apart along +x, far from each other and from every other body."""
PARKING_SPACING = 2.0
"""Metres between parked free objects (every object is smaller than 0.5 m)."""


class Reading(NamedTuple):
    """The simulator state read once after a control step, shared by the observation, the blow-up check
    and the success judge. Nothing moves between the read and the end of the step.

    Attributes:
        joints: positions of the Franka's :data:`~taskcond.sim.franka.ARM_JOINTS` (rad), then of its two
            :data:`~taskcond.sim.franka.FINGER_JOINTS` (m).
        bases: centre-of-mass pose (position m, quaternion xyzw, world) of each free object, in the order of
            :attr:`KitchenScene.free_objects <taskcond.sim.scene.KitchenScene.free_objects>`, as
            ``p.getBasePositionAndOrientation`` reports it.
        containers: container joint positions (m or rad) per articulated body
            (:meth:`~taskcond.sim.scene.KitchenScene.container_joint_positions`).
        open_fractions: open fraction of each container of :data:`~taskcond.sim.scene.ARTICULATED`, in that
            order, from ``containers`` (:meth:`~taskcond.sim.scene.KitchenScene.open_fractions`).
        cloth_nodes: (n*n, 3) world node positions (m) of the cloth, or ``None`` without one.
        contacts: body id → its contact points as ``p.getContactPoints(bodyA=body)`` reports them, for the
            bodies the blow-up check read one by one (:meth:`BlowupMonitor.check` fills it; empty before).
    """

    joints: list[float]
    bases: list[FramePose]
    containers: list[tuple[float, ...]]
    open_fractions: list[float]
    cloth_nodes: np.ndarray | None
    contacts: dict[int, Sequence[tuple[Any, ...]]]


class StepReader:
    """Reads a :class:`KitchenScene` once per control step and turns the free objects' poses into the
    observation's base-link poses.

    Args:
        scene: the scene to read.
    """

    def __init__(self, scene: KitchenScene) -> None:
        self.scene = scene
        self._free_ids = [scene.bodies[n] for n in scene.free_objects]
        self._com_to_base = [scene.com_to_base(body) for body in self._free_ids]
        """Per free object, its base-link frame in its centre-of-mass frame (the observation's poses)."""
        self._base_frames: list[tuple[FramePose, tuple[float, ...]] | None] = [None] * len(self._free_ids)
        """Per free object, the last centre-of-mass pose :meth:`_base_link_poses` transformed and its
        base-link frame (position m + quaternion xyzw, world)."""
        self._poses_of: tuple[list[FramePose] | None, np.ndarray] = (None, np.zeros((0, 7)))
        """The free objects' centre-of-mass poses of the last :meth:`object_poses` and their base-link poses
        (n, 7), which it copies while the poses compare equal."""
        self._fractions_of: tuple[list[tuple[float, ...]] | None, list[float]] = (None, [])
        """The container joint positions of the last reading and their open fractions."""

    def read(self) -> Reading:
        """Read the Franka's joints, the free objects' poses, the container joints and the cloth's nodes
        (one query each, one per articulated body). While the container joints compare equal to the previous
        reading's, its open fractions are reused (they are a function of the joints alone)."""
        scene, client = self.scene, self.scene.client
        containers = scene.container_joint_positions()
        if containers != self._fractions_of[0]:
            self._fractions_of = (containers, scene.open_fractions(containers))
        return Reading(
            list(map(_FIRST, p.getJointStates(scene.robot.body, ROBOT_JOINTS, client))),
            list(map(p.getBasePositionAndOrientation, self._free_ids, repeat(client))),
            containers,
            self._fractions_of[1],
            scene.cloth_nodes() if scene.cloth is not None else None,
            {},
        )

    def object_poses(self, bases: list[FramePose]) -> np.ndarray:
        """Base-link poses (n, 7) (position m + quaternion xyzw, world) of the free objects whose
        centre-of-mass poses are ``bases`` (a new array)."""
        if bases != self._poses_of[0]:
            self._poses_of = (bases, np.array(self._base_link_poses(bases)).reshape(len(bases), 7))
        return self._poses_of[1].copy()

    def _base_link_poses(self, bases: list[FramePose]) -> list[float]:
        """Base-link pose (position m + quaternion xyzw, world) of each free object, concatenated, from the
        centre-of-mass poses ``bases``: :meth:`~taskcond.sim.scene.KitchenScene.base_frame` with each
        object's transform looked up once at construction. It is a function of the centre-of-mass pose
        alone, so an object that kept its pose keeps its frame."""
        flat: list[float] = []
        frames = self._base_frames
        for k, (pose, (offset, rotation)) in enumerate(zip(bases, self._com_to_base, strict=True)):
            cached = frames[k]
            if cached is None or cached[0] != pose:
                position, orientation = p.multiplyTransforms(pose[0], pose[1], offset, rotation)
                cached = frames[k] = (pose, position + orientation)
            flat += cached[1]
        return flat


class BlowupMonitor:
    """The simulation blow-up check after each control step (NaN, an object leaving :data:`WORKSPACE`, deep
    interpenetration), and the reset that makes episodes independent of earlier ones.

    Args:
        scene: the scene to watch.
    """

    def __init__(self, scene: KitchenScene) -> None:
        self.scene = scene
        self._free_ids = [scene.bodies[n] for n in scene.free_objects]
        self._tracked: tuple[int, ...] | None = None
        """Bodies whose state :meth:`moved_bodies` compares, in the order of :meth:`_body_states`: the
        Franka, the free objects, the articulated containers; ``None`` in a scene with the Kinova or the
        cloth, whose check asks for every contact point."""
        if scene.kinova is None and scene.cloth is None:
            self._tracked = (scene.robot.body, *self._free_ids, *scene.articulated_bodies)
        self._checked_states: list[Any] | None = None
        """:meth:`_body_states` at the last deep-penetration check, ``None`` before the episode's first."""
        self._moved_before: list[bool] = []
        """Per tracked body, whether it had moved at the last check."""

    def reset(self) -> None:
        """Start an episode (reset time, before anything is placed): drop the free objects' persistent
        contact points and sleeping state, and forget the last episode's body states. Parks the free objects
        :data:`PARKING_SPACING` apart from :data:`PARKING`, out of contact with anything, and runs one
        physics step with sleeping disabled, which removes their contact pairs and zeroes their sleep
        timers; then allows sleeping again. Everything the step moves must be put in place afterwards."""
        client = self.scene.client
        for k, body in enumerate(self._free_ids):
            p.changeDynamics(
                body, -1, activationState=p.ACTIVATION_STATE_DISABLE_SLEEPING, physicsClientId=client
            )
            position = (PARKING[0] + k * PARKING_SPACING, PARKING[1], PARKING[2])
            p.resetBasePositionAndOrientation(body, position, (0, 0, 0, 1), physicsClientId=client)
        p.stepSimulation(physicsClientId=client)
        for body in self._free_ids:
            p.changeDynamics(
                body, -1, activationState=p.ACTIVATION_STATE_ENABLE_SLEEPING, physicsClientId=client
            )
        self._checked_states = None

    @staticmethod
    def _body_states(reading: Reading) -> list[Any]:
        """What places each tracked body, from ``reading``: the Franka's joint positions (its base is
        fixed), each free object's base pose, each articulated container's joint positions."""
        return [reading.joints, *reading.bases, *reading.containers]

    def moved_bodies(self, reading: Reading) -> list[int] | None:
        """The bodies whose contacts the deep-penetration check must read after this control step, or
        ``None`` for all contact points (the episode's first check, a scene with the Kinova or the cloth,
        more than :data:`BODY_QUERIES` bodies); records the states of ``reading`` for the next check.

        A body counts if its state (:meth:`_body_states`, compared bit for bit) changed since the last check
        or had changed at the one before. Bullet updates a pair's contact points only in a physics step; of
        a pair whose two bodies kept their state, the step recomputes the same points (the first step after
        a body stopped moves its points from where it was during its last step to where it stopped, hence
        the second check). The bodies not tracked (table, the containers' bases) are fixed. So every contact
        point not read has been read, with the same depth, at an earlier check of the episode, which found
        none too deep."""
        states = self._body_states(reading)
        before, self._checked_states = self._checked_states, states
        if self._tracked is None or before is None:
            self._moved_before = [True] * len(states)
            return None
        # the lists have one entry per tracked body (the scene's bodies are fixed at construction)
        moved = list(map(ne, states, before))
        bodies = list(compress(self._tracked, map(or_, moved, self._moved_before)))
        self._moved_before = moved
        return bodies if len(bodies) <= BODY_QUERIES else None

    def check(self, reading: Reading) -> str | None:
        """The blow-up of the state in ``reading`` and the current contacts, or ``None``: ``nan_state`` (a
        non-finite Franka arm joint, free-object position, Kinova joint or cloth node),
        ``<object>_left_workspace`` (the first free object whose centre of mass is outside
        :data:`WORKSPACE`), ``cloth_left_workspace``, ``deep_penetration`` (a rigid contact deeper than
        :data:`PENETRATION`; the contacts of the bodies :meth:`moved_bodies` names, all of them when it
        names none), checked in this order. The contact points read body by body are put in
        ``reading.contacts`` for the success judge."""
        if not all(map(math.isfinite, reading.joints[:ARM_DOFS])):
            return "nan_state"
        (x_lo, x_hi), (y_lo, y_hi), (z_lo, z_hi) = _WORKSPACE_BOUNDS
        for (x, y, z), _ in reading.bases:
            # NaN fails every comparison, so this passes exactly the finite positions inside
            if not (x_lo <= x <= x_hi and y_lo <= y <= y_hi and z_lo <= z <= z_hi):
                positions = np.array([com for com, _ in reading.bases])
                if not np.isfinite(positions).all():
                    return "nan_state"
                outside = ((positions < WORKSPACE[0]) | (positions > WORKSPACE[1])).any(axis=1)
                return f"{self.scene.free_objects[int(np.argmax(outside))]}_left_workspace"
        kinova = self.scene.kinova
        if kinova is not None and not np.all(np.isfinite(kinova.joint_positions())):
            return "nan_state"
        if reading.cloth_nodes is not None:
            nodes = reading.cloth_nodes
            if not np.all(np.isfinite(nodes)):
                return "nan_state"
            if np.any(nodes < WORKSPACE[0]) or np.any(nodes > WORKSPACE[1]):
                return "cloth_left_workspace"
        client = self.scene.client
        bodies = self.moved_bodies(reading)
        if bodies is not None:
            contacts = reading.contacts
            for body in bodies:
                points = contacts[body] = p.getContactPoints(bodyA=body, physicsClientId=client)
                if any(map(_DEEPER_THAN_PENETRATION, map(_CONTACT_DISTANCE, points))):
                    return "deep_penetration"
            return None
        points = p.getContactPoints(physicsClientId=client)
        if not any(map(_DEEPER_THAN_PENETRATION, map(_CONTACT_DISTANCE, points))):
            return None
        soft = self.scene.cloth  # soft contacts report no meaningful depth
        for pt in points:
            if _DEEPER_THAN_PENETRATION(pt[8]) and soft not in (pt[1], pt[2]):
                return "deep_penetration"
        return None


__all__ = ["BODY_QUERIES", "PENETRATION", "WORKSPACE", "BlowupMonitor", "Reading", "StepReader"]
