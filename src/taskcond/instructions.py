"""The instruction benchmark (``taskcond eval instructions``, beyond the paper): free instructions, each with
the goal predicates that say it was done, in the condition vocabulary (§III-A.1).

The package ships ``data/instructions.toml``; a user's file has the same form::

    version = 1

    [[instruction]]
    id = "bottle-box-close"          # unique; letters, digits, '-' and '_'
    text = "Pick up the bottle, put it into the box and close the box."
    goal = ["bottle inside box", "box closed", "gripper not grasping"]
    tags = ["move_into", "closed-container"]    # optional: what the instruction covers
    note = "..."                     # optional: what the goal cannot say
    wordings = ["Put the bottle in the box, then shut it."]   # optional: other phrasings (below)

An instruction with ``wordings`` is said in one of ``[text, *wordings]`` per episode, the one the episode's
seed picks (:meth:`Instruction.text_for`: seed modulo their number), so that any n consecutive seeds say it
each of its n ways once (the combination benchmark, :mod:`taskcond.combinations`).

Goal predicates are parsed and checked like a task condition's (:func:`taskcond.conditions.
parse_predicate`, no contradicting pair); whether their objects exist in the instruction's scene is checked
where the scene is known (:func:`check_objects`). The decomposition of each instruction comes from the LLM,
as in ``taskcond run``; the shipped goals, judged by the ground truth at the end, are the benchmark's
success criterion.
"""

from __future__ import annotations

import re
import tomllib
from collections.abc import Iterable
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

from taskcond.conditions import ConditionError, Predicate, contradictions, parse_predicate
from taskcond.primitives import PRIMITIVES

FORMAT_VERSION = 1
"""The ``version`` an instructions file declares."""

TAGS = (
    *(pid for pid, primitive in PRIMITIVES.items() if not primitive.declared),  # the ten of Table I
    "closed-container",
    "in-the-way",
    "paraphrase",
    "multi-word",
    "misspelling",
    "dual-arm",
    "novel-object",
)
"""What an instruction may be tagged as covering: a primitive it needs (the ten of Table I), a start that
needs more than the instruction says (a closed container, an object or open drawer in the way), its wording
(paraphrase, multi-word object names, misspellings), the dual-arm scene, an object no demonstration shows."""

_ID = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_\-]*$")
_KEYS = {"id", "text", "goal", "tags", "note", "wordings"}


class InstructionError(ValueError):
    """A malformed instructions file; one line naming the file, the entry and what is valid."""


@dataclass(frozen=True)
class Instruction:
    """One benchmark instruction.

    Attributes:
        id: unique key of the instruction in results files.
        text: the instruction as a user types it.
        goal: the predicates that hold when it is done (ground truth at the end of an episode).
        tags: what it covers (:data:`TAGS`).
        note: what the goal cannot express (a tilt angle, a target position), or empty.
        wordings: other phrasings of the same instruction (same goal); an episode says one of ``text`` and
            these, by its seed (:meth:`text_for`).
    """

    id: str
    text: str
    goal: tuple[Predicate, ...]
    tags: tuple[str, ...] = ()
    note: str = ""
    wordings: tuple[str, ...] = ()

    @property
    def texts(self) -> tuple[str, ...]:
        """Every phrasing: ``text`` first, then :attr:`wordings`."""
        return (self.text, *self.wordings)

    def text_for(self, seed: int) -> str:
        """The phrasing an episode of reset seed ``seed`` says: ``texts[seed % len(texts)]``."""
        return self.texts[seed % len(self.texts)]


def default_file() -> Path:
    """The package's ``data/instructions.toml``."""
    return Path(str(resources.files("taskcond") / "data" / "instructions.toml"))


def load_instructions(path: Path | None = None) -> list[Instruction]:
    """The instructions of ``path`` (default :func:`default_file`), in file order.

    Raises:
        InstructionError: an unreadable file, not TOML, another ``version``, no instruction, an unknown
            key or tag, a duplicate id, an empty text or goal, a goal predicate outside the vocabulary, or
            contradicting goal predicates.
    """
    path = path or default_file()
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise InstructionError(f"{path}: cannot read ({exc.strerror or exc})") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise InstructionError(f"{path}: not TOML ({exc})") from None
    if data.get("version") != FORMAT_VERSION:
        raise InstructionError(
            f"{path}: 'version = {FORMAT_VERSION}' expected, found {data.get('version')!r}"
        )
    entries = data.get("instruction")
    if not isinstance(entries, list) or not entries:
        raise InstructionError(f"{path}: no [[instruction]] entries")
    out: list[Instruction] = []
    for k, entry in enumerate(entries, start=1):
        out.append(_instruction(entry, f"{path}: instruction {k}"))
    seen: set[str] = set()
    for ins in out:
        if ins.id in seen:
            raise InstructionError(f"{path}: duplicate id {ins.id!r}")
        seen.add(ins.id)
    return out


def _instruction(entry: object, where: str) -> Instruction:
    if not isinstance(entry, dict):
        raise InstructionError(f"{where}: a table with id, text, goal expected")
    unknown = sorted(set(entry) - _KEYS)
    if unknown:
        raise InstructionError(f"{where}: unknown key {unknown[0]!r}; valid: {', '.join(sorted(_KEYS))}")
    ident = entry.get("id")
    if not isinstance(ident, str) or not _ID.match(ident):
        raise InstructionError(f"{where}: 'id' must be letters, digits, '-' or '_', found {ident!r}")
    where = f"{where} ({ident})"
    text = entry.get("text")
    if not isinstance(text, str) or not text.strip():
        raise InstructionError(f"{where}: 'text' must be a non-empty string")
    goal_texts = entry.get("goal")
    if not isinstance(goal_texts, list) or not goal_texts or not all(isinstance(g, str) for g in goal_texts):
        raise InstructionError(f"{where}: 'goal' must be a non-empty list of condition strings")
    try:
        goal = tuple(dict.fromkeys(parse_predicate(g) for g in goal_texts))
    except ConditionError as exc:
        raise InstructionError(f"{where}: {exc}") from None
    clash = contradictions(goal)
    if clash:
        a, b = clash[0]
        raise InstructionError(f"{where}: goal predicates {str(a)!r} and {str(b)!r} contradict each other")
    tags = entry.get("tags", [])
    if not isinstance(tags, list) or any(t not in TAGS for t in tags):
        bad = tags if not isinstance(tags, list) else next(t for t in tags if t not in TAGS)
        raise InstructionError(f"{where}: unknown tag {bad!r}; valid: {', '.join(TAGS)}")
    note = entry.get("note", "")
    if not isinstance(note, str):
        raise InstructionError(f"{where}: 'note' must be a string")
    wordings = entry.get("wordings", [])
    if not isinstance(wordings, list) or not all(isinstance(w, str) and w.strip() for w in wordings):
        raise InstructionError(f"{where}: 'wordings' must be a list of non-empty strings")
    return Instruction(
        ident, " ".join(text.split()), goal, tuple(tags), note, tuple(" ".join(w.split()) for w in wordings)
    )


def check_objects(instruction: Instruction, objects: Iterable[str], grippers: Iterable[str]) -> str | None:
    """Why the goal of ``instruction`` names something its scene lacks (one line), or None."""
    objects = tuple(objects)
    known = {*objects, *grippers}
    for pred in instruction.goal:
        missing = [o for o in pred.objects if o not in known]
        if missing:
            return (
                f"instruction {instruction.id!r}: goal {str(pred)!r} names {missing[0]!r}, not in its scene "
                f"(objects: {', '.join(objects)})"
            )
    return None


__all__ = [
    "FORMAT_VERSION",
    "TAGS",
    "Instruction",
    "InstructionError",
    "check_objects",
    "default_file",
    "load_instructions",
]
