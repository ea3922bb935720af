"""Leave-one-out with the conditions written as Python functions: an exploration, not the generator's method.

The coder model answers leave-one-out (paper §III-C, Table II protocol) better when every example
condition is a Python function it continues as plain text than when it answers the Listing 1 format in a
chat. Each example becomes::

    def move_into(gripper, a, b):
        \"\"\"move A into B\"\"\"
        # before
        assert gripper.holding(a)
        assert b.is_open()
        robot.move_into(a, b)
        # after
        assert a.inside(b)
        ...
        return [(gripper, a)]  # allowed contacts

The left-out primitive's function is opened (signature and docstring, from its letter task name only) and
the model writes the body, greedy, through llama.cpp's raw completion (no chat template; the generator's
backends only chat, which is why this lives here). The body's asserts are read back into a condition; a
body that does not read back counts as wrong. Each order is the registry order (order 0) or a shuffle of
the examples seeded by the order number. ``--vote K`` also scores the majority, per condition, of K
consecutive orders (self-consistency over example orders).

    .venv/bin/python benchmarks/explore_code_form.py [--orders 15] [--vote 5] [--chat]

``--chat`` asks the same through the embedded chat backend instead (the code in one user message, the
function's body as the answer).
"""

from __future__ import annotations

import argparse
import random
import re
import time
from collections import Counter

from taskcond.conditions import (
    GRIPPER,
    Collision,
    ConditionError,
    ContainerState,
    GripperState,
    Predicate,
    TaskCondition,
    parse_predicate,
)
from taskcond.examples import example_conditions, letter_example
from taskcond.llm.base import ChatMessage, ChatRequest, Sampling
from taskcond.llm.embedded import EmbeddedBackend
from taskcond.llm.models import DEFAULT_EMBEDDED_MODEL, get_embedded_model, model_path
from taskcond.primitives import PRIMITIVES, parse_task

HEADER = (
    "# Each function checks one robot task: the asserts before the robot call must hold before it,\n"
    "# the asserts after it hold when it is done. gripper.holding(x): the gripper grasps x (None: nothing);\n"
    "# x.is_open() / x.is_closed(): a container's state; x.inside(y), x.above(y), x.below(y),\n"
    "# x.in_front_of(y): where x is relative to y. The list returned: the contacts allowed during the task.\n"
    "\n"
)
ASSERT = re.compile(r"assert (\w+)\.(\w+)\((\w*)\)")
CONTACT = re.compile(r"\((\w+), (\w+)\)")


def letters(pid: str) -> list[str]:
    """The letters of a primitive's objects (``A``, ``B``)."""
    return list(parse_task(example_conditions()[pid].task_name).letters().values())


def code_line(pred: Predicate) -> str:
    """One condition as an assert (objects as lower-case variables)."""
    if isinstance(pred, GripperState):
        return f"assert gripper.holding({pred.obj.lower() if pred.obj else 'None'})"
    if isinstance(pred, ContainerState):
        return f"assert {pred.container.lower()}.is_{'open' if pred.is_open else 'closed'}()"
    return f"assert {pred.subject.lower()}.{pred.relation.value.replace(' ', '_')}({pred.reference.lower()})"


def signature(pid: str) -> str:
    """The opening of a primitive's function: its name, its objects, its letter task name."""
    params = "".join(f", {x.lower()}" for x in letters(pid))
    return f'def {pid}(gripper{params}):\n    """{letter_example(pid).task_name}"""\n    # before\n'


def function(pid: str) -> str:
    """A primitive's example condition as a Python function."""
    cond = letter_example(pid)
    args = ", ".join(x.lower() for x in letters(pid))
    lines = [f"    {code_line(p)}" for p in cond.pre_conditions]
    lines += [f"    robot.{pid}({args})", "    # after"]
    lines += [f"    {code_line(p)}" for p in cond.post_conditions]
    contacts = ", ".join(f"({c.a.lower()}, {c.b.lower()})" for c in cond.collisions)
    lines.append(f"    return [{contacts}]  # allowed contacts")
    return signature(pid) + "\n".join(lines) + "\n\n\n"


def condition_text(subject: str, method: str, arg: str) -> str:
    """The vocabulary's string of one assert (the inverse of :func:`code_line`)."""
    if method == "holding":
        return f"{subject} not grasping" if arg == "None" else f"{subject} grasping {arg}"
    if method in ("is_open", "is_closed"):
        return f"{subject} {method.removeprefix('is_')}"
    return f"{subject} {method.replace('_', ' ')} {arg}"


def read_body(pid: str, body: str) -> TaskCondition:
    """The condition a function body states (objects as lower-case letters); raises ConditionError."""
    names = {x.lower() for x in letters(pid)} | {GRIPPER}
    pre: list[Predicate] = []
    post: list[Predicate] = []
    contacts: list[Collision] = []
    current = pre
    for line in (ln.strip() for ln in body.splitlines()):
        if line.startswith("robot.") or line == "# after":
            current = post
        elif m := ASSERT.fullmatch(line):
            if not {m[1], m[3]} <= names | {"", "None"}:
                raise ConditionError(f"unreadable line {line!r}: it names objects not in the task")
            current.append(parse_predicate(condition_text(*m.groups())))
        elif line.startswith("return"):
            pairs = CONTACT.findall(line)
            if not {x for pair in pairs for x in pair} <= names:
                raise ConditionError(f"unreadable line {line!r}: it names objects not in the task")
            contacts = [Collision(a, b) for a, b in pairs]
            break
    objects = (*(x.lower() for x in letters(pid)), GRIPPER)
    return TaskCondition("", objects, tuple(pre), tuple(post), tuple(contacts))


def prompt_for(pid: str, order: int) -> str:
    """The file the model continues: the header, every other primitive's function, the left-out opening."""
    others = [p for p in PRIMITIVES if p != pid]
    if order:
        random.Random(order).shuffle(others)
    return HEADER + "".join(function(p) for p in others) + signature(pid)


def majority(conds: list[TaskCondition | None]) -> TaskCondition:
    """Every condition and contact more than half of ``conds`` state (an unreadable body states none)."""
    read = [c for c in conds if c is not None]

    def vote(field: str) -> tuple:
        counts = Counter(x for c in read for x in set(getattr(c, field)))
        return tuple(x for x, n in counts.items() if 2 * n > len(conds))

    objects = read[0].relevant_objects if read else ()
    return TaskCondition("", objects, vote("pre_conditions"), vote("post_conditions"), vote("collisions"))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--orders", type=int, default=15, help="example orders per primitive (0 = registry order)"
    )
    ap.add_argument("--vote", type=int, default=5, help="orders per majority vote (0: no vote)")
    ap.add_argument(
        "--chat", action="store_true", help="ask through the chat backend instead of raw completion"
    )
    args = ap.parse_args()
    if args.orders < 1 or not 0 <= args.vote <= args.orders:
        ap.error(
            f"need --orders >= 1 and 0 <= --vote <= --orders; got --orders {args.orders} --vote {args.vote}"
        )
    if args.chat:
        backend = EmbeddedBackend()

        def complete(prompt: str) -> str:
            text = (
                f"```python\n{prompt}```\n\n"
                "Write the body of the last function in the same way, "
                "with only the asserts and calls used above."
            )
            answer = backend.chat(ChatRequest((ChatMessage("user", text),), Sampling(max_tokens=200))).text
            return answer.split("# before", 1)[-1].split("```")[0]
    else:
        from llama_cpp import Llama

        llm = Llama(
            str(model_path(get_embedded_model(DEFAULT_EMBEDDED_MODEL))),
            n_ctx=4096,
            n_threads=2,
            verbose=False,
        )

        def complete(prompt: str) -> str:
            out = llm.create_completion(prompt, max_tokens=160, temperature=0.0, stop=["\ndef ", "\n\n"])
            return out["choices"][0]["text"]

    print("| primitive | right, single orders | wrong answers' orders | right, majority votes |")
    print("|---|---|---|---|")
    total = voted_total = votes = 0
    start = time.perf_counter()
    for pid in PRIMITIVES:
        reference = letter_example(pid).rename({x: x.lower() for x in letters(pid)})
        conds: list[TaskCondition | None] = []
        for order in range(args.orders):
            try:
                conds.append(read_body(pid, complete(prompt_for(pid, order))))
            except ConditionError:
                conds.append(None)
        right = [c is not None and c.matches(reference) for c in conds]
        groups = (
            [conds[i : i + args.vote] for i in range(0, len(conds) - args.vote + 1, args.vote)]
            if args.vote
            else []
        )
        voted = sum(majority(g).matches(reference) for g in groups)
        total += sum(right)
        voted_total += voted
        votes += len(groups)
        wrong = ", ".join(str(i) for i, ok in enumerate(right) if not ok) or "-"
        vote_cell = f"{voted}/{len(groups)}" if args.vote else "-"
        print(f"| {pid} | {sum(right)}/{args.orders} | {wrong} | {vote_cell} |", flush=True)
    n = args.orders * len(PRIMITIVES)
    print(f"\nsingle orders: {total}/{n} ({100 * total / n:.0f}%)", end="")
    if votes:
        print(
            f"; majority of {args.vote} orders: {voted_total}/{votes} ({100 * voted_total / votes:.0f}%)",
            end="",
        )
    print(f"; {time.perf_counter() - start:.0f} s")


if __name__ == "__main__":
    main()
