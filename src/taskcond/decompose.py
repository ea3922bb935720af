"""From a free instruction to primitive task names with the LLM (beyond the paper, which runs long-horizon
tasks as given sequences of primitive task names).

The prompt (``prompts/<version>/decompose.txt``) lists the primitive task forms of
:data:`taskcond.primitives.PRIMITIVES` and the scene's objects, with three of the paper's long-horizon
tasks as examples. Every answer line must parse as a primitive task (:func:`taskcond.primitives.parse_task`)
on objects of the scene; an invalid answer is shown its error and asked again, a bounded number of times.
The prompt's rule "grasp an object before moving it, release it after" is then enforced on the release
(:func:`with_releases`): a small model often ends "put the mug on the box" holding the mug. An answer must
also say what the instruction's clauses say where they read as primitive tasks (:func:`said_tasks`,
:func:`contradiction`); when no answer does and every clause reads as one, the plan is what they say.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping, Sequence

from taskcond.generator import load_prompt
from taskcond.llm.base import ChatBackend, ChatMessage, ChatRequest, LLMError, Sampling
from taskcond.primitives import PRIMITIVES, TaskNameError, parse_task

MAX_STEPS = 12
"""Longest plan accepted."""


MISPLACED = re.compile(
    r"\b(?:(?:into|in to|onto|on to)\s+(?P<where>front)|(?:onto|on to)\s+(?P<on>top))\s+of\b", re.IGNORECASE
)
"""A place word run into a relation's: "move can into front of microwave", "put cube onto top of box" ("into
top of box" stays: the top of the box is a part of it, a lidded container)."""


def _placed_words(m: re.Match[str]) -> str:
    """The vocabulary's words for the relation of :data:`MISPLACED`'s match ``m``."""
    return "in front of" if m["where"] else "on top of"


class DecompositionError(ValueError):
    """The instruction could not be turned into primitive tasks; one line."""


def parse_plan(
    text: str, objects: Sequence[str], affords: Callable[[str, tuple[str, ...]], str | None] | None = None
) -> list[str]:
    """Primitive task names from an answer, one per non-empty line (list markers and numbering ignored);
    an object named by one of its parts (``open microwave door``) is read as the object, and a place word
    run into a relation's (:data:`MISPLACED`: ``move can into front of microwave``) as the relation (the
    embedded model wrote it for "stand it in front of the microwave", which then read as a move into the
    microwave).

    Raises:
        DecompositionError: no task, too many, a line that is no primitive task, or an object not in
            ``objects`` / a task ``affords`` refuses.
    """
    tasks = []
    for raw in text.splitlines():
        line = MISPLACED.sub(_placed_words, raw.strip().lstrip("-*0123456789.) ").strip().rstrip("."))
        if not line:
            continue
        if line.lower().startswith(("instruction:", "tasks:")):
            break
        try:
            task = parse_task(line)
        except TaskNameError as exc:
            raise DecompositionError(f"{line!r} is not a primitive task ({exc})") from None
        named = tuple(_part_of(o, objects) for o in task.objects)
        if named != task.objects:
            task = parse_task(task.primitive.task_name(*named))
        unknown = [o for o in task.objects if o not in objects]
        if unknown:
            raise DecompositionError(
                f"{line!r} names {', '.join(unknown)}, not in the scene ({', '.join(objects)})"
            )
        if affords is not None and (reason := affords(task.primitive.id, task.objects)) is not None:
            raise DecompositionError(f"{line!r}: {reason}")
        tasks.append(task.name)
    if not tasks:
        raise DecompositionError("the answer names no primitive task")
    if len(tasks) > MAX_STEPS:
        raise DecompositionError(f"{len(tasks)} tasks; at most {MAX_STEPS} are accepted")
    return tasks


CLAUSE_BREAK = re.compile(
    r"\s*(?:[,;.!?]|\band after that\b|\band then\b|\bthen\b|\band\b)\s*", re.IGNORECASE
)
"""Where an instruction's clauses meet: punctuation and the words that join them."""
SETTING_UP = ("grasp", "release", "open", "close")
"""Primitives a plan may add to what its words say: the grasps, releases, opens and closes that other steps
need (the prompt's rule "grasp an object before moving it, release it after")."""


def said_tasks(instruction: str, objects: Sequence[str]) -> list[str | None]:
    """The primitive task each clause of ``instruction`` (split at :data:`CLAUSE_BREAK`) reads as on
    objects of the scene (:func:`~taskcond.primitives.parse_task`; "it" is the previous clause's object
    where it names one: "pick up the mug and tilt it"; after "put the bowl in the box", "close it" reads as
    none), None for a clause that reads as none."""
    out: list[str | None] = []
    previous: str | None = None
    for clause in filter(None, (c.strip() for c in CLAUSE_BREAK.split(instruction))):
        if previous is not None:
            clause = re.sub(r"\bit\b", f"the {previous}", clause)
        try:
            task = parse_task(clause)
        except TaskNameError:
            out.append(None)
            continue
        known = set(task.objects) <= set(objects)
        out.append(task.name if known else None)
        previous = task.objects[0] if known and len(task.objects) == 1 else None
    return out


def contradiction(plan: Sequence[str], said: Sequence[str | None]) -> str | None:
    """How ``plan`` (canonical task names) contradicts the tasks its instruction's clauses say
    (:func:`said_tasks`), or None: a said task missing from the plan, or, when every clause says a task, a
    step that is none of them and no :data:`SETTING_UP` step ("pick up the toothpaste" answered ``grasp
    toothpaste``, ``move toothpaste into bowl``). Asked of each answer, like the scene's refusals, so that
    the LLM answers again ("Stack the cube on the box" was answered ``move cube into box``)."""
    for task in filter(None, said):
        if task not in plan:
            return f"the instruction says {task!r}, and the answer does not"
    if said and all(said):
        extra = [t for t in plan if t not in said and parse_task(t).primitive.id not in SETTING_UP]
        if extra:
            return f"the instruction does not say {extra[0]!r}"
    return None


def _refused(task: str, affords: Callable[[str, tuple[str, ...]], str | None]) -> bool:
    parsed = parse_task(task)
    return affords(parsed.primitive.id, parsed.objects) is not None


def with_releases(tasks: Sequence[str]) -> list[str]:
    """``tasks`` (canonical primitive task names) with ``release A`` right after the last move of each A to a
    place (:attr:`~taskcond.primitives.Primitive.places`) that no later task releases, moves, tilts or
    grasps again (the prompt's rule that an object is released after it is moved); the gripper's last move
    of an object then leaves it there. A move to a position is a carry that leaves the object held
    (:attr:`~taskcond.primitives.Primitive.to_position`: "move it to the target position")."""
    plan = list(tasks)
    for index in range(len(plan) - 1, -1, -1):
        task = parse_task(plan[index])
        if task.primitive.places is None:
            continue
        obj = task.objects[0]
        later = [parse_task(t) for t in plan[index + 1 :]]
        if not any(t.objects[:1] == (obj,) and t.primitive.movable for t in later):
            plan.insert(index + 1, parse_task(f"release {obj}").name)
    return plan


LET_GO = ("release", "let go", "drop", "put down", "set down", "place", "put it", "leave")
"""Words by which an instruction asks for what it holds to be let go of."""
PUT_DOWN = ("release", "let go", "drop", "put down", "set down", "put it down", "set it down", "put it back")
"""Words by which an instruction asks for what it has just picked up to be let go of where it is."""


def mentions(instruction: str, words: Sequence[str]) -> bool:
    """Whether ``instruction`` contains one of ``words`` (each one or more lower-case words) as whole words,
    whatever the case and punctuation."""
    text = " ".join("".join(c if c.isalnum() else " " for c in instruction.lower()).split())
    return any(f" {w} " in f" {text} " for w in words)


def without_carry_releases(tasks: Sequence[str], instruction: str) -> list[str]:
    """``tasks`` without a ``release A`` that directly follows ``move A to position`` when ``instruction``
    has none of the :data:`LET_GO` words, or ``grasp A`` when it has none of the :data:`PUT_DOWN` words:
    a move to a position is a carry that leaves the object held
    (:attr:`~taskcond.primitives.Primitive.to_position`), a grasp leaves it held, and a small model adds the
    release by the prompt's rule "release it after" ("Stack the mug on the box and grasp the can." →
    ``..., grasp can, release can``)."""
    keep_after_carry, keep_after_grasp = mentions(instruction, LET_GO), mentions(instruction, PUT_DOWN)
    plan: list[str] = []
    last = None  # the last task kept, parsed
    for name in tasks:
        task = parse_task(name)
        same = last is not None and last.objects[:1] == task.objects[:1]
        held = same and (
            (last.primitive.to_position and not keep_after_carry)
            or (last.primitive.grasps and not keep_after_grasp)
        )
        if not (task.primitive.lets_go and held):
            plan.append(name)
            last = task
    return plan


def _part_of(name: str, objects: Sequence[str]) -> str:
    """The scene object that ``name`` names by one of its parts (``microwave door``, ``box lid``: the one
    object of ``objects`` that ``name`` starts or ends with as whole words), else ``name``."""
    if name in objects:
        return name
    whole = [o for o in objects if name.startswith(f"{o} ") or name.endswith(f" {o}")]
    return whole[0] if len(whole) == 1 else name


def with_object_names(instruction: str, objects: Sequence[str], aliases: Mapping[str, str]) -> str:
    """``instruction`` with each alias of ``aliases`` (whole words, any case) whose object is in
    ``objects`` replaced by the object's name: "the upper drawer" → "the top drawer". One pass, the
    longest match first, names included, so an alias inside a longer name stays ("soup", an alias of the
    soup can, in "the soup can"). A small model maps an alias to the wrong object of the list it is shown."""
    names = {n.lower(): None for n in objects}  # a name is kept as written
    names |= {a.lower(): o for a, o in aliases.items() if o in objects and a.lower() not in names}
    if not names:
        return instruction
    words = "|".join(re.escape(w) for w in sorted(names, key=len, reverse=True))
    pattern = re.compile(rf"(?<![\w-])(?:{words})(?![\w-])", re.IGNORECASE)
    return pattern.sub(lambda m: names[m[0].lower()] or m[0], instruction)


PUT_ON = re.compile(
    r"\b(?P<put>put|place|set|stack|stand|lay|drop)\b(?P<what>[^,;.]*?)\s+on(?:to)?\s+(?!top\s+of\b)",
    re.IGNORECASE,
)
"""A verb that puts something somewhere, its object, and "on" or "onto" not followed by "top of"."""


def with_on_top(instruction: str) -> str:
    """``instruction`` with "on" and "onto" after a verb that puts something (:data:`PUT_ON`) said as "on top
    of", the vocabulary's one way of being on (issue 31, item 5: "stack the can on the cabinet" means on top
    of it). The embedded model read "stack ... on" as ``move ... into``."""
    return PUT_ON.sub(lambda m: f"{m['put']}{m['what']} on top of ", instruction)


POUR = re.compile(r"\b(p)our\b(?:\s+out\b)?", re.IGNORECASE)
"""The verb pour (or "pour out"), whole words, any case."""


def with_tilt(instruction: str) -> str:
    """``instruction`` with "pour" and "pour out" said as "tilt", the vocabulary's primitive that pours a
    vessel (issue 31, item 5). The embedded model read "pour the bowl" as a move of the bowl into a
    container."""
    return POUR.sub(lambda m: "Tilt" if m[1] == "P" else "tilt", instruction)


PUSH_SHUT = re.compile(r"\b(?P<verb>push|pull)\s+(?P<what>[^,;.!?]+?)\s+(?P<how>shut|closed|open)\b", re.I)
"""A drawer, lid or door pushed shut or pulled open: "push the top drawer shut"."""


PUT_DOWN_WORDS = re.compile(
    r"\b(?:put|set|lay)\s+(?P<what>it|them|the\s+[^,;.!?]+?)\s+(?:back\s+)?down(?:\s+again)?"
    r"(?=\s*(?:$|[,;.!?]|\band\b|\bthen\b))",
    re.I,
)
"""What is held put down where it is, the clause ending there: "put it down again" (not "set the bowl down
in front of the cabinet")."""


def with_open_close(instruction: str) -> str:
    """``instruction`` with "push X shut" said as "close X" and "pull X open" as "open X", the vocabulary's
    verbs (issue 31, item 5): the embedded model answered "push the top drawer shut" with ``open top
    drawer``. The verbs stay free for a primitive a user declares (``push A in front of B``)."""

    def said(m: re.Match[str]) -> str:
        verb = "open" if m["how"].lower() == "open" else "close"
        return f"{verb.title() if m['verb'][0].isupper() else verb} {m['what']}"

    return PUSH_SHUT.sub(said, instruction)


def said_text(instruction: str, objects: Sequence[str], aliases: Mapping[str, str]) -> str:
    """``instruction`` as the LLM and the words check read it: single-spaced, the objects' ``aliases``
    replaced by their names (:func:`with_object_names`), "on" said as "on top of" (:func:`with_on_top`),
    "pour" as "tilt" (:func:`with_tilt`), "push X shut" as "close X" (:func:`with_open_close`), "put X
    down" as "release X" (:func:`with_release`)."""
    named = with_object_names(" ".join(instruction.split()), objects, aliases)
    return with_release(with_open_close(with_tilt(with_on_top(named))))


def with_release(instruction: str) -> str:
    """``instruction`` with "put X down (again)" said as "release X", the vocabulary's primitive that lets go
    of an object and sets it down where the hand is (issue 31, item 5): for "pick up the bottle and put it
    down again" the embedded model answered moves of the bottle into the table, then into each drawer."""
    return PUT_DOWN_WORDS.sub(lambda m: f"{'R' if m[0][0].isupper() else 'r'}elease {m['what']}", instruction)


def decompose(
    instruction: str,
    backend: ChatBackend,
    objects: Sequence[str],
    affords: Callable[[str, tuple[str, ...]], str | None] | None = None,
    max_retries: int = 2,
    version: str = "v1",
    aliases: Mapping[str, str] | None = None,
    tell: Callable[[str], None] | None = None,
) -> list[str]:
    """Ask the LLM for the primitive tasks of ``instruction`` in order (a release the instruction does not
    ask for after a carry dropped, :func:`without_carry_releases`; :func:`with_releases` added),
    the instruction said in the vocabulary's words first (:func:`said_text`: the objects' ``aliases``,
    alias → object name, replaced by their names, "on" as "on top of", "push X shut" as "close X"). Each
    answer must also say what the instruction's clauses say
    (:func:`contradiction`); when no answer does and every clause reads as a primitive task, the plan is
    those tasks (releases added, the grasps and opens left to the planner), and ``tell`` is told so.

    Raises:
        DecompositionError: no valid plan within ``1 + max_retries`` answers (the last error is given).
        LLMError: the backend failed.
    """
    patterns = "\n".join(f"  {p.pattern}" for p in PRIMITIVES.values())
    text = said_text(instruction, objects, aliases or {})
    prompt = load_prompt("decompose", version).substitute(
        patterns=patterns, objects=", ".join(objects), instruction=text
    )
    messages = [ChatMessage("user", prompt)]
    error = ""
    said = said_tasks(text, objects)
    for _ in range(max_retries + 1):
        response = backend.chat(
            ChatRequest(
                tuple(messages), Sampling(temperature=0.0, max_tokens=160), stop=("\n\n", "Instruction:")
            )
        )
        try:
            plan = with_releases(without_carry_releases(parse_plan(response.text, objects, affords), text))
            wrong = contradiction(plan, said)
            if wrong is not None:
                raise DecompositionError(wrong)
            return plan
        except DecompositionError as exc:
            error = str(exc)
            messages += [
                ChatMessage("assistant", response.text),
                ChatMessage("user", f"That answer is not valid: {error}. Answer again, one task per line."),
            ]
    refused = [t for t in said if t is not None and affords is not None and _refused(t, affords)]
    if said and all(said) and not refused and len(said) <= MAX_STEPS:
        if tell is not None:
            tell(f"the LLM's answers contradict the instruction's words ({error}); the plan is what they say")
        return with_releases([t for t in said if t is not None])
    raise DecompositionError(f"no valid plan for {instruction!r}: {error}")


__all__ = [
    "CLAUSE_BREAK",
    "DecompositionError",
    "LLMError",
    "contradiction",
    "decompose",
    "mentions",
    "parse_plan",
    "said_tasks",
    "said_text",
    "with_object_names",
    "with_on_top",
    "with_open_close",
    "with_release",
    "with_releases",
    "with_tilt",
    "without_carry_releases",
]
