"""The combination benchmark (``taskcond eval combinations``, issue 31): every primitive task the kitchen
makes feasible, generated from the scene's objects and their roles (:func:`taskcond.sim.roles.scene_roles`),
each said in several wordings from the templates of ``data/combinations.toml`` and judged by the goal
predicates its template derives (the instruction benchmark's form,
:class:`~taskcond.instructions.Instruction`).

What is generated, for the objects of the scene:

* ``grasp A`` for each graspable A; ``tilt A`` for each graspable vessel;
* ``open C`` and ``close C`` for each container with a lid, door or drawer;
* ``move A into C`` for each movable A and container C it fits (:func:`~taskcond.sim.roles.fits_into`) and
  the hand can enter (:func:`~taskcond.sim.roles.hand_enters`), ``move A on top of S``
  for each surface S its footprint fits on (:func:`fits_on`), ``move A in front of F`` for each fixed object
  F (not the table, not a drawer);
* sequences of two and three of these that are consistent (:func:`conflict`): a seeded sample, drawn
  uniformly among the consistent ones, of the sizes the templates file gives (the kitchen has 3,888
  consistent sequences of two and 117,054 of three; all of them would be days of episodes).

A pairing that cannot work is refused with its reason (:class:`Refusal`: ``move bowl into mug``: the bowl
is wider than the mug's inside), listed and never run. The goal of a task is its template's goal; a
sequence's goal is its steps' goals together, the gripper's state only from the last step. A plan that
contradicts the words (``move bowl into box`` for "stack the bowl on the box") fails the goal check
(``bowl above box`` does not hold of a bowl inside the box).

Templates file format (``version = 1``): ``[sequences]`` with ``seed``, ``count`` (sequence length → how
many are sampled) and ``joins`` (wording k of a sequence joins wording k of its steps with ``joins[k]``);
one ``[[primitive]]`` per primitive: ``id``, ``clauses`` (wordings, placeholders ``{a}``, ``{b}``,
``{part}``, ``{the_part}``), ``goal`` (condition strings with ``{a}``, ``{b}``), optional ``note``.
"""

from __future__ import annotations

import json
import re
import tomllib
from collections.abc import Iterable
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np

from taskcond.conditions import ConditionError, GripperState, Predicate, contradictions, parse_predicate
from taskcond.instructions import Instruction
from taskcond.primitives import PRIMITIVES
from taskcond.sim.roles import SceneObject, fits_into, hand_enters, part_aliases
from taskcond.sim.scene import TABLE

FORMAT_VERSION = 1
"""The ``version`` a templates file declares."""
_PLACEHOLDER = re.compile(r"\{(\w+)\}")


class TemplateError(ValueError):
    """A malformed templates file; one line naming the file, the entry and what is valid."""


# ------------------------------------------------------------------------------------------ templates
@dataclass(frozen=True)
class Template:
    """How one primitive is said and what holds when it is done.

    Attributes:
        primitive: the primitive's id (:data:`~taskcond.primitives.PRIMITIVES`).
        clauses: its wordings, lower case without a full stop, with placeholders.
        goal: condition strings with ``{a}``, ``{b}``.
        note: what the goal cannot say, or empty.
    """

    primitive: str
    clauses: tuple[str, ...]
    goal: tuple[str, ...]
    note: str = ""


@dataclass(frozen=True)
class Templates:
    """A templates file: one :class:`Template` per primitive and how sequences are sampled and said.

    Attributes:
        primitives: primitive id → its template.
        seed: seed of the sample of sequences (those of n steps are drawn with ``seed + n - 2``: each
            length its own stream, so that a change of one length's draws leaves the others').
        count: sequence length → how many consistent sequences of that length are sampled.
        joins: wording k of a sequence joins wording k of its steps with ``joins[k]``.
    """

    primitives: dict[str, Template]
    seed: int
    count: dict[int, int]
    joins: tuple[str, ...]


def default_templates_file() -> Path:
    """The package's ``data/combinations.toml``."""
    return Path(str(resources.files("taskcond") / "data" / "combinations.toml"))


def load_templates(path: Path | None = None) -> Templates:
    """The templates of ``path`` (default :func:`default_templates_file`).

    Raises:
        TemplateError: unreadable, not TOML, another version, an unknown primitive, no clause, a goal outside
            the vocabulary, a bad ``[sequences]`` table.
    """
    path = path or default_templates_file()
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise TemplateError(f"{path}: cannot read ({exc.strerror or exc})") from None
    except tomllib.TOMLDecodeError as exc:
        raise TemplateError(f"{path}: not TOML ({exc})") from None
    if data.get("version") != FORMAT_VERSION:
        raise TemplateError(f"{path}: 'version = {FORMAT_VERSION}' expected, found {data.get('version')!r}")
    out: dict[str, Template] = {}
    for k, entry in enumerate(data.get("primitive", []), start=1):
        template = _template(entry, f"{path}: primitive {k}")
        out[template.primitive] = template
    seq = data.get("sequences", {})
    try:
        count = {int(n): int(c) for n, c in seq.get("count", {}).items()}
        joins = tuple(str(j) for j in seq["joins"])
        seed = int(seq["seed"])
    except (KeyError, TypeError, ValueError) as exc:
        raise TemplateError(
            f"{path}: [sequences] needs seed, count {{2 = n, 3 = n}} and joins ({exc})"
        ) from None
    if not joins or any(n not in (2, 3) or c < 0 for n, c in count.items()):
        raise TemplateError(f"{path}: [sequences]: joins must not be empty; count keys 2 or 3, counts >= 0")
    return Templates(out, seed, count, joins)


def _template(entry: dict, where: str) -> Template:
    pid = entry.get("id")
    if pid not in PRIMITIVES:
        raise TemplateError(f"{where}: unknown primitive {pid!r}; valid: {', '.join(PRIMITIVES)}")
    clauses = entry.get("clauses")
    if not isinstance(clauses, list) or not clauses or not all(isinstance(c, str) for c in clauses):
        raise TemplateError(f"{where} ({pid}): 'clauses' must be a non-empty list of strings")
    if set(_PLACEHOLDER.findall(clauses[0])) - {"a", "b"}:
        raise TemplateError(f"{where} ({pid}): the first clause may use only {{a}} and {{b}}")
    goal = entry.get("goal")
    if not isinstance(goal, list) or not goal:
        raise TemplateError(f"{where} ({pid}): 'goal' must be a non-empty list of condition strings")
    try:
        for g in goal:
            parse_predicate(g.format(a="object a", b="object b"))
    except (ConditionError, KeyError, AttributeError) as exc:
        raise TemplateError(f"{where} ({pid}): goal {exc}") from None
    return Template(pid, tuple(clauses), tuple(goal), str(entry.get("note", "")))


# ------------------------------------------------------------------------------------------ the tasks
@dataclass(frozen=True)
class Step:
    """One primitive task of a combination: the primitive's id and its objects (pattern order)."""

    primitive: str
    objects: tuple[str, ...]

    @property
    def name(self) -> str:
        """The canonical task name (``move bottle into box``)."""
        return PRIMITIVES[self.primitive].task_name(*self.objects)

    @property
    def id(self) -> str:
        """The suite's id form (``move_into-bottle-box``)."""
        return "-".join((self.primitive, *(o.replace(" ", "_") for o in self.objects)))

    @property
    def subject(self) -> str:
        return self.objects[0]

    @property
    def target(self) -> str | None:
        return self.objects[1] if len(self.objects) > 1 else None


@dataclass(frozen=True)
class Combination:
    """One generated task of the benchmark.

    Attributes:
        id: its key in results files (a sequence's step ids joined by ``__``).
        steps: its primitive tasks in order.
        wordings: how it is said (an episode's seed picks one).
        goal: what holds when it is done.
        note: what the goal cannot say.
        templates: the clause template each wording was said from (a sequence's joined by `` / ``).
    """

    id: str
    steps: tuple[Step, ...]
    wordings: tuple[str, ...]
    goal: tuple[Predicate, ...]
    note: str = ""
    templates: tuple[str, ...] = ()

    @property
    def cell(self) -> tuple[str, str]:
        """Its row and column of the table: a single step's primitive (with its target) and object; a
        sequence's length and ``all``."""
        if len(self.steps) > 1:
            return f"{len(self.steps)} steps", "all"
        step = self.steps[0]
        row = step.primitive if step.target is None else f"{step.primitive} {step.target}"
        return row, step.subject

    def instruction(self) -> Instruction:
        """The instruction benchmark's form of it (first wording the text, the others its wordings)."""
        tags = tuple(dict.fromkeys(s.primitive for s in self.steps))
        return Instruction(self.id, self.wordings[0], self.goal, tags, self.note, self.wordings[1:])


@dataclass(frozen=True)
class Refusal:
    """A pairing the generator refuses: its task name and why it cannot work."""

    task: str
    reason: str


@dataclass(frozen=True)
class Generated:
    """What :func:`generate` makes.

    Attributes:
        combinations: single steps first, then the sampled sequences of two, then of three.
        refused: the pairings that cannot work, with their reasons.
        pairs: how many consistent sequences of two steps there are (of which the templates' ``count`` are
            sampled).
    """

    combinations: list[Combination]
    refused: list[Refusal]
    pairs: int


def fits_on(a: SceneObject, s: SceneObject) -> str | None:
    """Why A cannot be put on top of surface S, or None: S is not what everything stands on at the start
    (the goal would hold before anything moves), and A's footprint fits S's top."""
    if s.name == TABLE:
        return f"every start stands the {a.name} on the {TABLE}: the goal holds before anything moves"
    if any(x > y for x, y in zip(sorted(a.size[:2]), sorted(s.size[:2]), strict=True)):
        return f"the {a.name}'s footprint is larger than the {s.name}'s top"
    return None


@dataclass(frozen=True)
class Singles:
    """The single steps of a scene (:func:`single_steps`).

    Attributes:
        steps: every primitive task the roles of the objects make feasible.
        drawn: what sequences are drawn from (:func:`_sample`): ``steps`` and, in their places, the
            pairings whose objects fit but that the robot cannot do (:func:`~taskcond.sim.roles.hand_enters`),
            so that the sample stays the same when the robot gains or loses such an ability.
        refused: the pairings that cannot work, with their reasons.
    """

    steps: list[Step]
    drawn: list[Step]
    refused: list[Refusal]


def _put_into(a: SceneObject, c: SceneObject) -> tuple[str | None, str | None]:
    """Why A cannot be put into C: by their sizes (:func:`fits_into`), and by the robot
    (:func:`hand_enters`)."""
    return fits_into(a, c), hand_enters(a, c)


def _put_on(a: SceneObject, s: SceneObject) -> tuple[str | None, str | None]:
    return fits_on(a, s), None


def single_steps(objects: dict[str, SceneObject]) -> Singles:
    """Every primitive task the roles of ``objects`` make feasible, what sequences are drawn from, and the
    refused pairings."""
    steps: list[Step] = []
    drawn: list[Step] = []
    refused: list[Refusal] = []
    free = [o for o in objects.values() if o.free and o.roles.graspable]
    steps += [Step("grasp", (a.name,)) for a in free]
    drawn += steps
    for pid, test, targets in (
        (
            "move_into",
            _put_into,
            [c for c in objects.values() if c.roles.container and c.interior is not None],
        ),
        ("move_on_top", _put_on, [s for s in objects.values() if s.roles.surface]),
    ):
        for a in free:
            for b in targets:
                if b.name == a.name:
                    continue
                sizes, robot = test(a, b)
                step = Step(pid, (a.name, b.name))
                if sizes is None:
                    drawn.append(step)
                if sizes is None and robot is None:
                    steps.append(step)
                else:
                    refused.append(Refusal(step.name, sizes or robot or ""))
    fixed = [f for f in objects.values() if not f.free and f.name != TABLE and f.owner == f.name]
    rest = [Step("move_in_front", (a.name, f.name)) for a in free for f in fixed]
    closable = [c for c in objects.values() if c.closable]
    rest += [Step(pid, (c.name,)) for pid in ("open", "close") for c in closable]
    rest += [Step("tilt", (a.name,)) for a in free if a.roles.vessel]
    return Singles(steps + rest, drawn + rest, refused)


def conflict(steps: tuple[Step, ...], objects: dict[str, SceneObject]) -> str | None:
    """Why ``steps`` are not a consistent sequence (their goals could not hold jointly, or a step undoes or
    repeats what an earlier one did), or None. The rules: a grasp or tilt (the hand keeps the object)
    only last, and not of an object another step moves or puts something in or on; each object moved at
    most once and never also a target; one object per container, surface or fixed object; no open or
    close of a container that an earlier open or close set, or whose state an earlier step needed, except
    closing it over what was put into it (a move into it needs it open, a move onto its lid closed);
    nothing in front of an object whose lid, door or drawer the sequence moves."""
    moved: set[str] = set()
    targets: set[str] = set()
    state: dict[str, tuple[bool, bool]] = {}  # container → (open, set by an open or close step)
    for k, step in enumerate(steps):
        if step.primitive in ("grasp", "tilt"):
            if k != len(steps) - 1:
                return f"the hand still holds the {step.subject} for step {k + 2}"
            if step.subject in moved | targets:
                return f"{step.name!r} undoes an earlier step"
            continue
        if step.primitive in ("open", "close"):
            opens = step.primitive == "open"
            was = state.get(step.subject)
            if was is not None and (was[1] or was[0] == opens or not was[0]):
                return f"{step.name!r} repeats or undoes an earlier step"
            state[step.subject] = (opens, True)  # closing over what went in: the one change allowed
            continue
        a, b = step.subject, step.target
        assert b is not None
        if a in moved or a in targets or b in moved or b in targets:
            return f"{step.name!r} moves an object twice, or one that another step moves or fills"
        moved.add(a)
        targets.add(b)
        need = {"move_into": True, "move_on_top": False}.get(step.primitive)
        if need is not None and objects[b].closable:
            if b in state and state[b][0] != need:
                return f"{step.name!r} needs the {b} {'open' if need else 'closed'}"
            state[b] = (need, False)
    for step in steps:
        if step.primitive == "move_in_front":
            owner = step.target
            if any(objects[c].owner == owner for c in state):
                part = objects[owner].part or "drawers"
                return f"the {step.subject} would stand where the {owner}'s {part} move"
    return None


def _sample(
    singles: Singles, objects: dict[str, SceneObject], length: int, count: int, rng: np.random.Generator
) -> list[tuple[Step, ...]]:
    """``count`` distinct consistent sequences of ``length`` feasible steps, drawn uniformly among them by
    rejection (ordered draws of distinct steps of ``singles.drawn``; a draw with a step the robot cannot do,
    or an inconsistent one, is drawn again), in the order drawn."""
    out: dict[tuple[Step, ...], None] = {}
    feasible = set(singles.steps)
    for _ in range(1000 * max(count, 1)):
        if len(out) == count:
            break
        seq = tuple(singles.drawn[i] for i in rng.choice(len(singles.drawn), size=length, replace=False))
        if feasible.issuperset(seq) and conflict(seq, objects) is None:
            out[seq] = None
    return list(out)


def consistent_pairs(singles: list[Step], objects: dict[str, SceneObject]) -> int:
    """How many consistent sequences of two steps there are (of three steps the kitchen has 117,054: too
    many to count at every run)."""
    return sum(conflict((a, b), objects) is None for a in singles for b in singles if a != b)


# ------------------------------------------------------------------------------------------ wordings
def _clause(template: str, step: Step, objects: dict[str, SceneObject]) -> str | None:
    """``template`` said of ``step``, or None when a placeholder does not apply to its object (``{part}``
    of a drawer; ``{the_part}`` where more than one object has that part)."""
    a = objects[step.subject]
    part = a.part if a.part is not None and a.part != "drawer" else None
    unique = part is not None and part_aliases(objects.values()).get(part) == a.name
    values = {
        "a": step.subject,
        "b": step.target,
        "part": part,
        "the_part": f"the {part}" if unique else None,
    }
    used = _PLACEHOLDER.findall(template)
    if any(values.get(u) is None for u in used):
        return None
    return template.format(**{u: values[u] for u in used})


def _sentence(clause: str) -> str:
    return clause[0].upper() + clause[1:] + "."


def _goal(steps: tuple[Step, ...], templates: Templates) -> tuple[Predicate, ...]:
    """The steps' goals together: each step's template goal, the gripper's state only from the last."""
    goal: list[Predicate] = []
    for k, step in enumerate(steps):
        values = {"a": step.subject, "b": step.target or ""}
        for text in templates.primitives[step.primitive].goal:
            pred = parse_predicate(text.format(**values))
            if isinstance(pred, GripperState) and k != len(steps) - 1:
                continue
            if pred not in goal:
                goal.append(pred)
    clash = contradictions(goal)
    if clash:
        raise ValueError(f"goal of {[s.name for s in steps]}: {clash[0][0]} and {clash[0][1]} contradict")
    return tuple(goal)


def _combination(
    steps: tuple[Step, ...], objects: dict[str, SceneObject], templates: Templates
) -> Combination:
    said = [
        [(t, c) for t in templates.primitives[s.primitive].clauses if (c := _clause(t, s, objects))]
        for s in steps
    ]
    if len(steps) == 1:
        pairs = [(t, _sentence(c)) for t, c in said[0]]
    else:
        pairs = [
            (
                " / ".join(clauses[k % len(clauses)][0] for clauses in said),
                _sentence(join.join(clauses[k % len(clauses)][1] for clauses in said)),
            )
            for k, join in enumerate(templates.joins)
        ]
    said_by: dict[str, str] = {}  # each wording once, with the first template that says it
    for template, wording in pairs:
        said_by.setdefault(wording, template)
    notes = {templates.primitives[s.primitive].note for s in steps} - {""}
    return Combination(
        "__".join(s.id for s in steps),
        steps,
        tuple(said_by),
        _goal(steps, templates),
        "; ".join(sorted(notes)),
        tuple(said_by.values()),
    )


def generate(objects: dict[str, SceneObject], templates: Templates | None = None) -> Generated:
    """Every feasible single step and the seeded sample of consistent sequences for ``objects``
    (:func:`taskcond.sim.roles.scene_roles`), each with its wordings and goal, and the refused pairings.

    Raises:
        ValueError: a primitive the scene makes feasible has no template.
    """
    templates = templates or load_templates()
    singles = single_steps(objects)
    missing = sorted({s.primitive for s in singles.steps} - set(templates.primitives))
    if missing:
        raise ValueError(
            f"no template for primitive {missing[0]!r}; add a [[primitive]] to the templates file"
        )
    out = [_combination((s,), objects, templates) for s in singles.steps]
    for length, count in sorted(templates.count.items()):
        rng = np.random.default_rng(templates.seed + length - 2)  # each length its own stream
        out += [
            _combination(seq, objects, templates) for seq in _sample(singles, objects, length, count, rng)
        ]
    return Generated(out, singles.refused, consistent_pairs(singles.steps, objects))


def _said(text: str) -> str:
    """An instruction's words for matching: lower case, no punctuation, single spaces."""
    return " ".join(re.sub(r"[^\w' ]+", " ", text.lower()).split())


JOIN_WORDS = ("and after that", "and then", "then", "and")
"""Words that join an instruction's clauses (after :func:`_said`: no commas), longest first."""


def goal_of_words(text: str, generated: Generated) -> tuple[Predicate, ...] | None:
    """The goal an instruction's own words say, when they are one of the ``generated`` tasks' wordings
    ("Stack the bowl on the box." → ``bowl above box``, ``gripper not grasping``) or clauses that are single
    tasks' wordings joined by "then", "and", "and then" or "and after that" (a clause may say "it" for the
    previous clause's object), else None: what ``taskcond run`` judges such an instruction by, so that a
    plan contradicting its words (``move bowl into box``) fails the goal check instead of meeting the goal
    it derives itself. A sequence's goal is its steps' goals together (:func:`_goal`)."""
    said = _said(text)
    for c in generated.combinations:
        if any(_said(w) == said for w in c.wordings):
            return c.goal
    singles = {_said(w): c.steps[0] for c in generated.combinations if len(c.steps) == 1 for w in c.wordings}
    steps = _clauses(said.split(), singles, None)
    if not steps or len(steps) == 1:
        return None
    try:
        return _goal(tuple(steps), load_templates())
    except ValueError:
        return None


def _clauses(words: list[str], singles: dict[str, Step], previous: Step | None) -> list[Step] | None:
    """``words`` read as single tasks' wordings joined by :data:`JOIN_WORDS`, the first clause first (the
    longest that reads), or None."""
    for end in range(len(words), 0, -1):
        clause = " ".join(words[:end])
        step = singles.get(clause)
        if step is None and previous is not None:
            step = singles.get(re.sub(r"\bit\b", f"the {previous.subject}", clause))
        if step is None:
            continue
        rest = words[end:]
        if not rest:
            return [step]
        for join in JOIN_WORDS:
            n = len(join.split())
            if " ".join(rest[:n]) == join and (later := _clauses(rest[n:], singles, step)):
                return [step, *later]
    return None


def select(
    combinations: Iterable[Combination],
    primitives: Iterable[str] = (),
    objects: Iterable[str] = (),
    max_steps: int = 3,
) -> list[Combination]:
    """The combinations of at most ``max_steps`` steps that use one of ``primitives`` (all when empty) and
    name one of ``objects`` (all when empty)."""
    prims, objs = set(primitives), set(objects)
    return [
        c
        for c in combinations
        if len(c.steps) <= max_steps
        and (not prims or any(s.primitive in prims for s in c.steps))
        and (not objs or any(o in objs for s in c.steps for o in s.objects))
    ]


def write_instructions(combinations: Iterable[Combination], path: Path) -> None:
    """Write ``combinations`` as an instructions file (:mod:`taskcond.instructions`), the form the
    evaluation's workers read (its digest is part of the results' configuration)."""
    lines = [
        "# Generated by `taskcond eval combinations` (taskcond.combinations); do not edit.",
        "version = 1",
    ]
    for c in combinations:
        ins = c.instruction()
        lines += [
            "",
            "[[instruction]]",
            f"id = {json.dumps(ins.id)}",
            f"text = {json.dumps(ins.text)}",
            f"wordings = {json.dumps(list(ins.wordings))}",
            f"goal = {json.dumps([str(q) for q in ins.goal])}",
            f"tags = {json.dumps(list(ins.tags))}",
            f"note = {json.dumps(ins.note)}",
        ]
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")


__all__ = [
    "FORMAT_VERSION",
    "Combination",
    "Generated",
    "Refusal",
    "Singles",
    "Step",
    "Template",
    "TemplateError",
    "Templates",
    "conflict",
    "consistent_pairs",
    "default_templates_file",
    "fits_on",
    "generate",
    "goal_of_words",
    "load_templates",
    "select",
    "single_steps",
    "write_instructions",
]
