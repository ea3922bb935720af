"""What an LLM knows, without examples, about the object states of the paper's ten primitives: a gate
beside Table II's generalization figure (beyond the paper).

Leave-one-out generalization (paper §III-C) can only be as good as the model's own knowledge of a
primitive it was shown no example of. For every primitive's example task (``taskcond/data/examples.txt``,
real object names), the model is asked, zero-shot and in plain words, the yes/no questions behind the
condition's object states: is the gripper holding the object before the task starts, and after it is done;
must each object be open before, and is it open after. The expected answer of each question is read from
the example condition. Answers are constrained to ``yes``/``no`` by a grammar where the backend supports
one (greedy); any other answer counts as wrong. A model at chance answers about half the questions as the
conditions imply; the Qwen2.5-Coder models shipped here do (BENCHMARKS.md).

The requests go through the backend given, so a cached backend answers a repeated probe from its cache.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from taskcond.conditions import ContainerState, GripperState, TaskCondition
from taskcond.examples import example_conditions
from taskcond.llm.base import ChatBackend, ChatMessage, ChatRequest, Sampling
from taskcond.primitives import parse_task

SYSTEM = (
    "You are a robotics expert. A robot arm with a two-finger gripper does one short task. Answer yes or no."
)
GRAMMAR = 'root ::= "yes" | "no"'


@dataclass(frozen=True)
class Question:
    """One yes/no question about a primitive's example task and the answer its condition implies."""

    primitive: str
    text: str
    expected: bool


@dataclass
class ProbeRow:
    """One primitive's questions and the model's answers (``None``: neither yes nor no)."""

    primitive: str
    questions: list[Question] = field(default_factory=list)
    answers: list[bool | None] = field(default_factory=list)

    @property
    def right(self) -> int:
        return sum(a is q.expected for q, a in zip(self.questions, self.answers, strict=True))


@dataclass
class ProbeResult:
    """The probe of one model: a row per primitive."""

    model: str
    rows: list[ProbeRow]

    @property
    def right(self) -> int:
        return sum(r.right for r in self.rows)

    @property
    def total(self) -> int:
        return sum(len(r.questions) for r in self.rows)

    @property
    def said_yes(self) -> int:
        return sum(a is True for r in self.rows for a in r.answers)

    @property
    def expected_yes(self) -> int:
        return sum(q.expected for r in self.rows for q in r.questions)

    def summary(self) -> str:
        """``state probe: 23/46 (chance ≈ 23)``: the questions answered as the conditions imply."""
        return f"state probe: {self.right}/{self.total} (chance ≈ {self.total / 2:.0f})"

    def to_dict(self) -> dict:
        return {
            "model": self.model,
            "right": self.right,
            "total": self.total,
            "chance": self.total / 2,
            "said_yes": self.said_yes,
            "expected_yes": self.expected_yes,
            "primitives": {r.primitive: {"right": r.right, "questions": len(r.questions)} for r in self.rows},
        }


def questions(pid: str, cond: TaskCondition) -> list[Question]:
    """The gripper and container questions of one example condition."""
    task = parse_task(cond.task_name)
    obj = task.objects[0]
    start = f'The robot is about to do the task "{cond.task_name}".'
    end = f'The robot has just done the task "{cond.task_name}".'
    pre, post = cond.pre_conditions, cond.post_conditions
    out = [
        Question(pid, f"{start} Is its gripper already holding the {obj}?", GripperState(obj) in pre),
        Question(pid, f"{end} Is its gripper holding the {obj} now?", GripperState(obj) in post),
    ]
    for name in task.objects:
        out.append(
            Question(pid, f"{start} Must the {name} be open for it?", ContainerState(name, True) in pre)
        )
        out.append(Question(pid, f"{end} Is the {name} open now?", ContainerState(name, True) in post))
    return out


def ask(backend: ChatBackend, question: Question) -> bool | None:
    """The model's answer: True for yes, False for no, None for anything else. Raises
    :class:`~taskcond.llm.base.LLMError` when the backend fails."""
    request = ChatRequest(
        (ChatMessage("system", SYSTEM), ChatMessage("user", question.text)),
        Sampling(temperature=0.0, max_tokens=4),
        grammar=GRAMMAR,
    )
    answer = backend.chat(request).text.strip().lower().rstrip(".")
    return {"yes": True, "no": False}.get(answer)


def probe(backend: ChatBackend) -> ProbeResult:
    """Ask every primitive's questions (46 for the ten primitives)."""
    rows = []
    for pid, cond in example_conditions().items():
        row = ProbeRow(pid, questions(pid, cond))
        row.answers = [ask(backend, q) for q in row.questions]
        rows.append(row)
    return ProbeResult(f"{backend.name}:{backend.model}", rows)


__all__ = ["ProbeResult", "ProbeRow", "Question", "ask", "probe", "questions"]
