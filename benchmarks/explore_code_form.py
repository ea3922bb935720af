"""Leave-one-out in the code form as a Python file the model continues (raw completion), beside the chat.

Prompt version v6 (the default) asks a left-out primitive's condition as a Python function in a chat
(:mod:`taskcond.code_form`; ``taskcond eval conditions`` measures it). This script measures the other way
of asking the same, which the chat backends cannot: the examples' functions in one file (the header of
v6's ``code.txt`` as comments) whose last function the coder model continues through llama.cpp's raw
completion, greedy. The answer is read and validated by the generator's own parser; an answer that does
not read back counts as wrong. Each order is the registry order (order 0) or a shuffle of the examples
seeded by the order number; ``--vote K`` also scores the majority, per condition, of K consecutive orders.
Task objects are the letters' own example objects (the Table II reference of each primitive's example).

    .venv/bin/python benchmarks/explore_code_form.py [--orders 15] [--vote 5]
"""

from __future__ import annotations

import argparse
import time

from taskcond import code_form
from taskcond.conditions import ConditionError, TaskCondition
from taskcond.examples import example_conditions
from taskcond.generator import _majority, code_turns, load_prompt, parse_answer
from taskcond.llm.models import DEFAULT_EMBEDDED_MODEL, get_embedded_model, model_path
from taskcond.primitives import PRIMITIVES, parse_task


def prompt_for(pid: str, order: int) -> str:
    """The file the model continues: the header, every other primitive's function, the left-out opening."""
    task = parse_task(example_conditions()[pid].task_name)
    header = "".join(f"# {line}\n" for line in load_prompt("code").template.strip().splitlines()[:-1])
    turns = code_turns(task, exclude=[pid], order_seed=order or None)
    functions = "".join(f"{name}\n{body}\n\n\n" for name, body in turns)
    return f"{header}\n{functions}{code_form.signature(task)}\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--orders", type=int, default=15, help="example orders per primitive (0 = registry order)"
    )
    ap.add_argument("--vote", type=int, default=5, help="orders per majority vote (0: no vote)")
    args = ap.parse_args()
    if args.orders < 1 or not 0 <= args.vote <= args.orders:
        ap.error(
            f"need --orders >= 1 and 0 <= --vote <= --orders; got --orders {args.orders} --vote {args.vote}"
        )
    from llama_cpp import Llama

    llm = Llama(
        str(model_path(get_embedded_model(DEFAULT_EMBEDDED_MODEL))), n_ctx=4096, n_threads=2, verbose=False
    )
    print("| primitive | right, single orders | wrong answers' orders | right, majority votes |")
    print("|---|---|---|---|")
    total = voted_total = votes = 0
    start = time.perf_counter()
    for pid in PRIMITIVES:
        reference = example_conditions()[pid]
        task = parse_task(reference.task_name)
        conds: list[TaskCondition | None] = []
        for order in range(args.orders):
            out = llm.create_completion(
                prompt_for(pid, order), max_tokens=240, temperature=0.0, stop=["\ndef ", "\n\n"]
            )
            try:
                conds.append(parse_answer(out["choices"][0]["text"], "code", task))
            except ConditionError:
                conds.append(None)
        right = [c is not None and c.matches(reference) for c in conds]
        groups = [conds[i : i + args.vote] for i in range(0, len(conds) - args.vote + 1, args.vote or 1)]
        voted = 0
        for group in groups if args.vote else []:
            read = [c for c in group if c is not None]
            voted += bool(read) and _majority(read, task.name, voters=len(group)).matches(reference)
        total += sum(right)
        voted_total += voted
        votes += len(groups) if args.vote else 0
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
