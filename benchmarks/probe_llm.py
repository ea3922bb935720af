"""What an LLM knows, without examples, about the conditions of the paper's ten primitive tasks.

A diagnostic beside Table II (``taskcond eval conditions``): leave-one-out generalization (paper §III-C)
can only be as good as the model's own knowledge of a primitive it was shown no example of. For every
primitive's example task (``taskcond/data/examples.txt``, real object names), the model is asked, zero-shot
and in plain words, the yes/no questions behind the condition's object states: is the gripper holding the
object before the task starts, and after it is done; must each object be open before, and is it open after.
The expected answer of each question is read from the example condition. Answers are constrained to
``yes``/``no`` by a grammar where the backend supports one (greedy), and any other answer counts as wrong.

    .venv/bin/python benchmarks/probe_llm.py [--llm embedded]
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass

from taskcond.conditions import ContainerState, GripperState, TaskCondition
from taskcond.examples import example_conditions
from taskcond.llm.base import ChatBackend, ChatMessage, ChatRequest, LLMError, Sampling
from taskcond.llm.config import LLMConfig, make_backend
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
    """The model's answer: True for yes, False for no, None for anything else."""
    request = ChatRequest(
        (ChatMessage("system", SYSTEM), ChatMessage("user", question.text)),
        Sampling(temperature=0.0, max_tokens=4),
        grammar=GRAMMAR,
    )
    answer = backend.chat(request).text.strip().lower().rstrip(".")
    return {"yes": True, "no": False}.get(answer)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--llm", default=None, help="backend spec as for taskcond --llm (default: the configured backend)"
    )
    args = ap.parse_args()
    try:
        probe(make_backend(LLMConfig.load(args.llm)))
    except LLMError as exc:  # the rows printed so far stand; answers already given are in the response cache
        print(f"probe_llm: {exc}", file=sys.stderr)
        return 1
    return 0


def probe(backend: ChatBackend) -> None:
    """Ask every question and print a markdown table row per primitive, then the totals."""
    print(f"backend {backend.name}, model {backend.model}\n")
    print("| primitive | right | wrong answers (question: model's answer) |")
    print("|---|---|---|")
    right = total = said_yes = expected_yes = 0
    for pid, cond in example_conditions().items():
        wrong = []
        qs = questions(pid, cond)
        for q in qs:
            got = ask(backend, q)
            said_yes += got is True
            expected_yes += q.expected
            if got is q.expected:
                right += 1
            else:
                said = "no answer" if got is None else ("yes" if got else "no")
                wrong.append(f"{q.text.split('. ', 1)[1]}: {said}")
            total += 1
        print(f"| {pid} | {len(qs) - len(wrong)}/{len(qs)} | {'; '.join(wrong)} |", flush=True)
    print(f"\n{right}/{total} questions answered as the example conditions imply")
    print(f"the model said yes {said_yes} times; the conditions imply yes {expected_yes} times")


if __name__ == "__main__":
    raise SystemExit(main())
