"""Task conditions grounded in a demonstration (beyond the paper).

To execute a primitive it has never seen, the robot needs a demonstration of it to learn its DMPs (§III-D),
and that demonstration also shows what is true before and after the primitive: the environment information
(§III-A.2) at its start and at its end. :func:`ground` checks an LLM's condition against it:

1. *Contradicted conditions* are corrected or removed. A pre-condition the start contradicts, or a
   post-condition the end contradicts, becomes the state the demonstration shows (``gripper grasping A`` →
   ``gripper not grasping``, ``A open`` → ``A closed``), or the relation the demonstration shows between
   the same two objects when the vocabulary rules the two out together (``A above B`` → ``A below B``). A
   relation between objects that does not hold is contradicted (the environment information lists every
   relation that holds); a post-condition relation becomes the one relation between the same two objects
   (same order) that the demonstration's end shows and its start does not, if there is exactly one (the
   answer named the pair the primitive relates, the demonstration shows how: ``A in front of B`` →
   ``A inside B`` in "move A into B", where ``A in front of B`` was the start's incidental placement);
   otherwise it moves to the other end of the demonstration if it holds there (a pre-condition that is
   only true at the end is what the primitive achieves), else it is removed. A relation of the
   gripper's own place (``gripper inside box``) is only contradicted by a relation that rules it out: where
   the hand paused at the end of one demonstration does not define it, and the executor treats it as soft
   too (no primitive achieves it on its own, Alg. 1 leaves it to the motion). A container state the
   demonstration contradicts is removed rather than corrected when the demonstration leaves that
   container's state unchanged and no relation of the condition puts anything inside it: the primitive
   was done with the opposite state and does not change it, so the state is neither needed nor achieved
   (``box open`` in a "move A in front of box" shown with the box closed throughout).
2. *Missed changes* are added: when the state of the gripper, or of a container among the relevant objects,
   differs between start and end, its start state is a pre-condition and its end state a post-condition.
   *Containers entered* likewise: when a relation of the condition puts something inside a relevant
   container (``A inside B``, ``gripper inside B``), the container's state at the start and at the end
   are a pre- and a post-condition even if unchanged, since reaching inside depends on it (``B open`` in
   "move A into B"; the relation, the LLM's, says the state matters, the demonstration says which it is).
3. *The gripper's state* at the start and at the end is completed when the condition has none: every
   primitive needs to know whether the hand starts free or holding something (Alg. 1 raises a grasp or a
   release for it).
4. *A carried object and its gripper go together*: when a post-condition places the object the gripper
   holds at the end (``A inside B``), the same relation of the gripper (``gripper inside B``) is added
   unless the end rules it out; a post-condition placing the gripper adds the held object's relation when
   the demonstration shows it appear. The gripper's other place by the same object, one the end does not
   show (``gripper in front of B`` beside ``A inside B``), then goes.
5. *Collisions*: the gripper's contacts during the demonstration with a relevant object are allowed.

The LLM's relevant objects and relations decide what matters, the demonstration only decides what is true:
nothing is added about an object outside the relevant objects, and no relation is added that is not the
counterpart of one the LLM gave, so the incidental relations of the paper's FromEnv (``bottle in front of
box`` during ``move bottle into box``) stay out. Every change is a :class:`ConditionRepair` with its reason.

This module knows no simulator: a :class:`DemoEvidence` is the predicate sets an
:class:`~taskcond.sim.perception.EnvironmentInfo` gives at the demonstration's start and end.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any, Literal

from taskcond.conditions import (
    GRIPPER,
    Collision,
    ContainerState,
    GripperState,
    Predicate,
    Relation,
    SpatialRelation,
    TaskCondition,
    about_gripper_place,
    contradictions,
    is_gripper,
    parse_predicate,
    rename_predicate,
)


@dataclass(frozen=True)
class DemoEvidence:
    """What a demonstration shows (§III-A.2): the predicates that held at its start and at its end and the
    pairs of bodies that touched during it.

    Attributes:
        task_name: the demonstrated primitive task, e.g. ``"move bottle into box"``.
        objects: every name the evidence can speak about (the task's objects and the grippers); a predicate
            about anything else is neither confirmed nor contradicted by it.
        start, end: every relation and object state that held, in the condition vocabulary.
        touched: contacts observed during the demonstration.
    """

    task_name: str
    objects: frozenset[str]
    start: frozenset[Predicate]
    end: frozenset[Predicate]
    touched: frozenset[Collision] = frozenset()

    def restricted(self, objects: Iterable[str]) -> DemoEvidence:
        """Only what concerns ``objects``."""
        keep = frozenset(objects) & self.objects

        def about(pred: Predicate) -> bool:
            return all(o in keep for o in pred.objects)

        return DemoEvidence(
            self.task_name,
            keep,
            frozenset(p for p in self.start if about(p)),
            frozenset(p for p in self.end if about(p)),
            frozenset(c for c in self.touched if c.a in keep and c.b in keep),
        )

    def rename(self, mapping: dict[str, str], task_name: str) -> DemoEvidence:
        """The evidence of the same demonstration for other objects (demonstrated object → task object):
        first restricted to the mapped objects and the grippers, so an object of the demonstrated scene that
        shares a name with a task object cannot leak in."""
        grippers = {o for o in self.objects if is_gripper(o)}
        ev = self.restricted({*mapping, *grippers})

        def sub(name: str) -> str:
            return mapping.get(name, name)

        return DemoEvidence(
            task_name,
            frozenset(sub(o) for o in ev.objects),
            frozenset(rename_predicate(p, mapping) for p in ev.start),
            frozenset(rename_predicate(p, mapping) for p in ev.end),
            frozenset(Collision(sub(c.a), sub(c.b)) for c in ev.touched),
        )

    def to_dict(self) -> dict[str, Any]:
        """JSON form: names, predicates and collisions as canonical strings, sorted."""
        return {
            "task_name": self.task_name,
            "objects": sorted(self.objects),
            "start": sorted(str(p) for p in self.start),
            "end": sorted(str(p) for p in self.end),
            "touched": sorted([c.a, c.b] for c in self.touched),
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> DemoEvidence:
        """Inverse of :meth:`to_dict`; raises :class:`~taskcond.conditions.ConditionError` on a bad entry."""
        return cls(
            str(data["task_name"]),
            frozenset(data["objects"]),
            frozenset(parse_predicate(p) for p in data["start"]),
            frozenset(parse_predicate(p) for p in data["end"]),
            frozenset(Collision(a, b) for a, b in data.get("touched", [])),
        )


@dataclass(frozen=True)
class ConditionRepair:
    """One change grounding made to a condition.

    Attributes:
        action: ``removed``, ``corrected`` (``before`` replaced by ``after``, possibly in another list) or
            ``added``.
        where: ``pre``, ``post``, ``collisions`` or ``relevant objects``: the list changed (for a
            correction, the list ``after`` went into).
        before: the LLM's condition, as a string (None when added).
        after: the grounded condition (None when removed).
        reason: what the demonstration showed.
    """

    action: Literal["removed", "corrected", "added"]
    where: str
    before: str | None
    after: str | None
    reason: str

    def __str__(self) -> str:
        if self.action == "removed":
            what = f"removed '{self.before}'"
        elif self.action == "added":
            what = f"added '{self.after}'"
        else:
            what = f"'{self.before}' -> '{self.after}'"
        return f"{self.where}: {what} ({self.reason})"

    def to_dict(self) -> dict[str, Any]:
        return {
            "action": self.action,
            "where": self.where,
            "before": self.before,
            "after": self.after,
            "reason": self.reason,
        }


@dataclass(frozen=True)
class Grounded:
    """A condition after grounding, the condition it came from, and every repair made."""

    condition: TaskCondition
    original: TaskCondition
    repairs: tuple[ConditionRepair, ...] = field(default=())


def _state_of(moment: frozenset[Predicate], thing: str) -> Predicate | None:
    """The gripper or container state of ``thing`` at that moment, or None when it has none."""
    for pred in moment:
        if isinstance(pred, GripperState) and pred.gripper == thing:
            return pred
        if isinstance(pred, ContainerState) and pred.container == thing:
            return pred
    return None


def _rivals(pred: Predicate, moment: frozenset[Predicate]) -> list[Predicate]:
    """The relations of ``moment`` between the same two objects that rule ``pred`` out."""
    return sorted(
        (q for q in moment if set(q.objects) == set(pred.objects) and contradictions([pred, q])), key=str
    )


def _subject(pred: Predicate) -> str | None:
    """The thing whose state a state predicate gives (None for a relation)."""
    if isinstance(pred, GripperState):
        return pred.gripper
    if isinstance(pred, ContainerState):
        return pred.container
    return None


def _made(pred: Predicate, evidence: DemoEvidence) -> list[Predicate]:
    """The relations of ``pred``'s subject to its reference that the demonstration's end shows and its
    start does not: what the demonstrated primitive made of the two objects."""
    if not isinstance(pred, SpatialRelation):
        return []
    return sorted(
        (
            q
            for q in evidence.end - evidence.start
            if isinstance(q, SpatialRelation) and (q.subject, q.reference) == (pred.subject, pred.reference)
        ),
        key=str,
    )


def _entered(*lists: Iterable[Predicate]) -> set[str]:
    """The objects a relation of the lists puts something inside (``A inside B``, ``gripper inside B``):
    containers whose state the condition depends on."""
    return {
        p.reference
        for p in (q for preds in lists for q in preds)
        if isinstance(p, SpatialRelation) and p.relation == Relation.INSIDE and not is_gripper(p.reference)
    }


_MOMENT = {"pre": "start", "post": "end"}


class _Grounding:
    """The working state of one :func:`ground` call: the two lists being repaired and the repairs."""

    def __init__(self, cond: TaskCondition, evidence: DemoEvidence) -> None:
        self.cond = cond
        self.ev = evidence
        self.lists: dict[str, list[Predicate]] = {
            "pre": list(dict.fromkeys(cond.pre_conditions)),
            "post": list(dict.fromkeys(cond.post_conditions)),
        }
        self.relevant = list(cond.relevant_objects)
        self.collisions = list(cond.collisions)
        self.repairs: list[ConditionRepair] = []

    def unchanged(self, thing: str) -> bool:
        """Whether the demonstration shows a state of ``thing`` at both ends, the same one."""
        first = _state_of(self.ev.start, thing)
        return first is not None and first == _state_of(self.ev.end, thing)

    def moment(self, where: str) -> frozenset[Predicate]:
        return self.ev.start if where == "pre" else self.ev.end

    def other(self, where: str) -> str:
        return "post" if where == "pre" else "pre"

    def decides(self, pred: Predicate) -> bool:
        """Whether the evidence speaks about every object of ``pred``."""
        return all(o in self.ev.objects for o in pred.objects)

    def add(self, where: str, pred: Predicate, reason: str) -> None:
        if pred in self.lists[where]:
            return
        self.lists[where].append(pred)
        self.repairs.append(ConditionRepair("added", where, None, str(pred), reason))
        for obj in pred.objects:
            if obj not in self.relevant:
                self.relevant.append(obj)
                self.repairs.append(
                    ConditionRepair("added", "relevant objects", None, obj, f"'{pred}' names it")
                )

    # ------------------------------------------------------------------------------------------ rules
    def contradicted(self) -> None:
        """Rule 1: every pre-condition checked against the start, every post-condition against the end;
        the containers' states last, once the relations that say which containers are entered are."""
        for containers in (False, True):
            for where in ("pre", "post"):
                for pred in list(self.lists[where]):
                    if isinstance(pred, ContainerState) == containers:
                        self._check(where, pred)

    def _check(self, where: str, pred: Predicate) -> None:
        """Rule 1 for one condition of the list ``where``."""
        moment, when = self.moment(where), _MOMENT[where]
        if not self.decides(pred) or pred in moment:
            return
        rival = _rivals(pred, moment)
        if about_gripper_place(pred) and not rival:
            return  # not seen is not contradicted: the hand's place is soft (module doc)
        self.lists[where].remove(pred)
        subject = _subject(pred)
        if subject is not None:
            actual = _state_of(moment, subject)
            if actual is None:
                reason = f"the demonstration shows no open or closed state of {subject}"
                self.repairs.append(ConditionRepair("removed", where, str(pred), None, reason))
            elif (
                isinstance(pred, ContainerState)
                and subject not in _entered(self.lists["pre"], self.lists["post"])
                and self.unchanged(subject)
            ):
                reason = (
                    f"the demonstration shows '{actual}' throughout: nothing goes inside {subject} "
                    "and its state does not change, so the task neither needs nor changes it"
                )
                self.repairs.append(ConditionRepair("removed", where, str(pred), None, reason))
            else:
                self._replace(where, pred, actual, f"the demonstration's {when} shows '{actual}'")
            return
        other = self.other(where)
        made = _made(pred, self.ev) if where == "post" else []
        if rival:
            self._replace(where, pred, rival[0], f"the demonstration's {when} shows '{rival[0]}'")
        elif len(made) == 1:
            reason = f"the demonstration relates the two objects by '{made[0]}' at its end, not its start"
            self._replace(where, pred, made[0], reason)
        elif pred in self.moment(other):
            other_when = _MOMENT[other]
            reason = f"it holds at the demonstration's {other_when}, not its {when}"
            if pred in self.lists[other]:
                self.repairs.append(ConditionRepair("removed", where, str(pred), None, reason))
            else:
                self.lists[other].append(pred)
                self.repairs.append(ConditionRepair("corrected", other, str(pred), str(pred), reason))
        else:
            reason = f"it holds at neither the start nor the end of the demonstration (its {when})"
            self.repairs.append(ConditionRepair("removed", where, str(pred), None, reason))

    def _replace(self, where: str, old: Predicate, new: Predicate, reason: str) -> None:
        if new in self.lists[where]:
            self.repairs.append(ConditionRepair("removed", where, str(old), None, reason))
            return
        self.lists[where].append(new)
        self.repairs.append(ConditionRepair("corrected", where, str(old), str(new), reason))

    def changes(self) -> None:
        """Rules 2 and 3: state changes of the gripper or a relevant container, and the gripper's state."""
        grippers = [o for o in self.relevant if is_gripper(o)]
        things = [*dict.fromkeys([*grippers, GRIPPER]), *(o for o in self.relevant if not is_gripper(o))]
        for thing in things:
            if thing not in self.ev.objects:
                continue
            first, last = _state_of(self.ev.start, thing), _state_of(self.ev.end, thing)
            if first is None or last is None:
                continue
            changed = first != last
            entered = isinstance(first, ContainerState) and thing in _entered(
                self.lists["pre"], self.lists["post"]
            )
            if not changed and thing not in grippers and not entered:
                continue
            for where, state in (("pre", first), ("post", last)):
                if any(_subject(p) == thing for p in self.lists[where]):
                    continue
                when = _MOMENT[where]
                if changed:
                    reason = f"the demonstration changes it: '{first}' at the start, '{last}' at the end"
                elif entered:
                    reason = f"something goes inside {thing}: its state at the demonstration's {when}"
                else:
                    reason = f"the gripper's state at the demonstration's {when}"
                self.add(where, state, reason)

    def carried(self) -> None:
        """Rule 4: a relation of the grasped object and of the gripper holding it go together."""
        for gripper in [o for o in self.relevant if is_gripper(o)]:
            held = next(
                (
                    p.obj
                    for p in self.lists["post"]
                    if isinstance(p, GripperState) and p.gripper == gripper and p.obj
                ),
                None,
            )
            if held is None:
                continue
            for pred in list(self.lists["post"]):
                if pred not in self.lists["post"]:
                    continue  # removed by this rule since
                if not isinstance(pred, SpatialRelation) or pred.subject not in (gripper, held):
                    continue
                partner = held if pred.subject == gripper else gripper
                twin = SpatialRelation(partner, pred.relation, pred.reference)
                if twin.reference == partner or _rivals(twin, self.ev.end):
                    continue
                if partner == gripper:
                    reason = f"{gripper} holds {held}, so it is where {held} is"
                    if pred in self.ev.end:  # the gripper's other, unseen place by the same object goes
                        for q in list(self.lists["post"]):
                            if (
                                isinstance(q, SpatialRelation)
                                and q.subject == gripper
                                and q.reference == pred.reference
                                and q != twin
                                and q not in self.ev.end
                            ):
                                self.lists["post"].remove(q)
                                why = f"{reason} ('{pred}'), not also '{q}' (not seen at the end)"
                                self.repairs.append(ConditionRepair("removed", "post", str(q), None, why))
                elif twin in self.ev.end and twin not in self.ev.start:
                    reason = f"{gripper} holds {held}: the demonstration ends with '{twin}'"
                else:
                    continue
                self.add("post", twin, reason)

    def contacts(self) -> None:
        """Rule 5: the gripper's demonstrated contacts with relevant objects are allowed collisions."""
        relevant = set(self.relevant)
        for touch in sorted(self.ev.touched, key=str):
            if touch in self.collisions or not {touch.a, touch.b} <= relevant:
                continue
            if is_gripper(touch.a) == is_gripper(touch.b):
                continue
            self.collisions.append(touch)
            self.repairs.append(
                ConditionRepair(
                    "added", "collisions", None, str(touch), "they touch during the demonstration"
                )
            )

    def result(self) -> Grounded:
        cond = TaskCondition(
            task_name=self.cond.task_name,
            relevant_objects=tuple(self.relevant),
            pre_conditions=tuple(self.lists["pre"]),
            post_conditions=tuple(self.lists["post"]),
            collisions=tuple(self.collisions),
        )
        return Grounded(cond, self.cond, tuple(self.repairs))


def ground(condition: TaskCondition, evidence: DemoEvidence) -> Grounded:
    """Check ``condition`` against what ``evidence`` (a demonstration of the same task, renamed to the
    condition's objects with :meth:`DemoEvidence.rename`) shows, and repair it (rules in the module doc).

    Only the condition's relevant objects (and the gripper, whose state every primitive needs) are looked at
    in the evidence; the result never names an object the condition does not, bar that gripper.
    """
    scope = {*condition.relevant_objects, *condition.mentioned_objects(), GRIPPER}
    work = _Grounding(condition, evidence.restricted(scope))
    work.contradicted()
    work.changes()
    work.carried()
    work.contacts()
    return work.result()


__all__ = ["ConditionRepair", "DemoEvidence", "Grounded", "ground"]
