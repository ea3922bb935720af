"""Look-ahead repair of a plan with the task conditions, and the goal of a plan (beyond the paper).

The paper runs a long-horizon task as the given sequence of primitive tasks and satisfies each one's
pre-conditions only when it is about to run (Alg. 1, §III-E). That looks one step ahead: a plan that needs
the box open while the bottle is held releases the bottle to open the box. :func:`repair` reads the whole
plan before anything moves, with the same conditions the executor will use, and the environment
information of the start (§III-A.2) as the state:

* **regression with frame rules** (:func:`apply`): the state before step *i* is the start state changed by
  the post-conditions of the steps before it. A predicate holds until a post-condition contradicts it
  (:func:`taskcond.conditions.contradictions`), or until a step places its subject anew (a move's
  ``bottle inside box`` ends the bottle's earlier relations as subject);
* **drop** (an idempotent primitive, :attr:`~taskcond.primitives.Primitive.idempotent`): a grasp,
  release, open or close whose own effect (:func:`named_effects`) holds in the start state and no earlier
  step has touched it, and whose other post-conditions hold before
  it (``gripper not grasping`` after an earlier ``close box``), does nothing;
* **undone** (:func:`_undone`): an open or close that a later close or open of the same container undoes
  before any step between them needs it does nothing either ("close everything" planned by a small model
  as ``open top drawer``, ..., ``close top drawer``);
* **flaws**: a pre-condition of a step that does not hold in the state before it (relations of the gripper
  itself excluded: the primitive's own motion achieves them, as in Alg. 1), the vocabulary's implied ones
  included (``move A on top of B`` on a container B that can be closed needs ``B closed``:
  :meth:`_Model._implied`);
* **repair**, one flaw at a time, first flaw first: either *move* a later step that achieves the missing
  predicate, or *insert* the primitive that achieves it (Cond2Task, :func:`taskcond.primitives.
  task_for_condition`), at every position up to the step that needs it. The candidate with the fewest
  flaws wins, then the shorter plan, then the later position (the one Alg. 1 would pick). A flaw no
  candidate reduces is left to Alg. 1 at run time;
* **impossible**: a flaw whose achieving primitive the scene refuses (``move box into bottle``: the box
  cannot be picked up), so that the instruction stops before the arm moves.

Everything here is pure: conditions come from a callable (the executor's condition source), the start
state is a set of :data:`~taskcond.conditions.Predicate`, what the scene affords is the
:meth:`~taskcond.execution.world.World.affords` callable. No simulator.

:func:`goal_of` composes the effects of a plan into goal predicates: each step's post-conditions that
Cond2Task maps back to that step (its own effect, in the condition vocabulary), later steps replacing
earlier ones on the same subject, and the gripper's state only from the last step when that step is a
grasp or a release (the instruction then says what the hand holds at the end), or, when nothing else would
be checked, as the plan leaves it (grasp and tilt: the vocabulary cannot state the tilt's angle, so the
object still held is what there is to check).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Literal

from taskcond.conditions import (
    ContainerState,
    GripperState,
    Predicate,
    Relation,
    SpatialRelation,
    TaskCondition,
    about_gripper_place,
    contradictions,
)
from taskcond.primitives import TaskNameError, achiever, parse_task, task_for_condition

Conditions = Callable[[str], TaskCondition]
"""Task name → its task condition (the executor's condition source)."""
Affords = Callable[[str, tuple[str, ...]], str | None]
"""Primitive id and objects → why the scene refuses them, or None (:meth:`World.affords`)."""

MAX_CHANGES = 8
"""Most insertions and moves one repair makes."""


@dataclass(frozen=True)
class Change:
    """One change of :func:`repair`.

    Attributes:
        kind: ``insert``, ``drop`` or ``move``.
        task: the primitive task concerned.
        position: 1-based position of the task in the repaired plan (``insert``, ``move``) or in the plan
            before the change (``drop``).
        reason: one line.
    """

    kind: Literal["insert", "drop", "move"]
    task: str
    position: int
    reason: str

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)

    def __str__(self) -> str:
        return f"{self.kind} '{self.task}' (step {self.position}): {self.reason}"


@dataclass(frozen=True)
class PlanRepair:
    """What :func:`repair` made of a plan.

    Attributes:
        original: the plan as given.
        steps: the plan to execute.
        changes: the changes, in the order they were made.
        unresolved: flaws left to Alg. 1 (``'box open' for 'move bottle into box'``).
        impossible: why the plan cannot be done at all (nothing should move), or None.
    """

    original: tuple[str, ...]
    steps: tuple[str, ...]
    changes: tuple[Change, ...] = ()
    unresolved: tuple[str, ...] = ()
    impossible: str | None = None

    def to_dict(self) -> dict[str, Any]:
        return {
            "original": list(self.original),
            "steps": list(self.steps),
            "changes": [c.to_dict() for c in self.changes],
            "unresolved": list(self.unresolved),
            "impossible": self.impossible,
        }


# ------------------------------------------------------------------------------------------ the model
def named_effects(task: str) -> tuple[Predicate, ...]:
    """The predicate a primitive task achieves by its name alone, its primitive's declared effect
    (:meth:`~taskcond.primitives.Primitive.effect`, the inverse of Cond2Task): ``grasp X`` → ``gripper
    grasping X``, ``release X`` → ``gripper not grasping``, ``open X`` → ``X open``, ``close X`` → ``X
    closed``, ``move A into B`` → ``A inside B``, ``move A on top of B`` → ``A above B``, ``move A in front of
    B`` → ``A in front of B``; nothing for move to a position, tilt and fold."""
    parsed = parse_task(task)
    effect = parsed.primitive.effect(*parsed.objects)
    return () if effect is None else (effect,)


def achievable(pred: Predicate, affords: Affords) -> bool:
    """The scene affords the primitive that achieves ``pred`` (Cond2Task, :func:`taskcond.primitives.
    achiever`); False when no primitive achieves it."""
    task = achiever(pred)
    return task is not None and affords(task.primitive.id, task.objects) is None


def applicable(pred: Predicate, holds: Callable[[Predicate], bool], affords: Affords | None) -> bool:
    """Whether a condition can apply in this scene: not a container state of an object that has no such
    state here (``cloth closed``: no primitive can achieve it and no observation can show it; the scene
    refuses the primitive that achieves the opposite state), unless it ``holds`` now (an open-top mug is
    ``open``). ``affords`` None accepts everything. The executor and the planner both drop what is not."""
    if not isinstance(pred, ContainerState) or holds(pred) or affords is None:
        return True
    return achievable(ContainerState(pred.container, not pred.is_open), affords)


def effects(task: str, cond: TaskCondition | None) -> tuple[Predicate, ...]:
    """The goal-relevant effects of ``task``: :func:`named_effects` and the post-conditions of ``cond``
    that Cond2Task maps back to ``task`` (``B below A`` for ``move A on top of B``)."""
    own = list(named_effects(task))
    if cond is not None:
        held = parse_task(task).objects[0]
        own += [q for q in cond.post_conditions if q not in own and task_for_condition(q, held) == task]
    return tuple(own)


def _slot(pred: Predicate) -> tuple[str, str]:
    """What a predicate is about, for 'a later step replaces an earlier one': a gripper, a container, or
    the subject of a spatial relation (``B below A`` is about A's place, as ``A above B``)."""
    if isinstance(pred, GripperState):
        return ("gripper", pred.gripper)
    if isinstance(pred, ContainerState):
        return ("container", pred.container)
    subject = pred.reference if pred.relation is Relation.BELOW else pred.subject
    return ("place", subject)


def apply(state: frozenset[Predicate], cond: TaskCondition) -> frozenset[Predicate]:
    """The state after a step with condition ``cond`` (its post-conditions hold), under the frame rule: a
    predicate of ``state`` survives unless a post-condition contradicts it, or it is a spatial relation of
    an object the step places anew (subject of a spatial post-condition that was not a pre-condition)."""
    post = [q for q in cond.post_conditions if not about_gripper_place(q)]
    placed = {
        _slot(q)[1]
        for q in post
        if isinstance(q, SpatialRelation) and q not in cond.pre_conditions and _slot(q)[0] == "place"
    }
    kept = {
        s
        for s in state
        if not (isinstance(s, SpatialRelation) and _slot(s)[1] in placed and s not in post)
        and not any(contradictions((s, q)) for q in post)
    }
    return frozenset(kept | set(post))


def _grasped(state: frozenset[Predicate], gripper: str) -> str | None:
    for pred in state:
        if isinstance(pred, GripperState) and pred.gripper == gripper and pred.obj is not None:
            return pred.obj
    return None


@dataclass(frozen=True)
class _Flaw:
    index: int
    pred: Predicate
    state: frozenset[Predicate]


class _Model:
    """The conditions of a repair, fetched once per task name and reduced to what the scene can show."""

    def __init__(self, conditions: Conditions, start: frozenset[Predicate], affords: Affords | None):
        self._source = conditions
        self._cache: dict[str, TaskCondition] = {}
        self.start = start
        self.affords = affords

    def condition(self, task: str) -> TaskCondition:
        if task not in self._cache:
            cond = self._source(task)
            keep = self._applicable
            pre = tuple(p for p in (*cond.pre_conditions, *self._implied(task)) if keep(p))
            self._cache[task] = dataclasses.replace(
                cond,
                pre_conditions=tuple(dict.fromkeys(pre)),
                post_conditions=tuple(p for p in cond.post_conditions if keep(p)),
            )
        return self._cache[task]

    def _implied(self, task: str) -> tuple[Predicate, ...]:
        """Pre-conditions the vocabulary implies whatever the condition says: ``move A on top of B`` on a
        container B that can be closed needs ``B closed`` (on an open box, ``A above B`` cannot hold: A
        goes inside, and the judge's ``above`` excludes ``inside``)."""
        placed = [e for e in named_effects(task) if isinstance(e, SpatialRelation)]
        if not placed or placed[0].relation is not Relation.ABOVE or self.affords is None:
            return ()
        closed = ContainerState(placed[0].reference, False)
        return (closed,) if achievable(closed, self.affords) else ()

    def _applicable(self, pred: Predicate) -> bool:
        """:func:`applicable` with the start state for what holds."""
        return applicable(pred, self.start.__contains__, self.affords)

    def flaws(self, plan: Sequence[str]) -> list[_Flaw]:
        """Every pre-condition of every step that does not hold in the state before it."""
        state, found = self.start, []
        for i, task in enumerate(plan):
            cond = self.condition(task)
            found += [
                _Flaw(i, p, state)
                for p in dict.fromkeys(cond.pre_conditions)
                if not about_gripper_place(p) and p not in state
            ]
            state = apply(state, cond)
        return found

    def state_before(self, plan: Sequence[str], upto: int) -> frozenset[Predicate]:
        """The state before step ``upto``: the start changed by the steps before it (:func:`apply`)."""
        state = self.start
        for task in plan[:upto]:
            state = apply(state, self.condition(task))
        return state

    def untouched(self, plan: Sequence[str], upto: int) -> frozenset[Predicate]:
        """The start-state predicates that no step before ``upto`` re-achieved or removed."""
        state = self.start
        for task in plan[:upto]:
            cond = self.condition(task)
            state = apply(state, cond) - set(cond.post_conditions)
        return state & self.start


# ---------------------------------------------------------------------------------------------- repair
def repair(
    steps: Sequence[str],
    start: frozenset[Predicate] | set[Predicate],
    conditions: Conditions,
    affords: Affords | None = None,
    max_changes: int = MAX_CHANGES,
) -> PlanRepair:
    """Check ``steps`` against the start state with the task conditions and repair it (module doc).

    Args:
        steps: canonical primitive task names in order.
        start: the predicates that hold at the start (the perceived environment information).
        conditions: task name → task condition; asked for each step and each candidate primitive.
        affords: what the scene refuses; None accepts everything.
        max_changes: most insertions and moves.

    Raises:
        whatever ``conditions`` raises (the caller decides whether to run the plan unrepaired).
    """
    model = _Model(conditions, frozenset(start), affords)
    plan = list(steps)
    changes = _undone(plan, model)
    changes += _drops(plan, model)
    given_up: set[tuple[str, Predicate]] = set()  # by the task that has the flaw: its index moves
    for _ in range(max_changes):
        flaws = [f for f in model.flaws(plan) if (plan[f.index], f.pred) not in given_up]
        if not flaws:
            break
        flaw = flaws[0]
        achiever = _achiever(flaw)
        if achiever is not None and affords is not None:
            parsed = parse_task(achiever)
            refused = affords(parsed.primitive.id, parsed.objects)
            if refused is not None:
                impossible = (
                    f"'{plan[flaw.index]}' needs '{flaw.pred}', and the only primitive that achieves it, "
                    f"'{achiever}', cannot be done here: {refused}"
                )
                return PlanRepair(tuple(steps), tuple(plan), tuple(changes), (), impossible)
        best = _best_fix(plan, flaw, achiever, model)
        if best is None:
            given_up.add((plan[flaw.index], flaw.pred))
            continue
        plan, change = best
        changes.append(change)
    left = [f"'{f.pred}' for '{plan[f.index]}'" for f in model.flaws(plan)]
    return PlanRepair(tuple(steps), tuple(plan), tuple(changes), tuple(left))


def _achiever(flaw: _Flaw) -> str | None:
    """Cond2Task of the missing predicate, in the state before the step that needs it."""
    pred = flaw.pred
    gripper = pred.gripper if isinstance(pred, GripperState) else "gripper"
    try:
        name = task_for_condition(pred, _grasped(flaw.state, gripper))
        return None if name is None else parse_task(name).name
    except TaskNameError:
        return None


def _undone(plan: list[str], model: _Model) -> list[Change]:
    """Remove, in place, each open or close that a later close or open of the same container undoes
    before any step between them needs its effect ("close everything" planned as ``open top drawer``,
    ..., ``close top drawer``)."""
    changes: list[Change] = []
    i = 0
    while i < len(plan):
        parsed = parse_task(plan[i])
        if not parsed.primitive.sets_container:
            i += 1
            continue
        (effect,) = named_effects(plan[i])
        undo = next(
            (
                k
                for k in range(i + 1, len(plan))
                if any(contradictions((effect, q)) for q in named_effects(plan[k]))
            ),
            None,
        )
        if undo is None or any(effect in model.condition(t).pre_conditions for t in plan[i + 1 : undo]):
            i += 1
            continue
        reason = f"'{plan[undo]}' undoes its '{effect}' before any step needs it"
        changes.append(Change("drop", plan[i], i + 1 + len(changes), reason))
        del plan[i]
    return changes


def _drops(plan: list[str], model: _Model) -> list[Change]:
    """Remove, in place, the steps whose effects hold at the start and were not touched before them."""
    changes: list[Change] = []
    i = 0
    while i < len(plan):
        task = plan[i]
        parsed = parse_task(task)
        if not parsed.primitive.idempotent:
            i += 1
            continue
        cond = model.condition(task)
        own = tuple(
            dict.fromkeys(
                (*named_effects(task), *(q for q in cond.post_conditions if not about_gripper_place(q)))
            )
        )
        before = model.state_before(plan, i)
        if all(q in model.untouched(plan, i) for q in named_effects(task)) and all(q in before for q in own):
            changes.append(
                Change("drop", task, i + 1 + len(changes), f"{_join(own)} already hold(s) at the start")
            )
            del plan[i]
            continue
        i += 1
    return changes


def _cost(plan: Sequence[str], model: _Model) -> tuple[int, int]:
    return (len(model.flaws(plan)), len(plan))


def _best_fix(
    plan: list[str], flaw: _Flaw, achiever: str | None, model: _Model
) -> tuple[list[str], Change] | None:
    """The cheapest plan that fixes ``flaw`` by moving a later step that achieves it or inserting its
    achiever, if it has fewer flaws than ``plan`` (or as many, the first one later); else None."""
    i, need = flaw.index, plan[flaw.index]
    candidates: list[tuple[tuple[int, int, int], list[str], Change]] = []
    for k in range(i + 1, len(plan)):
        if flaw.pred not in effects(plan[k], model.condition(plan[k])):
            continue
        rest = plan[:k] + plan[k + 1 :]
        for j in range(i + 1):
            new = [*rest[:j], plan[k], *rest[j:]]
            reason = f"'{need}' needs '{flaw.pred}', which '{plan[k]}' achieves later: moved before it"
            candidates.append(((*_cost(new, model), -j), new, Change("move", plan[k], j + 1, reason)))
    if achiever is not None and achiever != need:
        for j in range(i + 1):
            new = [*plan[:j], achiever, *plan[j:]]
            reason = f"'{need}' needs '{flaw.pred}'; '{achiever}' achieves it"
            if j < i:
                later = model.flaws([*plan[:i], achiever, *plan[i:]])
                blocked = [f.pred for f in later if f.index == i]
                if blocked:
                    reason += (
                        f", before '{plan[j]}' since it needs {_join(blocked)}, which hold(s) only until then"
                    )
            candidates.append(((*_cost(new, model), -j), new, Change("insert", achiever, j + 1, reason)))
    if not candidates:
        return None
    key, new, change = min(candidates, key=lambda c: c[0])
    now = model.flaws(plan)
    after = model.flaws(new)
    if key[0] < len(now) or (key[0] == len(now) and after and after[0].index > i + 1):
        return new, change
    return None


def _sets_hand(task: str) -> bool:
    """``task`` takes an object into the hand or lets it go (a grasp or a release)."""
    prim = parse_task(task).primitive
    return prim.grasps or prim.lets_go


def _join(preds: Sequence[Predicate]) -> str:
    return ", ".join(f"'{p}'" for p in preds)


# ------------------------------------------------------------------------------------------------ goal
def goal_of(steps: Sequence[str], conditions: Conditions | None = None) -> tuple[Predicate, ...]:
    """The goal predicates of a plan (module doc): the composed :func:`effects` of its steps, a later
    step's effect replacing an earlier one about the same gripper, container or object's place; the
    gripper's state only from a final grasp or release, or as the plan leaves it when the goal would be
    empty without it. In first-achieved order."""
    goal: dict[tuple[str, str], Predicate] = {}
    hand: dict[tuple[str, str], Predicate] = {}  # each gripper's state after the last step that set it
    for k, task in enumerate(steps):
        cond = conditions(task) if conditions is not None else None
        last = k == len(steps) - 1
        own: dict[tuple[str, str], Predicate] = {}
        for pred in effects(task, cond):  # the named effect first: it wins over an equivalent one
            own.setdefault(_slot(pred), pred)
        for slot, pred in own.items():
            goal.pop(slot, None)
            if slot[0] == "gripper":
                hand[slot] = pred
            if slot[0] != "gripper" or (last and _sets_hand(task)):
                goal[slot] = pred
    return tuple(goal.values()) or tuple(hand.values())


__all__ = [
    "MAX_CHANGES",
    "Affords",
    "Change",
    "Conditions",
    "PlanRepair",
    "achievable",
    "applicable",
    "apply",
    "effects",
    "goal_of",
    "named_effects",
    "repair",
]
