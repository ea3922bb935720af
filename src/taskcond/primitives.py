"""The catalogue of the paper's 10 primitive tasks (Table I, PT1–PT10): the single registry of their
identifiers, task-name patterns and the conditions each one achieves.

Everything that names a primitive — the CLI's ``--exclude``, the LLM example selection, Alg. 1's
condition-to-task mapping, the task suite — reads it from :data:`PRIMITIVES`.
"""

from __future__ import annotations

import json
import re
import tomllib
from dataclasses import dataclass
from enum import StrEnum
from pathlib import Path

from taskcond.conditions import (
    ConditionError,
    ContainerState,
    GripperState,
    Predicate,
    Relation,
    is_gripper,
    normalize_name,
)

LETTERS = "ABCDEFGH"
"""Object placeholders used in prompts (§III-B: object names are replaced by letters)."""

_ARTICLES = re.compile(r"\b(the|a|an)\b ")


class TaskNameError(ValueError):
    """A task name that no primitive's pattern matches, with the valid patterns in its message."""


class HandApproach(StrEnum):
    """How the hand comes to a primitive (the executor's approach, :mod:`taskcond.execution.approach`)."""

    EMPTY_HAND = "empty_hand"
    """It starts with an empty hand at its target; a hand far from the demonstrated start is carried there
    first (grasp, open, close)."""
    CARRY = "carry"
    """It carries the object it names: held and far from the demonstrated start, it is carried there first,
    over what lies on the way (the moves)."""
    IN_PLACE = "in_place"
    """It starts where the hand is (release, tilt, fold, and a declared primitive unless it says)."""


@dataclass(frozen=True)
class Primitive:
    """One primitive task of the catalogue.

    Attributes:
        id: identifier used everywhere (CLI, registry, skill library), e.g. ``"move_into"``.
        title: the paper's name (Table I).
        pattern: canonical task name with letter placeholders, e.g. ``"move A into B"``.
        aliases: other phrasings accepted by the parser, same placeholders.
        n_objects: number of objects the task name names.
        target: index of the task object whose centre the approach aims at (Alg. 2 line 3), -1 for the
            goal position of ``move A to position``, None when the primitive has no target and replays its
            demonstrated displacement (release, tilt).
        movable: indices of the task objects the primitive carries or pushes (the scene must let them move).
        declared: declared by a user (:func:`register_primitive`) rather than one of the paper's ten.
        approach: how the hand comes to the primitive (:class:`HandApproach`), read by the executor.
        idempotent: repeating it is harmless, because its post-conditions say all it achieves (a grasp, an
            open box): the executor skips it and the planner drops it when they already hold. A move's
            post-conditions (``mug above table``) may hold before it runs while its goal, a place, does not.
    """

    id: str
    title: str
    pattern: str
    aliases: tuple[str, ...] = ()
    n_objects: int = 1
    target: int | None = 0
    movable: tuple[int, ...] = ()
    declared: bool = False
    approach: HandApproach = HandApproach.IN_PLACE
    idempotent: bool = False

    @property
    def verb(self) -> str:
        return self.pattern.split()[0]

    def task_name(self, *objects: str) -> str:
        """The canonical task name for ``objects`` (in pattern order)."""
        if len(objects) != self.n_objects:
            raise TaskNameError(f"{self.id} takes {self.n_objects} object(s), got {len(objects)}: {objects}")
        return _fill(self.pattern, objects)

    def regexes(self) -> list[re.Pattern[str]]:
        out = []
        for pat in (self.pattern, *self.aliases):
            body = re.escape(pat)
            for letter in LETTERS[: self.n_objects]:
                body = re.sub(rf"\b{letter}\b", f"(?P<{letter}>.+?)", body, count=1)
            out.append(re.compile(f"^{body}$"))
        return out


def _fill(pattern: str, objects: tuple[str, ...] | list[str]) -> str:
    out = pattern
    for letter, obj in zip(LETTERS, objects, strict=False):
        out = re.sub(rf"\b{letter}\b", obj, out, count=1)
    return out


PRIMITIVES: dict[str, Primitive] = {
    p.id: p
    for p in (
        Primitive(
            "grasp",
            "Grasp",
            "grasp A",
            ("pick up A", "pick A up", "pick A", "grab A", "hold A up", "hold A"),
            movable=(0,),
            approach=HandApproach.EMPTY_HAND,
            idempotent=True,
        ),
        Primitive(
            "release",
            "Release",
            "release A",
            ("let go of A", "drop A", "put down A", "put A down"),
            target=None,
            movable=(0,),
            idempotent=True,
        ),
        Primitive("open", "Open", "open A", approach=HandApproach.EMPTY_HAND, idempotent=True),
        Primitive(
            "close", "Close", "close A", ("shut A",), approach=HandApproach.EMPTY_HAND, idempotent=True
        ),
        Primitive("tilt", "Tilt", "tilt A", ("pour A",), target=None, movable=(0,)),
        Primitive("fold", "Fold", "fold A"),
        Primitive(
            "move",
            "Move",
            "move A to position",
            (
                "move A to the position",
                "move A to a position",
                "move A to target position",
                "move A to the target position",
                "move A to a target position",
            ),
            target=-1,
            movable=(0,),
            approach=HandApproach.CARRY,
        ),
        Primitive(
            "move_on_top",
            "MoveOnTop",
            "move A on top of B",
            (
                "put A on top of B",
                "place A on top of B",
                "place A onto B",
                "put A onto B",
                "place A on B",
                "put A on B",
                "move A onto B",
            ),
            2,
            target=1,
            movable=(0,),
            approach=HandApproach.CARRY,
        ),
        Primitive(
            "move_into",
            "MoveInTo",
            "move A into B",
            ("put A into B", "place A into B", "put A in B", "place A in B"),
            2,
            target=1,
            movable=(0,),
            approach=HandApproach.CARRY,
        ),
        Primitive(
            "move_in_front",
            "MoveInFront",
            "move A in front of B",
            ("put A in front of B", "place A in front of B"),
            2,
            target=1,
            movable=(0,),
            approach=HandApproach.CARRY,
        ),
    )
}
"""The registry: primitive id → :class:`Primitive`, in the paper's Table I order."""


@dataclass(frozen=True)
class ParsedTask:
    """A task name parsed into its primitive and objects (in pattern order, canonical names)."""

    primitive: Primitive
    objects: tuple[str, ...]

    @property
    def name(self) -> str:
        """Canonical task name, e.g. ``"move coffee mug into top drawer"``."""
        return self.primitive.task_name(*self.objects)

    def letters(self) -> dict[str, str]:
        """Object → letter mapping used in prompts (``{"bottle": "A", "box": "B"}``)."""
        return {obj: LETTERS[i] for i, obj in enumerate(self.objects)}

    @property
    def letter_name(self) -> str:
        """The task name with letters for objects, as shown to the LLM (``"move A into B"``)."""
        return self.primitive.pattern


def _valid_patterns() -> str:
    return "; ".join(p.pattern for p in PRIMITIVES.values())


def _specificity(prim: Primitive, regex: re.Pattern[str]) -> int:
    return len(re.sub(r"\(\?P<\w>\.\+\?\)", "", regex.pattern))


def _patterns() -> list[tuple[Primitive, re.Pattern[str]]]:
    """Every pattern and alias, most specific (longest literal text) first, so that ``put A in front of B``
    is not read as ``put A in B``."""
    return sorted(
        ((p, r) for p in PRIMITIVES.values() for r in p.regexes()), key=lambda pr: -_specificity(*pr)
    )


_PATTERNS = _patterns()


def _parsed(name: str, prim: Primitive, m: re.Match[str]) -> ParsedTask:
    try:
        objects = tuple(normalize_name(m.group(letter)) for letter in LETTERS[: prim.n_objects])
    except ConditionError as exc:
        raise TaskNameError(f"{name!r}: {exc}") from None
    if any(is_gripper(o) for o in objects):
        raise TaskNameError(f"{name!r}: the gripper is not an object a task can act on")
    if len(set(objects)) != len(objects):
        raise TaskNameError(f"{name!r}: the two objects must differ")
    return ParsedTask(prim, objects)


def parse_task(name: str) -> ParsedTask:
    """Parse a task name such as ``"move the coffee mug into the top drawer"``.

    Articles are dropped, case and spacing normalized, multi-word object names kept whole. Raises
    :class:`TaskNameError` with the valid patterns when nothing matches, when the verb is unknown, or when
    the task names the wrong number of objects.
    """
    canon = " ".join(name.lower().replace(".", " ").split())
    canon = _ARTICLES.sub("", canon + " ").strip() if canon else canon
    if not canon:
        raise TaskNameError(f"empty task name; valid patterns: {_valid_patterns()}")
    for prim, regex in _PATTERNS:
        m = regex.match(canon)
        if m is not None:
            return _parsed(name, prim, m)
    verbs = sorted(
        {p.verb for p in PRIMITIVES.values()} | {a.split()[0] for p in PRIMITIVES.values() for a in p.aliases}
    )
    first = canon.split()[0]
    if first not in verbs:
        raise TaskNameError(f"unknown verb {first!r} in {name!r}; valid verbs: {', '.join(verbs)}")
    same_verb = [
        pat for p in PRIMITIVES.values() for pat in (p.pattern, *p.aliases) if pat.split()[0] == first
    ]
    raise TaskNameError(
        f"{name!r} does not match a task pattern (wrong number of objects?); "
        f"patterns for {first!r}: {'; '.join(same_verb)}"
    )


def get_primitive(pid: str) -> Primitive:
    """Look up a primitive by id, with a one-line error listing the valid ids."""
    try:
        return PRIMITIVES[pid]
    except KeyError:
        raise TaskNameError(f"unknown primitive {pid!r}; valid: {', '.join(PRIMITIVES)}") from None


PRIMITIVES_ENV = "TASKCOND_PRIMITIVES"
"""Environment variable naming declaration files of user primitives (several separated by the path
separator, ``:`` on Linux), read by the command line like ``--primitives``."""
_ID_RE = re.compile(r"^[a-z][a-z0-9_]*$")


def register_primitive(
    id: str,
    pattern: str,
    aliases: tuple[str, ...] | list[str] = (),
    title: str | None = None,
    target: str | None = None,
    movable: tuple[str, ...] | list[str] = (),
) -> Primitive:
    """Declare a primitive beyond the paper's ten, so that its task names parse everywhere (conditions,
    skills, execution). Its conditions come from the LLM's generalization (no example of it exists),
    grounded in its demonstration when one is given; its skill from a demonstration (``taskcond learn
    --demo``). Declaring the same primitive again is allowed; changing a declared one or reusing a built-in
    id is not.

    Args:
        id: identifier, lower case letters, digits and ``_`` (``"push_in_front"``).
        pattern: task name with the letters A, B, ... for its objects in order (``"push A in front of B"``);
            it must start with a word and name each letter once.
        aliases: other phrasings with the same letters.
        title: display name (default: the id in CamelCase).
        target: the letter of the object whose centre the demonstrated approach aims at (Alg. 2 line 3);
            None: the skill replays its demonstrated motion from wherever the hand is.
        movable: letters of the objects the primitive moves (checked against the scene before a run).

    Raises:
        TaskNameError: a malformed declaration, or one that clashes with a registered primitive.
    """
    where = f"primitive {id!r}"
    if not _ID_RE.match(id):
        raise TaskNameError(f"{where}: an id is lower case letters, digits and '_', starting with a letter")
    canon = " ".join(pattern.lower().split())
    letters = [w.upper() for w in canon.split() if len(w) == 1 and w.upper() in LETTERS]
    n = len(letters)
    if not n or letters != list(LETTERS[:n]):
        raise TaskNameError(
            f"{where}: pattern {pattern!r} must name its objects A, B, ... once each, in order "
            "(e.g. 'push A in front of B')"
        )
    if canon.split()[0].upper() in LETTERS:
        raise TaskNameError(f"{where}: pattern {pattern!r} must start with a verb, not an object")
    canon = " ".join(w.upper() if w.upper() in LETTERS[:n] and len(w) == 1 else w for w in canon.split())
    alias_list = tuple(" ".join(w.upper() if len(w) == 1 else w for w in a.lower().split()) for a in aliases)
    for alias in alias_list:
        if sorted(w for w in alias.split() if w in LETTERS) != list(LETTERS[:n]):
            raise TaskNameError(f"{where}: alias {alias!r} must name the letters of {canon!r} once each")

    def index(letter: str) -> int:
        if letter.upper() not in LETTERS[:n]:
            raise TaskNameError(f"{where}: {letter!r} is not one of the pattern's letters {letters}")
        return LETTERS.index(letter.upper())

    prim = Primitive(
        id=id,
        title=title or "".join(w.capitalize() for w in id.split("_")),
        pattern=canon,
        aliases=alias_list,
        n_objects=n,
        target=None if target is None else index(target),
        movable=tuple(index(m) for m in movable),
        declared=True,
    )
    old = PRIMITIVES.get(id)
    if old is not None:
        if old == prim:
            return old
        kind = "a built-in primitive" if not old.declared else "declared differently already"
        raise TaskNameError(f"{where} is {kind}; choose another id")
    clash = [
        (p, pat)
        for p in PRIMITIVES.values()
        for pat in (p.pattern, *p.aliases)
        if pat in (canon, *alias_list)
    ]
    if clash:
        raise TaskNameError(f"{where}: {clash[0][1]!r} is already a pattern of {clash[0][0].id!r}")
    PRIMITIVES[id] = prim
    global _PATTERNS
    _PATTERNS = _patterns()
    return prim


def unregister_primitive(id: str) -> None:
    """Forget a declared primitive (the paper's ten cannot be removed)."""
    prim = get_primitive(id)
    if not prim.declared:
        raise TaskNameError(f"{id!r} is a built-in primitive; only declared ones can be removed")
    del PRIMITIVES[id]
    global _PATTERNS
    _PATTERNS = _patterns()


def load_primitives(path: str | Path) -> list[Primitive]:
    """Declare the primitives of a TOML or JSON file (see :func:`register_primitive` for the fields)::

        [[primitive]]                      # JSON: {"primitive": [{...}, ...]}
        id = "push_in_front"
        pattern = "push A in front of B"
        aliases = ["slide A in front of B"]
        target = "A"
        movable = ["A"]

    Raises:
        TaskNameError: an unreadable file or a bad declaration, with the file's name.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
        data = json.loads(text) if path.suffix.lower() == ".json" else tomllib.loads(text)
    except (OSError, ValueError) as exc:
        raise TaskNameError(f"cannot read primitives from {path}: {' '.join(str(exc).split())}") from None
    entries = data.get("primitive") if isinstance(data, dict) else None
    if not isinstance(entries, list) or not entries:
        raise TaskNameError(f"{path}: declare primitives as [[primitive]] tables (JSON: a 'primitive' list)")
    fields = {"id", "pattern", "aliases", "title", "target", "movable"}
    out = []
    for k, entry in enumerate(entries, start=1):
        if not isinstance(entry, dict) or not {"id", "pattern"} <= set(entry):
            raise TaskNameError(f"{path}: primitive {k} needs at least 'id' and 'pattern'")
        unknown = sorted(set(entry) - fields)
        if unknown:
            raise TaskNameError(
                f"{path}: primitive {k} has unknown field(s) {unknown}; valid: {sorted(fields)}"
            )
        try:
            out.append(register_primitive(**entry))
        except TaskNameError as exc:
            raise TaskNameError(f"{path}: {exc}") from None
        except TypeError as exc:
            raise TaskNameError(f"{path}: primitive {k}: {exc}") from None
    return out


def task_for_condition(pred: Predicate, grasped: str | None = None) -> str | None:
    """The primitive task that achieves an unmet condition: Cond2Task of the paper's Alg. 1 (§III-E).

    ``gripper grasping X`` → ``grasp X``; ``gripper not grasping`` → ``release Y`` for the currently
    ``grasped`` object Y; ``X open`` → ``open X``; ``X closed`` → ``close X``; ``A inside B`` → ``move A into
    B``; ``A above B`` → ``move A on top of B``; ``A below B`` → ``move B on top of A``; ``A in front of B`` →
    ``move A in front of B``. Returns ``None`` when no primitive achieves the condition on its own (a
    relation of the gripper itself, or releasing when nothing is grasped).
    """
    if isinstance(pred, GripperState):
        if pred.obj is not None:
            return PRIMITIVES["grasp"].task_name(pred.obj)
        return None if grasped is None else PRIMITIVES["release"].task_name(grasped)
    if isinstance(pred, ContainerState):
        return PRIMITIVES["open" if pred.is_open else "close"].task_name(pred.container)
    if is_gripper(pred.subject) or is_gripper(pred.reference):
        return None
    if pred.relation is Relation.BELOW:
        return PRIMITIVES["move_on_top"].task_name(pred.reference, pred.subject)
    target = {
        Relation.INSIDE: "move_into",
        Relation.ABOVE: "move_on_top",
        Relation.IN_FRONT_OF: "move_in_front",
    }
    return PRIMITIVES[target[pred.relation]].task_name(pred.subject, pred.reference)


__all__ = [
    "LETTERS",
    "PRIMITIVES",
    "PRIMITIVES_ENV",
    "HandApproach",
    "ParsedTask",
    "Primitive",
    "TaskNameError",
    "get_primitive",
    "load_primitives",
    "parse_task",
    "register_primitive",
    "task_for_condition",
    "unregister_primitive",
]
