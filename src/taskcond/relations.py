"""The spatial relations of the condition vocabulary (paper §III-A.1: ``inside``, ``above``, ``below``,
``in front of``), defined once, on axis-aligned boxes in the world frame (metres, z up).

Both sides of the framework call these functions: the judge of the task suite
(:class:`taskcond.tasks.groundtruth.GroundTruth`, on PyBullet's AABBs) and the environment-information layer
(:func:`taskcond.sim.perception.spatial_relations`, on perceived, possibly noisy boxes), so that a condition
means the same to the success check as to the executor that pursues it. The rules follow REFLECT (Liu et
al. 2023), as the paper's §III-A.2 does.

With A's and B's boxes, their centres ``cA``, ``cB``, ``t`` a :class:`RelationThresholds` and ``f`` the unit
horizontal front direction (towards the robot, default world -x; ``l`` the horizontal direction across it):

* ``A inside B``: ``cA`` lies in B's box grown by ``t.inside_margin`` on every side, at least
  ``t.inside_fraction`` of A's box volume lies in B's box, and A's box is not larger than B's.
* ``A inside G`` for a gripper G (whose box, the fingers', is smaller than what it holds): the fingers are
  around A: ``cG`` (the grasp point) lies in A's box grown by ``t.inside_margin`` and along at least one axis
  G's box reaches past A's on both sides. ``G inside A`` does not hold while ``A inside G`` does.
* ``A above B``: the horizontal footprints overlap by at least ``t.above_overlap`` of the smaller one's area,
  A's bottom is no lower than ``t.above_tolerance`` below B's top, and ``cA`` is higher than ``cB``. B's top
  is its bottom for a soft B (the cloth): it gives way under what stands on it, and a wrinkle standing up
  elsewhere is its box's top.
* ``A below B`` exactly when ``B above A``.
* ``A in front of B``: the boxes' extents along ``l`` overlap by at least ``t.front_lateral_overlap`` of the
  narrower one; the free gap along ``f`` from B's front face to A's back face is at most
  ``t.front_max_gap`` and A reaches at most ``t.front_max_overlap`` behind B's front face; A's bottom is
  lower than B's top; and neither is above, below or inside the other.

Nothing here knows PyBullet; the boxes come from the caller.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

from taskcond.conditions import Relation, SpatialRelation

Vec3 = tuple[float, float, float]

FRONT: Vec3 = (-1.0, 0.0, 0.0)
"""Default front direction: a robot at the origin facing +x looks at a table at positive x, so what is
nearer to it (smaller x) is in front."""


@dataclass(frozen=True)
class Box:
    """One object's axis-aligned box, world frame, metres, as Python floats.

    Attributes:
        lower, upper: minimum and maximum corners, ``lower <= upper``.
        center: the object's centre: the box centre for anything measured; a gripper's grasp point.
        gripper: the box is a gripper's (its two fingers'): ``inside`` then means "held between them".
        soft: the box is a soft body's (the cloth's): ``A above B`` then measures A's bottom from B's bottom.
    """

    lower: Vec3
    upper: Vec3
    center: Vec3
    gripper: bool = False
    soft: bool = False

    @classmethod
    def of(
        cls, lower: Sequence[float], upper: Sequence[float], center: Sequence[float] | None = None, **kw: bool
    ) -> Box:
        """A box from any three-element sequences (numpy arrays included); ``center`` defaults to the box
        centre."""
        lo = (float(lower[0]), float(lower[1]), float(lower[2]))
        hi = (float(upper[0]), float(upper[1]), float(upper[2]))
        mid = (
            ((lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, (lo[2] + hi[2]) / 2)
            if center is None
            else (float(center[0]), float(center[1]), float(center[2]))
        )
        return cls(lo, hi, mid, **kw)


@dataclass(frozen=True)
class RelationThresholds:
    """The constants of the relation rules (lengths in metres, fractions in [0, 1]); see the module doc.

    One set serves the judge and the perceiver: ground-truth boxes of resting objects never sink more than
    a few millimetres into each other, so the tolerances that absorb 5 mm perception noise change no
    ground-truth answer of the suite (BENCHMARKS.md, "Relations: one definition for the judge and the
    perceiver").

    Attributes:
        inside_margin: ``A inside B`` needs A's centre within B's box grown by this on every side ...
        inside_fraction: ... and at least this fraction of A's box volume inside B's box (REFLECT's
            ``INSIDE_THRESH``).
        above_overlap: ``A above B`` needs the footprints to overlap by at least this fraction of the smaller
            footprint's area ...
        above_tolerance: ... and A's bottom no lower than this below B's top (resting contact, noise).
        front_lateral_overlap: ``A in front of B`` needs the boxes' extents across the front direction to
            overlap by at least this fraction of the narrower one ...
        front_max_gap: ... the free gap from B's front face to A's back face to be at most this ...
        front_max_overlap: ... and A's back face no more than this behind B's front face.
    """

    inside_margin: float = 0.01
    inside_fraction: float = 0.5
    above_overlap: float = 0.5
    above_tolerance: float = 0.015
    front_lateral_overlap: float = 0.25
    front_max_gap: float = 0.20
    front_max_overlap: float = 0.01


THRESHOLDS = RelationThresholds()
"""The thresholds of the judge and, by default, of the perceiver."""


def _volume(lo: Vec3, hi: Vec3) -> float:
    return max(hi[0] - lo[0], 0.0) * max(hi[1] - lo[1], 0.0) * max(hi[2] - lo[2], 0.0)


def _overlap(a: Box, b: Box, axis: int) -> float:
    """Length (m) of the overlap of the two boxes' extents along world ``axis`` (0 if apart)."""
    return max(min(a.upper[axis], b.upper[axis]) - max(a.lower[axis], b.lower[axis]), 0.0)


def _point_in(point: Vec3, box: Box, margin: float) -> bool:
    return all(box.lower[k] - margin <= point[k] <= box.upper[k] + margin for k in range(3))


def _fingers_around(gripper: Box, a: Box, t: RelationThresholds) -> bool:
    """The gripper's grasp point is in A's box (grown by the margin) and its box spans A's along an axis."""
    spans = any(gripper.lower[k] <= a.lower[k] and gripper.upper[k] >= a.upper[k] for k in range(3))
    return spans and _point_in(gripper.center, a, t.inside_margin)


def inside(a: Box, b: Box, t: RelationThresholds = THRESHOLDS) -> bool:
    """``A inside B`` (module doc)."""
    if b.gripper:
        held = _fingers_around(b, a, t)
    else:
        volume = _volume(a.lower, a.upper)
        common = _overlap(a, b, 0) * _overlap(a, b, 1) * _overlap(a, b, 2)
        held = (
            _point_in(a.center, b, t.inside_margin)
            and common >= t.inside_fraction * max(volume, 1e-18)
            and volume <= _volume(b.lower, b.upper)
        )
    return held and not (a.gripper and _fingers_around(a, b, t))


def above(a: Box, b: Box, t: RelationThresholds = THRESHOLDS) -> bool:
    """``A above B`` (module doc)."""
    top = b.lower[2] if b.soft else b.upper[2]
    if a.lower[2] < top - t.above_tolerance or a.center[2] <= b.center[2]:
        return False
    footprint_a = (a.upper[0] - a.lower[0]) * (a.upper[1] - a.lower[1])
    footprint_b = (b.upper[0] - b.lower[0]) * (b.upper[1] - b.lower[1])
    smaller = max(min(footprint_a, footprint_b), 1e-18)
    return _overlap(a, b, 0) * _overlap(a, b, 1) >= t.above_overlap * smaller


def below(a: Box, b: Box, t: RelationThresholds = THRESHOLDS) -> bool:
    """``A below B``: ``B above A``."""
    return above(b, a, t)


def _project(box: Box, direction: tuple[float, float]) -> tuple[float, float]:
    """Centre and half extent of a box along a horizontal unit ``direction``."""
    mid = (box.lower[0] + box.upper[0]) / 2 * direction[0] + (box.lower[1] + box.upper[1]) / 2 * direction[1]
    half = (box.upper[0] - box.lower[0]) / 2 * abs(direction[0]) + (box.upper[1] - box.lower[1]) / 2 * abs(
        direction[1]
    )
    return mid, half


def _horizontal(front: Sequence[float]) -> tuple[float, float]:
    norm = math.hypot(front[0], front[1])
    if norm < 1e-9:
        raise ValueError(f"front {tuple(front)} has no horizontal component")
    return front[0] / norm, front[1] / norm


def in_front_of(a: Box, b: Box, t: RelationThresholds = THRESHOLDS, front: Sequence[float] = FRONT) -> bool:
    """``A in front of B`` (module doc); ``front`` points towards the robot, only its horizontal part
    counts."""
    f = _horizontal(front)
    along_a, half_a = _project(a, f)
    along_b, half_b = _project(b, f)
    gap = (along_a - half_a) - (along_b + half_b)
    if not -t.front_max_overlap <= gap <= t.front_max_gap or a.lower[2] >= b.upper[2]:
        return False
    across = (-f[1], f[0])
    mid_a, width_a = _project(a, across)
    mid_b, width_b = _project(b, across)
    lateral = min(mid_a + width_a, mid_b + width_b) - max(mid_a - width_a, mid_b - width_b)
    if lateral < t.front_lateral_overlap * 2 * min(width_a, width_b):
        return False
    return not (above(a, b, t) or above(b, a, t) or inside(a, b, t) or inside(b, a, t))


def holds(
    relation: Relation, a: Box, b: Box, t: RelationThresholds = THRESHOLDS, front: Sequence[float] = FRONT
) -> bool:
    """Whether ``A <relation> B`` holds between the boxes ``a`` and ``b``."""
    if relation is Relation.INSIDE:
        return inside(a, b, t)
    if relation is Relation.ABOVE:
        return above(a, b, t)
    if relation is Relation.BELOW:
        return below(a, b, t)
    return in_front_of(a, b, t, front)


def relations(
    boxes: Mapping[str, Box], t: RelationThresholds = THRESHOLDS, front: Sequence[float] = FRONT
) -> frozenset[SpatialRelation]:
    """Every relation that holds between an ordered pair of distinct ``boxes`` (by name)."""
    _horizontal(front)
    items = list(boxes.items())
    out: list[SpatialRelation] = []
    for i, (name_a, a) in enumerate(items):
        for name_b, b in items[i + 1 :]:
            out.extend(_pair(name_a, a, name_b, b, t, front))
    return frozenset(out)


def _pair(
    name_a: str, a: Box, name_b: str, b: Box, t: RelationThresholds, front: Sequence[float]
) -> Iterable[SpatialRelation]:
    """The relations between A and B in both directions."""
    for x, y, nx, ny in ((a, b, name_a, name_b), (b, a, name_b, name_a)):
        if inside(x, y, t):
            yield SpatialRelation(nx, Relation.INSIDE, ny)
        if above(x, y, t):
            yield SpatialRelation(nx, Relation.ABOVE, ny)
            yield SpatialRelation(ny, Relation.BELOW, nx)
        if in_front_of(x, y, t, front):
            yield SpatialRelation(nx, Relation.IN_FRONT_OF, ny)


__all__ = [
    "FRONT",
    "THRESHOLDS",
    "Box",
    "RelationThresholds",
    "above",
    "below",
    "holds",
    "in_front_of",
    "inside",
    "relations",
]
