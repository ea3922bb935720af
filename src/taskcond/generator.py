"""Task-condition generation and generalization with an LLM (paper §III-B, §III-C, Listings 2–4).

Two separate chats answer for one task name, as in the paper: one gives the relevant objects, spatial
relations and allowed collisions, the other the object states (gripper and containers). Objects are
replaced by letters (``move A into B``) in the prompts and mapped back in the answers. The two answers are
merged into one :class:`~taskcond.conditions.TaskCondition`.

*Generation* shows the LLM an example of every primitive. *Generalization* leaves out the examples of
the task's own primitive (``exclude``, the paper's Table II protocol). In prompt versions v1–v5 it uses
the two chain-of-thought chats of Listing 4; in v4 and v5 each example carries a one-line worked
reasoning (few-shot chain of thought, Wei et al. 2022), so the model reasons about the new primitive in
the same way before it answers; a reason speaks of its own example only and leaves with it. In v5 and v6,
generation shows the examples as the chat's earlier turns (the task name asked, its condition answered)
with the question as the last turn. In v6 (beyond the paper), a left-out primitive is asked in one chat
whose examples are Python functions (:mod:`taskcond.code_form`): the signature asked, the body of asserts
answered; the body is read back into a condition and validated like any answer. v7 is v6 whose code chat
adds when a container's state is asserted: only when the task opens or closes it, or puts something inside
it. v8 (the default) asks a seen primitive in v7's code chat too, with its own example repeated right
before the question: one request per condition instead of two (BENCHMARKS.md, issue 34).

Beyond the paper, the answer's form is guaranteed: a GBNF grammar constrains decoding where the backend
supports it, and every answer passes a validator that checks the vocabulary, the task's objects and that
no two conditions contradict each other, never the content, and asks again with the error shown, within
a bound. Optional self-consistency draws ``samples`` answers per chat (in the code form: greedy answers
over as many example orders) and keeps each condition a majority of them has.
"""

from __future__ import annotations

import random
import time
import zlib
from collections import Counter
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from functools import cache
from importlib import resources
from string import Template
from typing import TYPE_CHECKING, Any, Literal, get_args

from taskcond import code_form
from taskcond.conditions import (
    GRIPPER,
    RELATIONS,
    ConditionError,
    ContainerState,
    GripperState,
    SpatialRelation,
    TaskCondition,
    contradictions,
    is_spatial,
)
from taskcond.examples import example_conditions, letter_example
from taskcond.llm.base import ChatBackend, ChatMessage, ChatRequest, LLMError, Sampling
from taskcond.llm.models import Mode
from taskcond.primitives import LETTERS, PRIMITIVES, ParsedTask, Primitive, get_primitive, parse_task

if TYPE_CHECKING:
    from taskcond.llm.config import LLMConfig

Chat = Literal["spatial", "state", "code"]
CHATS: tuple[Chat, ...] = ("spatial", "state")
"""The paper's two chats (§III-B); a prompt version with the code form asks a left-out primitive in one
``"code"`` chat instead."""
PROMPT_VERSION = "v8"
ExampleOrder = Literal["auto", "registry", "similar", "recall"]
GrammarUse = Literal["always", "fallback", "never"]
REASONING = "Reasoning:"
"""The line of a worked example (and of an answer to it) that gives the reasoning before the answer."""
STOP = ("\n\n",)
"""An answer has no blank line; one marks the model starting another example."""


@cache
def prompt_versions() -> list[str]:
    """The prompt versions shipped in the package (directories of ``taskcond/prompts``)."""
    root = resources.files("taskcond").joinpath("prompts")
    return sorted(entry.name for entry in root.iterdir() if entry.is_dir() and not entry.name.startswith("_"))


def _prompt_file(name: str, version: str):
    """The file ``taskcond/prompts/<version>/<name>``, else the one of the version named in the version's
    ``parent.txt`` file (a version that changes some prompts and keeps the others); ``None`` when neither has
    it."""
    root = resources.files("taskcond").joinpath("prompts")
    while True:
        path = root.joinpath(f"{version}/{name}")
        if path.is_file():
            return path
        parent = root.joinpath(f"{version}/parent.txt")
        if not parent.is_file():
            return None
        version = parent.read_text(encoding="utf-8").strip()


def load_prompt(name: str, version: str = PROMPT_VERSION) -> Template:
    """A prompt template from ``taskcond/prompts/<version>/<name>.txt`` (or its parent version's)."""
    path = _prompt_file(f"{name}.txt", version)
    if path is None:
        raise ValueError(f"no prompt {name!r} in prompt version {version!r}")
    return Template(path.read_text(encoding="utf-8"))


@cache
def uses_code_form(version: str = PROMPT_VERSION) -> bool:
    """Whether a prompt version asks a left-out primitive for its condition as a Python function (one chat,
    :mod:`taskcond.code_form`) instead of the two chain-of-thought chats: it has a ``code.txt`` prompt."""
    return _prompt_file("code.txt", version) is not None


@cache
def code_only(version: str = PROMPT_VERSION) -> bool:
    """Whether a prompt version asks every condition, a generated one too, in the code form: it has a
    ``code.txt`` prompt and no two-chat prompts (``spatial.txt``, ``state.txt``). One chat instead of two
    halves the requests and the tokens evaluated per condition (BENCHMARKS.md, issue 34)."""
    return uses_code_form(version) and _prompt_file("spatial.txt", version) is None


def similarity(a: Primitive, b: Primitive) -> tuple[int, int]:
    """How alike two primitives' task names are, from their form only: the same number of objects first,
    then the number of words their patterns share (letters excluded)."""

    def words(p: Primitive) -> set[str]:
        return {w for w in p.pattern.split() if w not in set(LETTERS)}

    return (int(a.n_objects == b.n_objects), len(words(a) & words(b)))


@cache
def load_reasons(chat: Chat, version: str = PROMPT_VERSION) -> dict[str, str] | None:
    """The worked reasoning of a prompt version's examples, ``letter task name → one-line reason``, from
    ``taskcond/prompts/<version>/reasons_<chat>.txt`` (lines ``grasp A: ...``); ``None`` when the version
    shows bare examples. Each reason speaks of its own example only, so leaving a primitive's example
    out leaves its reason out too."""
    path = _prompt_file(f"reasons_{chat}.txt", version)
    if path is None:
        return None
    reasons: dict[str, str] = {}
    for line in path.read_text(encoding="utf-8").splitlines():
        name, sep, reason = line.partition(":")
        if sep and reason.strip():
            reasons[" ".join(name.split())] = " ".join(reason.split())
    missing = [pid for pid in example_conditions() if letter_example(pid).task_name not in reasons]
    if missing:
        raise ValueError(f"prompt version {version!r}: reasons_{chat}.txt lacks the examples of {missing}")
    return reasons


def example_turns(
    chat: Chat,
    exclude: Iterable[str] = (),
    order_seed: int | None = None,
    nearest: Primitive | None = None,
    reasons: dict[str, str] | None = None,
) -> list[tuple[str, str]]:
    """The examples of a chat's prompt as ``(task name line, answer)`` pairs: every primitive's letter
    example not in ``exclude``, cut to the chat's half of the condition, in registry order (so prompts
    share a long cacheable prefix). ``order_seed`` shuffles their order (a trial of the evaluation). With
    ``nearest`` (the question's primitive), the examples are then stably sorted by :func:`similarity` to
    it, the most similar last, next to the question. With ``reasons`` (see :func:`load_reasons`), each
    answer opens with a ``Reasoning:`` line: a worked few-shot chain of thought (Wei et al., 2022) that
    the model imitates before it answers."""
    excluded = set(exclude)
    ids = [pid for pid in example_conditions() if pid not in excluded]
    if order_seed is not None:
        random.Random(order_seed).shuffle(ids)
    if nearest is not None:
        ids.sort(key=lambda pid: similarity(PRIMITIVES[pid], nearest))
    spatial = chat == "spatial"
    turns = []
    for pid in ids:
        example = letter_example(pid)
        name_line, rest = example.only(spatial).to_text(include_collisions=spatial).split("\n", 1)
        reason = [f"{REASONING} {reasons[example.task_name]}"] if reasons else []
        turns.append((name_line, "\n".join([*reason, rest])))
    return turns


def code_turns(
    task: ParsedTask, exclude: Iterable[str] = (), order_seed: int | None = None
) -> list[tuple[str, str]]:
    """The examples of the code form as ``(signature, body)`` pairs (:mod:`taskcond.code_form`): every
    primitive's letter example not in ``exclude``, in registry order or in the order ``order_seed``
    shuffles all of them into. Shuffling all, then leaving some out, gives the remaining examples a
    uniformly random order as shuffling them would, and the prompts of one order, whichever primitive
    they leave out, share the examples before the first one left out: a prefix llama.cpp reuses."""
    ids = list(PRIMITIVES)
    if order_seed is not None:
        random.Random(order_seed).shuffle(ids)
    excluded = set(exclude)
    ids = [pid for pid in ids if pid not in excluded]
    turns = []
    for pid in ids:
        example_task = parse_task(example_conditions()[pid].task_name)
        turns.append((code_form.signature(example_task), code_form.body(letter_example(pid), example_task)))
    return turns


def order_seeds(order_seed: int | None, n: int) -> list[int | None]:
    """The example orders of ``n`` samples: ``order_seed`` itself first (one sample asks what no sampling
    asks), then orders derived from it and the sample's number."""
    return [order_seed, *(zlib.crc32(f"{order_seed}:{i}".encode()) for i in range(1, n))]


def examples_block(
    chat: Chat,
    exclude: Iterable[str] = (),
    order_seed: int | None = None,
    nearest: Primitive | None = None,
    reasons: dict[str, str] | None = None,
) -> str:
    """The examples part of a one-message prompt: the :func:`example_turns` as text."""
    return _as_text(example_turns(chat, exclude, order_seed, nearest, reasons))


def _as_text(turns: list[tuple[str, str]]) -> str:
    """Example turns as one text: each task name line above its answer, a blank line between two."""
    return "\n\n".join(f"{name}\n{answer}" for name, answer in turns)


def _alternatives(options: Iterable[str]) -> str:
    return " | ".join(f'"{o}"' for o in options)


def answer_grammar(chat: Chat, task: ParsedTask, max_lines: int = 6, reasoning: bool = False) -> str:
    """GBNF grammar of a valid answer for ``chat``: the Listing 1 format with only the task's letters, the
    gripper, and the chat's half of the vocabulary; with ``reasoning``, after one free ``Reasoning:``
    line. State answers are written in the examples' order (the gripper, then each container), which
    leaves no room for two states of one thing."""
    letters = list(task.letters().values())
    objects = [*letters, GRIPPER]
    if chat == "spatial":
        pairs = [(a, b) for a in objects for b in objects if a != b]
        cond = " | ".join(f'"{a} " rel " {b}"' for a, b in pairs)
        extra = [
            f"rel ::= {_alternatives(RELATIONS)}",
            f"pair ::= {_alternatives(f'{a} and {b}' for a, b in pairs)}",
        ]
        extra.append('colls ::= "none" | pair (", " pair){0,5}')
        tail = ' "Collisions: " colls "\\n"'
        conds = [
            f'conds ::= "  none\\n" | ("  " cond "\\n"){{1,{max_lines}}}',
            f"cond ::= {cond}",
        ]
    else:
        # at most one gripper line, then at most one state per container in letter order (the order of
        # the examples): no answer can grasp and not grasp, or leave a container both open and closed
        states = [f"state-{letter.lower()}" for letter in letters]
        starts = ["gripper " + " ".join(f"{r}?" for r in states)]
        starts += [" ".join([r, *(f"{q}?" for q in states[i + 1 :])]) for i, r in enumerate(states)]
        conds = [f'conds ::= "  none\\n" | {" | ".join(starts)}']
        conds.append('gripper ::= "  gripper grasping " item "\\n" | "  gripper not grasping\\n"')
        conds += [
            f'{r} ::= "  {letter} open\\n" | "  {letter} closed\\n"'
            for r, letter in zip(states, letters, strict=True)
        ]
        extra = [f"item ::= {_alternatives(letters)}"]
        tail = ' "\\n"'  # a blank line ends the answer, as it ends each example
    head = f'"{REASONING} " [^\\n]+ "\\n" ' if reasoning else ""
    rules = [
        f'root ::= {head}"Relevant objects: " objs "\\nPre-conditions:\\n" conds '
        f'"Post-conditions:\\n" conds{tail}',
        f'objs ::= obj (", " obj){{0,{len(objects) - 1}}}',
        *conds,
        f"obj ::= {_alternatives(objects)}",
        *extra,
    ]
    return "\n".join(rules) + "\n"


def code_grammar(task: ParsedTask, max_lines: int = 6) -> str:
    """GBNF grammar of a valid function body (:mod:`taskcond.code_form`) for ``task``: asserts of the
    vocabulary on the gripper and the task's objects, the robot call, the returned contacts."""
    params = code_form.parameters(task)
    objects = [GRIPPER, *params]
    methods = [r.replace(" ", "_") for r in RELATIONS]
    call = code_form.robot_call(task)
    return (
        "\n".join(
            [
                f'root ::= "    # before\\n" line{{0,{max_lines}}} "    {call}\\n    # after\\n" '
                f'line{{0,{max_lines}}} "    return [" contacts "]{code_form.CONTACTS_COMMENT}\\n"',
                'line ::= "    assert " pred "\\n"',
                f'pred ::= "{GRIPPER}.holding(" item ")" | param ".is_open()" | param ".is_closed()" '
                '| any "." rel "(" any ")"',
                f"item ::= {_alternatives(['None', *params])}",
                f"param ::= {_alternatives(params)}",
                f"any ::= {_alternatives(objects)}",
                f"rel ::= {_alternatives(methods)}",
                'contacts ::= "" | pair (", " pair){0,5}',
                'pair ::= "(" any ", " any ")"',
            ]
        )
        + "\n"
    )


def _after_reasoning(lines: list[str]) -> list[str]:
    """The lines of an answer from its ``Relevant objects:`` line on (what precedes it is the model's
    reasoning); without that line, every line but the ``Reasoning:`` ones."""
    for i, line in enumerate(lines):
        if line.strip().lower().startswith("relevant objects:"):
            return lines[i:]
    return [ln for ln in lines if not ln.startswith(REASONING)]


def parse_answer(text: str, chat: Chat, task: ParsedTask, reasoning: bool = False) -> TaskCondition:
    """Validate one chat's answer and map its letters back to the task's objects.

    Checks form only: the Listing 1 layout (a function body in the ``"code"`` chat,
    :func:`taskcond.code_form.parse_body`), the vocabulary, the chat's half of it, that every object is one
    of the task's letters or the gripper, and that no two conditions of one list contradict each other by
    the vocabulary's meaning (:func:`~taskcond.conditions.contradictions`; never what a primitive needs).
    With ``reasoning`` (prompts whose examples reason first), whatever precedes the ``Relevant objects:``
    line is the model's reasoning and is not parsed. Raises :class:`ConditionError` saying what is wrong.
    """
    if chat == "code":
        return validate(code_form.parse_body(text, task), chat, task)
    body = text.strip().strip("`").strip()
    if not body:
        raise ConditionError("the answer is empty")
    lines = [ln for ln in body.splitlines() if not ln.strip().lower().startswith(("q:", "a:"))]
    if reasoning:
        lines = _after_reasoning(lines)
    return validate(TaskCondition.from_text("\n".join(lines), task_name=task.letter_name), chat, task)


def validate(cond: TaskCondition, chat: Chat, task: ParsedTask) -> TaskCondition:
    """The checks of :func:`parse_answer` on a condition read from an answer (objects as the task's
    letters, any case); returns it with the task's objects. The ``"code"`` chat gives both halves."""
    to_object = {letter.lower(): obj for obj, letter in task.letters().items()}
    allowed = {*to_object, GRIPPER}
    names = set(cond.relevant_objects) | cond.mentioned_objects()
    unknown = sorted(names - allowed)
    if unknown:
        valid = ", ".join([*(letter.upper() for letter in to_object), GRIPPER])
        raise ConditionError(f"it names objects not in the task: {', '.join(unknown)}; use only {valid}")
    if not cond.relevant_objects:
        raise ConditionError("'Relevant objects:' is empty")
    unlisted = sorted(cond.mentioned_objects() - set(cond.relevant_objects))
    if unlisted:
        raise ConditionError(
            f"conditions name objects missing from 'Relevant objects:': {', '.join(unlisted)}"
        )
    if chat != "code":
        wrong = [
            str(p)
            for p in (*cond.pre_conditions, *cond.post_conditions)
            if is_spatial(p) != (chat == "spatial")
        ]
        if wrong:
            kind = (
                "spatial relations (above, below, inside, in front of)"
                if chat == "spatial"
                else "object states"
            )
            raise ConditionError(f"{', '.join(wrong)} not allowed here: give only {kind}")
    if chat == "state" and cond.collisions:
        raise ConditionError("give no collisions here, only object states")
    for pred in (*cond.pre_conditions, *cond.post_conditions):
        if isinstance(pred, ContainerState) and pred.container == GRIPPER:
            raise ConditionError(f"{pred}: the gripper is not a container")
        if isinstance(pred, GripperState) and pred.obj == GRIPPER:
            raise ConditionError(f"{pred}: the gripper cannot grasp itself")
    for pred in (*cond.pre_conditions, *cond.post_conditions):
        if isinstance(pred, SpatialRelation) and pred.subject == pred.reference:
            raise ConditionError(f"{pred}: an object cannot be in a relation with itself")
    for title, preds in (("pre-conditions", cond.pre_conditions), ("post-conditions", cond.post_conditions)):
        clashes = contradictions(preds)
        if clashes:
            if chat == "code":
                a, b = (code_form.assert_line(x) for x in clashes[0])
            else:
                a, b = (" ".join(w.upper() if len(w) == 1 else w for w in str(x).split()) for x in clashes[0])
            raise ConditionError(f"the {title} '{a}' and '{b}' contradict each other: keep at most one")
    for col in cond.collisions:
        if col.a == col.b:
            raise ConditionError(f"collision {col}: an object cannot collide with itself")
    return cond.rename(to_object, task_name=task.name)


def _majority(
    conditions: Sequence[TaskCondition], task_name: str, voters: int | None = None
) -> TaskCondition:
    """Self-consistency: keep every object, condition and collision more than half the samples contain;
    ``voters`` samples in all (default: ``conditions``), those not among ``conditions`` stating nothing."""
    need = (voters or len(conditions)) / 2

    def vote(field_values: list[tuple]) -> tuple:
        counts: Counter = Counter()
        first: dict = {}
        for values in field_values:
            for v in dict.fromkeys(values):
                counts[v] += 1
                first.setdefault(v, len(first))
        return tuple(sorted((v for v in counts if counts[v] > need), key=first.__getitem__))

    return TaskCondition(
        task_name=task_name,
        relevant_objects=vote([c.relevant_objects for c in conditions]),
        pre_conditions=vote([c.pre_conditions for c in conditions]),
        post_conditions=vote([c.post_conditions for c in conditions]),
        collisions=vote([c.collisions for c in conditions]),
    )


@dataclass
class ChatTranscript:
    """What one chat asked and got: every answer in order (rejected ones with their errors)."""

    chat: Chat
    messages: tuple[ChatMessage, ...]
    shared_messages: int = 0
    answers: list[str] = field(default_factory=list)
    errors: list[str] = field(default_factory=list)
    cached: bool = True


@dataclass
class GenerationResult:
    """A generated task condition with how it came about: ``model`` is ``BACKEND:MODEL`` of the backend
    asked (:meth:`ConditionGenerator.backend_for`)."""

    condition: TaskCondition
    mode: Mode
    excluded: tuple[str, ...]
    transcripts: list[ChatTranscript]
    seconds: float
    model: str

    @property
    def cached(self) -> bool:
        return all(t.cached for t in self.transcripts)

    @property
    def attempts(self) -> int:
        return sum(len(t.answers) for t in self.transcripts)


@dataclass
class ConditionGenerator:
    """Generates task conditions with two chats of ``backend`` (paper §III-B/C).

    Attributes:
        backend: any :class:`~taskcond.llm.base.ChatBackend`.
        generation_backend: the backend of generation conditions (the task's primitive has its example in
            the prompt), None: :attr:`backend` (:meth:`backend_for`, :meth:`from_config`).
        max_retries: how often a chat is asked again after an invalid answer.
        samples: self-consistency samples per chat (1: a single greedy answer).
        temperature: sampling temperature when ``samples > 1``.
        grammar: when to send the answer grammar (constrained decoding): ``"fallback"`` (default) lets the
            model answer freely and constrains only the retries after an invalid answer, as llama.cpp's
            grammar sampling is several times slower than free decoding (BENCHMARKS.md, Speed);
            ``"always"`` constrains every request; ``"never"`` relies on the validator alone.
        prompt_version: directory of the prompt files.
        example_order: ``"registry"`` (the registry's order, shuffled by the trial's ``order_seed``),
            ``"similar"`` (then the examples most similar to the task's primitive last, next to the
            question; see :func:`similarity`), ``"recall"`` (the registry's order, then the task's own
            example once more, right before the question, if it is shown: every prompt shares the prefix
            of all examples, which llama.cpp reuses), or ``"auto"`` (default): ``"recall"`` in the
            few-shot turns layout, ``"registry"`` in the one-message layout (why: BENCHMARKS.md,
            Accuracy).
    """

    backend: ChatBackend
    generation_backend: ChatBackend | None = None
    max_retries: int = 2
    samples: int = 1
    temperature: float = 0.7
    grammar: GrammarUse = "fallback"
    prompt_version: str = PROMPT_VERSION
    example_order: ExampleOrder = "auto"

    @classmethod
    def from_config(cls, config: LLMConfig, **settings: Any) -> ConditionGenerator:
        """The generator of ``config``'s model for each mode (:meth:`LLMConfig.for_mode`), each backend
        loaded on its first request; ``settings`` are the other attributes."""
        from taskcond.llm.config import make_backend

        general, generation = config.for_mode("generalization"), config.for_mode("generation")
        other = make_backend(generation) if generation != general else None
        return cls(make_backend(general), other, **settings)

    def backend_for(self, mode: Mode) -> ChatBackend:
        """The backend that answers ``mode``'s conditions."""
        return (self.generation_backend or self.backend) if mode == "generation" else self.backend

    def model_for(self, mode: Mode) -> str:
        """``BACKEND:MODEL`` of :meth:`backend_for` ``mode``."""
        backend = self.backend_for(mode)
        return f"{backend.name}:{backend.model}"

    @property
    def model(self) -> str:
        """``BACKEND:MODEL`` of the backend, or of each mode's where they differ
        (``generation=BACKEND:MODEL,generalization=BACKEND:MODEL``)."""
        names = {mode: self.model_for(mode) for mode in get_args(Mode)}
        if len(set(names.values())) == 1:
            return names["generation"]
        return ",".join(f"{mode}={name}" for mode, name in names.items())

    def messages(
        self, chat: Chat, task: ParsedTask, exclude: Iterable[str] = (), order_seed: int | None = None
    ) -> tuple[ChatMessage, ...]:
        """The opening messages of one chat for ``task``; see :meth:`layout`."""
        return self.layout(chat, task, exclude, order_seed)[0]

    def layout(
        self, chat: Chat, task: ParsedTask, exclude: Iterable[str] = (), order_seed: int | None = None
    ) -> tuple[tuple[ChatMessage, ...], int]:
        """The opening messages of one chat for ``task``; chain-of-thought (Listing 4) when the task's
        primitive is excluded, its examples then with their worked reasoning if the prompt version has it
        (:func:`load_reasons`).

        A prompt file with ``$examples`` is one user message holding the examples and the question (the
        paper's layout). A prompt file without it is the system message of a few-shot chat (prompt v5's
        generation): each example is a user turn (its task name) and an assistant turn (its answer), and
        the question is the last user turn, so the model answers as it has answered before. The examples'
        order follows :attr:`example_order`.

        Returns the messages and how many of them lead every prompt of this chat, task primitive aside
        (the system message and the examples before the repeated own example; 0 in the one-message
        layout): the prefix a backend may keep (:attr:`~taskcond.llm.base.ChatRequest.shared_messages`).
        """
        excluded = set(exclude)
        if chat == "code":
            return self._code_layout(task, excluded, order_seed)
        cot = task.primitive.id in excluded
        template = load_prompt(f"{chat}_cot" if cot else chat, self.prompt_version)
        one_message = "$examples" in template.template
        order = (
            self.example_order if self.example_order != "auto" else "registry" if one_message else "recall"
        )
        nearest = task.primitive if order == "similar" else None
        reasons = load_reasons(chat, self.prompt_version) if cot else None
        examples = example_turns(chat, excluded, order_seed, nearest, reasons)
        shared = 1 + 2 * len(examples)
        if order == "recall":
            own = f"Task name: {letter_example(task.primitive.id).task_name}"
            examples += [turn for turn in examples if turn[0] == own]
        if one_message:
            text = template.substitute(examples=_as_text(examples), task=task.letter_name)
            return (ChatMessage("user", text),), 0
        turns = [ChatMessage("system", template.template.strip())]
        for name, answer in examples:
            turns += [ChatMessage("user", name), ChatMessage("assistant", answer)]
        return (*turns, ChatMessage("user", f"Task name: {task.letter_name}")), shared

    def _code_layout(
        self, task: ParsedTask, excluded: set[str], order_seed: int | None
    ) -> tuple[tuple[ChatMessage, ...], int]:
        """The code form's chat (:meth:`layout`): the system message, each example's signature and body as
        a user and an assistant turn, the task's signature last. Where the task's own primitive is shown
        and the order is ``"recall"`` (``"auto"`` here), its example is repeated right before the
        question; the prompts then share everything before the repeat. A left-out primitive has no
        example to repeat: its prompt is the same whatever the order setting."""
        turns = [ChatMessage("system", load_prompt("code", self.prompt_version).template.strip())]
        examples = code_turns(task, excluded, order_seed)
        for name, answer in examples:
            turns += [ChatMessage("user", name), ChatMessage("assistant", answer)]
        shared = 0
        if self.example_order in ("auto", "recall") and task.primitive.id not in excluded:
            own = code_form.signature(parse_task(example_conditions()[task.primitive.id].task_name))
            shared = len(turns)
            for name, answer in examples:
                if name == own:
                    turns += [ChatMessage("user", name), ChatMessage("assistant", answer)]
        return (*turns, ChatMessage("user", code_form.signature(task))), shared

    def prompt(
        self, chat: Chat, task: ParsedTask, exclude: Iterable[str] = (), order_seed: int | None = None
    ) -> str:
        """The :meth:`messages` as one text, a blank line between two messages: the prompt itself in the
        one-message layout."""
        return "\n\n".join(m.content for m in self.messages(chat, task, exclude, order_seed))

    def _chat(
        self,
        backend: ChatBackend,
        chat: Chat,
        task: ParsedTask,
        seed: int,
        temperature: float,
        transcript: ChatTranscript,
    ) -> TaskCondition:
        messages = list(transcript.messages)
        code = chat == "code"
        reasoning = not code and any(REASONING in m.content for m in messages)
        grammar = None
        if self.grammar != "never":
            grammar = code_grammar(task) if code else answer_grammar(chat, task, reasoning=reasoning)
        for attempt in range(self.max_retries + 1):
            constrained = self.grammar == "always" or (self.grammar == "fallback" and attempt > 0)
            resample = attempt >= 2  # a greedy second retry mostly repeats the first one
            request = ChatRequest(
                messages=tuple(messages),
                stop=STOP,
                sampling=Sampling(
                    temperature=max(temperature, self.temperature) if resample else temperature,
                    max_tokens=240 if code else 160,
                    seed=seed + attempt,
                ),
                grammar=grammar if constrained else None,
                shared_messages=transcript.shared_messages,
            )
            response = backend.chat(request)
            transcript.cached &= response.cached
            transcript.answers.append(response.text)
            try:
                return parse_answer(response.text, chat, task, reasoning)
            except ConditionError as exc:
                transcript.errors.append(str(exc))
                retry = load_prompt("code_retry" if code else "retry", self.prompt_version).substitute(
                    error=exc,
                    task=task.letter_name,
                    objects=", ".join([*task.letters().values(), GRIPPER]),
                    function=code_form.signature(task).split("\n", 1)[0].removeprefix("def ").rstrip(":"),
                )
                messages += [ChatMessage("assistant", response.text), ChatMessage("user", retry)]
        lines = transcript.answers[-1].splitlines()
        if reasoning:  # the part the validator refused, not the reasoning before it
            lines = _after_reasoning(lines)
        last = " ".join(" ".join(lines).split())[:120]
        raise LLMError(
            f"{backend.model} gave no valid {chat} answer for {task.name!r} in {self.max_retries + 1} "
            f"attempts; last answer {last!r}: {transcript.errors[-1]}",
            backend=backend.name,
        )

    def _code_votes(
        self,
        backend: ChatBackend,
        task: ParsedTask,
        excluded: tuple[str, ...],
        order_seed: int | None,
        seed: int,
    ) -> tuple[TaskCondition, list[ChatTranscript]]:
        """The code form's answer for a left-out primitive: one greedy answer per example order of
        :func:`order_seeds` (:attr:`samples` of them), and with several, every condition more than half
        of them state (self-consistency over example orders; an order without a valid answer states
        nothing). Raises the last :class:`LLMError` when no order gave a valid answer."""
        transcripts, answers = [], []
        error: LLMError | None = None
        for order in order_seeds(order_seed, self.samples):
            transcript = ChatTranscript("code", *self.layout("code", task, excluded, order))
            transcripts.append(transcript)
            try:
                answers.append(self._chat(backend, "code", task, seed, 0.0, transcript))
            except LLMError as exc:
                error = exc
        if not answers:
            assert error is not None
            raise error
        if self.samples == 1:
            return answers[0], transcripts
        return _majority(answers, task.name, voters=self.samples), transcripts

    def generate(
        self,
        task_name: str | ParsedTask,
        exclude: Iterable[str] = (),
        order_seed: int | None = None,
        seed: int = 0,
    ) -> GenerationResult:
        """Generate the task condition of ``task_name``.

        Args:
            task_name: e.g. ``"move bottle into box"`` (parsed by :func:`taskcond.primitives.parse_task`).
            exclude: primitive ids whose examples are left out of the prompts; excluding the task's own
                primitive makes this generalization (§III-C).
            order_seed: shuffles the order of the examples in the prompts.
            seed: sampling seed.

        Raises:
            TaskNameError: the task name does not parse.
            LLMError: the backend failed, or gave no valid answer within the retry bound.
        """
        start = time.perf_counter()
        task = task_name if isinstance(task_name, ParsedTask) else parse_task(task_name)
        excluded = tuple(get_primitive(pid).id for pid in exclude)
        if task.primitive.id not in example_conditions() and task.primitive.id not in excluded:
            excluded += (task.primitive.id,)  # a declared primitive has no example: always generalized
        mode: Mode = "generalization" if task.primitive.id in excluded else "generation"
        backend, model = self.backend_for(mode), self.model_for(mode)
        if uses_code_form(self.prompt_version) and (
            mode == "generalization" or code_only(self.prompt_version)
        ):
            condition, transcripts = self._code_votes(backend, task, excluded, order_seed, seed)
            seconds = time.perf_counter() - start
            return GenerationResult(condition, mode, excluded, transcripts, seconds, model)
        parts: dict[Chat, TaskCondition] = {}
        transcripts = []
        for chat in CHATS:
            transcript = ChatTranscript(chat, *self.layout(chat, task, excluded, order_seed))
            transcripts.append(transcript)
            if self.samples <= 1:
                parts[chat] = self._chat(backend, chat, task, seed, 0.0, transcript)
            else:
                answers = [
                    self._chat(backend, chat, task, seed + i, self.temperature, transcript)
                    for i in range(self.samples)
                ]
                parts[chat] = _majority(answers, task.name)
        condition = TaskCondition.merge(parts["spatial"], parts["state"])
        return GenerationResult(
            condition=condition,
            mode=mode,
            excluded=excluded,
            transcripts=transcripts,
            seconds=time.perf_counter() - start,
            model=model,
        )


__all__ = [
    "CHATS",
    "ConditionGenerator",
    "GenerationResult",
    "answer_grammar",
    "code_grammar",
    "code_only",
    "code_turns",
    "example_turns",
    "examples_block",
    "load_prompt",
    "load_reasons",
    "order_seeds",
    "parse_answer",
    "prompt_versions",
    "similarity",
    "uses_code_form",
    "validate",
]
