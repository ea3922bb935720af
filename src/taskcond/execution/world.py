"""What the executor needs from a robot and its environment, independent of the simulator.

The condition-guided executor (Alg. 1, Alg. 2) talks to a :class:`World`: it reads environment
information (§III-A.2) as an :class:`Observation` in the task-condition vocabulary and commands end-effector
poses. :class:`taskcond.worlds.kitchen.KitchenWorld` implements it over the PyBullet suite; a real robot
would implement the same few methods.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from taskcond.conditions import Collision, GripperState, Predicate


@dataclass(frozen=True, eq=False)
class Touch:
    """Two named bodies in contact at ``position`` (3,), metres, world frame."""

    a: str
    b: str
    position: np.ndarray

    @property
    def collision(self) -> Collision:
        return Collision(self.a, self.b)


@dataclass(frozen=True, eq=False)
class Observation:
    """Environment information of one moment (§III-A.2).

    Attributes:
        predicates: every relation and object state that holds now, in the condition vocabulary.
        centers: object name → centre (3,), metres, world frame (possibly noisy).
        touches: bodies in contact now.
        boxes: object name → its axis-aligned bounding box as (lower (3,), upper (3,)) corners, metres,
            world frame (possibly noisy); what a grasp's approach must keep clear of.
        round: the free objects that look the same turned about their vertical axis (a bottle, a bowl):
            a grasp of one may come from any side.
        lying: the free objects that fell over (their upright axis tilted more than 45°): a grasp
            demonstrated on an upright object cannot hold them.
        shapes: free object → its shape class (``cylinder``, ``vessel``, ``box``, ``sphere``, ``flat``,
            ``mesh``): what :func:`taskcond.execution.skills.dissimilarity` compares beside the boxes.
        yaws: object name → its heading about the world's vertical, rad (the angle from world x of the
            horizontal part of its own x axis), for the upright, not round free objects, and the hinged
            ones, a world perceives it of; a primitive aimed at one is turned by its heading's change since
            the skill's demonstration (a box held across its narrow side, a door turned on its base).
            Empty where a world perceives no orientation (the kitchen).
        yaw_periods: object name → the turn (rad) about the vertical after which it looks the same (π for
            a rectangular section, π/2 for a square one), for each object of :attr:`yaws`.
        openings: free vessel → the centre (3,) m, world frame, of its opening (its inside's axis at the
            height of its rim), for the upright vessels a world perceives it of: a handle widens the box, so
            the box's centre is not the opening's. Empty where a world perceives none.
    """

    predicates: frozenset[Predicate]
    centers: dict[str, np.ndarray]
    touches: tuple[Touch, ...]
    boxes: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    round: frozenset[str] = frozenset()
    lying: frozenset[str] = frozenset()
    shapes: dict[str, str] = field(default_factory=dict)
    yaws: dict[str, float] = field(default_factory=dict)
    yaw_periods: dict[str, float] = field(default_factory=dict)
    openings: dict[str, np.ndarray] = field(default_factory=dict)

    def holds(self, predicate: Predicate) -> bool:
        return predicate in self.predicates

    def grasped(self, gripper: str = "gripper") -> str | None:
        """The object ``gripper`` holds, if any."""
        for pred in self.predicates:
            if isinstance(pred, GripperState) and pred.gripper == gripper and pred.obj is not None:
                return pred.obj
        return None


REACHED = 0.02
"""Distance (m) within which an end effector reaches a pose of :meth:`World.wound`."""


class World(Protocol):
    """One or more robot arms with parallel grippers in an observed environment.

    Poses and commands of k arms are stacked arm by arm in :attr:`arms` order: positions (3k,), orientations
    (4k,). A command for fewer arms than the world has moves the first ones; the others hold their last
    command.
    """

    dt: float
    """Control period, s."""

    @property
    def arms(self) -> tuple[str, ...]:
        """The grippers' names in the condition vocabulary, first arm first (``("gripper",)`` for one)."""
        ...

    @property
    def ground(self) -> tuple[str, ...]:
        """Names of what everything stands on (the table): under every footprint, never an obstacle beside
        one."""
        ...

    @property
    def time(self) -> float:
        """Simulated (or wall) seconds since the episode began."""
        ...

    @property
    def objects(self) -> tuple[str, ...]:
        """Names of the objects that can appear in conditions."""
        ...

    def observe(self) -> Observation:
        """Full environment information (relations, states, centres, contacts)."""
        ...

    def touches(self) -> tuple[Touch, ...]:
        """Contacts only: cheap enough for every control step."""
        ...

    def locate(self, name: str, observation: Observation) -> np.ndarray | None:
        """Centre (3,) of ``name`` (an object, or ``"position"``: the goal position of a move) in
        ``observation``, or None if unknown."""
        ...

    def affords(self, primitive: str, objects: tuple[str, ...]) -> str | None:
        """Why the primitive (an id of :data:`taskcond.primitives.PRIMITIVES`) cannot act on ``objects``
        here (an unknown object, opening something without a lid, door or drawer), or None if it can."""
        ...

    def reach_error(self, position: np.ndarray, orientation: np.ndarray | None = None) -> str | None:
        """Why the end effectors cannot reach ``position`` (3k,) m (one point per arm), or None. With the
        first arm's ``orientation`` (4,) xyzw, also why its hand cannot take that pose (an arm solved by IK
        misses it by more than :data:`REACHED`, e.g. a hand pointing down at the far edge of the cabinet's
        top, which sags 10 cm short and tips what it sets down)."""
        ...

    def sweep(self, positions: np.ndarray, orientations: np.ndarray, ignore: tuple[str, ...]) -> float:
        """Least distance (m, negative for penetration, at most 0.05) between the first arm and every
        object but ``ignore`` and the :attr:`ground`, were its end effector to pass through ``positions``
        (m, 3) with ``orientations`` (m, 4) xyzw; nothing moves."""
        ...

    def wound(self, positions: np.ndarray, orientations: np.ndarray) -> bool:
        """Whether the first arm, from its joints now, cannot take its end effector through ``positions``
        (m, 3) with ``orientations`` (m, 4) xyzw in turn (each within :data:`REACHED`) where from its home
        joints it can: an arm whose commands are solved by IK seeded by its last answer, wound far from home
        (the Panda's wrist at its limit after an open of the bottom drawer), misses them by decimetres;
        :meth:`unwind` mends it. Nothing moves. Always False for an arm driven in task space."""
        ...

    def follows(self, positions: np.ndarray, orientations: np.ndarray) -> bool:
        """Whether the first arm, from its joints now, takes its end effector through ``positions`` (m, 3)
        with ``orientations`` (m, 4) xyzw in turn, each within :data:`REACHED`, as its commands would be
        solved. Nothing moves. Always True for an arm driven in task space."""
        ...

    def unwind(self, gripper: float) -> str | None:
        """Move the first arm back to its home joints, in joint space, one control step at a time (never a
        jump), holding the ``gripper`` command; the others hold their last command. Returns a failure
        reason (simulation blow-up) or None."""
        ...

    def ee_pose(self, arms: int = 1) -> tuple[np.ndarray, np.ndarray]:
        """Positions (3k,) m and orientations (4k,) xyzw of the first ``arms`` end effectors, world
        frame."""
        ...

    def step(self, position: np.ndarray, orientation: np.ndarray, gripper: float) -> str | None:
        """Command one control period towards the poses of the first k arms (position (3k,),
        orientation (4k,), every one of their grippers ``gripper``); returns a failure reason
        (simulation blow-up, an unreachable pose) or None."""
        ...


__all__ = ["REACHED", "Observation", "Touch", "World"]
