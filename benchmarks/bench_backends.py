"""Benchmark of the evaluation backends: Ray tasks (``--backend ray``) against local worker processes.

Run: ``.venv/bin/python benchmarks/bench_backends.py [--episodes N] [--workers K] [--task T]``. Both
run the same episodes (DMP only, seeds 1000+) and are timed end to end, start-up included: the local
backend spawns its worker processes, Ray starts a local instance (none may be running) and its workers.
Prints a markdown table: wall seconds, start-up (first record), episodes per minute after it, and whether
every episode's result (success, failure, simulated seconds, adjustments) is the same.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from taskcond.application.evaluate import execution_config, run_jobs
from taskcond.application.library import default_library_dir, load_library
from taskcond.application.workers import WorkerArgs, llm_threads
from taskcond.results import Job


def timed(jobs: list[Job], backend: str, workers: int, library_dir: Path) -> tuple[list[dict], float, float]:
    """Records, wall seconds, and seconds until the first record."""
    start = time.perf_counter()
    first = None
    records = []
    args = WorkerArgs(str(library_dir), None, 0.005, llm_threads=llm_threads(workers, backend))
    for rec in run_jobs(jobs, args, workers, backend):
        first = first or time.perf_counter() - start
        records.append(rec)
    return records, time.perf_counter() - start, first or 0.0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--episodes", type=int, default=20)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--task", default="grasp-bottle")
    args = ap.parse_args()
    load_library()  # learned once if missing
    library_dir = default_library_dir()
    jobs = [Job(args.task, "none", 1000 + k) for k in range(args.episodes)]
    keys = ("success", "failure", "sim_seconds", "adjustments", "raised")
    results = {}
    print(f"config {execution_config(library_dir, 0.005).digest}; {args.episodes} x {args.task}, DMP only")
    print("| backend | workers | wall s | first episode after s | episodes/min after the first |")
    print("|---|---|---|---|---|")
    for backend in ("local", "ray"):
        records, wall, first = timed(jobs, backend, args.workers, library_dir)
        results[backend] = {r["seed"]: tuple(r.get(k) for k in keys) for r in records}
        rate = 60.0 * (len(records) - 1) / max(wall - first, 1e-9)
        print(f"| {backend} | {args.workers} | {wall:.1f} | {first:.1f} | {rate:.1f} |", flush=True)
    same = results["local"] == results["ray"]
    print(f"\nper-episode results identical: {same}")


if __name__ == "__main__":
    main()
