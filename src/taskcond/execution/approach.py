"""How the hand approaches a primitive's target (beyond the paper, around Alg. 2 lines 3–4): the skill and
goal a primitive aims at (:class:`Aim`), a grasp turned to a free side of a round object, a carried object
set down beside what is on top, transits to a skill's demonstrated start (over what lies on the way when
carrying), backing off and setting down. :class:`Approach` is the part of the
:class:`~taskcond.execution.executor.Executor` that does this; the hand's geometry is data
(:class:`~taskcond.execution.config.Hand`, :attr:`~taskcond.execution.config.ExecutionConfig.hand`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

from taskcond.conditions import Relation
from taskcond.dmp import DMPParameters, DMPRollout, rollout
from taskcond.execution.collisions import CollisionMonitor
from taskcond.execution.config import ExecutionConfig, Hand
from taskcond.execution.events import EventLog
from taskcond.execution.failures import ExecutionError, FailureKind
from taskcond.execution.observer import ExecutionObserver, planned_path
from taskcond.execution.skills import (
    Choice,
    ObjectShape,
    Segment,
    Skill,
    SkillError,
    SkillLibrary,
    offset_scale,
    target_object,
    turned,
    twin_turn,
)
from taskcond.execution.world import Observation, World
from taskcond.primitives import HandApproach, parse_task
from taskcond.relations import THRESHOLDS, Box, in_front_of

CARRY_MARGIN = 0.03
"""Clearance (m) a carried object keeps above what it is carried over, and around it."""


MAX_STRETCH = 3.0
"""Largest ratio of new to demonstrated goal offset per dimension that keeps Eq. 2's scaling."""
MIN_SCALED = 0.01
"""Least demonstrated displacement (m) of a piece's dimension for Eq. 2's scaling of its forcing term."""


def _conditioned(
    seg: Segment, start: np.ndarray, goal: np.ndarray, descent: bool = False, straight: bool = False
) -> DMPParameters:
    """The piece's DMP for a movement from ``start`` to ``goal`` (3,): Eq. 2's scaled forcing term where
    the new offset ``goal − start`` keeps the demonstrated sign and at most :data:`MAX_STRETCH` times its
    size, the unscaled term elsewhere (:meth:`DMPParameters.unscaled`), so that a demonstration is never
    replayed mirrored or blown up; a dimension the demonstration hardly moved (less than
    :data:`MIN_SCALED`) is always unscaled, and one the new offset hardly moves (less than that) always
    scaled, whatever its sign, so that a millimetre more or less of offset does not switch its
    demonstrated excursion on or off (issue 31: a carry whose transit ended at its first goal's height,
    a fraction of a millimetre above it, replayed the demonstrated 28 cm rise unscaled and dived 19 cm).
    A ``descent`` (:attr:`Aim.descent`) keeps no horizontal forcing term: the hand comes straight down
    onto its goal, whatever way the demonstration came in sideways. A ``straight`` piece
    (:attr:`Aim.detour`) keeps none at all: a straight line to its goal."""
    dmp = seg.dmp
    if straight:
        return dmp.unforced(np.ones(dmp.n_dims, dtype=bool))
    if descent:
        dmp = dmp.unforced(np.tile([True, True, False], dmp.n_dims // 3))
    demo, new = dmp.goal - dmp.y0, np.asarray(goal) - np.asarray(start)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(dmp.goal_scaled, new / demo, 1.0)
    mirrored = (ratio < 0) & (np.abs(new) >= MIN_SCALED)
    bad = dmp.goal_scaled & (mirrored | (np.abs(ratio) > MAX_STRETCH) | (np.abs(demo) < MIN_SCALED))
    return dmp.unscaled(bad) if bad.any() else dmp


@dataclass(frozen=True)
class Aim:
    """What one execution of a primitive runs, and towards what (Alg. 2 lines 3–4).

    Attributes:
        task: the primitive task.
        skill: its DMP skill, looked up for the current end-effector pose relative to the target.
        target_name: the object whose centre is goalPos (or ``"position"``); None for a primitive without a
            target, whose pieces move by their demonstrated offsets.
        target: (3,) the target's perceived centre, m, world frame; None without a target.
        turn: rad about the world's vertical through the target's centre by which the skill's
            demonstration is turned (:meth:`Approach._turn`); 0 as demonstrated.
        aside: (3,) m the goal is moved from the demonstrated spot (:meth:`Approach._aside`: horizontally
            on top of a crowded target, up onto its top; :func:`carry_shift`: up or down for a carried
            object held at another height or a target of another height than demonstrated), already added
            to ``target``; zero as demonstrated.
        approach: (3,) m, world frame: where the hand goes before the skill runs (:meth:`Approach._transit`):
            the skill's demonstrated start relative to the target, or with ``descent`` the pre-grasp pose
            above the grasp point (:meth:`Approach._pregrasp`); None to start where it is.
        over: least height (m, world z) of the hand on its way to ``approach`` when it carries an object
            (:func:`_carry_height`) or takes a ``detour`` (:func:`_over_height`); None otherwise.
        scale: (3,) factors on the target-anchored piece's demonstrated offset per world axis
            (:func:`~taskcond.execution.skills.offset_scale`): a grasp borrowed from an object of another
            size closes at the same place relative to the perceived box; ones as demonstrated.
        choice: why this skill (:attr:`~taskcond.execution.skills.Choice.reason`); empty when it was
            demonstrated on the task's own objects.
        descent: an object-centred grasp (issue 31) of an object that stands up (:func:`_tall`): the hand
            goes to ``approach`` above the demonstrated grasp point and the skill's open piece comes
            straight down onto it (its horizontal forcing term off, :func:`_conditioned`), so that no
            sideways way of the demonstration sweeps the object or a neighbour; False replays the
            demonstrated way.
        hold: the hand keeps its heading through the skill (:meth:`Segment.orientation
            <taskcond.execution.skills.Segment.orientation>`'s ``hold``; the transit too): a carry of a
            round object by a hand with :attr:`~taskcond.execution.config.Hand.round_carry_holds`.
        detour: the demonstrated way of an empty-hand primitive that grasps nothing (an open, a close)
            would sweep the arm through a free object standing beside it (:meth:`Approach._clear_way`,
            issue 31): the hand went over what stands on the way to ``approach``, a point on the line of
            the demonstrated last approach to the first piece's goal, turned as it arrives there (and
            ``tilt``), and the first piece goes on straight (its forcing term off, :func:`_conditioned`)
            holding that heading.
        swept: the free objects the demonstrated way would have swept (with ``detour``); empty otherwise.
        tilt: rad by which the hand arrives at ``approach`` on a ``detour`` tilted (:func:`tilted`), its
            wrist higher; the later pieces keep it.
        mirror: the pieces of a skill without a target turn the hand the other way about the demonstrated
            axis (:meth:`Segment.orientation <taskcond.execution.skills.Segment.orientation>`): the arm
            cannot follow the demonstrated turn from its joints now and can follow that one
            (:meth:`Approach._mirrored`).
    """

    task: str
    skill: Skill
    target_name: str | None
    target: np.ndarray | None
    turn: float = 0.0
    aside: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(3))
    approach: np.ndarray | None = None
    over: float | None = None
    scale: np.ndarray = dataclasses.field(default_factory=lambda: np.ones(3))
    choice: str = ""
    descent: bool = False
    hold: bool = False
    detour: bool = False
    swept: tuple[str, ...] = ()
    tilt: float = 0.0
    mirror: bool = False

    @property
    def arms(self) -> int:
        """Number of arms k the skill moves together."""
        return self.skill.arms


@dataclass(frozen=True)
class TargetAim:
    """A primitive's aim at its target in progress (:meth:`Approach._aim`): what
    :meth:`Approach._demo_turn`, :meth:`Approach._turn` and :meth:`Approach._pregrasp` share.

    Attributes:
        skill: the primitive's skill, its first DMP piece anchored on the target.
        target_name: the object the primitive is aimed at.
        target: (3,) m, world frame: its perceived centre.
        obs: the observation the primitive is aimed in.
        far: the hand goes to the skill's demonstrated start first (:meth:`Approach._far`).
        scale: (3,) factors on the grasp's demonstrated offset (:func:`_empty_hand_scale`).
        descent: the object-centred way straight down from above it (:attr:`Aim.descent`).
    """

    skill: Skill
    target_name: str
    target: np.ndarray
    obs: Observation
    far: bool
    scale: np.ndarray
    descent: bool


@dataclass(frozen=True)
class CarriedWay:
    """How the hand goes to a skill's start (:meth:`Approach._carried_way`).

    Attributes:
        approach: (3,) m, world frame, where the transit ends (:attr:`Aim.approach`), or None.
        over: least height (m, world z) of the transit when it carries an object (:attr:`Aim.over`), or None.
        descent: the first piece comes straight down from ``approach`` (:attr:`Aim.descent`).
        detour: ``approach`` is on the line of the demonstrated last approach, reached over the objects
            the demonstrated way would sweep (:attr:`Aim.detour`).
        swept: those objects (:attr:`Aim.swept`).
        tilt: rad the hand is tilted on the detour (:attr:`Aim.tilt`).
    """

    approach: np.ndarray | None
    over: float | None
    descent: bool
    detour: bool = False
    swept: tuple[str, ...] = ()
    tilt: float = 0.0


@dataclass(frozen=True)
class Picked:
    """Where a held object was picked up (:meth:`Approach._put_back`).

    Attributes:
        box: its perceived box (lower, upper (3,) m, world frame) before the grasp.
        position: (3,) m, world frame, where the hand was once the grasp held it.
        orientation: (4,) xyzw, how the hand was turned then.
    """

    box: tuple[np.ndarray, np.ndarray]
    position: np.ndarray
    orientation: np.ndarray


class Approach:
    """The approach geometry of the :class:`~taskcond.execution.executor.Executor` (its base class): what it
    needs is the world, the skill library, the constants, the hand, the event log, and a control step
    (:meth:`_step`)."""

    world: World
    library: SkillLibrary
    config: ExecutionConfig
    hand: Hand
    log: EventLog
    observer: ExecutionObserver | None
    picked: dict[str, Picked]

    def _back_off(self, task: str, depth: int, why: str) -> None:
        """Beyond the paper: open the hand and lift it straight up by :data:`BACK_OFF_HEIGHT`. Before a
        grasp is tried again, so that the object the missed grasp disturbed settles and the next try
        starts above it, not beside it in whatever pose the miss left the hand (a retry from there
        brushes the object over); and when a release is skipped because its object is no longer grasped
        but a finger still touches it (it slipped), so that the hand lets go of it. A missed grasp that
        still lifted its object off its support (pinched at an edge, not held as a grasp) first lowers it
        back onto it (:meth:`_lower`): opened up there, the hand would drop it and it would fall over."""
        target = target_object(task)
        if target is not None and self._touched(target):
            self._lower(task, depth, target)
        here, quat = self.world.ee_pose()
        opened = 0.0
        self.log.back_off(task, depth, BACK_OFF_HEIGHT, why)
        for _ in range(BACK_OFF_RELEASE):
            self._step(here, quat, opened)
        self._straight(here + np.array([0.0, 0.0, BACK_OFF_HEIGHT]), quat, opened)

    def _touched(self, obj: str, arms: int | None = None) -> bool:
        """Whether a hand (of the first ``arms`` arms; None: any) touches ``obj`` now."""
        hands = self.world.arms[:arms]
        return any(obj in (t.a, t.b) and not {t.a, t.b}.isdisjoint(hands) for t in self.world.touches())

    def _gripper_command(self) -> float:
        """The gripper command of the last control step (closed, 1, before any)."""
        return self._last[2] if hasattr(self, "_last") else 1.0

    def _set_down(self, task: str, depth: int) -> None:
        """Beyond the paper: before a release, lower the held object onto what lies under it
        (:meth:`_lower`), so that it is put down rather than dropped from where the hand happened to be (a
        dropped bottle falls over, and no grasp skill picks up a lying object): a release Alg. 1 raised to
        free the hand (another primitive needs ``gripper not grasping``), and a release after a move whose
        hand ended above the place (issue 31: a carry held back on its way down)."""
        held = parse_task(task).objects[0]
        if self.world.observe().grasped() == held:
            if depth > 0:
                self._put_back(task, depth, held)
            self._lower(task, depth, held)

    def _put_back(self, task: str, depth: int, held: str) -> None:
        """Beyond the paper: before a release Alg. 1 raised to free the hand, carry ``held`` back to where its
        grasp took it from: the hand goes back to its pose once the grasp held it (:class:`Picked`), over
        what lies on the way (:func:`_carry_height`), when it is now more than :data:`PUT_BACK_MIN` from
        there or turned more than :data:`PUT_BACK_TURN`, and the object's place is still clear
        (:attr:`ExecutionConfig.clearance` from every other box that reaches above its bottom there). Held by
        no carry since, the object was moved only by what held it up: set down where and as a tilt left it,
        it lands on its side, on whatever is there (issue 31: the mug tilted over the open bottom drawer fell
        in on its side, and the cube could not be put into it)."""
        picked = self.picked.get(held)
        if picked is None:
            return
        obs = self.world.observe()
        here, quat = self.world.ee_pose()
        turned = (Rotation.from_quat(picked.orientation) * Rotation.from_quat(quat).inv()).magnitude()
        if float(np.linalg.norm(picked.position[:2] - here[:2])) < PUT_BACK_MIN and turned < PUT_BACK_TURN:
            return
        lo = picked.box[0]
        skip = (held, *self.world.ground, *self.world.arms)
        others = [(a[:2], b[:2]) for n, (a, b) in obs.boxes.items() if n not in skip and b[2] > lo[2]]
        if _gap((lo[:2], picked.box[1][:2]), others, np.zeros(2)) < self.config.clearance:
            return
        gripper = self._gripper_command()
        self.log.put_back(task, depth, held, picked.position - here, math.degrees(turned))
        over = _carry_height(held, here, picked.position, obs, self.world.arms)
        self._transit(picked.position, picked.orientation, gripper, over)

    def _let_go(self, task: str, depth: int, monitor: CollisionMonitor) -> None:
        """Beyond the paper: before a release's DMP, open the hand where it is until the held object is no
        longer grasped (both fingers no longer touch it, the perceiver's rule), for at most
        :data:`REGRIP_TIME`; while it stays grasped, close the hand on it again and reopen, at most
        :data:`REGRIPS` times, as the scripted demonstrator's release does
        (:func:`taskcond.tasks.motions.release_plans`). An object that turns in the opening hand can wedge
        across the pads: their edges sink into its wall, which presses them along their width, across the
        way they open, and the finger motors cannot overcome the friction; the release's rise then lifts
        it with the hand. Closing again presses the wall flat between the pads. The hand is held where it
        is, not where it was last commanded (issue 31: the bowl carried into the bottom drawer, under a hand
        Alg. 2 had pressed against the top drawer, turned 9° as the fingers opened and pinched them at
        5.6 mm with 20–36 N along their width; every rise lifted it). A contact of the hand that
        ``monitor`` (the release's, Alg. 2 line 2) does not allow, a finger opening into a neighbour, ends
        it at once: the DMP's Alg. 2 answers that contact."""
        held = parse_task(task).objects[0]
        if self.world.observe().grasped() != held:
            return
        here, quat = self.world.ee_pose()
        steps = math.ceil(REGRIP_TIME / self.world.dt)
        for regrip in range(REGRIPS + 1):
            if regrip:
                self.log.regrip(task, depth, held, regrip)
            for gripper in (1.0, 0.0) if regrip else (0.0,):
                for _ in range(steps):
                    self._step(here, quat, gripper)
                    if monitor.unallowed(self.world.touches(), closed=False) is not None:
                        return
                    if gripper < 0.5 and self.world.observe().grasped() != held:
                        return

    def _lower(self, task: str, depth: int, held: str) -> None:
        """Lower the hand with ``held`` straight down onto what lies under it (:func:`_support_below`)
        until it touches something or is :data:`SET_DOWN_GAP` above it; nothing when it is already
        lower than twice that or stands on nothing."""
        obs = self.world.observe()
        if held not in obs.boxes:
            return
        lower, _ = obs.boxes[held]
        support = _support_below(held, obs, self.world.arms)
        if support is None or float(lower[2]) - support <= 2 * SET_DOWN_GAP:
            return
        drop = float(lower[2]) - support - SET_DOWN_GAP
        here, quat = self.world.ee_pose()
        gripper = self._gripper_command()
        self.log.set_down(task, depth, held, drop)

        def landed() -> bool:
            return any(
                held in (t.a, t.b) and {t.a, t.b}.isdisjoint(self.world.arms) for t in self.world.touches()
            )

        self._straight(here - np.array([0.0, 0.0, drop]), quat, gripper, landed)

    def _straight(
        self,
        goal: np.ndarray,
        orientation: np.ndarray,
        gripper: float,
        stop: Callable[[], bool] | None = None,
    ) -> None:
        """Move the hand in a straight line from where it is to ``goal`` (3,) m at
        :attr:`ExecutionConfig.speed_limit`, holding ``orientation`` (4,) xyzw and the ``gripper`` command,
        until ``stop()`` says so after a step."""
        line = self._line(self.world.ee_pose()[0], goal)
        self._tell(line, goal, None, gripper >= 0.5)
        for point in line:
            self._step(point, orientation, gripper)
            if stop is not None and stop():
                break

    def _tell(
        self,
        path: np.ndarray | list[np.ndarray] | DMPRollout,
        goal: np.ndarray,
        monitor: CollisionMonitor | None,
        closed: bool,
    ) -> None:
        """Tell the observer, if any, of a movement starting or re-planned: a straight ``path`` (n, 3k) m or
        a DMP ``rollout``'s plan from its current state (:func:`~taskcond.execution.observer.planned_path`),
        towards ``goal`` (3k,) m."""
        if self.observer is None:
            return
        if isinstance(path, DMPRollout):
            path = planned_path(path, self.world.dt)
        self.observer.moving(np.asarray(path), goal, monitor, closed)

    def _line(self, start: np.ndarray, goal: np.ndarray) -> list[np.ndarray]:
        """Positions (3,) m, one per control step, from ``start`` (exclusive) to ``goal`` (inclusive) in a
        straight line at :attr:`ExecutionConfig.speed_limit`."""
        n = max(1, math.ceil(float(np.linalg.norm(goal - start)) / (self.config.speed_limit * self.world.dt)))
        return [start + (goal - start) * (k / n) for k in range(1, n + 1)]

    def _aim(self, task: str, obs: Observation, retry: bool = False) -> Aim:
        """Alg. 2 lines 3–4: the target's perceived centre in ``obs`` (targetPos, the goalPos of a primitive
        with a target) and the skill for the end effector's pose relative to it.

        A grasp of an object that fell over stops the run: every grasp skill is demonstrated on an upright
        object, and re-grasps that cannot hold it would only spend the budget. A grasp of a round object
        whose demonstrated approach would bring the hand against a neighbour comes from another side
        (:meth:`_turn`); any primitive aimed at a target with a perceived heading (a grasp of the cereal box,
        the opening of robosuite's door) is turned by its change (:meth:`_demo_turn`). A
        grasp whose hand is far from every demonstrated start goes to the highest one first (:meth:`_far`,
        :meth:`_transit`), and so does an open or close, unless the primitive is tried again (``retry``):
        the failed try came from there (a retried grasp starts above the object, where :meth:`_back_off`
        left the hand; a retried open goes on from the lid where the hand is).

        Raises:
            ExecutionError: the target is unseen or lies (a grasp), no skill fits, or it needs more arms.
        """
        target_name, target = self._target(task, obs)
        parsed = parse_task(task)
        grasp = parsed.primitive.grasps
        here, here_q = self.world.ee_pose()
        choice, skill = self._choose(task, obs, here - target if target is not None else here, here_q)
        carry = parsed.primitive.approach is HandApproach.CARRY and obs.grasped() == parsed.objects[0]
        far = (
            ((parsed.primitive.approach is HandApproach.EMPTY_HAND and not retry) or carry)
            and target is not None
            and self._far(task, skill, here - target)
        )
        if far and not carry:
            skill = max(choice.skills, key=lambda s: float(s.start_offset[2]))
        scale = _empty_hand_scale(task, skill, obs)
        descent = grasp and target is not None and _tall(target_name, obs) and _descends(skill)
        aiming = None
        if target is not None and target_name is not None and skill.segments[0].anchor == "target":
            aiming = TargetAim(skill, target_name, target, obs, far, scale, descent)
        turn = 0.0 if aiming is None else self._demo_turn(aiming, grasp)
        aside = _grip_drop(aiming, turn) if descent and aiming is not None else np.zeros(3)
        if carry and target is not None and target_name is not None:
            aside = self._carry_aside(task, skill, target, obs, here)
        if parsed.primitive.places in PLACED and target is not None and target_name is not None:
            aside = aside + self._aside(skill, target_name, target + aside, obs, parsed.primitive.places)
        approach = target + aside + turned(skill.start_offset, turn) if far and target is not None else None
        if descent and aiming is not None:
            approach = self._pregrasp(aiming, turn)
        way = CarriedWay(approach, None, descent)
        if carry and target is not None:
            way = self._carried_way(task, skill, target + aside, approach, obs, here)
        empty = parsed.primitive.approach is HandApproach.EMPTY_HAND and not (grasp or retry)
        if aiming is not None and empty:
            way = self._clear_way(aiming, turn, way)
        placed = (task, skill, target_name, None if target is None else target + aside, turn, aside)
        hold = carry and self.hand.round_carry_holds and parsed.objects[0] in obs.round
        mirror = target is None and self._mirrored(skill)
        steer = (way.descent, hold, way.detour, way.swept, way.tilt, mirror)
        return Aim(*placed, way.approach, way.over, scale, choice.reason, *steer)

    def _target(self, task: str, obs: Observation) -> tuple[str | None, np.ndarray | None]:
        """The target of ``task`` and its perceived centre ((3,) m) in ``obs``; (None, None) without one.

        Raises:
            ExecutionError: the target is unseen, or lies and the task grasps it.
        """
        target_name = target_object(task)
        target = self.world.locate(target_name, obs) if target_name is not None else None
        if target_name is not None and target is None:
            raise ExecutionError(
                f"{target_name!r} is not perceived; cannot aim {task!r} at it", FailureKind.NOT_PERCEIVED
            )
        if parse_task(task).primitive.grasps and target_name in obs.lying:
            raise ExecutionError(
                f"{target_name!r} fell over; no grasp skill holds it lying (each is demonstrated upright)",
                FailureKind.FALLEN,
            )
        return target_name, target

    def _carry_aside(
        self, task: str, skill: Skill, target: np.ndarray, obs: Observation, here: np.ndarray
    ) -> np.ndarray:
        """(3,) m by which a carry's place moves from the skill's goal at ``target`` (the target's centre,
        (3,) m; the hand at ``here`` (3,) m): :func:`carry_shift`, and for a move into a vessel
        :meth:`_rim`."""
        shift = carry_shift(task, skill, obs, here)
        parsed = parse_task(task)
        if parsed.primitive.places is Relation.INSIDE:
            shift = shift + self._over_opening(skill, parsed.objects, target + shift, obs, here)
            shift = shift + self._rim(skill, parsed.objects[-1], target + shift, obs, here)
        return shift

    def _over_opening(
        self, skill: Skill, objects: tuple[str, ...], target: np.ndarray, obs: Observation, here: np.ndarray
    ) -> np.ndarray:
        """(3,) m across by which a move of ``objects[0]`` into a vessel ``objects[-1]`` with a perceived
        opening (:attr:`~taskcond.execution.world.Observation.openings`; a one-arm ``skill`` aimed at
        ``target``, the vessel's centre with the place's shift, (3,) m, from the hand at ``here`` (3,) m)
        moves its place so that the held object's perceived centre ends over the opening's centre: the
        demonstrated place is measured from the centre of the vessel's box, which a handle turned another
        way than in the demonstration moves (issue 31: the cube, 4 cm, moved into the mug, whose opening is
        7 cm wide, ended 1.4 cm off its axis and landed on the rim); zero for another container."""
        held, vessel = objects[0], objects[-1]
        opening = obs.openings.get(vessel)
        if skill.arms != 1 or opening is None or held not in obs.boxes:
            return np.zeros(3)
        end = _skill_end(skill, here, target)
        lo, hi = obs.boxes[held]
        middle = (lo + hi)[:2] / 2 - here[:2] + end[:2]
        return np.array([*(opening[:2] - middle), 0.0])

    def _rim(
        self, skill: Skill, container: str, target: np.ndarray, obs: Observation, here: np.ndarray
    ) -> np.ndarray:
        """(3,) m up by which a move into ``container`` (a one-arm ``skill`` aimed at ``target``, its centre
        with the place's shift, (3,) m, from the hand at ``here`` (3,) m) raises its place so that the
        fingertips end :attr:`ExecutionConfig.clearance` above the container's perceived top, when the
        container is a free vessel (:attr:`~taskcond.execution.world.Observation.shapes`: the mug, the
        bowl, no wider inside than the open fingers): the release opens the hand there, and fingers opened
        inside the vessel press on its walls and hold it (issue 31: the toothpaste, held lower by
        :func:`_grip_drop`, was let go inside the mug, and the hand then grasped the mug). The object drops
        the rest of the way in; zero when the fingertips already end above the rim or for another
        container (a drawer, the box)."""
        if skill.arms != 1 or obs.shapes.get(container) != "vessel":
            return np.zeros(3)
        end = _skill_end(skill, here, target)
        top = float(obs.boxes[container][1][2])
        return np.array([0.0, 0.0, max(0.0, top + self.config.clearance - float(end[2]))])

    def _mirrored(self, skill: Skill) -> bool:
        """Whether a one-arm ``skill`` without a target (its pieces move by their demonstrated displacements
        from where the hand is: a tilt, a release) turns the hand the other way about the demonstrated axis
        (:attr:`Aim.mirror`): the first arm, from its joints now, cannot take the hand through the poses of
        the pieces as demonstrated (their DMP rollouts and orientation profiles, sampled at
        :data:`TURN_SAMPLES` points each; :meth:`World.follows
        <taskcond.execution.world.World.follows>`) and can through the mirrored ones (issue 31: the bowl,
        held by its rim from the side, tilted as the mug's demonstration tilts, wound the Panda's wrist to
        its limit; the IK answer jumped to another branch and swung the bowl into the table)."""
        if skill.arms != 1 or _turn_angle(skill) < MIRROR_TURN:
            return False
        here, here_q = self.world.ee_pose()

        def way(mirror: bool) -> tuple[np.ndarray, np.ndarray]:
            points, quats, start, quat = [], [], here, here_q
            for seg in skill.segments:
                goal = seg.goal(start, None)
                rolled = rollout(_conditioned(seg, start, goal), start, goal, n_steps=TURN_SAMPLES).positions
                turned_ = seg.orientation(np.linspace(0.0, 1.0, len(rolled)), quat, mirror=mirror)
                points.append(rolled)
                quats.append(turned_)
                start, quat = rolled[-1], turned_[-1]
            return np.concatenate(points), np.concatenate(quats)

        return not self.world.follows(*way(False)) and self.world.follows(*way(True))

    def _carried_way(
        self,
        task: str,
        skill: Skill,
        target: np.ndarray,
        approach: np.ndarray | None,
        obs: Observation,
        here: np.ndarray,
    ) -> CarriedWay:
        """The way of a carry from the hand at ``here`` (3,) m to the place at ``target`` (the target's centre
        with the place's shift, (3,) m). A move that sets its object down on top of or in front of its target
        (:data:`CARRIED_OVER`) goes over everything on the way (:func:`_carry_height`) to
        :data:`PLACE_DESCENT` straight above where its first piece sets the object down, and comes straight
        down (:attr:`Aim.descent`, issue 31), however near the hand already is: the demonstrated way runs low
        through whatever stands between the grasp and the place in another scene (a neighbour knocked over in
        26 of 324 episodes from random starts), and, on a target the skill was not demonstrated on (the
        cabinet borrowing the box's), rises beside the box and runs into the taller target's front. So does a
        move into a vessel with a perceived opening (:attr:`~taskcond.execution.world.Observation.openings`):
        the demonstrated way comes in aslant, and an object nearly as wide as the opening clips the rim on its
        way in (the cube into the mug). The skill's later pieces (the demonstrated last lowering) are kept.
        Another carry with a transit to ``approach`` (3,) m, the skill's demonstrated start relative to
        ``target``, goes over what lies on the way, and comes down to it no lower than its first piece's goal:
        a demonstrated start below the place (a move into the top drawer demonstrated with the bowl picked up
        from the table) would have the transit come down beside the container only for the first piece to rise
        again, and a longer object than the demonstrated one lands on what stands there (issue 31: the spatula
        on the bottom drawer's front, turned 67° in the hand); from that height the first piece goes across
        (:func:`_conditioned` scales away its demonstrated rise). Without a transit (None) the demonstrated
        way is followed from the hand."""
        parsed = parse_task(task)
        held, first = parsed.objects[0], skill.segments[0]
        into_vessel = parsed.primitive.places is Relation.INSIDE and parsed.objects[-1] in obs.openings
        over = parsed.primitive.places in CARRIED_OVER or into_vessel
        descent = over and first.anchor == "target" and skill.arms == 1
        place = first.goal(first.dmp.y0, target)
        if descent and not _overhung(held, place, here, obs, self.world.arms):
            approach = place + np.array([0.0, 0.0, PLACE_DESCENT])
        else:
            descent = False
        if approach is None:
            return CarriedWay(None, None, False)
        if not descent and first.anchor == "target":  # never down to a start below the place
            approach = np.array([approach[0], approach[1], max(float(approach[2]), float(place[2]))])
        return CarriedWay(approach, _carry_height(held, here, approach, obs, self.world.arms), descent)

    def _clear_way(self, g: TargetAim, turn: float, way: CarriedWay) -> CarriedWay:
        """The way of an empty-hand primitive that grasps nothing (an open, a close; ``g`` turned by ``turn``
        rad, going first by ``way``) clear of the free objects standing beside its target
        (:func:`_bystanders`; issue 31). The demonstrated way (``way``'s transit, if any, and the skill's
        pieces rolled out, :meth:`_pieces_way`) is kept when the whole arm passes at least
        :data:`BYSTANDER_CLEARANCE` from each of them (:meth:`_gaps`; :data:`HELD_CLEARANCE` farther once
        the hand holds a lid or a handle, whose hinge it follows rather than the plan; :meth:`World.sweep
        <taskcond.execution.world.World.sweep>`: the wrist behind a hand turned to a drawer's handle sweeps
        low over the table in front of it, where the hand itself never goes). Else the hand goes over what
        stands on the way (:func:`_over_height`) to a point on the line of the demonstrated last approach
        (:func:`_rejoins`), turned there as the first piece ends, tilted by the least of :data:`TILTS`
        (:func:`tilted`: the wrist higher) from which the arm keeps that far from all of them on the way
        there and through the whole skill as planned (the pull, the hand backing off the handle; and from
        everything else on the way there: a drawer open above the handle), and the first piece goes on
        straight (:attr:`Aim.detour`). When none keeps that far: the one that keeps farthest among those
        whose approach keeps that far, if the demonstrated approach itself does not (it will hit), or if it
        touches nothing (a plan of the held part alone is too uncertain for less); else the demonstrated
        way is kept."""
        standing = _bystanders(g.target_name, g.obs)
        first = g.skill.segments[0]
        if not standing or g.skill.arms != 1:
            return way
        here, here_q = self.world.ee_pose()
        start, quat, head = here, here_q, (np.zeros((0, 3)), np.zeros((0, 4)))
        if way.approach is not None:
            start, quat = way.approach, start_orientation(first, here_q)
            head = self._transit_way(here, here_q, start, quat, way.over)
        reach = (WAY_SAMPLES + 1) * opened(g.skill)
        pieces = self._pieces_way(g, turn, start, quat, straight=False)
        gaps = {n: self._gaps(head, pieces, reach, (n,), g.obs) for n in standing}
        swept = tuple(
            n for n, (a, held) in gaps.items() if min(a, held - HELD_CLEARANCE) < BYSTANDER_CLEARANCE
        )
        if not swept:
            return way
        end_q = first.orientation(1.0, here_q, turn)
        goal = first.goal(g.target, g.target, turn, g.scale)
        pad = self.config.hand[0] + CARRY_MARGIN
        hits = any(a < BYSTANDER_CLEARANCE for a, _ in gaps.values())
        best, best_gap = way, -math.inf if hits else 0.0
        for tilt in TILTS if _level(end_q) else TILTS[:1]:
            quat = tilted(end_q, tilt)
            for point in _rejoins(first, goal, turn):
                if self.world.reach_error(point) is not None:
                    continue
                over = _over_height(here, point, g.obs, (g.target_name, *self.world.arms), pad) + CARRY_MARGIN
                head = self._transit_way(here, here_q, point, quat, over)
                a, held = self._gaps(
                    head, self._pieces_way(g, turn, point, quat, True, tilt), reach, standing, g.obs
                )
                a = min(a, self.world.sweep(*head, (g.target_name,)))
                gap = min(a, held - HELD_CLEARANCE)
                if a >= BYSTANDER_CLEARANCE and gap > best_gap:
                    best, best_gap = CarriedWay(point, over, False, True, swept, tilt), gap
                if gap >= BYSTANDER_CLEARANCE:
                    return best
        return best

    def _transit_way(
        self, here: np.ndarray, here_q: np.ndarray, goal: np.ndarray, quat: np.ndarray, over: float | None
    ) -> tuple[np.ndarray, np.ndarray]:
        """Every :data:`TRANSIT_EVERY`-th position (m, 3) and orientation (m, 4) xyzw of a transit
        (:meth:`_transit`) from ``here`` turned ``here_q`` to ``goal`` turned ``quat``, at least ``over``
        high."""
        path = self._transit_path(here, goal, over)
        return path[::TRANSIT_EVERY], self._transit_orientations(here_q, quat, len(path))[::TRANSIT_EVERY]

    def _pieces_way(
        self,
        g: TargetAim,
        turn: float,
        start: np.ndarray,
        quat: np.ndarray,
        straight: bool,
        tilt: float = 0.0,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Positions (m, 3) and orientations (m, 4) xyzw of the hand through every piece of ``g``'s skill
        (turned by ``turn`` rad) from ``start`` (3,) m turned ``quat`` (4,) xyzw, :data:`WAY_SAMPLES` per
        piece, each piece from the last one's goal as :meth:`Executor._follow
        <taskcond.execution.executor.Executor._follow>` plans it (:func:`piece_goal`, ``tilt`` rad); with
        ``straight`` the first piece is a straight line holding ``quat`` (:attr:`Aim.detour`)."""
        points, quats, fractions = [], [], np.linspace(0.0, 1.0, WAY_SAMPLES + 1)
        for k, seg in enumerate(g.skill.segments):
            goal = piece_goal(g.skill, k, start, g.target, turn, g.scale, tilt)
            line = straight and k == 0
            dmp = _conditioned(seg, start, goal, straight=line)
            points.append(rollout(dmp, start, goal, n_steps=WAY_SAMPLES).positions[:, :3])
            quats.append(
                np.tile(quat, (len(fractions), 1)) if line else seg.orientation(fractions, quat, turn)
            )
            start, quat = goal, quats[-1][-1]
        return np.concatenate(points), np.concatenate(quats)

    def _gaps(
        self,
        head: tuple[np.ndarray, np.ndarray],
        pieces: tuple[np.ndarray, np.ndarray],
        reach: int,
        names: Sequence[str],
        obs: Observation,
    ) -> tuple[float, float]:
        """Least distances (m) of the arm from the objects ``names`` along a transit ``head`` and the first
        ``reach`` points of a skill's ``pieces`` (:meth:`_pieces_way`; each positions (m, 3) and orientations
        (m, 4) xyzw): the approach (:func:`opened`); and along the rest, where the hand holds a handle or a
        lid and follows its hinge rather than the plan (:data:`HELD_CLEARANCE`); 0.05 for none."""
        approach = np.concatenate([head[0], pieces[0][:reach]]), np.concatenate([head[1], pieces[1][:reach]])
        held = SWEEP_NONE
        if reach < len(pieces[0]):
            held = self._sweep_of(pieces[0][reach:], pieces[1][reach:], names, obs)
        return self._sweep_of(*approach, names, obs), held

    def _sweep_of(
        self, points: np.ndarray, quats: np.ndarray, names: Sequence[str], obs: Observation
    ) -> float:
        """:meth:`World.sweep <taskcond.execution.world.World.sweep>` of the arm along ``points`` (m, 3)
        with ``quats`` (m, 4) xyzw against the perceived objects ``names`` only."""
        ignore = tuple(n for n in obs.boxes if n not in names)
        return self.world.sweep(points, quats, ignore)

    def _turnable(self, target_name: str, obs: Observation) -> bool:
        """Whether a grasp of ``target_name`` may come from another side (:meth:`_turn`): a round object,
        held the same from every side, or one whose perceived box is narrower than the open hand
        (:attr:`~taskcond.execution.config.Hand.opening`) both ways, so that the fingers close on it
        across either side (the toothpaste, the cube)."""
        if target_name in obs.round:
            return True
        if target_name not in obs.boxes:
            return False
        lo, hi = obs.boxes[target_name]
        return bool(np.all(hi[:2] - lo[:2] < self.hand.opening))

    @staticmethod
    def _pregrasp(g: TargetAim, turn: float = 0.0) -> np.ndarray:
        """(3,) m, world frame: the pre-grasp pose of an object-centred grasp (:attr:`Aim.descent`) ``g``:
        straight above the grasp point (the goal of the skill's open piece, turned by ``turn`` rad and its
        offset scaled by ``g.scale``), as high as the demonstration started above the target, and at least
        :data:`PREGRASP_CLEARANCE` above the top of the target's perceived box, so that the fingers pass
        over it on their way there."""
        grasp = g.skill.segments[0].goal(g.target, g.target, turn, g.scale)
        top = float(g.obs.boxes[g.target_name][1][2])
        height = max(float(g.target[2] + g.skill.start_offset[2]), top + PREGRASP_CLEARANCE)
        return np.array([grasp[0], grasp[1], height])

    def _choose(
        self, task: str, obs: Observation, offset: np.ndarray, orientation: np.ndarray
    ) -> tuple[Choice, Skill]:
        """The skills for ``task`` on the objects as perceived in ``obs`` (those demonstrated on the most
        similar objects, :meth:`~taskcond.execution.skills.SkillLibrary.choose`) and of them the one
        demonstrated from nearest the hand's ``offset`` (3,) m and ``orientation`` (4,) xyzw.

        Raises:
            ExecutionError: no skill of the primitive, or it needs more arms than the robot has.
        """
        try:
            choice = self.library.choose(task, perceived_shapes(obs, parse_task(task).objects))
        except SkillError as exc:
            raise ExecutionError(str(exc), FailureKind.NO_SKILL) from None
        skill = self.library.nearest(choice.skills, offset, orientation)
        if skill.arms > len(self.world.arms):
            raise ExecutionError(
                f"skill {skill.task_id} of {task!r} moves {skill.arms} arms; this robot has "
                f"{len(self.world.arms)}",
                FailureKind.NO_SKILL,
            )
        return choice, skill

    def _demo_turn(self, a: TargetAim, grasp: bool) -> float:
        """The turn (rad) of the demonstration ``a`` aims at its target: a target with a perceived heading
        turned by its change since the demonstration (:func:`heading_turn`), whatever the primitive (a
        grasp of the spatula or the cereal box; the release of the spatula, whose hand turned with it; the
        opening of robosuite's door, which robosuite places turned by up to 0.25 rad: its lever, and the way
        the door swings, turn with it); for a ``grasp`` of a round or narrow object (:meth:`_turnable`), a
        free side (:meth:`_turn`); else 0."""
        if a.target_name in a.obs.yaws and a.skill.target_yaw is not None:
            period = a.obs.yaw_periods.get(a.target_name, math.pi)
            return heading_turn(a.obs.yaws[a.target_name] - a.skill.target_yaw, period)
        if grasp and self._turnable(a.target_name, a.obs):
            return self._turn(a)
        return 0.0

    def _far(self, task: str, skill: Skill, offset: np.ndarray) -> bool:
        """Whether the hand, at ``offset`` (3,) m from the target, is farther than
        :attr:`ExecutionConfig.approach_distance` from the start of ``skill`` (the nearest demonstrated
        one): a one-arm skill anchored on its target only."""
        limit = self.config.approach_distance
        if limit is None or skill.arms != 1 or skill.segments[0].anchor != "target":
            return False
        return float(np.linalg.norm(skill.start_offset - offset)) > limit

    def _transit(
        self, goal: np.ndarray, orientation: np.ndarray, gripper: float, over: float | None = None
    ) -> None:
        """Beyond the paper: carry the hand to ``goal`` (3,) m, world frame, before a skill that was
        demonstrated from there, so that its DMP starts where it was learned (a DMP started far from its
        demonstration keeps the demonstrated path's shape and brings it, scaled, into whatever lies
        between), along :meth:`_transit_path`, turning the hand to ``orientation`` (4,) xyzw on the way
        (the demonstration's first; turned there at once, the arm swings the hand off its path) and holding
        the ``gripper`` command; at least ``over`` (m, world z) high on the way across, if given."""
        here, here_q = self.world.ee_pose()
        path = self._transit_path(here, goal, over)
        turns = self._transit_orientations(here_q, orientation, len(path))
        self._tell(path, goal, None, gripper >= 0.5)
        for point, quat in zip(path[1:], turns[1:], strict=True):
            self._step(point, quat, gripper)
        for _ in range(TRANSIT_SETTLE):  # the arm lags its commands: the DMP starts where the hand is
            if float(np.linalg.norm(self.world.ee_pose()[0] - goal)) < TRANSIT_TOLERANCE:
                break
            self._step(goal, orientation, gripper)

    @staticmethod
    def _transit_orientations(start: np.ndarray, end: np.ndarray, n: int) -> np.ndarray:
        """(n, 4) xyzw orientations slerped from ``start`` to ``end`` (each (4,) xyzw) over a transit."""
        slerp = Slerp([0.0, 1.0], Rotation.from_quat([start, end]))
        return slerp(np.linspace(0.0, 1.0, n)).as_quat()

    def _transit_path(self, start: np.ndarray, goal: np.ndarray, over: float | None = None) -> np.ndarray:
        """(m, 3) positions, one per control step, from ``start`` to ``goal`` (each (3,) m): straight up to
        the higher of the two heights (and of ``over``, m), across, and down, at
        :attr:`ExecutionConfig.speed_limit`."""
        top = max(float(start[2]), float(goal[2]), -math.inf if over is None else over)
        points, here = [np.asarray(start, float)], np.asarray(start, float)
        for waypoint in (np.array([*start[:2], top]), np.array([*goal[:2], top]), np.asarray(goal, float)):
            points += self._line(here, waypoint)
            here = waypoint
        return np.array(points)

    def _aside(
        self,
        skill: Skill,
        target_name: str,
        target: np.ndarray,
        obs: Observation,
        relation: Relation = Relation.ABOVE,
    ) -> np.ndarray:
        """Where on top of (``relation`` ABOVE) or in front of (IN_FRONT_OF) ``target_name`` (centre
        ``target`` (3,) m) the carried object goes: the demonstrated spot (the skill's end: the approach's
        goal plus the later pieces' displacements) if the carried object's footprint there (its perceived box,
        carried with the hand) keeps :attr:`ExecutionConfig.clearance` from every other box that reaches above
        its bottom there (not a drawer under the cabinet's top), keeps its ``relation`` to the target as it
        stands now (:func:`_keeps_place`; an opened lid widens its box), and the hand, turned as it holds the
        object now, reaches the skill's goals there (:meth:`World.reach_error`; it sagged 10 cm short of the
        cabinet's far corner and tipped the toothpaste). Else the nearest such spot, in steps of
        :data:`ASIDE_STEP` up to 20 cm in 16 directions, or :meth:`_clearest`'s fallback. On top, a carried
        object whose bottom would end more than :data:`PLACE_ABOVE` below the top of ``target_name``'s box is
        raised to that much above it (a skill demonstrated with another object holds it at another height).
        Returns the goal's shift (3,) m. A demonstrated spot is where the demonstration's scene had room, not
        where a random scene has (issue 31: the cube set down in front of the box onto the bottle that stood
        there knocked it over)."""
        zero = np.zeros(3)
        carried = obs.grasped()
        if carried is None or carried not in obs.boxes or target_name not in obs.boxes:
            return zero
        first = skill.segments[0]
        if first.anchor != "target":
            return zero
        end = first.goal(first.dmp.y0, target)
        for seg in skill.segments[1:]:
            end = seg.goal(end, target)
        here, heading = self.world.ee_pose()
        lo, hi = obs.boxes[carried]
        foot = (lo[:2] - here[:2] + end[:2], hi[:2] - here[:2] + end[:2])
        middle = (obs.centers.get(carried, (lo + hi) / 2)[:2] - here[:2]) + end[:2]
        below = float(obs.boxes[target_name][1][2] - (end[2] - here[2] + lo[2]))
        lift = below + PLACE_ABOVE if below > PLACE_ABOVE and relation is Relation.ABOVE else 0.0
        down = np.array([*(end[:2] - here[:2]), end[2] - here[2] + lift])
        placed = (lo + down, hi + down)
        bottom = float(placed[0][2]) + self.config.clearance
        skip = (target_name, carried, *self.world.ground, *self.world.arms)
        near = {n: (a[:2], b[:2]) for n, (a, b) in obs.boxes.items() if n not in skip and b[2] > bottom}
        others = list(near.values())
        out = (middle - target[:2]) / max(float(np.linalg.norm(middle - target[:2])), 1e-9)
        goals = [first.goal(first.dmp.y0, target), end]

        def reached(shift: np.ndarray) -> bool:  # the hand, as it holds the object now
            return all(self.world.reach_error(q + np.array([*shift, lift]), heading) is None for q in goals)

        def fits(shift: np.ndarray) -> bool:
            kept = _keeps_place(relation, middle, shift, obs.boxes[target_name], out, placed)
            return kept and reached(shift)

        if _gap(foot, others, np.zeros(2)) >= self.config.clearance and fits(np.zeros(2)):
            return np.array([0.0, 0.0, lift])
        free = set(_bystanders(target_name, obs))
        standing = [b for n, b in near.items() if n in free]
        fixed = [b for n, b in near.items() if n not in free]
        return np.array([*self._clearest(foot, standing, fixed, fits), lift])

    def _clearest(
        self,
        foot: tuple[np.ndarray, np.ndarray],
        standing: Sequence[tuple[np.ndarray, np.ndarray]],
        fixed: Sequence[tuple[np.ndarray, np.ndarray]],
        fits: Callable[[np.ndarray], bool],
    ) -> np.ndarray:
        """(2,) m: the horizontal shift of the footprint ``foot`` (lower and upper (2,) m corners) of
        :meth:`_aside`, in steps of :data:`ASIDE_STEP` up to 20 cm in 16 directions, that ``fits`` (the
        carried object keeps its place, the hand's goals are in reach) and keeps
        :attr:`ExecutionConfig.clearance` from the footprints of the free objects ``standing`` there
        (:func:`_bystanders`) and the ``fixed`` rest, the nearest first and of those the farthest from them.
        When none keeps that far and the unshifted foot comes nearer than that to a free object (what it would
        knock over), the one that keeps farthest from those (or reaches least into one, :func:`_gap`) and no
        nearer to the fixed rest than the unshifted foot or the clearance; else zero: a fixed part of the
        scene in the way (an open drawer in front of the cabinet) is not worth leaving the demonstrated spot
        for."""
        zero = np.zeros(2)
        clearest, clearest_gap = zero, _gap(foot, standing, zero)
        if clearest_gap >= self.config.clearance:
            clearest_gap = math.inf
        floor = min(_gap(foot, fixed, zero), self.config.clearance)
        for radius in np.arange(ASIDE_STEP, 0.2 + 1e-9, ASIDE_STEP):
            best, best_gap = None, self.config.clearance
            for shift in radius * np.column_stack([np.cos(ANGLES), np.sin(ANGLES)]):
                free, kept = _gap(foot, standing, shift), _gap(foot, fixed, shift)
                g = min(free, kept)  # from all the others
                if (g < best_gap and free <= clearest_gap) or not fits(shift):
                    continue
                if g >= best_gap:
                    best, best_gap = shift, g
                elif free > clearest_gap and kept >= floor:
                    clearest, clearest_gap = shift, free
            if best is not None:
                return best
        return clearest

    # long: one search over the hand's sides; its two closures share the sampled way
    def _turn(self, g: TargetAim) -> float:
        """The side the grasp ``g`` of the round or narrow object ``g.target_name`` (centre ``g.target``
        (3,) m, :meth:`_turnable`) comes from: the demonstration turned by 0, ±π/2 or π rad about the object's
        vertical axis (a round object is held the same from every side, a narrow one across either). The
        hand's way there is what the skill's pieces with the gripper still open make of it (their DMPs
        rolled out from the hand, or from the demonstrated start when ``far``: :meth:`_far`, or straight
        down from the pre-grasp pose of a ``descent``: :meth:`_pregrasp`), ending at the grasp pose. The
        demonstrated side (0) is kept unless the hand's footprint
        (:attr:`ExecutionConfig.hand`, along the finger axis of the demonstrated orientation,
        turned) reaches into the perceived box of anything standing above the fingertips at the grasp pose,
        or above the housing (``self.hand.housing`` over the fingertips) on the way, by more than
        :attr:`ExecutionConfig.clearance` (an open drawer, a neighbouring bottle, the box's corner passed
        on the way down; a grazed corner is left to Alg. 2 for a skill demonstrated from about here, as
        demonstrations near such neighbours succeed) or at all (``far``: a skill demonstrated in another
        scene), or the arm itself would meet a neighbour on the way (:meth:`World.sweep`, more than
        :data:`SWEEP_TOLERANCE` into it). Then the reachable side that passes clear, then reaches least
        into a box, then keeps the largest gap, wins (the demonstrated one on a tie). A hand housing
        against a neighbour cannot be repaired by Alg. 2's goal shifts, which move the fingers off the wall
        they are to hold. A box round the whole target (:func:`_encloses`: a bin it stands in) is no
        neighbour: every side's footprint lies in it; its walls are :meth:`World.sweep`'s."""
        skill, target_name, target, obs = g.skill, g.target_name, g.target, g.obs
        far, descent = g.far, g.descent
        arms = self.world.arms
        others = [
            (lo, hi)
            for name, (lo, hi) in obs.boxes.items()
            if name not in (target_name, *self.world.ground, *arms)
            and not _encloses((lo, hi), obs.boxes.get(target_name))
        ]
        opened = []
        for seg in skill.segments:
            if seg.gripper >= 0.5:
                break
            opened.append(seg)
        if not opened:
            return 0.0
        half_length, half_width = self.config.hand
        u = np.linspace(-1.0, 1.0, 9)[None, :, None, None] * half_length
        v = np.linspace(-1.0, 1.0, 3)[None, None, :, None] * half_width
        here, here_q = self.world.ee_pose()
        fractions = np.linspace(0.0, 1.0, WAY_SAMPLES + 1)

        def way(turn: float) -> tuple[np.ndarray, np.ndarray]:
            """(m, 3) hand positions to the grasp pose and (m, 4) orientations xyzw on the way."""
            point, quat = (target + turned(skill.start_offset, turn) if far else here), here_q
            if descent:
                point = self._pregrasp(g, turn)
            points, quats = [], []
            if far or descent:
                path = self._transit_path(here, point)
                quat = opened[0].orientation(1.0, here_q, turn)
                points.append(path[::TRANSIT_EVERY])
                quats.append(self._transit_orientations(here_q, quat, len(path))[::TRANSIT_EVERY])
            for seg in opened:
                goal = seg.goal(point, target, turn, g.scale)
                points.append(
                    rollout(
                        _conditioned(seg, point, goal, descent), point, goal, n_steps=WAY_SAMPLES
                    ).positions
                )
                quats.append(seg.orientation(fractions, quat, turn))
                point, quat = goal, quats[-1][-1]
            return np.concatenate(points)[:, :3], np.concatenate(quats)[:, :4]

        def clearance(points: np.ndarray, quats: np.ndarray) -> tuple[bool, float, float]:
            """Of a way (:func:`way`): (the arm passes clear, − deepest reach of a footprint sample into a
            box, least gap): larger is clearer."""
            axes = Rotation.from_quat(quats).apply(self.hand.closing)
            flat = axes[:, :2] / np.maximum(np.linalg.norm(axes[:, :2], axis=1, keepdims=True), 1e-9)
            across = np.column_stack([-flat[:, 1], flat[:, 0]])
            feet = points[:, None, None, :2] + u * flat[:, None, None, :] + v * across[:, None, None, :]
            floor = points[:, 2] + np.where(np.arange(len(points)) == len(points) - 1, 0.0, self.hand.housing)
            depth, gap = 0.0, np.inf
            for lo, hi in others:
                above = hi[2] > floor
                if not above.any():
                    continue
                samples = feet[above].reshape(-1, 2)
                outside = np.maximum(np.maximum(lo[:2] - samples, samples - hi[:2]), 0.0)
                gap = min(gap, float(np.linalg.norm(outside, axis=1).min()))
                inner = np.minimum(samples - lo[:2], hi[:2] - samples).min(axis=1)
                depth = max(depth, float(inner.max(initial=0.0)))
            clear = self.world.sweep(points, quats, (target_name,)) > -SWEEP_TOLERANCE
            return clear, -depth, gap

        best, best_clearance = 0.0, clearance(*way(0.0))
        if best_clearance[0] and -best_clearance[1] <= (0.0 if far or descent else self.config.clearance):
            return 0.0
        for turn in (math.pi / 2, -math.pi / 2, math.pi):
            points, quats = way(turn)
            reachable = all(self.world.reach_error(q) is None for q in points)
            if reachable and (score := clearance(points, quats)) > best_clearance:
                best, best_clearance = turn, score
        return best

    def _step(self, position: np.ndarray, orientation: np.ndarray, gripper: float) -> None:
        """One control step (ControlManipulator) towards the end-effector poses; the command is kept for
        the settle steps."""
        self._last = (position, orientation, gripper)
        reason = self.world.step(position, orientation, gripper)
        if reason is not None:
            raise ExecutionError(f"simulation failed: {reason}", FailureKind.SIMULATION)


def heading_turn(change: float, period: float = math.pi) -> float:
    """The turn (rad, in [−period/2, period/2)) of a grasp's demonstration for an object whose heading
    changed by ``change`` rad since it was demonstrated: the least turn the object looks the same after,
    the change modulo its ``period`` (rad; at most half a turn, as a parallel gripper turned half a turn
    about its approach axis holds the same way, :func:`~taskcond.execution.skills.twin_turn`)."""
    period = min(period, math.pi)
    return float((change + period / 2) % period - period / 2)


SLENDER = 2.0
"""Least ratio of a perceived box's height to its narrower horizontal side of an object that an
object-centred grasp holds lower (:func:`_grip_drop`)."""
GRIP_DEPTH = 0.03
"""Depth (m) below the top of a slender object's perceived box at which its grasp closes at the highest
(:func:`_grip_drop`; the bottle's demonstrated grasp closes 3.3 cm below its top, the Panda hand's housing
:attr:`~taskcond.execution.config.Hand.housing` 4.5 cm above the fingertips)."""
PREGRASP_CLEARANCE = 0.05
"""Least height (m) of the fingertips above the top of the target's perceived box at the pre-grasp pose of
an object-centred grasp (:meth:`Approach._pregrasp`)."""
WAY_SAMPLES = 30
"""Points per open-gripper piece at which :meth:`Approach._turn` checks the hand's footprint."""
BACK_OFF_HEIGHT = 0.15
"""How far (m) the open hand rises before a grasp is tried again (:meth:`Approach._back_off`)."""
BACK_OFF_RELEASE = 10
"""Control steps the hand stays where it missed, open, before it rises."""
SET_DOWN_GAP = 0.01
"""Height (m) above its support at which a held object is let go when Alg. 1 frees the hand
(:meth:`Approach._set_down`)."""
PUT_BACK_MIN = 0.03
"""Distance (m, horizontal) of the hand from where it was once its grasp held an object beyond which the
object is carried back there before a release Alg. 1 raised (:meth:`Approach._put_back`)."""
PUT_BACK_TURN = math.radians(20.0)
"""Turn (rad) of the hand from how it held an object after its grasp beyond which the object is turned back
before a release Alg. 1 raised (:meth:`Approach._put_back`)."""
REGRIPS = 2
"""Times :meth:`Approach._let_go` closes the hand on an object it could not let go of and reopens it."""
REGRIP_TIME = 0.6
"""Most seconds :meth:`Approach._let_go` gives the fingers to let go of an object, and the seconds it
gives them to close on it again."""
UNWIND_LIFT = 0.10
"""How far (m) the open hand rises before a wound arm moves back through its home joints
(:meth:`Approach._unwind`)."""
TRANSIT_SETTLE = 60
"""Most control steps a transit's last command is held for the hand to arrive."""
TRANSIT_TOLERANCE = 0.01
"""Distance (m) from a transit's goal at which the hand has arrived."""
TRANSIT_EVERY = 10
"""Every how many control steps of a transit (:meth:`Approach._transit_path`) :meth:`Approach._turn`
checks the arm's way."""
SWEEP_TOLERANCE = 0.005
"""Penetration (m) of the arm into a neighbour on a grasp's way that :meth:`Approach._turn` lets pass (the
fingertips brush what stands right beside the object)."""

MIRROR_TURN = math.radians(30.0)
"""Least turn (rad) of the hand over a skill without a target for which :meth:`Approach._mirrored` checks
that the arm follows it: a tilt, not a release (each check solves the arm's IK along the way, and resetting
the joints to measure an answer perturbs the simulation)."""
TURN_SAMPLES = 30
"""Points per piece at which :meth:`Approach._mirrored` checks that the arm follows a skill's turn."""
PLACE_DESCENT = 0.05
"""Height (m) above the place from which a carry on top of or in front of a target comes straight down
(:meth:`Approach._carried_way`)."""
CARRIED_OVER = (Relation.ABOVE, Relation.IN_FRONT_OF)
"""The relations a move places its object in that it carries it to over everything on the way and sets it
down straight from above (:meth:`Approach._carried_way`)."""
PLACED = (Relation.ABOVE, Relation.IN_FRONT_OF)
"""The relations a move places its object in whose demonstrated spot :meth:`Approach._aside` clears."""
PLACE_ABOVE = 0.01
"""Height (m) of a carried object's bottom above the top of what it is set on at the end of a move on top
when the demonstrated height would push it more than this into it (:meth:`Approach._aside`)."""


def _gap(
    foot: tuple[np.ndarray, np.ndarray], others: Sequence[tuple[np.ndarray, np.ndarray]], shift: np.ndarray
) -> float:
    """Least horizontal distance (m) from the footprint ``foot`` (lower and upper (2,) m corners) moved by
    ``shift`` (2,) m to any of the ``others``' footprints, negative by how far it reaches into one (the
    least slide out of it); infinite without others."""
    flo, fhi = foot[0] + shift, foot[1] + shift
    return min((_apart(np.maximum(a - fhi, flo - b)) for a, b in others), default=np.inf)


def _apart(outside: np.ndarray) -> float:
    """Distance (m) between two footprints that lie ``outside`` (2,) m of each other along x and y (each
    negative where they overlap along it), negative by the shallower overlap when they overlap both ways."""
    if np.all(outside < 0.0):
        return float(outside.max())
    return float(np.linalg.norm(np.maximum(outside, 0.0)))


ANGLES = np.linspace(0.0, 2 * math.pi, 16, endpoint=False)
"""Directions (rad from world x) in which :meth:`Approach._clearest` looks for a spot beside the
demonstrated one."""
FRONT_MARGIN = 0.02
"""Margin (m) within the greatest gap of :func:`taskcond.relations.in_front_of` at which
:func:`_keeps_place` keeps a spot in front of a target: the object settles and is perceived again once let
go."""
FRONT_THRESHOLDS = dataclasses.replace(THRESHOLDS, front_max_gap=THRESHOLDS.front_max_gap - FRONT_MARGIN)
"""The relation thresholds :func:`_keeps_place` holds a spot in front of a target to."""
ASIDE_STEP = 0.01
"""Step (m) of the distances from the demonstrated spot at which :meth:`Approach._clearest` looks for a
clear spot: the cabinet's top keeps a tall object whole only at its corner nearest the robot, where the
hand still reaches, a few centimetres wide (issue 31: at 2 cm steps the search missed it, and the bottle was
set down at the far, unreachable spot by a hand that sagged 13 cm short, onto the top's front edge)."""


def _keeps_place(
    relation: Relation,
    middle: np.ndarray,
    shift: np.ndarray,
    target: tuple[np.ndarray, np.ndarray],
    out: np.ndarray,
    placed: tuple[np.ndarray, np.ndarray],
) -> bool:
    """Whether a carried object whose centre ends at ``middle + shift`` (each (2,) m, world x-y) still
    stands in ``relation`` to the target whose box is ``target`` (lower and upper (3,) m corners), its own
    box at the unshifted place being ``placed`` (the same): over it (ABOVE), its footprint sticking out of
    the top no farther than at the demonstrated spot (a bowl pulled half over the microwave's front edge
    tips); in front of it (IN_FRONT_OF): moved no nearer to it along ``out`` (unit (2,), from the target's
    centre towards the demonstrated spot ``middle``, the demonstration's front), its centre across that way
    within the target's extent, and in front of it as the goal check tells
    (:func:`taskcond.relations.in_front_of`) with :data:`FRONT_MARGIN` to spare on the gap (issue 31: the
    can moved 8 cm out, clear of the bowl in front of the box, stood 20.4 cm from the box's front once
    let go, past the relation's 20 cm)."""
    point = middle + shift
    lo, hi = target[0][:2], target[1][:2]
    foot = (placed[0][:2], placed[1][:2])
    if relation is Relation.ABOVE:
        inside = bool(np.all(point >= lo) and np.all(point <= hi))
        return inside and _overhang(foot, shift, (lo, hi)) <= _overhang(foot, np.zeros(2), (lo, hi)) + 1e-3
    across = np.array([-out[1], out[0]])
    corners = np.array([[lo[0], lo[1]], [lo[0], hi[1]], [hi[0], lo[1]], [hi[0], hi[1]]]) @ across
    if float(shift @ out) < 0.0 or not corners.min() <= float(point @ across) <= corners.max():
        return False
    moved = np.array([*shift, 0.0])
    return in_front_of(Box.of(placed[0] + moved, placed[1] + moved), Box.of(*target), FRONT_THRESHOLDS)


def _overhang(
    foot: tuple[np.ndarray, np.ndarray], shift: np.ndarray, support: tuple[np.ndarray, np.ndarray]
) -> float:
    """How far (m, summed over the four sides) the footprint ``foot`` (lower and upper (2,) m corners)
    moved by ``shift`` (2,) m sticks out of ``support`` (the same)."""
    lo, hi = foot[0] + shift, foot[1] + shift
    return float(np.sum(np.maximum(support[0] - lo, 0.0) + np.maximum(hi - support[1], 0.0)))


def _tall(name: str, obs: Observation) -> bool:
    """Whether ``name``'s perceived box is at least as high as its narrower horizontal side: an object that
    a hand coming in sideways can tip over (the bottle, the mug, the toothpaste, the cube), unlike a flat
    one (the spatula, the cloth), whose demonstrated way in (a finger slid along the table) is kept."""
    if name not in obs.boxes:
        return False
    lo, hi = obs.boxes[name]
    size = hi - lo
    return bool(size[2] >= min(size[0], size[1]))


def _grip_drop(g: TargetAim, turn: float) -> np.ndarray:
    """(3,) m down by which an object-centred grasp (:attr:`Aim.descent`) ``g`` of a slender object (its
    perceived box at least :data:`SLENDER` times as high as its narrower horizontal side: the toothpaste)
    closes below the demonstrated grasp point (the skill's open piece's goal, turned by ``turn`` rad): no
    higher than :data:`GRIP_DEPTH` below the top of the box and no lower than its centre; zero for another
    object or a grasp point already that low (issue 31: the toothpaste held 1 cm below its top pivoted
    about the fingers during the carry, ~20°, and fell when the hand opened; held nearer its centre of
    mass, the weight's lever about the grip is shorter)."""
    lo, hi = g.obs.boxes[g.target_name]
    size = hi - lo
    if size[2] < SLENDER * min(size[0], size[1]):
        return np.zeros(3)
    grasp = float(g.skill.segments[0].goal(g.target, g.target, turn, g.scale)[2])
    lowest = max(float(hi[2]) - GRIP_DEPTH, float(g.target[2]))
    return np.array([0.0, 0.0, min(0.0, lowest - grasp)])


def _encloses(box: tuple[np.ndarray, np.ndarray], inner: tuple[np.ndarray, np.ndarray] | None) -> bool:
    """Whether ``box`` (lower, upper (3,) m) holds all of ``inner`` (a box, or None) within its sides and
    above its bottom: a container the object stands in."""
    if inner is None:
        return False
    return bool(
        np.all(box[0][:2] <= inner[0][:2]) and np.all(inner[1][:2] <= box[1][:2]) and box[0][2] <= inner[0][2]
    )


def _descends(skill: Skill) -> bool:
    """Whether a grasp ``skill`` can come straight down onto its object (:attr:`Aim.descent`): one arm, and
    one open piece anchored on the target (the way to the grasp point) before the hand closes. A grasp
    whose open way has more pieces (the bowl's: over the rim, then down to it) is replayed as
    demonstrated."""
    first = skill.segments[0]
    return (
        skill.arms == 1
        and first.anchor == "target"
        and first.gripper < 0.5
        and len(skill.segments) > 1
        and skill.segments[1].gripper >= 0.5
    )


def _overhung(held: str, place: np.ndarray, here: np.ndarray, obs: Observation, arms: Sequence[str]) -> bool:
    """Whether a perceived box hangs over the place where the hand, now at ``here`` (3,) m holding
    ``held``, sets it down with the hand at ``place`` (3,) m: its bottom more than :data:`CARRY_MARGIN`
    above the carried object's bottom there and its footprint within :data:`CARRY_MARGIN` of the carried
    object's (an open drawer above the spot in front of the cabinet), so that the object cannot come down
    onto the place from above. What stands on the same floor beside the place (its perceived bottom a
    centimetre higher by perception noise) does not hang over it."""
    lower, upper = obs.boxes[held]
    bottom = float(place[2] - (here[2] - lower[2])) + CARRY_MARGIN
    half = (upper[:2] - lower[:2]) / 2 + CARRY_MARGIN
    return any(
        float(lo[2]) > bottom and np.all(lo[:2] < place[:2] + half) and np.all(hi[:2] > place[:2] - half)
        for name, (lo, hi) in obs.boxes.items()
        if name not in (held, *arms)
    )


def _carry_height(
    held: str, here: np.ndarray, goal: np.ndarray, obs: Observation, arms: Sequence[str]
) -> float:
    """The least height (m, world z) of the hand carrying ``held`` from ``here`` to ``goal`` (each
    (3,) m) over everything whose bounding box the straight way passes near (:func:`_over_height`, within
    half the held object's width and :data:`CARRY_MARGIN`): their highest top plus the height of the hand
    above the held object's bottom plus :data:`CARRY_MARGIN`."""
    lower, upper = obs.boxes[held]
    pad = float(np.max(upper[:2] - lower[:2])) / 2 + CARRY_MARGIN
    return _over_height(here, goal, obs, (held, *arms), pad) + float(here[2] - lower[2]) + CARRY_MARGIN


def _over_height(
    here: np.ndarray, goal: np.ndarray, obs: Observation, skip: Sequence[str], pad: float
) -> float:
    """The highest top (m, world z) of the perceived boxes but ``skip`` that the straight way from ``here``
    to ``goal`` (each (3,) m) passes within ``pad`` (m) of horizontally, except a surface under the whole
    way (the table); 0 when it passes none."""
    way = here[:2] + np.linspace(0.0, 1.0, 25)[:, None] * (goal[:2] - here[:2])
    tops = []
    for name, (lo, hi) in obs.boxes.items():
        near = np.all((way > lo[:2] - pad) & (way < hi[:2] + pad), axis=1)
        under = np.all((way > lo[:2]) & (way < hi[:2]))
        if name not in skip and near.any() and not under:
            tops.append(float(hi[2]))
    return max(tops, default=0.0)


BYSTANDER_CLEARANCE = 0.01
"""Least distance (m) between the arm and a free object standing beside the target (:func:`_bystanders`)
on the way of an empty-hand primitive that grasps nothing, below which the hand goes another way
(:meth:`Approach._clear_way`): the arm lags its commands, and what it brushes may fall."""
HELD_CLEARANCE = 0.02
"""Room (m) beyond :data:`BYSTANDER_CLEARANCE` that the planned way of a hand holding a handle or a lid keeps
from a free object beside it (:meth:`Approach._clear_way`): the hand follows the hinge, not its plan."""
SWEEP_NONE = 0.05
"""The distance (m) :meth:`Approach._gaps` reports for a part of a way that has no points (at most what
:meth:`World.sweep <taskcond.execution.world.World.sweep>` reports)."""
REJOIN_BACK = (0.12, 0.09, 0.06, 0.18, 0.24)
"""Distances (m) back from the first piece's goal along its demonstrated last approach at which a way clear
of the free objects beside the target may join it (:func:`_rejoins`), in the order tried: the last approach
to a drawer's handle is 12 cm straight in (nearer than 6 cm the open fingers would come down onto the
handle); farther back, the hand comes in under a drawer open above it."""
REJOIN_LAST = 0.03
"""Length (m) of the end of the first piece's demonstrated way whose direction is its last approach."""


TILTS = (0.0, math.pi / 12, math.pi / 6, math.pi / 4)
"""Tilts (rad, least first) of a level hand on a detour (:meth:`Approach._clear_way`, :func:`tilted`)."""


def _skill_end(skill: Skill, here: np.ndarray, target: np.ndarray) -> np.ndarray:
    """(3,) m: where the first hand ends after every piece of ``skill`` aimed at ``target`` (3,) m, started
    from ``here`` (3,) m."""
    end = np.asarray(here, float)
    for segment in skill.segments:
        end = segment.goal(end, target)
    return end


def _turn_angle(skill: Skill) -> float:
    """The largest turn (rad) of the first arm's hand from its orientation at the start of ``skill`` over
    its pieces' demonstrated orientation profiles."""
    quats = np.concatenate([seg.orientations[:, :4] for seg in skill.segments])
    turns = Rotation.from_quat(quats) * Rotation.from_quat(quats[0]).inv()
    return float(np.max(turns.magnitude()))


def _level(quat: np.ndarray) -> bool:
    """Whether the hand turned ``quat`` (4,) xyzw points more sideways than down or up (its own z axis, the
    way its fingers point, within 45° of horizontal): a hand turned to a drawer's handle."""
    axis = Rotation.from_quat(quat).apply([0.0, 0.0, 1.0])
    return bool(np.linalg.norm(axis[:2]) > math.sqrt(0.5))


def tilted(quat: np.ndarray, tilt: float) -> np.ndarray:
    """(4,) xyzw: the hand turned ``quat`` (4,) xyzw pitched by ``tilt`` rad (:func:`_pitch`), its
    fingertips down and its wrist up; ``quat`` itself for no tilt."""
    if tilt == 0.0:
        return np.asarray(quat, float)
    return (_pitch(quat, tilt) * Rotation.from_quat(quat)).as_quat()


def _pitch(quat: np.ndarray, tilt: float) -> Rotation:
    """The turn by ``tilt`` rad about the horizontal axis across the way the fingers of a hand turned
    ``quat`` (4,) xyzw point (its own z axis) that turns them down; none for a hand pointing straight up or
    down."""
    axis = Rotation.from_quat(quat).apply([0.0, 0.0, 1.0])
    across = np.cross([0.0, 0.0, 1.0], axis)
    if tilt == 0.0 or np.linalg.norm(across) < 1e-9:
        return Rotation.identity()
    return Rotation.from_rotvec(tilt * across / np.linalg.norm(across))


def piece_goal(
    skill: Skill,
    k: int,
    start: np.ndarray,
    target: np.ndarray | None,
    turn: float = 0.0,
    scale: np.ndarray | None = None,
    tilt: float = 0.0,
) -> np.ndarray:
    """Goal (3k,) m of the ``k``-th piece of ``skill`` started at ``start`` (3k,) m (:meth:`Segment.goal
    <taskcond.execution.skills.Segment.goal>` with ``target``, ``turn`` and ``scale``); a piece that lets go
    (relative, the hand open after it held something: the hand backing off a handle) of a one-arm skill
    whose hand a detour tilted by ``tilt`` rad (:attr:`Aim.tilt`) backs off along the tilted hand: its
    displacement pitched with the demonstrated hand (:func:`_pitch`)."""
    seg = skill.segments[k]
    goal = seg.goal(start, target, turn, scale)
    held = any(s.gripper >= 0.5 for s in skill.segments[:k])
    if tilt == 0.0 or seg.arms != 1 or seg.anchor != "relative" or seg.gripper >= 0.5 or not held:
        return goal
    pitch = _pitch(seg.orientation(0.0, seg.orientations[0, :4], turn), tilt)
    return np.asarray(start, float) + pitch.apply(goal - np.asarray(start, float))


def opened(skill: Skill) -> int:
    """The number of the skill's first pieces with the gripper open: its approach, before the hand takes
    hold of anything."""
    return next((k for k, seg in enumerate(skill.segments) if seg.gripper >= 0.5), len(skill.segments))


def _bystanders(target: str, obs: Observation) -> list[str]:
    """The free objects but ``target`` that are not flat
    (:attr:`~taskcond.execution.world.Observation.shapes`) and have not fallen: what an arm brushing past
    may knock over (the mug too, wider than high with its handle)."""
    return [n for n in obs.shapes if n != target and n not in obs.lying and obs.shapes[n] != "flat"]


def _rejoins(first: Segment, goal: np.ndarray, turn: float) -> list[np.ndarray]:
    """(3,) m, world frame: the points :data:`REJOIN_BACK` back from ``goal`` (3,) m, the first piece's
    goal, against the direction of its demonstrated last approach (its way's last :data:`REJOIN_LAST`,
    turned by ``turn`` rad); none when the demonstration ends without moving."""
    dmp = first.dmp
    path = rollout(dmp, dmp.y0, dmp.goal, n_steps=200).positions[:, :3]
    back = np.linalg.norm(path - path[-1], axis=1)
    before = np.nonzero(back >= REJOIN_LAST)[0]
    if not len(before):
        return []
    way = turned(path[-1] - path[before[-1]], turn)
    way = way / np.linalg.norm(way)
    return [np.asarray(goal, float) - length * way for length in REJOIN_BACK]


def start_orientation(first: Segment, here: np.ndarray) -> np.ndarray:
    """(4,) xyzw: the orientation the demonstration of ``first`` started in, or its twin half a turn about
    the hand's axis (:func:`~taskcond.execution.skills.twin_turn`), whichever is nearer the hand's
    ``here`` (4,) xyzw: where the transit of an open or close turns the hand (it turns to the handle on the
    way)."""
    start = Rotation.from_quat(first.orientations[0, :4])
    return (start * twin_turn(start, Rotation.from_quat(here))).as_quat()


def _support_below(obj: str, obs: Observation, arms: Sequence[str]) -> float | None:
    """The height (m, world z) of the highest top among the bounding boxes under the middle of ``obj``'s
    footprint (its central half in x and y: a neighbour's box that only overlaps a corner of a round
    object's is beside it, not under it) and below its bottom, or None when nothing is under it or it is
    inside a container's box (:func:`_encloses`), whose floor is no box of its own."""
    lower, upper = obs.boxes[obj]
    middle, half = (lower[:2] + upper[:2]) / 2, (upper[:2] - lower[:2]) / 4
    walls = [b for b in _others(obj, obs, arms) if b[1][2] > lower[2] + SET_DOWN_GAP]
    if any(_encloses(b, (lower, upper)) for b in walls):
        return None  # inside a container (the open top drawer): its floor is not a box of its own
    tops = [
        float(hi[2])
        for name, (lo, hi) in obs.boxes.items()
        if name != obj
        and name not in arms
        and hi[2] <= lower[2] + SET_DOWN_GAP
        and np.all(lo[:2] < middle + half)
        and np.all(hi[:2] > middle - half)
    ]
    return max(tops, default=None)


def _others(obj: str, obs: Observation, arms: Sequence[str]) -> list[tuple[np.ndarray, np.ndarray]]:
    """The perceived boxes (lower, upper (3,) m) of everything but ``obj`` and the ``arms``."""
    return [box for name, box in obs.boxes.items() if name != obj and name not in arms]


def _empty_hand_scale(task: str, skill: Skill, obs: Observation) -> np.ndarray:
    """(3,) factors on the demonstrated offset of an empty-hand primitive (a grasp) borrowed from another
    target object (:func:`~taskcond.execution.skills.offset_scale` of the perceived and the demonstrated
    boxes); ones for its own demonstration and for the other primitives."""
    parsed = parse_task(task)
    role = parsed.primitive.target
    if parsed.primitive.approach is not HandApproach.EMPTY_HAND or role is None or role < 0:
        return np.ones(3)
    target, demo = parsed.objects[role], parse_task(skill.task_name).objects[role]
    if target == demo:
        return np.ones(3)
    return offset_scale(perceived_shapes(obs, (target,)).get(target), skill.shapes.get(demo))


def perceived_shapes(obs: Observation, names: Sequence[str]) -> dict[str, ObjectShape]:
    """The shape class (``fixed`` for what is not a free object) and perceived box size of each of ``names``
    that ``obs`` has a box of: what :meth:`~taskcond.execution.skills.SkillLibrary.choose` compares."""
    return {
        name: ObjectShape(obs.shapes.get(name, "fixed"), tuple(float(v) for v in hi - lo))  # type: ignore[arg-type]
        for name in names
        if name in obs.boxes
        for lo, hi in (obs.boxes[name],)
    }


HOLD_TOLERANCE = 0.01
"""Difference (m) of the hand's height above a carried object's bottom from its demonstration's beyond
which a carry of the demonstrated object itself is shifted by it (:func:`carry_shift`: the toothpaste held
lower, :func:`_grip_drop`); smaller ones are perception noise."""


def carry_shift(task: str, skill: Skill, obs: Observation, hand: np.ndarray) -> np.ndarray:
    """(3,) m by which a carry borrowed from other objects moves its goal (issue 31: the place above the
    target scaled from the perceived boxes): up by how much higher the hand holds the carried object above
    its bottom than the demonstration's hand held its object
    (:attr:`~taskcond.execution.skills.Skill.hold_depth`; ``hand`` (3,) m, the hand now), so that the
    object's bottom arrives at the demonstrated height (for the demonstrated object itself only beyond
    :data:`HOLD_TOLERANCE`: held lower by :func:`_grip_drop`); and for a target of another height than the
    demonstrated one (both standing on the same floor, the goal measured from the centre), up by half the
    difference of heights on top of or into it, down by it in front of it, where the object stays on the
    floor."""
    shift = np.zeros(3)
    parsed, demo = parse_task(task), parse_task(skill.task_name).objects
    primitive, objects = parsed.primitive.id, parsed.objects
    carried, target = objects[0], objects[-1]
    if carried in obs.boxes and skill.hold_depth is not None:
        held = float(hand[2] - obs.boxes[carried][0][2]) - skill.hold_depth
        if carried != demo[0] or abs(held) > HOLD_TOLERANCE:
            shift[2] += held
    shapes = perceived_shapes(obs, (target,))
    theirs = skill.shapes.get(demo[-1])
    if len(objects) == 2 and target != demo[-1] and target in shapes and theirs is not None:
        half = (shapes[target].height - theirs.height) / 2
        shift[2] += -half if primitive == "move_in_front" else half
    return shift
