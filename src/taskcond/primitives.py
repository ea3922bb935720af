"""The catalogue of the paper's 10 primitive tasks (Table I, PT1–PT10): the single registry of their
identifiers, task-name patterns and the conditions each one achieves.

Everything that names a primitive — the CLI's ``--exclude``, the LLM example selection, Alg. 1's
condition-to-task mapping, the task suite — reads it from :data:`PRIMITIVES`.
"""

from __future__ import annotations

import functools
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
    SpatialRelation,
    about_gripper_place,
    converse,
    is_gripper,
    normalize_name,
    parse_predicate,
    rename_predicate,
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
        achieves: the condition it achieves by its name alone, in the vocabulary with the pattern's letters
            (``"A inside B"``, ``"gripper grasping A"``, ``"gripper not grasping"``, ``"A open"``); None
            when the vocabulary cannot state it (a move to a position, tilt, fold). Alg. 1's Cond2Task
            (:func:`achiever`) and the planner's effects (:meth:`effect`) both read it. An effect names
            every letter of the pattern, except ``gripper not grasping``, whose primitive names one object:
            the one the hand lets go.
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
    achieves: str | None = None

    @property
    def verb(self) -> str:
        return self.pattern.split()[0]

    def effect(self, *objects: str) -> Predicate | None:
        """What it achieves (:attr:`achieves`) on ``objects`` (in pattern order): ``move_into`` on (bottle,
        box) → ``bottle inside box``; None without an effect."""
        if self.achieves is None:
            return None
        if len(objects) != self.n_objects:
            raise TaskNameError(f"{self.id} takes {self.n_objects} object(s), got {len(objects)}: {objects}")
        return rename_predicate(_template(self.achieves), dict(zip(_PLACEHOLDERS, objects, strict=False)))

    def binding(self, pred: Predicate) -> dict[str, str] | None:
        """The objects (placeholder letter, lower case → name) for which :meth:`effect` is ``pred``, or None
        when it achieves no such predicate (another kind, relation or state). ``gripper not grasping``
        binds no letter, and any gripper's state matches the template's ``gripper``."""
        if self.achieves is None:
            return None
        return _bind(_template(self.achieves), pred)

    @property
    def grasps(self) -> bool:
        """It takes its object into the hand (its effect is ``gripper grasping A``): the approach turns a
        round object's grasp to a free side and refuses a fallen object, the hand points down on its way
        there, and a missed try backs off before the next."""
        return isinstance(t := self._effect_template, GripperState) and t.obj is not None

    @property
    def lets_go(self) -> bool:
        """It opens the hand on its one object (its effect is ``gripper not grasping``): raised by Alg. 1 it
        sets the object down first, and skipped it still lets go of an object a finger touches."""
        return isinstance(t := self._effect_template, GripperState) and t.obj is None

    @property
    def sets_container(self) -> bool:
        """Its effect is a container's state (open, close)."""
        return isinstance(self._effect_template, ContainerState)

    @property
    def to_position(self) -> bool:
        """It carries its object to a position rather than into a relation with another (the suite's
        ``move A to position``): a carry whose effect places nothing, which leaves the object held."""
        return self.approach is HandApproach.CARRY and self.places is None

    @property
    def places(self) -> Relation | None:
        """The relation its effect puts its first object in with another (``above`` for a move on top of),
        or None."""
        t = self._effect_template
        return t.relation if isinstance(t, SpatialRelation) else None

    @property
    def _effect_template(self) -> Predicate | None:
        return None if self.achieves is None else _template(self.achieves)

    def problems(self) -> list[str]:
        """What is missing or inconsistent in this declaration, one line each (empty when complete): its
        pattern names its objects A, B, ... once each in order; its target and moved objects are among
        them; a carrying approach moves its first object to a target; an empty hand's approach aims at its
        first object; its effect (:attr:`achieves`) is in the vocabulary and names each of its letters and
        no other object (``gripper not grasping`` none, for a primitive of one object: the one let go);
        an idempotent primitive's effect is a hand's or a container's state (a move's post-conditions may
        hold before its place does)."""
        out = []
        letters = [w for w in self.pattern.split() if len(w) == 1 and w in LETTERS]
        if letters != list(LETTERS[: self.n_objects]):
            out.append(
                f"pattern {self.pattern!r} must name its {self.n_objects} object(s) A, B, ... in order"
            )
        if not (self.target is None or self.target == -1 or 0 <= self.target < self.n_objects):
            out.append(f"target {self.target} is not one of its {self.n_objects} object(s)")
        if not all(0 <= m < self.n_objects for m in self.movable):
            out.append(f"movable {self.movable} are not all among its {self.n_objects} object(s)")
        if not isinstance(self.approach, HandApproach) or not isinstance(self.idempotent, bool):
            out.append(f"approach must be one of {[a.value for a in HandApproach]}, idempotent true or false")
        if self.approach is HandApproach.CARRY and (0 not in self.movable or self.target is None):
            out.append("a carrying approach needs its first object movable and a target")
        if self.approach is HandApproach.EMPTY_HAND and self.target != 0:
            out.append("an empty hand's approach aims at its first object (target A)")
        effect = self._effect_problems()
        if not effect and self.idempotent and (self.achieves is None or self.places is not None):
            effect.append("only a primitive whose effect is a hand's or a container's state is idempotent")
        return out + effect

    def _effect_problems(self) -> list[str]:
        """:meth:`problems` of :attr:`achieves` alone."""
        if self.achieves is None:
            return []
        try:
            template = _template(self.achieves)
        except ConditionError as exc:
            return [f"achieves {self.achieves!r}: {exc}"]
        if self.lets_go:
            return [] if self.n_objects == 1 else ["'gripper not grasping' is achieved on one object"]
        names = sorted(n for n in template.objects if not is_gripper(n))
        if names != list(_PLACEHOLDERS[: self.n_objects]):
            letters = ", ".join(LETTERS[: self.n_objects])
            return [f"achieves {self.achieves!r} must name {letters} once each and no other object"]
        return []

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


_PLACEHOLDERS = tuple(letter.lower() for letter in LETTERS)
"""The letters as object names of a parsed effect template (the vocabulary's names are lower case)."""


@functools.cache
def _template(achieves: str) -> Predicate:
    """The predicate of an effect template (:attr:`Primitive.achieves`), its letters lower case."""
    return parse_predicate(achieves)


def _bind(template: Predicate, pred: Predicate) -> dict[str, str] | None:
    """Placeholder → object for which ``template`` renamed is ``pred`` (any gripper), or None."""
    if isinstance(template, GripperState) and isinstance(pred, GripperState):
        if (template.obj is None) != (pred.obj is None):
            return None
        return {} if template.obj is None or pred.obj is None else {template.obj: pred.obj}
    if isinstance(template, ContainerState) and isinstance(pred, ContainerState):
        return {template.container: pred.container} if template.is_open == pred.is_open else None
    if isinstance(template, SpatialRelation) and isinstance(pred, SpatialRelation):
        if template.relation is not pred.relation:
            return None
        return {template.subject: pred.subject, template.reference: pred.reference}
    return None


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
            achieves="gripper grasping A",
        ),
        Primitive(
            "release",
            "Release",
            "release A",
            ("let go of A", "drop A", "put down A", "put A down"),
            target=None,
            movable=(0,),
            idempotent=True,
            achieves="gripper not grasping",
        ),
        Primitive(
            "open",
            "Open",
            "open A",
            (),
            approach=HandApproach.EMPTY_HAND,
            idempotent=True,
            achieves="A open",
        ),
        Primitive(
            "close",
            "Close",
            "close A",
            ("shut A",),
            approach=HandApproach.EMPTY_HAND,
            idempotent=True,
            achieves="A closed",
        ),
        Primitive(
            "tilt",
            "Tilt",
            "tilt A",
            ("pour A", "pour out A", "pour A out", "tilt A out"),
            target=None,
            movable=(0,),
        ),
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
                "stack A on top of B",
                "stack A on B",
                "set A on top of B",
                "set A on B",
                "drop A on top of B",
                "drop A onto B",
                "drop A on B",
            ),
            2,
            target=1,
            movable=(0,),
            approach=HandApproach.CARRY,
            achieves="A above B",
        ),
        Primitive(
            "move_into",
            "MoveInTo",
            "move A into B",
            ("put A into B", "place A into B", "put A in B", "place A in B", "drop A into B", "drop A in B"),
            2,
            target=1,
            movable=(0,),
            approach=HandApproach.CARRY,
            achieves="A inside B",
        ),
        Primitive(
            "move_in_front",
            "MoveInFront",
            "move A in front of B",
            (
                "put A in front of B",
                "place A in front of B",
                "set A down in front of B",
                "drop A in front of B",
            ),
            2,
            target=1,
            movable=(0,),
            approach=HandApproach.CARRY,
            achieves="A in front of B",
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
    achieves: str | None = None,
    approach: str = HandApproach.IN_PLACE,
    idempotent: bool = False,
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
        achieves: the condition it achieves, with its letters (``"A in front of B"``; :attr:`Primitive.
            achieves`): Alg. 1 raises it for that condition when no built-in primitive achieves it, and
            the planner counts it as its effect. None: nothing the vocabulary states.
        approach: how the hand comes to it, a :class:`HandApproach` value (``empty_hand``, ``carry``,
            ``in_place``).
        idempotent: repeating it is harmless (:attr:`Primitive.idempotent`).

    Raises:
        TaskNameError: a malformed or incomplete declaration (:meth:`Primitive.problems`), or one that
            clashes with a registered primitive.
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
        approach=_approach(where, approach),
        idempotent=idempotent,
        achieves=None if achieves is None else " ".join(_letters_upper(w) for w in achieves.split()),
    )
    problems = prim.problems()
    if problems:
        raise TaskNameError(f"{where}: {problems[0]}")
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


def _letters_upper(word: str) -> str:
    return word.upper() if len(word) == 1 and word.upper() in LETTERS else word.lower()


def _approach(where: str, value: str) -> HandApproach:
    try:
        return HandApproach(value)
    except ValueError:
        valid = ", ".join(a.value for a in HandApproach)
        raise TaskNameError(f"{where}: approach {value!r} is not one of {valid}") from None


def unregister_primitive(id: str) -> None:
    """Forget a declared primitive (the paper's ten cannot be removed)."""
    prim = get_primitive(id)
    if not prim.declared:
        raise TaskNameError(f"{id!r} is a built-in primitive; only declared ones can be removed")
    del PRIMITIVES[id]
    global _PATTERNS
    _PATTERNS = _patterns()


@dataclass(frozen=True)
class Declarations:
    """A user's declaration file as read: its ``[[table]]`` entries (each a dict when well formed; the
    caller checks) and the file's bytes (to hash what a result was made with)."""

    entries: list
    raw: bytes


def read_declarations(path: Path, table: str, error: type[Exception]) -> Declarations:
    """The non-empty list of ``[[table]]`` entries of a TOML file (JSON: a ``table`` list) of user
    declarations (primitives here, objects in :mod:`taskcond.sim.objects`), the file read once.

    Raises:
        error: the file cannot be read or parsed, or has no such entries; one line naming the file.
    """
    try:
        raw = path.read_bytes()
        # newlines as Path.read_text translates them
        text = raw.decode("utf-8").replace("\r\n", "\n").replace("\r", "\n")
        data = json.loads(text) if path.suffix.lower() == ".json" else tomllib.loads(text)
    except (OSError, ValueError) as exc:
        raise error(f"cannot read {table}s from {path}: {' '.join(str(exc).split())}") from None
    entries = data.get(table) if isinstance(data, dict) else None
    if not isinstance(entries, list) or not entries:
        article = "an" if table[0] in "aeiou" else "a"
        raise error(f"{path}: declare {table}s as [[{table}]] tables (JSON: {article} '{table}' list)")
    return Declarations(entries, raw)


def load_primitives(path: str | Path) -> list[Primitive]:
    """Declare the primitives of a TOML or JSON file (see :func:`register_primitive` for the fields)::

        [[primitive]]                      # JSON: {"primitive": [{...}, ...]}
        id = "push_in_front"
        pattern = "push A in front of B"
        aliases = ["slide A in front of B"]
        target = "A"
        movable = ["A"]
        achieves = "A in front of B"       # optional: the condition it achieves
        approach = "carry"                 # optional: empty_hand, carry, in_place (default)
        idempotent = false                 # optional

    Raises:
        TaskNameError: an unreadable file or a bad declaration, with the file's name.
    """
    path = Path(path)
    entries = read_declarations(path, "primitive", TaskNameError).entries
    fields = {"id", "pattern", "aliases", "title", "target", "movable", "achieves", "approach", "idempotent"}
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


def achiever(pred: Predicate, grasped: str | None = None) -> ParsedTask | None:
    """The primitive task that achieves an unmet condition: Cond2Task of the paper's Alg. 1 (§III-E), read
    from the primitives' declared effects (:attr:`Primitive.achieves`), the first in catalogue order.

    The predicate's objects fill the effect's letters (``bottle inside box`` → ``move bottle into box``); a
    letter the effect leaves open is the object the hand holds, ``grasped`` (``gripper not grasping`` →
    ``release Y``); a predicate no effect states is tried as its converse (``A below B`` → ``move B on top
    of A``). Returns ``None`` when no primitive achieves the condition on its own (a relation of the gripper
    itself, or releasing when nothing is grasped).
    """
    if about_gripper_place(pred):
        return None
    for stated in (pred, converse(pred)):
        if stated is None:
            continue
        for prim in PRIMITIVES.values():
            binding = prim.binding(stated)
            if binding is None:
                continue
            objects = [binding.get(letter, grasped) for letter in _PLACEHOLDERS[: prim.n_objects]]
            named = tuple(o for o in objects if o is not None)
            return ParsedTask(prim, named) if len(named) == prim.n_objects else None
    return None


def task_for_condition(pred: Predicate, grasped: str | None = None) -> str | None:
    """The name of :func:`achiever`'s task: ``gripper grasping X`` → ``grasp X``; ``gripper not grasping``
    → ``release Y`` for the currently ``grasped`` object Y; ``X open`` → ``open X``; ``X closed`` → ``close
    X``; ``A inside B`` → ``move A into B``; ``A above B`` → ``move A on top of B``; ``A below B`` → ``move
    B on top of A``; ``A in front of B`` → ``move A in front of B``; None when no primitive achieves it."""
    task = achiever(pred, grasped)
    return None if task is None else task.name


__all__ = [
    "LETTERS",
    "PRIMITIVES",
    "PRIMITIVES_ENV",
    "HandApproach",
    "ParsedTask",
    "Primitive",
    "TaskNameError",
    "achiever",
    "get_primitive",
    "load_primitives",
    "parse_task",
    "register_primitive",
    "task_for_condition",
    "unregister_primitive",
]
