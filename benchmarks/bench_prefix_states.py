"""Uncached generation conditions when the prompt prefixes are on disk: the examples only (one state per
chat, as before prompt v8's per-primitive states) against the examples and the task's own repeated example
(one more state per primitive).

Both backends run in one process, each with its own prefix directory, alternating per condition (who goes
first rotates), so that both see the same load. A warm-up pass asks one task per primitive (the objects of
Table II's first trial) and keeps the prefixes on disk; each backend then drops what its slots hold, as a new
process would, and the measured pass asks tasks with other objects (the later trials' objects), every
primitive in turn, in the registry's example order, without a response cache.

    .venv/bin/python benchmarks/bench_prefix_states.py [--objects 2] [--threads 2]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import statistics
import tempfile
from pathlib import Path

from taskcond.evaluation import EVAL_OBJECTS
from taskcond.examples import reference_condition
from taskcond.generator import ConditionGenerator
from taskcond.llm.base import ChatRequest, ChatResponse
from taskcond.llm.xllamacpp_backend import XLlamaCppBackend
from taskcond.primitives import PRIMITIVES, ParsedTask


class ExamplesOnly:
    """A backend that keeps only the first shared prefix of each request (the examples)."""

    def __init__(self, backend: XLlamaCppBackend) -> None:
        self.backend = backend
        self.name = backend.name

    def chat(self, request: ChatRequest) -> ChatResponse:
        return self.backend.chat(dataclasses.replace(request, shared_messages=request.shared_messages[:1]))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--objects", type=int, default=2, help="measured tasks per primitive (at most 4)")
    ap.add_argument("--threads", type=int, default=None)
    args = ap.parse_args()
    root = Path(tempfile.mkdtemp(prefix="bench-prefixes-"))
    backends = {
        name: XLlamaCppBackend(n_threads=args.threads, prefix_dir=root / name) for name in ("examples", "own")
    }
    generators = {
        "examples": ConditionGenerator(ExamplesOnly(backends["examples"])),
        "own": ConditionGenerator(backends["own"]),
    }
    pids = [p for p in PRIMITIVES if not PRIMITIVES[p].declared]
    first: dict[str, list[float]] = {n: [] for n in generators}
    for pid in pids:  # warm-up: the first trial's objects, each primitive's first task
        for n, gen in generators.items():
            first[n].append(gen.generate(ParsedTask(PRIMITIVES[pid], EVAL_OBJECTS[pid][0])).seconds)
        print(json.dumps({"first task": pid, **{n: round(s[-1], 2) for n, s in first.items()}}), flush=True)
    for backend in backends.values():
        backend.forget()
    names = list(generators)
    seconds: dict[str, list[float]] = {n: [] for n in names}
    correct = dict.fromkeys(names, 0)
    same = 0
    hits = {n: backends[n].prefix_hits for n in names}
    for k, (i, pid) in enumerate((i, p) for i in range(1, args.objects + 1) for p in pids):
        task = ParsedTask(PRIMITIVES[pid], EVAL_OBJECTS[pid][i])
        row: dict = {"task": task.name}
        answers = {}
        for n in names[k % 2 :] + names[: k % 2]:
            out = generators[n].generate(task)
            seconds[n].append(out.seconds)
            correct[n] += out.condition.matches(reference_condition(task))
            answers[n] = out.condition.to_text()
            row[n] = round(out.seconds, 2)
        same += answers["examples"] == answers["own"]
        print(json.dumps(row), flush=True)
    print(
        "| prefixes on disk | median s, a primitive's first task (the process's first excluded) | correct "
        "| median s per condition | prefix states read | same answers |"
    )
    print("|---|---|---|---|---|---|")
    for n in names:
        print(
            f"| {n} | {statistics.median(first[n][1:]):.2f} | {correct[n]}/{len(seconds[n])} | "
            f"{statistics.median(seconds[n]):.2f} | {backends[n].prefix_hits - hits[n]} | "
            f"{same}/{len(seconds[n])} |"
        )


if __name__ == "__main__":
    main()
