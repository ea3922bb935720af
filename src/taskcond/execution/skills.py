"""Skills learned from demonstrations: the paper's "demo data" (Fig. 2, §III-D, §III-E).

A :class:`Skill` is what one oracle demonstration of a primitive task teaches: DMPs (Eq. 1–3) over the
end-effector position, the orientation profile, the gripper commands and the task condition observed in
the environment (FromEnv). Skills know nothing of the simulator: a :class:`Demonstration` is plain arrays.

Segmentation (our addition to the paper's single DMP per primitive). One DMP per Cartesian dimension maps
the demonstration's start and goal affinely onto the new ones (Eq. 2 scales the forcing term by
``g − y0``), so a via point whose coordinate differs from the goal's is only reproduced when the new start
and goal are close to the demonstrated ones. A grasp reaches the object, closes and lifts: a single DMP
started from anywhere but the demonstrated start misses the object in height. We therefore split the
demonstration where the gripper command changes (the paper keeps the gripper as timed events) and where the
free-space *approach* ends: at the last standstill before the gripper first touches the target object, or
before the first gripper event. Each piece is one DMP of the paper's form. The approach piece's goal is
taken from the environment information (target centre plus the demonstrated offset, Alg. 2 line 3); a
carry that never touches its target (move into, on top of, in front of) ends its approach at the last
standstill before its final movement (over the container, before lowering the object in), so the object
arrives above its place at the demonstrated height whatever the start. Every later piece starts where the
previous one ended and keeps its demonstrated displacement (the paper's rule for primitives without a
target), so contact-rich motions (drawer pulls, lid arcs) replay relative to where the hand meets the
object.

Several arms (our addition for the paper's dual-arm fold, §IV). A demonstration of k arms moving together
(shared timing and gripper events, as the fold oracle) stacks their positions into (n, 3k) and their
orientations into (n, 4k), arm by arm in the world's order (Franka first). Each piece is then one DMP of
3k dimensions (still one transformation system per Cartesian dimension, Eq. 1–3), and a target anchor
puts every arm's goal at the target's centre plus that arm's demonstrated offset.
"""

from __future__ import annotations

import itertools
import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Literal

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

from taskcond.conditions import TaskCondition
from taskcond.dmp import DMPParameters, learn_dmp, load_parameters, save_parameters
from taskcond.grounding import DemoEvidence
from taskcond.primitives import parse_task

LIBRARY_FORMAT = 4
"""Version of the on-disk skill library layout; a library with another version is refused (the formats'
history is in BENCHMARKS.md, "Formats and revisions")."""
STANDSTILL = 0.01
"""End-effector speed (m/s) below which a demonstration sample counts as a standstill (of every arm)."""
MIN_SEGMENT_SAMPLES = 3

Anchor = Literal["target", "relative"]


class SkillError(ValueError):
    """A skill library that is missing, of another format version, or lacks a skill; one line."""


@dataclass(frozen=True)
class ObjectShape:
    """What the similarity of two objects compares (:func:`dissimilarity`): the shape class (a free object's
    :func:`~taskcond.sim.assets.shape_class`, ``fixed`` for the furniture and containers that do not move)
    and the perceived bounding box's edge lengths ``size`` (x, y, z world axes, metres)."""

    shape: str
    size: tuple[float, float, float]

    @property
    def height(self) -> float:
        return self.size[2]

    @property
    def width(self) -> float:
        """Mean horizontal edge (m) of the box."""
        return (self.size[0] + self.size[1]) / 2


SHAPE_PENALTY = 2.0
"""What a different shape class adds to :func:`dissimilarity`: as much as a size ratio of e² (7.4). A grasp
is the shape's before it is the size's: with 1.0, noisy boxes (σ = 5 mm on a 4 cm cube) gave the cube the
bowl's wall grasp instead of the toothpaste's (BENCHMARKS.md, "Objects a user brings")."""
NEAR_CLASSES = (frozenset({"cylinder", "sphere"}), frozenset({"mesh", "cylinder", "box", "sphere"}))
"""Pairs of shape classes within one of these sets are half as unlike: two round solids (held from any
side), or a ``mesh`` (its class says nothing of its shape) and a solid. A vessel (held by its wall) and a
flat object (held lying) are unlike everything else."""


def dissimilarity(a: ObjectShape, b: ObjectShape) -> float:
    """How unlike two objects are for one to borrow the other's skill (issue 31: "the most similar
    demonstrated object by shape and size"): the sum of ``|ln(ratio)|`` of their heights and of their two
    horizontal box edges (each pair sorted, so that an object turned about the vertical compares the
    same), plus :data:`SHAPE_PENALTY` when their shape classes differ, half of it for the near classes of
    :data:`NEAR_CLASSES`, twice it when either is ``fixed`` (two pieces of furniture or fixed containers
    of different names: a goal demonstrated in front of the microwave is not one in front of the box, so
    a carry borrows the carried object before the target). 0 for equal shape and size; larger is less
    alike. With the suite's boxes: the can (a cylinder 0.10 m tall) against the bottle (0.13 m) 0.25,
    against the toothpaste (a box) 3.0, against the bowl (a vessel) 3.0."""
    edges = zip(sorted(a.size[:2]), sorted(b.size[:2]), strict=True)
    size = abs(np.log(max(a.height, 1e-3) / max(b.height, 1e-3)))
    size += sum(abs(np.log(max(x, 1e-3) / max(y, 1e-3))) for x, y in edges)
    if "fixed" in (a.shape, b.shape):  # furniture is told apart by name: an offset from another's centre
        return float(size + 2 * SHAPE_PENALTY)  # lands elsewhere (the box's front is not the microwave's)
    if a.shape == b.shape:
        return float(size)
    near = any({a.shape, b.shape} <= group for group in NEAR_CLASSES)
    return float(size + SHAPE_PENALTY * (0.5 if near else 1.0))


@dataclass(frozen=True, eq=False)
class Demonstration:
    """One executed oracle demonstration of a primitive task, in plain arrays.

    Attributes:
        task_name: canonical primitive task name, e.g. ``"grasp bottle"``.
        task_id: the suite's id, e.g. ``"grasp-bottle"``.
        times: (n,) s from the start, at the control rate.
        positions: (n, 3k) commanded end-effector positions of the k arms, metres, world frame.
        orientations: (n, 4k) commanded end-effector quaternions xyzw of the k arms, world frame.
        gripper: (n,) gripper commands (every arm's), 0 open, 1 closed.
        target: name of the object (or ``"position"``) whose centre anchors the approach; None if none.
        target_center: (3,) the target's centre at the start, metres, world frame (zeros if no target).
        target_contact: index of the first sample at which the gripper touched the target, or -1.
        condition: the task condition derived from the environment (FromEnv), or None.
        evidence: the environment information at the start and end and the contacts during it, or None.
        shapes: each task object's shape class and perceived box at the start (:class:`ObjectShape`).
        hold_depth: height (m) of the hand above the bottom of the object it holds at the start (a carry),
            or None.
        target_yaw: the target's perceived heading at the start, rad
            (:attr:`~taskcond.execution.world.Observation.yaws`), or None where the world perceives none.
    """

    task_name: str
    task_id: str
    times: np.ndarray
    positions: np.ndarray
    orientations: np.ndarray
    gripper: np.ndarray
    target: str | None
    target_center: np.ndarray
    target_contact: int = -1
    condition: TaskCondition | None = None
    evidence: DemoEvidence | None = None
    shapes: dict[str, ObjectShape] = field(default_factory=dict)
    hold_depth: float | None = None
    target_yaw: float | None = None


@dataclass(frozen=True, eq=False)
class Segment:
    """One DMP-encoded piece of a skill.

    Attributes:
        dmp: position DMP, 3k dimensions for k arms (metres, world frame), learned on the piece.
        orientations: (m, 4k) demonstrated quaternions xyzw over the piece, equally spaced in time.
        gripper: the gripper command during the piece (0 open, 1 closed), every arm's.
        anchor: ``"target"``: the goal is the target's centre plus :attr:`offset`; ``"relative"``: the goal
            is the piece's start plus the demonstrated displacement ``dmp.goal − dmp.y0``.
        offset: (3k,) demonstrated goal minus the target's centre per arm, metres (``"target"`` anchor
            only).
    """

    dmp: DMPParameters
    orientations: np.ndarray
    gripper: float
    anchor: Anchor
    offset: np.ndarray

    @property
    def duration(self) -> float:
        """Demonstrated duration in s (the DMP's τ)."""
        return self.dmp.tau

    @property
    def arms(self) -> int:
        """Number of arms k the piece moves."""
        return self.dmp.n_dims // 3

    def goal(
        self,
        start: np.ndarray,
        target_center: np.ndarray | None,
        turn: float = 0.0,
        scale: np.ndarray | None = None,
    ) -> np.ndarray:
        """Goal (3k,) of the piece started at ``start`` (3k,); the target's centre (3,) plus each arm's
        offset for target anchors (Alg. 2, line 3); without one, the demonstrated displacement. ``turn``
        (rad) turns the demonstration about the world's vertical through the target's centre: the offset,
        and a relative piece's displacement, are turned by it (a grasp from another side of a round
        object, :meth:`taskcond.execution.executor.Executor._turn`). ``scale`` (3,) multiplies the offset
        per world axis first (a skill borrowed from an object of another size, :func:`offset_scale`)."""
        start = np.asarray(start, float)
        if self.anchor == "target" and target_center is not None:
            offset = self.offset if scale is None else self.offset * np.tile(scale, self.arms)
            return np.tile(np.asarray(target_center, float), self.arms) + turned(offset, turn)
        return start + turned(self.dmp.goal - self.dmp.y0, turn)

    @cached_property
    def _profiles(self) -> list[Slerp]:
        profiles = []
        for arm in range(self.arms):
            quats = self.orientations[:, 4 * arm : 4 * arm + 4]
            if len(quats) == 1:
                profiles.append(Slerp([0.0, 1.0], Rotation.from_quat(np.repeat(quats, 2, axis=0))))
            else:
                profiles.append(Slerp(np.linspace(0.0, 1.0, len(quats)), Rotation.from_quat(quats)))
        return profiles

    def orientation(
        self,
        fraction: float | np.ndarray,
        start: np.ndarray,
        turn: float = 0.0,
        hold: bool = False,
        mirror: bool = False,
    ) -> np.ndarray:
        """Orientations xyzw of the k arms at ``fraction`` ∈ [0, 1] of the piece ((4k,), or (m, 4k) for m
        fractions) when it started at orientations ``start`` (4k,); ``turn`` (rad, about the world's
        vertical) turns the demonstrated profile as :meth:`goal` turns the offset.

        The demonstrated profile R_d(s) of each arm is carried over as ``Δ(s) R_d(s)``. For a relative
        piece, and for any piece with ``hold`` (:attr:`~taskcond.execution.approach.Aim.hold`), Δ is the
        constant world-frame rotation between the new and the demonstrated start; for the
        approach it is slerped from that rotation to identity, so the hand arrives in the demonstrated
        orientation relative to the world (the target's frame). A parallel gripper turned half a turn
        about its own axis (its z) holds the same way, so R_d is taken as it was or half a turn turned,
        whichever starts nearer to ``start``: a hand holding a bowl by its wall then keeps the bowl on its
        side instead of swinging it round the hand. With ``mirror``, the demonstrated turn from the piece's
        first orientation, R_d(0)⁻¹ R_d(s), is taken the other way about the same axis (a tilt that pours
        the other way; :attr:`~taskcond.execution.approach.Aim.mirror`)."""
        s = np.clip(np.asarray(fraction, dtype=float), 0.0, 1.0)
        u = np.atleast_1d(s)
        weight = 1.0 - u * u * (3 - 2 * u) if self.anchor == "target" and not hold else np.ones_like(u)
        start = np.asarray(start, float)
        spin = Rotation.from_rotvec([0.0, 0.0, turn])
        arms = []
        for arm, profile in enumerate(self._profiles):
            here = Rotation.from_quat(start[4 * arm : 4 * arm + 4])
            first = spin * Rotation.from_quat(self.orientations[0, 4 * arm : 4 * arm + 4])
            twin = twin_turn(first, here)
            offset = (here * (first * twin).inv()).as_rotvec()
            toward = Rotation.from_rotvec(weight[:, None] * offset[None, :])
            if mirror:  # the demonstrated turn from the first orientation, taken the other way
                turned = toward * (first * (spin * profile(u)).inv() * first) * twin
            else:  # in this order: another rounds differently, and the physics amplifies it
                turned = toward * spin * profile(u) * twin
            arms.append(turned.as_quat())
        quats = np.concatenate(arms, axis=1)
        return quats if s.ndim else quats[0]


def turned(vectors: np.ndarray, turn: float) -> np.ndarray:
    """(3k,) stacked 3-vectors turned by ``turn`` rad about the world's vertical."""
    if turn == 0.0:
        return np.asarray(vectors, float)
    c, s = np.cos(turn), np.sin(turn)
    v = np.asarray(vectors, float).reshape(-1, 3)
    return np.column_stack([c * v[:, 0] - s * v[:, 1], s * v[:, 0] + c * v[:, 1], v[:, 2]]).reshape(-1)


HALF_TURN = Rotation.from_rotvec([0.0, 0.0, np.pi])
"""Half a turn about the gripper's own z axis (its approach axis): a parallel gripper's twin pose."""


def twin_turn(orientation: Rotation, here: Rotation) -> Rotation:
    """:data:`HALF_TURN` if ``orientation`` turned half a turn about the hand's own axis is nearer to
    ``here`` than ``orientation`` itself, else the identity: a parallel gripper holds the same either way,
    so the nearer of the two twins is taken."""
    if (here.inv() * orientation * HALF_TURN).magnitude() < (here.inv() * orientation).magnitude():
        return HALF_TURN
    return Rotation.identity()


@dataclass(frozen=True, eq=False)
class Skill:
    """What the framework knows about a primitive task from its demonstration (the demo data, Fig. 2).

    Attributes:
        task_name: the demonstrated task, e.g. ``"grasp bottle"``.
        task_id: its suite id.
        primitive: primitive id.
        segments: the DMP pieces in order.
        condition: the FromEnv task condition of the demonstration, or None.
        evidence: what the demonstration showed at its start and end (:class:`DemoEvidence`), or None.
        shapes: the demonstrated objects' shape classes and boxes (:attr:`Demonstration.shapes`).
        hold_depth: the hand's height above the held object's bottom at the start of a carry, m, or None.
        target_yaw: the demonstrated target's heading, rad (:attr:`Demonstration.target_yaw`), or None.
    """

    task_name: str
    task_id: str
    primitive: str
    segments: tuple[Segment, ...]
    condition: TaskCondition | None = None
    evidence: DemoEvidence | None = None
    shapes: dict[str, ObjectShape] = field(default_factory=dict)
    hold_depth: float | None = None
    target_yaw: float | None = None

    @property
    def duration(self) -> float:
        return sum(s.duration for s in self.segments)

    @property
    def arms(self) -> int:
        """Number of arms k the skill moves together."""
        return self.segments[0].arms

    @property
    def start_offset(self) -> np.ndarray:
        """(3k,) where the demonstration started, per arm: relative to the target's centre for a skill
        with a target, else in the world frame; metres."""
        first = self.segments[0]
        if first.anchor == "target":
            return first.dmp.y0 - (first.dmp.goal - first.offset)
        return first.dmp.y0


def target_object(task_name: str) -> str | None:
    """The object (or ``"position"``) a primitive task's approach aims at: the task object of its
    primitive's :attr:`~taskcond.primitives.Primitive.target` (grasp/open/close X → X, move A on top of /
    into / in front of B → B, move A to position → the position); None for release and tilt, which use the
    demonstrated displacement (§III-E)."""
    task = parse_task(task_name)
    role = task.primitive.target
    if role is None:
        return None
    return "position" if role < 0 else task.objects[role]


def split_points(demo: Demonstration) -> list[int]:
    """Sample indices where the demonstration is cut into DMP pieces (see the module doc): every gripper
    command change, and the end of the approach: the last standstill up to the first contact with the
    target or gripper change, or that change if the hand stands still from there to it (robosuite's arm,
    lagging its oracle's standstill at the grip, touches the object before the hand closes; cut at the
    touch, the grasp had an open piece more and lost its straight descent, issue 32)."""
    n = len(demo.times)
    changes = [k for k in range(1, n) if abs(demo.gripper[k] - demo.gripper[k - 1]) > 1e-9]
    cuts = set(changes)
    first = min([k for k in (demo.target_contact, *changes[:1]) if k > 0], default=-1)
    if demo.target is None:
        return sorted(k for k in cuts if MIN_SEGMENT_SAMPLES <= k <= n - MIN_SEGMENT_SAMPLES)
    velocity = np.gradient(demo.positions, demo.times, axis=0).reshape(n, -1, 3)
    speed = np.linalg.norm(velocity, axis=2).max(axis=1)  # the fastest arm's
    if first > 0:
        still = [k for k in range(MIN_SEGMENT_SAMPLES, first + 1) if speed[k] < STANDSTILL]
        cut = still[-1] if still else first
        if changes and cut < changes[0] and np.all(speed[cut : changes[0] + 1] < STANDSTILL):
            cut = changes[0]  # touched during the standstill before the hand closes: one approach
        cuts.add(cut)
    else:  # a carry that never touches its target: the approach ends before the last movement
        moving = speed >= STANDSTILL
        still = [k for k in range(MIN_SEGMENT_SAMPLES, n) if not moving[k] and moving[k + 1 :].any()]
        if still:
            cuts.add(still[-1])
    return sorted(k for k in cuts if MIN_SEGMENT_SAMPLES <= k <= n - MIN_SEGMENT_SAMPLES)


def learn_skill(demo: Demonstration) -> Skill:
    """Fit the DMP pieces of one demonstration (§III-D locally weighted regression, per piece).

    Raises:
        SkillError: the demonstration has fewer than 3 samples.
    """
    n = len(demo.times)
    if n < MIN_SEGMENT_SAMPLES:
        raise SkillError(f"demonstration of {demo.task_name!r} has {n} samples; at least 3 are needed")
    bounds = [0, *split_points(demo), n - 1]
    segments = []
    for index, (lo, hi) in enumerate(itertools.pairwise(bounds)):
        times = demo.times[lo : hi + 1] - demo.times[lo]
        positions = demo.positions[lo : hi + 1]
        anchor: Anchor = "target" if index == 0 and demo.target is not None else "relative"
        segments.append(
            Segment(
                dmp=learn_dmp(times, positions),
                orientations=np.asarray(demo.orientations[lo : hi + 1], float),
                gripper=float(demo.gripper[min(lo + 1, hi)]),
                anchor=anchor,
                offset=(
                    positions[-1] - np.tile(demo.target_center, positions.shape[1] // 3)
                    if anchor == "target"
                    else np.zeros(positions.shape[1])
                ),
            )
        )
    task = parse_task(demo.task_name)
    return Skill(
        task_name=task.name,
        task_id=demo.task_id,
        primitive=task.primitive.id,
        segments=tuple(segments),
        condition=demo.condition,
        evidence=demo.evidence,
        shapes=dict(demo.shapes),
        hold_depth=demo.hold_depth,
        target_yaw=demo.target_yaw,
    )


UNKNOWN_SHAPE = 2 * SHAPE_PENALTY
""":func:`dissimilarity` assumed for an object whose shape is not known (unperceived, or a skill of an
older library): worse than any known object of the same class."""


@dataclass(frozen=True)
class Choice:
    """The skills a primitive task runs with (:meth:`SkillLibrary.choose`) and why.

    Attributes:
        skills: the candidates, all demonstrated on the same objects (the nearest start picks one).
        borrowed: task object → (the demonstrated object standing in for it, its :func:`dissimilarity`),
            for each task object that is not the demonstrated one.
    """

    skills: list[Skill]
    borrowed: dict[str, tuple[str, float]]

    @property
    def reason(self) -> str:
        """Why these skills: empty when demonstrated on the task's own objects."""
        return "; ".join(
            f"{demo} stands in for {obj} (most similar in shape and size demonstrated: {score:.2f})"
            for obj, (demo, score) in self.borrowed.items()
        )


SCALE_DEADBAND = 0.15
"""Ratios of perceived to demonstrated box edges within this fraction of 1 count as 1 in
:func:`offset_scale`: with the default perception noise (σ = 5 mm on each corner coordinate) a 6.6 cm edge
is perceived within ±11 % (1σ), and a grasp should not wander with the noise."""


def offset_scale(task_target: ObjectShape | None, demo_target: ObjectShape | None) -> np.ndarray:
    """Per world axis (3,), the factor on a grasp's demonstrated offset from the target's centre when the
    skill was demonstrated on another object (issue 31: grasp height and width scaled from the perceived
    box): the ratio of the perceived to the demonstrated box's mean horizontal edge for x and y (where the
    fingers close on a wall), of their heights for z (how high on the object the hand closes), each
    clipped to [1/4, 4] and 1 within :data:`SCALE_DEADBAND` of it; ones when either shape is unknown."""
    if task_target is None or demo_target is None:
        return np.ones(3)
    xy = task_target.width / max(demo_target.width, 1e-3)
    z = task_target.height / max(demo_target.height, 1e-3)
    ratios = np.clip(np.array([xy, xy, z]), 0.25, 4.0)
    return np.where(np.abs(ratios - 1.0) <= SCALE_DEADBAND, 1.0, ratios)


@dataclass
class SkillLibrary:
    """Skills by suite task id, saved as one directory of plain files (JSON + NPZ, :data:`LIBRARY_FORMAT`).

    Layout: ``library.json`` (format version, skills with their segments' metadata and FromEnv conditions)
    and per piece ``<task_id>-<k>.json/.npz`` (the DMP, :func:`taskcond.dmp.save_parameters`) and
    ``<task_id>-<k>-orientations.npz``.
    """

    skills: dict[str, Skill] = field(default_factory=dict)

    def add(self, skill: Skill) -> None:
        self.skills[skill.task_id] = skill

    def __len__(self) -> int:
        return len(self.skills)

    def candidates(self, task_name: str, shapes: Mapping[str, ObjectShape] | None = None) -> list[Skill]:
        """The skills that can run a primitive task name (:meth:`choose`)."""
        return self.choose(task_name, shapes).skills

    def choose(self, task_name: str, shapes: Mapping[str, ObjectShape] | None = None) -> Choice:
        """The skills that can run a primitive task name: those demonstrated on the same objects, else those
        of the same primitive demonstrated on the most similar objects: least summed :func:`dissimilarity`
        of each task object (its shape in ``shapes``, perceived now) to the object demonstrated in its
        place (0 for the same name; :data:`UNKNOWN_SHAPE` when either shape is unknown); a tie goes to the
        library's order (the suite's registry order, primitive tasks before long-horizon steps).

        Raises:
            SkillError: no skill of that primitive.
        """
        task = parse_task(task_name)
        same = [s for s in self.skills.values() if s.primitive == task.primitive.id]
        if not same:
            known = sorted({s.primitive for s in self.skills.values()})
            raise SkillError(
                f"no skill for {task.name!r} ({task.primitive.id}); skills exist for: {', '.join(known)}"
            )
        exact = [s for s in same if s.task_name == task.name]
        if exact:
            return Choice(exact, {})
        shapes = shapes or {}

        def unlike(skill: Skill) -> dict[str, tuple[str, float]]:
            demo = parse_task(skill.task_name).objects
            out = {}
            for obj, their in zip(task.objects, demo, strict=True):
                if obj == their:
                    continue
                mine, theirs = shapes.get(obj), skill.shapes.get(their)
                known = mine is not None and theirs is not None
                out[obj] = (their, dissimilarity(mine, theirs) if known else UNKNOWN_SHAPE)  # type: ignore[arg-type]
            return out

        scores = [(sum(d for _, d in unlike(s).values()), k, s) for k, s in enumerate(same)]
        best = min(scores, key=lambda t: (t[0], t[1]))[2]
        return Choice([s for s in same if s.task_name == best.task_name], unlike(best))

    def lookup(
        self,
        task_name: str,
        start: np.ndarray | None = None,
        orientation: np.ndarray | None = None,
        shapes: Mapping[str, ObjectShape] | None = None,
    ) -> Skill:
        """The skill for a primitive task name: among its :meth:`candidates` (``shapes``: the task objects'
        perceived shapes), the one whose demonstration started nearest to ``start`` (3,) — the first end
        effector's position relative to the target's centre, or in the world frame for primitives without
        a target — and ``orientation`` (4,) xyzw; a tenth of a radian counts as a centimetre.

        Raises:
            SkillError: no skill of that primitive.
        """
        return self.nearest(self.candidates(task_name, shapes), start, orientation)

    @staticmethod
    def nearest(
        candidates: list[Skill], start: np.ndarray | None = None, orientation: np.ndarray | None = None
    ) -> Skill:
        """Of ``candidates``, the one whose demonstration started nearest (see :meth:`lookup`)."""
        if start is None or len(candidates) == 1:
            return candidates[0]

        def distance(skill: Skill) -> float:
            d = float(np.linalg.norm(skill.start_offset[:3] - np.asarray(start, float)[:3]))
            if orientation is not None:
                first = Rotation.from_quat(skill.segments[0].orientations[0, :4])
                d += 0.1 * (first.inv() * Rotation.from_quat(orientation)).magnitude()
            return d

        return min(candidates, key=distance)

    def save(self, directory: str | Path) -> Path:
        """Write the library to ``directory`` (created); returns the path of ``library.json``."""
        directory = Path(directory)
        directory.mkdir(parents=True, exist_ok=True)
        entries = []
        for skill in self.skills.values():
            pieces = []
            for k, seg in enumerate(skill.segments):
                stem = f"{skill.task_id.replace('*', 'star')}-{k}"
                save_parameters(seg.dmp, directory / f"{stem}.json")
                np.savez(directory / f"{stem}-orientations.npz", orientations=seg.orientations)
                pieces.append(
                    {
                        "file": stem,
                        "gripper": seg.gripper,
                        "anchor": seg.anchor,
                        "offset": seg.offset.tolist(),
                    }
                )
            entries.append(
                {
                    "task_name": skill.task_name,
                    "task_id": skill.task_id,
                    "primitive": skill.primitive,
                    "segments": pieces,
                    "condition": None if skill.condition is None else skill.condition.to_dict(),
                    "evidence": None if skill.evidence is None else skill.evidence.to_dict(),
                    "shapes": {o: {"shape": v.shape, "size": list(v.size)} for o, v in skill.shapes.items()},
                    "hold_depth": skill.hold_depth,
                    "target_yaw": skill.target_yaw,
                }
            )
        path = directory / "library.json"
        path.write_text(json.dumps({"format": LIBRARY_FORMAT, "skills": entries}, indent=1), encoding="utf-8")
        return path

    @classmethod
    def load(cls, directory: str | Path) -> SkillLibrary:
        """Read a library written by :meth:`save`; no simulator needed.

        Raises:
            SkillError: missing directory/index, another format version, or unreadable files.
        """
        path = Path(directory) / "library.json"
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
        except FileNotFoundError:
            raise SkillError(f"no skill library at {path.parent}; create it with `taskcond learn`") from None
        except (OSError, ValueError) as exc:
            raise SkillError(f"unreadable skill library {path}: {exc}") from None
        if data.get("format") != LIBRARY_FORMAT:
            raise SkillError(
                f"skill library {path.parent} has format {data.get('format')!r}, this taskcond reads "
                f"{LIBRARY_FORMAT}; re-create it with `taskcond learn`"
            )
        library = cls()
        try:
            for entry in data["skills"]:
                segments = []
                for piece in entry["segments"]:
                    stem = Path(directory) / piece["file"]
                    with np.load(f"{stem}-orientations.npz") as arrays:
                        orientations = arrays["orientations"]
                    segments.append(
                        Segment(
                            dmp=load_parameters(f"{stem}.json"),
                            orientations=orientations,
                            gripper=float(piece["gripper"]),
                            anchor=piece["anchor"],
                            offset=np.asarray(piece["offset"], float),
                        )
                    )
                cond, evidence = entry.get("condition"), entry.get("evidence")
                library.add(
                    Skill(
                        task_name=entry["task_name"],
                        task_id=entry["task_id"],
                        primitive=entry["primitive"],
                        segments=tuple(segments),
                        condition=None if cond is None else TaskCondition.from_dict(cond),
                        evidence=None if evidence is None else DemoEvidence.from_dict(evidence),
                        shapes={
                            o: ObjectShape(v["shape"], tuple(map(float, v["size"])))  # type: ignore[arg-type]
                            for o, v in entry.get("shapes", {}).items()
                        },
                        hold_depth=entry.get("hold_depth"),
                        target_yaw=entry.get("target_yaw"),
                    )
                )
        except (KeyError, OSError, ValueError) as exc:
            raise SkillError(f"corrupt skill library {path.parent}: {exc}") from None
        return library


__all__ = [
    "LIBRARY_FORMAT",
    "Choice",
    "Demonstration",
    "ObjectShape",
    "Segment",
    "Skill",
    "SkillError",
    "SkillLibrary",
    "dissimilarity",
    "learn_skill",
    "offset_scale",
    "split_points",
    "target_object",
    "turned",
]
