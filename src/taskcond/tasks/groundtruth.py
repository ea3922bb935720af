"""Ground-truth evaluation of the condition vocabulary (paper §III-A.1) on the simulator state.

Success checks of the task suite read PyBullet directly (positions, joint positions, contacts), never the
perception layer, and are written as predicates of :mod:`taskcond.conditions` where the vocabulary has one:

* ``gripper grasping A``: both finger links touch A; for the cloth (a soft body, whose contacts PyBullet
  does not report): the gripper holds it by soft-body anchors, which exist only while its fingers are
  closed on cloth nodes (:class:`taskcond.sim.cloth.ClothGrips`);
* ``gripper not grasping``: neither finger touches any free object and the gripper holds no cloth;
* the same for ``kinova gripper`` (the Kinova's, in dual-arm scenes);
* ``A open`` / ``A closed``: the container joint is past ``open_fraction`` of its range / within
  :data:`CLOSED_FRACTION` of closed (bowls and mugs are always open);
* ``A inside B``, ``A above B``, ``A below B``, ``A in front of B``: the one definition of each relation in
  :mod:`taskcond.relations` (the perceiver's too), on PyBullet's axis-aligned boxes of A and B (a free
  object's, a drawer's or a cloth's own; a container's base without its lid or door) with their centres,
  at the thresholds :data:`taskcond.relations.THRESHOLDS` and the front direction world -x.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import pybullet as p

from taskcond import relations
from taskcond.conditions import (
    GRIPPER,
    KINOVA_GRIPPER,
    ContainerState,
    GripperState,
    Predicate,
    Relation,
    SpatialRelation,
)
from taskcond.envs.reader import Reading
from taskcond.relations import Box
from taskcond.sim.franka import FINGER_JOINTS
from taskcond.sim.scene import ARTICULATED, KitchenScene

CLOSED_FRACTION = 0.08
"""A container is closed when its joint is within this fraction of its range from closed."""


class GroundTruth:
    """Predicates of the condition vocabulary evaluated on a :class:`KitchenScene`.

    A judge made with ``GroundTruth(scene)`` asks PyBullet for everything; :meth:`at` gives one that takes
    what a step has read (:class:`taskcond.envs.reader.Reading`) from that reading instead. A judge never
    changes what it reads from, so the answers do not depend on the order of calls.
    """

    def __init__(self, scene: KitchenScene) -> None:
        self.scene = scene
        self._free_by_body = {scene.bodies[name]: name for name in scene.free_objects}
        self._free_index = {name: k for k, name in enumerate(scene.free_objects)}
        self._container_index = {name: k for k, name in enumerate(ARTICULATED)}
        self._known: Reading | None = None
        """The reading this judge takes free-object poses, open fractions and contacts from (those it
        holds); ``None``: it asks PyBullet."""

    def at(self, reading: Reading) -> GroundTruth:
        """A judge of the same scene that takes the state from ``reading`` where it has it; valid while
        nothing moves (:meth:`taskcond.envs.kitchen.KitchenEnv.step` judges success with it)."""
        view = object.__new__(GroundTruth)  # a shallow copy, cheaper than copy.copy (every control step)
        view.__dict__.update(self.__dict__)
        view._known = reading
        return view

    def com(self, name: str) -> np.ndarray:
        """Centre (3,) m, world: centre of mass of a free object, mean node of the cloth, AABB centre of
        anything else."""
        if name == "cloth" and self.scene.cloth is not None:
            return self.scene.cloth_nodes().mean(axis=0)
        point = self._known_com(name)
        if point is not None:
            return np.array(point)
        if name in self.scene.free_objects:
            return np.array(
                p.getBasePositionAndOrientation(self.scene.bodies[name], physicsClientId=self.scene.client)[0]
            )
        lo, hi = self.scene.aabb(name)
        return (lo + hi) / 2

    def _known_com(self, name: str) -> tuple[float, float, float] | None:
        """The centre of mass (m, world) of free object ``name`` as :attr:`_known` holds it; ``None`` for
        anything else or without a known state."""
        known, index = self._known, self._free_index.get(name)
        return known.bases[index][0] if known is not None and index is not None else None

    def _fingers(self, gripper: str) -> tuple[int, tuple[int, int]]:
        """Arm body and finger links of the gripper named ``gripper``."""
        if gripper == KINOVA_GRIPPER and self.scene.kinova is not None:
            return self.scene.kinova.body_id, self.scene.kinova.finger_links
        if gripper != GRIPPER:
            raise KeyError(f"no gripper named {gripper!r} in the scene")
        return self.scene.robot.body, FINGER_JOINTS

    def contacts(self, body: int) -> Sequence[tuple[Any, ...]]:
        """The contact points of ``body`` as ``p.getContactPoints(bodyA=body)`` reports them (``body`` is
        each point's body A, item 1): those :attr:`_known` holds, else asked now."""
        known = self._known
        if known is not None:
            points = known.contacts.get(body)
            if points is not None:
                return points
        return p.getContactPoints(bodyA=body, physicsClientId=self.scene.client)

    def finger_contacts(self, name: str, gripper: str = GRIPPER) -> tuple[bool, bool]:
        """Whether the left and the right finger of ``gripper`` touch ``name`` (the arm's contact points
        with ``name``'s body, and link if it is one, on each finger link)."""
        robot, fingers = self._fingers(gripper)
        body = self.scene.bodies[name]
        link = self.scene.links.get(name, -1)
        points = self.contacts(robot)
        left, right = (
            any(pt[2] == body and pt[3] == finger and (link < 0 or pt[4] == link) for pt in points)
            for finger in fingers
        )
        return left, right

    def free_objects_touched(self, gripper: str = GRIPPER) -> tuple[set[str], set[str]]:
        """The free objects the left and the right finger of ``gripper`` touch (from the arm's contact
        points)."""
        robot, (left_finger, right_finger) = self._fingers(gripper)
        by_body = self._free_by_body
        left: set[str] = set()
        right: set[str] = set()
        for pt in self.contacts(robot):
            name = by_body.get(pt[2])
            if name is not None:
                if pt[3] == left_finger:
                    left.add(name)
                elif pt[3] == right_finger:
                    right.add(name)
        return left, right

    def grasping(self, name: str, gripper: str = GRIPPER) -> bool:
        if name == "cloth" and self.scene.grips is not None:
            return self.scene.grips.holding(gripper)
        left, right = self.finger_contacts(name, gripper)
        return left and right

    def holding_cloth(self, gripper: str = GRIPPER) -> bool:
        """Whether ``gripper`` holds the cloth (``False`` without one)."""
        return self.scene.grips is not None and self.scene.grips.holding(gripper)

    def grasped(self, gripper: str = GRIPPER) -> str | None:
        """The free object held between both fingers (the first in the scene's order), or the cloth held, if
        any."""
        left, right = self.free_objects_touched(gripper)
        for name in self.scene.free_objects:
            if name in left and name in right:
                return name
        return "cloth" if self.holding_cloth(gripper) else None

    def touching_any(self, gripper: str = GRIPPER) -> bool:
        """Whether a finger of ``gripper`` touches any free object."""
        left, right = self.free_objects_touched(gripper)
        return bool(left or right)

    def open_fraction(self, container: str) -> float:
        """How far open an articulated container is (0 closed, 1 fully open): from :attr:`_known` if set,
        else :meth:`KitchenScene.open_fraction`."""
        known = self._known
        if known is not None:
            return known.open_fractions[self._container_index[container]]
        return self.scene.open_fraction(container)

    def is_open(self, container: str) -> bool:
        if container not in self.scene.joints:
            return container in self.scene.interiors
        return self.open_fraction(container) >= self.scene.joints[container].open_fraction

    def is_closed(self, container: str) -> bool:
        if container not in self.scene.joints:
            return False
        return self.open_fraction(container) <= CLOSED_FRACTION

    def box(self, name: str) -> Box:
        """PyBullet's axis-aligned box of ``name`` (world frame, m), centred, as the relations read it."""
        lo, hi = self.scene.aabb(name)
        return Box.of(lo, hi, soft=name == "cloth" and self.scene.cloth is not None)

    def relation(self, relation: Relation, a: str, b: str) -> bool:
        """Whether ``A <relation> B`` holds now (:mod:`taskcond.relations`)."""
        return relations.holds(relation, self.box(a), self.box(b))

    def height_over(self, a: str, b: str) -> float:
        """Gap (m) between A's lowest point and B's top."""
        return float(self.scene.aabb(a)[0][2] - self.scene.aabb(b)[1][2])

    def holds(self, pred: Predicate) -> bool:
        """Whether a condition holds in the current simulator state."""
        if isinstance(pred, GripperState):
            g = pred.gripper
            if pred.obj is not None:
                return self.grasping(pred.obj, g)
            # not grasping: no finger on a free object (so none grasped) and no cloth held
            return not self.touching_any(g) and not self.holding_cloth(g)
        if isinstance(pred, ContainerState):
            return self.is_open(pred.container) if pred.is_open else self.is_closed(pred.container)
        assert isinstance(pred, SpatialRelation)
        return self.relation(pred.relation, pred.subject, pred.reference)


__all__ = ["GroundTruth"]
