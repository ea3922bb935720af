"""Evaluation workers asking the embedded model at the same time: every core's threads each, or the cores
shared out among them (what :func:`taskcond.application.workers.llm_threads` gives a worker).

Each of ``--workers`` spawned processes loads the model and generates the same uncached conditions (no
response cache, no prefix states); the table gives the wall time until all are done, the median seconds
per condition, and whether every answer equals the one of the first setting (the answers must not depend
on the thread count, since the response cache does not key on it).

    .venv/bin/python benchmarks/bench_llm_workers.py [--workers 2] [--conditions 6]
"""

from __future__ import annotations

import argparse
import multiprocessing
import os
import statistics
import time

from taskcond.evaluation import EVAL_OBJECTS
from taskcond.generator import ConditionGenerator
from taskcond.llm.config import embedded_backend
from taskcond.primitives import PRIMITIVES, ParsedTask


def work(threads: int, conditions: int) -> tuple[list[float], list[str]]:
    """Seconds and condition text of each generation condition, one per primitive in registry order."""
    generator = ConditionGenerator(embedded_backend(n_threads=threads))
    seconds, answers = [], []
    for pid in list(PRIMITIVES)[:conditions]:
        result = generator.generate(ParsedTask(PRIMITIVES[pid], EVAL_OBJECTS[pid][0]), order_seed=0)
        seconds.append(result.seconds)
        answers.append(result.condition.to_text())
    return seconds, answers


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--conditions", type=int, default=6, help="generation conditions per worker (≤ 10)")
    args = ap.parse_args()
    cores = os.cpu_count() or 1
    ctx = multiprocessing.get_context("spawn")
    print(
        f"| threads per worker ({args.workers} workers, {cores} cores) | wall s | median s per condition "
        "| answers as the first row |"
    )
    print("|---|---|---|---|")
    first = None
    for threads in (cores, max(1, cores // args.workers)):
        start = time.perf_counter()
        with ctx.Pool(args.workers) as pool:
            out = pool.starmap(work, [(threads, args.conditions)] * args.workers)
        wall = time.perf_counter() - start
        answers = [a for _, a in out]
        first = first or answers
        median = statistics.median(s for seconds, _ in out for s in seconds)
        print(f"| {threads} | {wall:.1f} | {median:.2f} | {'yes' if answers == first else 'NO'} |")


if __name__ == "__main__":
    main()
