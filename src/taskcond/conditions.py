"""Task conditions: the data model of the paper's §III-A.1 and Listing 1.

A task condition describes one primitive task: its name, the objects relevant to it, the pre-conditions
that must hold before it starts, the post-conditions that mark its success, and the collisions it is
allowed to make. Conditions are predicates in a small, closed vocabulary:

* spatial relations between two objects: ``A inside B``, ``A above B``, ``A below B``, ``A in front of B``;
* object states: ``gripper grasping A``, ``gripper not grasping``, ``A open``, ``A closed``.

Every predicate has exactly one canonical string (lower case, single spaces); :func:`parse_predicate` and
``str()`` are inverse to each other on canonical strings. A task condition round-trips exactly through the
paper's text format (:meth:`TaskCondition.to_text` / :meth:`TaskCondition.from_text`) and through the JSON
form (:meth:`TaskCondition.to_json` / :meth:`TaskCondition.from_json`)::

    {"task_name": str, "relevant_objects": [str], "pre_conditions": [str],
     "post_conditions": [str], "collisions": [[str, str]]}
"""

from __future__ import annotations

import json
import re
from collections.abc import Iterable
from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any

GRIPPER = "gripper"
"""Name of the Franka's gripper in conditions (the only one in a single-arm scene)."""
KINOVA_GRIPPER = "kinova gripper"
"""Name of the Kinova's gripper in conditions (the second arm of the dual-arm scene). Any object name that
ends in ``gripper`` is a gripper."""

_NAME_RE = re.compile(r"^[a-z0-9][a-z0-9_\-]*( [a-z0-9_\-]+)*$")
_RESERVED = (" and ", ",", " inside ", " above ", " below ", " in front of ", " grasping ")


class ConditionError(ValueError):
    """A condition string, object name or task-condition text that is not in the vocabulary."""


class Relation(StrEnum):
    """Spatial relations of the paper's vocabulary (§III-A.1)."""

    INSIDE = "inside"
    ABOVE = "above"
    BELOW = "below"
    IN_FRONT_OF = "in front of"


RELATIONS: tuple[str, ...] = tuple(r.value for r in Relation)


def normalize_name(name: str) -> str:
    """Canonical form of an object name: lower case, single spaces, no surrounding whitespace.

    Raises :class:`ConditionError` when the name is empty, has characters other than letters, digits,
    ``_`` and ``-``, or contains a word of the condition vocabulary (``and``, ``inside``, ...).
    """
    canon = " ".join(name.lower().split())
    if not canon:
        raise ConditionError("empty object name")
    if not _NAME_RE.match(canon) or any(word in f" {canon} " for word in _RESERVED):
        raise ConditionError(
            f"invalid object name {name!r}: use letters, digits, '_' or '-' separated by spaces, "
            "without the words 'and', 'inside', 'above', 'below', 'in front of', 'grasping'"
        )
    return canon


def is_gripper(name: str) -> bool:
    """Whether an object name denotes a gripper (``gripper``, ``kinova gripper``, ...)."""
    return name == GRIPPER or name.endswith(" " + GRIPPER)


@dataclass(frozen=True)
class SpatialRelation:
    """``subject relation reference``, e.g. ``bottle inside box``."""

    subject: str
    relation: Relation
    reference: str

    def __str__(self) -> str:
        return f"{self.subject} {self.relation.value} {self.reference}"

    @property
    def objects(self) -> tuple[str, ...]:
        return (self.subject, self.reference)


@dataclass(frozen=True)
class GripperState:
    """``gripper grasping obj`` or, with ``obj=None``, ``gripper not grasping``."""

    obj: str | None
    gripper: str = GRIPPER

    def __str__(self) -> str:
        if self.obj is None:
            return f"{self.gripper} not grasping"
        return f"{self.gripper} grasping {self.obj}"

    @property
    def objects(self) -> tuple[str, ...]:
        return (self.gripper,) if self.obj is None else (self.gripper, self.obj)


@dataclass(frozen=True)
class ContainerState:
    """``container open`` or ``container closed``."""

    container: str
    is_open: bool

    def __str__(self) -> str:
        return f"{self.container} {'open' if self.is_open else 'closed'}"

    @property
    def objects(self) -> tuple[str, ...]:
        return (self.container,)


Predicate = SpatialRelation | GripperState | ContainerState
"""One condition of the vocabulary."""


def rename_predicate(pred: Predicate, mapping: dict[str, str]) -> Predicate:
    """``pred`` with its object names replaced through ``mapping`` (names not in it are kept)."""

    def sub(name: str) -> str:
        return mapping.get(name, name)

    if isinstance(pred, SpatialRelation):
        return SpatialRelation(sub(pred.subject), pred.relation, sub(pred.reference))
    if isinstance(pred, GripperState):
        return GripperState(None if pred.obj is None else sub(pred.obj), sub(pred.gripper))
    return ContainerState(sub(pred.container), pred.is_open)


def is_spatial(pred: Predicate) -> bool:
    """Spatial relations are generated by the first LLM chat, object states by the second (§III-B)."""
    return isinstance(pred, SpatialRelation)


def about_gripper_place(pred: Predicate) -> bool:
    """A spatial relation of a gripper itself (``gripper in front of box``): no primitive achieves it on its
    own (Cond2Task has no entry), the primitive's own motion does; Alg. 1 leaves it to Alg. 2."""
    return isinstance(pred, SpatialRelation) and (is_gripper(pred.subject) or is_gripper(pred.reference))


_CONVERSE: dict[Relation, Relation] = {Relation.ABOVE: Relation.BELOW, Relation.BELOW: Relation.ABOVE}
"""Relation → the relation that states the same fact with the two objects swapped (``A below B`` is ``B above
A``); inside and in front of have none in the vocabulary."""


def converse(pred: Predicate) -> Predicate | None:
    """The same fact stated from the other object (``box below bowl`` → ``bowl above box``), or None when the
    vocabulary has no converse of ``pred`` (a state, inside, in front of)."""
    if not isinstance(pred, SpatialRelation) or pred.relation not in _CONVERSE:
        return None
    return SpatialRelation(pred.reference, _CONVERSE[pred.relation], pred.subject)


_EXCLUDED_BY: dict[Relation, tuple[tuple[bool, Relation], ...]] = {
    Relation.INSIDE: ((True, Relation.INSIDE),),
    Relation.ABOVE: ((True, Relation.ABOVE), (False, Relation.BELOW)),
    Relation.BELOW: ((True, Relation.BELOW), (False, Relation.ABOVE)),
    Relation.IN_FRONT_OF: ((True, Relation.IN_FRONT_OF),),
}
"""Relation → the relations it rules out between the same two objects, as ``(swapped, relation)``: with
``swapped`` the pair reversed (``A inside B`` rules out ``B inside A``), else the same order (``A above B``
rules out ``A below B``)."""


def contradictions(preds: Iterable[Predicate]) -> list[tuple[Predicate, Predicate]]:
    """The pairs of ``preds`` that cannot hold at the same time by the vocabulary's meaning alone (§III-A.1):
    one gripper grasping two things or grasping and not grasping, a container both open and closed, a
    relation with its converse (``A inside B`` and ``B inside A``; likewise above, below, in front of), or
    ``A above B`` with ``A below B``. It knows no primitive: a set of conditions without such a pair may
    still be wrong for its task."""
    items = list(dict.fromkeys(preds))
    found = []
    for i, a in enumerate(items):
        for b in items[i + 1 :]:
            if isinstance(a, GripperState) and isinstance(b, GripperState):
                clash = a.gripper == b.gripper
            elif isinstance(a, ContainerState) and isinstance(b, ContainerState):
                clash = a.container == b.container
            elif isinstance(a, SpatialRelation) and isinstance(b, SpatialRelation):
                clash = any(
                    (b.subject, b.reference) == ((a.reference, a.subject) if swapped else a.objects)
                    and b.relation == relation
                    for swapped, relation in _EXCLUDED_BY[a.relation]
                )
            else:
                clash = False
            if clash:
                found.append((a, b))
    return found


def parse_predicate(text: str) -> Predicate:
    """Parse one condition string (any case and spacing) into a predicate.

    Raises :class:`ConditionError` naming the valid forms when ``text`` is not in the vocabulary.
    """
    canon = " ".join(text.lower().strip().split())
    if canon.endswith(" not grasping"):
        gripper = canon.removesuffix(" not grasping")
        if is_gripper(gripper):
            return GripperState(None, gripper)
    if " grasping " in canon:
        gripper, _, obj = canon.partition(" grasping ")
        if is_gripper(gripper) and obj:
            return GripperState(normalize_name(obj), gripper)
    for relation in (Relation.IN_FRONT_OF, Relation.INSIDE, Relation.ABOVE, Relation.BELOW):
        sep = f" {relation.value} "
        if sep in canon:
            subject, _, reference = canon.partition(sep)
            return SpatialRelation(normalize_name(subject), relation, normalize_name(reference))
    for suffix, is_open in ((" open", True), (" closed", False)):
        if canon.endswith(suffix):
            container = normalize_name(canon.removesuffix(suffix))
            if not is_gripper(container):
                return ContainerState(container, is_open)
    raise ConditionError(
        f"not a condition: {text!r}; valid forms are 'A inside B', 'A above B', 'A below B', "
        "'A in front of B', 'gripper grasping A', 'gripper not grasping', 'A open', 'A closed', "
        "or 'none' alone for an empty list"
    )


@dataclass(frozen=True)
class Collision:
    """An allowed collision between two named bodies; an unordered pair (``a and b`` == ``b and a``)."""

    a: str
    b: str

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Collision):
            return NotImplemented
        return frozenset((self.a, self.b)) == frozenset((other.a, other.b))

    def __hash__(self) -> int:
        return hash(frozenset((self.a, self.b)))

    def __str__(self) -> str:
        return f"{self.a} and {self.b}"

    @classmethod
    def parse(cls, text: str) -> Collision:
        """Parse ``"a and b"``."""
        parts = " ".join(text.lower().split()).split(" and ")
        if len(parts) != 2:
            raise ConditionError(f"not a collision: {text!r}; write it as 'A and B'")
        return cls(normalize_name(parts[0]), normalize_name(parts[1]))


def _unique(items: Iterable[Any]) -> list[Any]:
    seen: list[Any] = []
    for item in items:
        if item not in seen:
            seen.append(item)
    return seen


@dataclass(frozen=True)
class TaskCondition:
    """The task condition of one primitive task (paper §III-A.1, Listing 1).

    Lists keep the order they were written in (for exact round-trips); equality of two conditions in the
    sense of the paper's evaluation is :meth:`matches`, which ignores order and duplicates.
    """

    task_name: str
    relevant_objects: tuple[str, ...] = ()
    pre_conditions: tuple[Predicate, ...] = ()
    post_conditions: tuple[Predicate, ...] = ()
    collisions: tuple[Collision, ...] = field(default=())

    def __post_init__(self) -> None:
        for name in ("relevant_objects", "pre_conditions", "post_conditions", "collisions"):
            object.__setattr__(self, name, tuple(getattr(self, name)))

    # ----------------------------------------------------------------------------------------- queries
    def matches(self, other: TaskCondition) -> bool:
        """True when every field equals ``other``'s as a set (task name excluded)."""
        return (
            set(self.relevant_objects) == set(other.relevant_objects)
            and set(self.pre_conditions) == set(other.pre_conditions)
            and set(self.post_conditions) == set(other.post_conditions)
            and set(self.collisions) == set(other.collisions)
        )

    def mentioned_objects(self) -> set[str]:
        """Every object named in the pre/post-conditions and collisions."""
        names: set[str] = set()
        for pred in (*self.pre_conditions, *self.post_conditions):
            names.update(pred.objects)
        for col in self.collisions:
            names.update((col.a, col.b))
        return names

    def rename(self, mapping: dict[str, str], task_name: str | None = None) -> TaskCondition:
        """The same condition with object names replaced through ``mapping`` (names not in it are kept)."""

        def sub(name: str) -> str:
            return mapping.get(name, name)

        return TaskCondition(
            task_name=self.task_name if task_name is None else task_name,
            relevant_objects=tuple(sub(o) for o in self.relevant_objects),
            pre_conditions=tuple(rename_predicate(p, mapping) for p in self.pre_conditions),
            post_conditions=tuple(rename_predicate(p, mapping) for p in self.post_conditions),
            collisions=tuple(Collision(sub(c.a), sub(c.b)) for c in self.collisions),
        )

    def only(self, spatial: bool) -> TaskCondition:
        """The part one LLM chat generates: spatial relations and collisions, or object states only."""
        return TaskCondition(
            task_name=self.task_name,
            relevant_objects=self.relevant_objects,
            pre_conditions=tuple(p for p in self.pre_conditions if is_spatial(p) == spatial),
            post_conditions=tuple(p for p in self.post_conditions if is_spatial(p) == spatial),
            collisions=self.collisions if spatial else (),
        )

    @staticmethod
    def merge(spatial: TaskCondition, states: TaskCondition) -> TaskCondition:
        """Merge the answers of the two chats (§III-B) into one condition; duplicates are dropped."""
        return TaskCondition(
            task_name=spatial.task_name,
            relevant_objects=tuple(_unique((*spatial.relevant_objects, *states.relevant_objects))),
            pre_conditions=tuple(_unique((*states.pre_conditions, *spatial.pre_conditions))),
            post_conditions=tuple(_unique((*spatial.post_conditions, *states.post_conditions))),
            collisions=tuple(_unique(spatial.collisions)),
        )

    # ------------------------------------------------------------------------------------- text format
    def to_text(self, include_collisions: bool = True) -> str:
        """The paper's Listing 1 format. Empty condition lists are written as a ``none`` line."""
        lines = [f"Task name: {self.task_name}", f"Relevant objects: {', '.join(self.relevant_objects)}"]
        for title, preds in (
            ("Pre-conditions", self.pre_conditions),
            ("Post-conditions", self.post_conditions),
        ):
            lines.append(f"{title}:")
            lines.extend(f"  {p}" for p in preds) if preds else lines.append("  none")
        if include_collisions:
            cols = ", ".join(str(c) for c in self.collisions) if self.collisions else "none"
            lines.append(f"Collisions: {cols}")
        return "\n".join(lines)

    @classmethod
    def from_text(cls, text: str, task_name: str | None = None) -> TaskCondition:
        """Parse the Listing 1 format.

        ``task_name`` supplies the name when the text has no ``Task name:`` line (an LLM answer). A missing
        ``Collisions:`` line means no collisions. Raises :class:`ConditionError` on anything else.
        """
        name = task_name
        objects: list[str] | None = None
        sections: dict[str, list[Predicate]] = {"pre": [], "post": []}
        collisions: list[Collision] = []
        current: str | None = None
        seen_sections: set[str] = set()
        for raw in text.splitlines():
            line = raw.strip()
            if not line:
                continue
            key, sep, value = line.partition(":")
            key = key.strip().lower()
            if sep and key == "task name":
                name = " ".join(value.split())
                current = None
            elif sep and key == "relevant objects":
                objects = [normalize_name(o) for o in value.split(",") if o.strip()]
                current = None
            elif sep and key in ("pre-conditions", "post-conditions"):
                current = key.split("-")[0]
                seen_sections.add(current)
                if value.strip():
                    raise ConditionError(f"put each {key} on its own line below '{key.capitalize()}:'")
            elif sep and key == "collisions":
                current = None
                seen_sections.add("collisions")
                if value.strip().lower() != "none":
                    collisions.extend(Collision.parse(c) for c in value.split(",") if c.strip())
            elif current is not None:
                if line.lower() != "none":
                    sections[current].append(parse_predicate(line.lstrip("-* ")))
            else:
                raise ConditionError(
                    f"unexpected line {line!r}; expected 'Task name:', 'Relevant objects:', "
                    "'Pre-conditions:', 'Post-conditions:' or 'Collisions:'"
                )
        if not name:
            raise ConditionError("missing 'Task name:' line")
        if objects is None:
            raise ConditionError("missing 'Relevant objects:' line")
        missing = {"pre", "post"} - seen_sections
        if missing:
            raise ConditionError(
                f"missing {' and '.join(sorted(f'{m.capitalize()}-conditions:' for m in missing))}"
            )
        return cls(name, tuple(objects), tuple(sections["pre"]), tuple(sections["post"]), tuple(collisions))

    # ------------------------------------------------------------------------------------- JSON format
    def to_dict(self) -> dict[str, Any]:
        """The JSON form with canonical condition strings."""
        return {
            "task_name": self.task_name,
            "relevant_objects": list(self.relevant_objects),
            "pre_conditions": [str(p) for p in self.pre_conditions],
            "post_conditions": [str(p) for p in self.post_conditions],
            "collisions": [[c.a, c.b] for c in self.collisions],
        }

    def to_json(self, indent: int | None = 2) -> str:
        return json.dumps(self.to_dict(), indent=indent)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> TaskCondition:
        """Inverse of :meth:`to_dict`; raises :class:`ConditionError` on a missing or malformed field."""
        try:
            cols = data.get("collisions", [])
            if any(not isinstance(c, list | tuple) or len(c) != 2 for c in cols):
                raise ConditionError("each collision must be a pair [A, B]")
            return cls(
                task_name=str(data["task_name"]),
                relevant_objects=tuple(normalize_name(o) for o in data["relevant_objects"]),
                pre_conditions=tuple(parse_predicate(p) for p in data["pre_conditions"]),
                post_conditions=tuple(parse_predicate(p) for p in data["post_conditions"]),
                collisions=tuple(Collision(normalize_name(a), normalize_name(b)) for a, b in cols),
            )
        except KeyError as exc:
            raise ConditionError(f"task condition JSON is missing the field {exc.args[0]!r}") from None
        except TypeError as exc:
            raise ConditionError(f"malformed task condition JSON: {exc}") from None

    @classmethod
    def from_json(cls, text: str) -> TaskCondition:
        try:
            data = json.loads(text)
        except json.JSONDecodeError as exc:
            raise ConditionError(f"not JSON: {exc}") from None
        if not isinstance(data, dict):
            raise ConditionError("task condition JSON must be an object")
        return cls.from_dict(data)


def parse_examples(text: str) -> list[TaskCondition]:
    """Parse several Listing-1 blocks separated by blank lines (the package's example file)."""
    blocks = re.split(r"\n\s*\n", text.strip())
    return [TaskCondition.from_text(b) for b in blocks if b.strip() and not b.lstrip().startswith("#")]
