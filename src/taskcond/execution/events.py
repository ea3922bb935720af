"""What the executor reports: :class:`Event` and the :class:`EventLog` that words each kind of event.

The executor (Alg. 1, Alg. 2) says what happened through one :class:`EventLog` method per kind; the
console lines and the JSON trace of ``taskcond run`` are written here, not in the algorithms.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any

import numpy as np

from taskcond.conditions import Predicate, TaskCondition
from taskcond.execution.failures import FailureKind
from taskcond.execution.skills import Skill
from taskcond.execution.world import Touch
from taskcond.grounding import ConditionRepair
from taskcond.primitives import parse_task


class EventKind(StrEnum):
    """What an :class:`Event` reports."""

    STEP = "step"
    """A top-level primitive starts."""
    REPAIR = "repair"
    """What grounding in a demonstration changed in the LLM's condition (``repairs``: a list of ``{action,
    where, before, after, reason}``)."""
    CONDITION = "condition"
    """The condition a primitive runs with."""
    IGNORED = "ignored"
    """Condition parts that cannot apply here."""
    SKIP = "skip"
    """An idempotent primitive's post-conditions already hold: skipped."""
    RAISE = "raise"
    """Alg. 1 raises a primitive for an unmet pre-condition."""
    COVERED = "covered"
    """Open containers hang over the container a move puts its object into: their being closed is added to
    the move's pre-conditions (``covering``)."""
    BACK_OFF = "back_off"
    """The open hand rises before a grasp is tried again, or lets go of an object that slipped."""
    UNWIND = "unwind"
    """The empty hand rises and the arm, wound far from home, moves back through its home joints before a
    primitive (``lift``, m)."""
    SET_DOWN = "set_down"
    """A held object is lowered onto its support before a release that Alg. 1 raised."""
    PUT_BACK = "put_back"
    """A held object is carried back over the place its grasp took it from, turned back as it was held
    then, before a release that Alg. 1 raised (``held``, ``shift``: (3,) m from where it was,
    ``turn_degrees``)."""
    REGRIP = "regrip"
    """The hand could not let go of the object a release opened it on: it closes on it again and reopens
    (``held``, ``regrip``: the how-manyth time)."""
    PRIMITIVE = "primitive"
    """A primitive's DMPs start."""
    COLLISION = "collision"
    """An unallowed collision, adjusted (Alg. 2)."""
    POST = "post"
    """Post-conditions met."""
    POST_MISSING = "post_missing"
    """Post-conditions missing after an attempt (``final``: the primitive is given up)."""
    FAILURE = "failure"
    """The run stopped (``reason``, ``failure_kind``)."""


@dataclass(frozen=True)
class Event:
    """One thing that happened during execution, for the console and the JSON trace.

    Attributes:
        time: world time, s.
        kind: what it reports.
        task: the primitive task concerned.
        depth: recursion depth (0 = a step of the long-horizon task).
        message: human-readable line.
        data: JSON-ready details.
    """

    time: float
    kind: EventKind
    task: str
    depth: int
    message: str
    data: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {
            "time": round(self.time, 3),
            "kind": self.kind,
            "task": self.task,
            "depth": self.depth,
            "message": self.message,
            **self.data,
        }


TURNED_WHY = "(a neighbour in the way, or the object turned since its demonstration)"
"""Why a primitive's demonstration is turned about its target (:meth:`EventLog.primitive`)."""
MIRRORED = (
    "turning the hand the other way about the demonstrated axis (the arm cannot follow the demonstrated turn "
    "from its joints now)"
)
"""How a primitive's hand turns when its turn is mirrored (:meth:`EventLog.primitive`)."""


class EventLog:
    """The events of one run in order, each also passed to ``on_event`` as it happens.

    Args:
        clock: the world time now, s.
        on_event: called with every :class:`Event`.
    """

    def __init__(self, clock: Callable[[], float], on_event: Callable[[Event], None] | None = None) -> None:
        self.clock = clock
        self.on_event = on_event
        self.events: list[Event] = []

    def emit(
        self, kind: EventKind, task: str, depth: int, message: str, data: dict[str, Any] | None = None
    ) -> None:
        event = Event(self.clock(), kind, task, depth, message, data or {})
        self.events.append(event)
        if self.on_event is not None:
            self.on_event(event)

    def step(self, task: str) -> None:
        self.emit(EventKind.STEP, task, 0, f"step: {task}")

    def repair(self, task: str, depth: int, repairs: Sequence[ConditionRepair]) -> None:
        self.emit(
            EventKind.REPAIR,
            task,
            depth,
            f"{task}: grounded in its demonstration: {'; '.join(map(str, repairs))}",
            {"repairs": [r.to_dict() for r in repairs]},
        )

    def condition(self, task: str, depth: int, source: str, cond: TaskCondition) -> None:
        self.emit(
            EventKind.CONDITION,
            task,
            depth,
            f"condition ({source}): pre [{fmt_items(cond.pre_conditions)}] post "
            f"[{fmt_items(cond.post_conditions)}] collisions [{fmt_items(cond.collisions)}]",
            {"condition": cond.to_dict()},
        )

    def ignored(self, task: str, depth: int, dropped: Sequence[Predicate]) -> None:
        self.emit(
            EventKind.IGNORED,
            task,
            depth,
            f"{task}: ignoring {fmt_items(dropped)} (no such state here)",
            {"ignored": [str(p) for p in dropped]},
        )

    def skip(self, task: str, depth: int) -> None:
        self.emit(EventKind.SKIP, task, depth, f"{task}: post-conditions already hold, skipped")

    def raised(self, task: str, depth: int, pre: Predicate, for_task: str) -> None:
        self.emit(
            EventKind.RAISE,
            task,
            depth,
            f"pre-condition '{pre}' of {for_task!r} unmet: raising {task!r}",
            {"pre_condition": str(pre), "for": for_task},
        )

    def covered(self, task: str, depth: int, container: str, covering: Sequence[Predicate]) -> None:
        self.emit(
            EventKind.COVERED,
            task,
            depth,
            f"{task}: open above {container}'s opening, so also needs {fmt_items(covering)}",
            {"covering": [str(p) for p in covering]},
        )

    def back_off(self, task: str, depth: int, height: float, why: str) -> None:
        self.emit(
            EventKind.BACK_OFF,
            task,
            depth,
            f"{task}: opening the hand and lifting it {height * 100:.0f} cm {why}",
            {"height": height},
        )

    def unwind(self, task: str, depth: int, lift: float) -> None:
        self.emit(
            EventKind.UNWIND,
            task,
            depth,
            f"{task}: the arm is wound (its way misses where from home it reaches): lifting the hand "
            f"{lift * 100:.0f} cm and moving it back through its home joints first",
            {"lift": lift},
        )

    def set_down(self, task: str, depth: int, held: str, drop: float) -> None:
        self.emit(
            EventKind.SET_DOWN,
            task,
            depth,
            f"{task}: setting {held} down {drop * 100:.0f} cm first (before the hand opens)",
            {"held": held, "drop": round(drop, 4)},
        )

    def put_back(self, task: str, depth: int, held: str, shift: np.ndarray, turn: float) -> None:
        self.emit(
            EventKind.PUT_BACK,
            task,
            depth,
            f"{task}: carrying {held} {fmt_vector(shift)} back over where it was picked up, the hand turned "
            f"back {turn:.0f}° to how it held it then (to set it down there)",
            {"held": held, "shift": json_vector(shift), "turn_degrees": round(turn)},
        )

    def regrip(self, task: str, depth: int, held: str, regrip: int) -> None:
        self.emit(
            EventKind.REGRIP,
            task,
            depth,
            f"{task}: the fingers stayed shut on {held}: closing them on it again and reopening ({regrip})",
            {"held": held, "regrip": regrip},
        )

    def primitive(
        self,
        task: str,
        depth: int,
        skill: Skill,
        target_name: str | None,
        target: np.ndarray | None,
        turn: float = 0.0,
        aside: np.ndarray | None = None,
        approach: np.ndarray | None = None,
        choice: str = "",
        scale: np.ndarray | None = None,
        descent: bool = False,
        over: float | None = None,
        swept: Sequence[str] = (),
        tilt: float = 0.0,
        mirror: bool = False,
    ) -> None:
        """``turn``: rad the demonstration is turned about the target's vertical axis (a grasp from
        another side); ``aside``: (3,) m the place was moved from the demonstrated spot; each reported only
        when not 0; ``approach``: (3,) m, world frame, where the hand went first (the demonstrated start),
        or None; ``choice``: why the skill was demonstrated on other objects (empty: on these);
        ``scale``: (3,) factors on its demonstrated offset from the target (reported when not ones);
        ``descent``: ``approach`` is a pre-grasp pose above the grasp point (a grasp) or a pose above the
        place (a carry), from which the hand comes straight down, not the demonstrated start; ``over``: least
        height (m, world z) of the hand carrying its object to ``approach`` over what stands on the way, or
        None; ``swept``: the free objects the demonstrated way would have swept, when the hand went over
        them to ``approach`` on the line of the demonstrated last approach instead
        (:attr:`~taskcond.execution.approach.Aim.detour`); ``tilt``: rad the hand was tilted on it;
        ``mirror``: the hand turns the other way about the demonstrated axis
        (:attr:`~taskcond.execution.approach.Aim.mirror`)."""
        degrees = round(math.degrees(turn))
        way = _approach_note(approach, descent, parse_task(task).primitive.grasps, over, swept, tilt)
        moved = aside is not None and bool(np.any(aside))
        scaled = scale is not None and not np.allclose(scale, 1.0)
        self.emit(
            EventKind.PRIMITIVE,
            task,
            depth,
            f"{task}: skill {skill.task_id} ({len(skill.segments)} DMP pieces)"
            + (f" [{choice}]" if choice else "")
            + (f", offset scaled by {fmt_vector(scale)} to the perceived box" if scaled else "")
            + (f", goal from {target_name} at {fmt_vector(target)}" if target is not None else "")
            + (f", turned {degrees:+d}° about it {TURNED_WHY}" if degrees else "")
            + (f", {fmt_vector(aside)} aside of the demonstrated spot (taken)" if moved else "")
            + (f", {MIRRORED}" if mirror else "")
            + way[0],
            {"skill": skill.task_id, "target": target_name, "target_center": json_vector(target)}
            | ({"demonstration": skill.task_name, "similar": choice} if choice else {})
            | ({"offset_scale": json_vector(scale)} if scaled else {})
            | ({"turn_degrees": degrees} if degrees else {})
            | ({"aside": json_vector(aside)} if moved else {})
            | ({"mirrored": True} if mirror else {})
            | way[1],
        )

    def collision(
        self,
        task: str,
        depth: int,
        touch: Touch,
        back: int,
        shift: np.ndarray,
        goal: np.ndarray,
        below: str | None = None,
    ) -> None:
        """Alg. 2 lines 10–13 done for ``touch``; ``below``: the ground the hand touched below itself, for
        which the goal was moved up (:meth:`~taskcond.execution.executor.Executor._lift`)."""
        data = {
            "collision": [touch.a, touch.b],
            "position": json_vector(touch.position),
            "goal": json_vector(goal),
            "shift": json_vector(shift),
        }
        moved = "moved by"
        if below is not None:
            data["below"] = below
            moved = f"moved up (the hand touched the {below} below it: a sideways goal would not clear it) by"
        self.emit(
            EventKind.COLLISION,
            task,
            depth,
            f"{task}: unallowed collision {touch.a} / {touch.b} at {fmt_vector(touch.position)}: backed up "
            f"{back} points, goal {moved} {fmt_vector(shift)} to {fmt_vector(goal)}",
            data,
        )

    def post(self, task: str, depth: int, missing: Sequence[Predicate]) -> None:
        note = (
            f" (but not {fmt_items(missing)}: kept from the pre-conditions or the gripper's own place, "
            "not tried again)"
            if missing
            else ""
        )
        self.emit(EventKind.POST, task, depth, f"{task}: post-conditions met{note}")

    def retry(self, task: str, depth: int, missing: Sequence[Predicate], attempt: int) -> None:
        self.emit(
            EventKind.POST_MISSING,
            task,
            depth,
            f"{task}: post-conditions not met: {fmt_items(missing)}; trying again",
            {"missing": [str(m) for m in missing], "attempt": attempt},
        )

    def not_retried(
        self,
        task: str,
        depth: int,
        undo: tuple[Predicate, Predicate],
        missing: Sequence[Predicate],
        attempt: int,
    ) -> None:
        self.emit(
            EventKind.POST_MISSING,
            task,
            depth,
            f"{task}: not tried again, its pre-condition '{undo[0]}' would undo '{undo[1]}'",
            {"missing": [str(m) for m in missing], "attempt": attempt, "final": True},
        )

    def gave_up(self, task: str, depth: int, missing: Sequence[Predicate], attempts: int) -> None:
        self.emit(
            EventKind.POST_MISSING,
            task,
            depth,
            f"{task}: post-conditions not met after {attempts} attempt(s): {fmt_items(missing)}; going on",
            {"missing": [str(m) for m in missing], "attempt": attempts, "final": True},
        )

    def failure(self, reason: str, kind: FailureKind) -> None:
        self.emit(EventKind.FAILURE, "", 0, f"stopped: {reason}", {"reason": reason, "failure_kind": kind})


def fmt_items(items: Sequence[Any] | frozenset[Any]) -> str:
    """``a, b, c``, or ``none``."""
    return ", ".join(str(i) for i in items) or "none"


def fmt_vector(v: np.ndarray | None) -> str:
    """``(x, y, z)`` in millimetre precision, or ``-``."""
    return "-" if v is None else "(" + ", ".join(f"{x:.3f}" for x in np.asarray(v)) + ")"


def json_vector(v: np.ndarray | None) -> list[float] | None:
    """``v`` as a JSON list rounded to 0.1 mm, or None."""
    return None if v is None else [round(float(x), 4) for x in v]


__all__ = ["Event", "EventLog", "fmt_items", "fmt_vector", "json_vector"]


def _approach_note(
    approach: np.ndarray | None,
    descent: bool,
    grasp: bool,
    over: float | None,
    swept: Sequence[str] = (),
    tilt: float = 0.0,
) -> tuple[str, dict[str, Any]]:
    """The part of a primitive's event (:meth:`EventLog.primitive`) that says which approach the hand took:
    text for the message and entries for its data (``approach``, ``approach_kind``, ``carried_over``, and
    for a detour ``swept``, ``over`` and ``tilt_degrees``)."""
    if approach is None:
        return "", {}
    if swept:
        text = (
            f", over what stands on the way (its demonstrated way would sweep the arm through "
            f"{fmt_items(swept)}) at z >= {over or 0.0:.3f} m to {fmt_vector(approach)} on its last "
            f"approach, the hand tilted {round(math.degrees(tilt))}°, straight in from there"
        )
        return text, {
            "approach": json_vector(approach),
            "approach_kind": "detour clear of bystanders",
            "swept": list(swept),
            "over": round(float(over or 0.0), 4),
            "tilt_degrees": round(math.degrees(tilt)),
        }
    kind = ("pre-grasp", "pre-grasp pose") if grasp else ("place", "place")
    text = (
        f", straight down from a {kind[1]} above it at {fmt_vector(approach)}"
        if descent
        else f", from its demonstrated start at {fmt_vector(approach)}"
    )
    data: dict[str, Any] = {
        "approach": json_vector(approach),
        "approach_kind": f"{kind[0]} above" if descent else "demonstrated start",
    }
    if over is not None:
        text += f", carried over what stands on the way at z >= {over:.3f} m"
        data["carried_over"] = round(over, 4)
    return text, data
