"""What an LLM knows, without examples, about the conditions of the paper's ten primitive tasks: the
state probe of :mod:`taskcond.probe` as a table, one row per primitive with its wrong answers.

``taskcond eval conditions`` prints the probe's total beside the generalization figure; this script shows
which questions the model gets wrong.

    .venv/bin/python benchmarks/probe_llm.py [--llm embedded]
"""

from __future__ import annotations

import argparse
import sys

from taskcond.llm.base import LLMError
from taskcond.llm.config import LLMConfig, make_backend
from taskcond.probe import probe


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--llm", default=None, help="backend spec as for taskcond --llm (default: the configured backend)"
    )
    args = ap.parse_args()
    try:
        result = probe(make_backend(LLMConfig.load(args.llm)))
    except LLMError as exc:  # answers already given are in the response cache
        print(f"probe_llm: {exc}", file=sys.stderr)
        return 1
    print(f"model {result.model}\n")
    print("| primitive | right | wrong answers (question: model's answer) |")
    print("|---|---|---|")
    for row in result.rows:
        wrong = [
            f"{q.text.split('. ', 1)[1]}: {'no answer' if a is None else ('yes' if a else 'no')}"
            for q, a in zip(row.questions, row.answers, strict=True)
            if a is not q.expected
        ]
        print(f"| {row.primitive} | {row.right}/{len(row.questions)} | {'; '.join(wrong)} |")
    print(f"\n{result.summary()}: questions answered as the example conditions imply")
    print(f"the model said yes {result.said_yes} times; the conditions imply yes {result.expected_yes} times")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
