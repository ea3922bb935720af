"""The embedded LLM's two llama.cpp runtimes side by side: xllamacpp (prebuilt) and llama-cpp-python
(compiled on install), in one run, alternating, so that both see the same load on a shared machine.

``--table2`` runs the Table II protocol (``taskcond eval conditions``: each trial of each primitive, in
generation and leave-one-out generalization) uncached with both runtimes, one condition on one and then the
same condition on the other, both models loaded in this process, and reports each runtime's accuracy, its
median seconds per condition, the median of the per-condition ratios, and every condition the two answered
differently. ``--process`` starts new processes, alternating the runtimes, and measures the first condition
of a process without and then with the prefix states a previous process left on disk, and each process's
peak resident memory.

    .venv/bin/python benchmarks/bench_runtimes.py --table2 [--trials 3] [--mode generation] [--threads N]
        [--out F.json]
    .venv/bin/python benchmarks/bench_runtimes.py --process [--rounds 2]
"""

from __future__ import annotations

import argparse
import json
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from taskcond.evaluation import score_trial
from taskcond.generator import ConditionGenerator
from taskcond.llm.config import EMBEDDED_RUNTIMES, runtime_label
from taskcond.primitives import PRIMITIVES

FIRST_TASK = "move bottle into box"


def backend(runtime: str, prefix_dir: Path | None = None, threads: int | None = None):
    if runtime == "xllamacpp":
        from taskcond.llm.xllamacpp_backend import XLlamaCppBackend

        return XLlamaCppBackend(n_threads=threads, prefix_dir=prefix_dir)
    from taskcond.llm.embedded import EmbeddedBackend

    return EmbeddedBackend(n_threads=threads, prefix_dir=prefix_dir)


def table2(args: argparse.Namespace) -> None:
    runtimes = list(EMBEDDED_RUNTIMES)
    generators = {r: ConditionGenerator(backend(r, threads=args.threads)) for r in runtimes}
    pids = [p for p in PRIMITIVES if not PRIMITIVES[p].declared]
    records = []
    k = 0
    for mode in args.mode or ["generation", "generalization"]:
        for trial in range(args.trials):
            for pid in pids:
                pair = {}
                for r in runtimes if k % 2 == 0 else runtimes[::-1]:  # who goes first alternates
                    outcome = score_trial(generators[r], pid, mode, trial)
                    pair[r] = {
                        "correct": outcome.correct,
                        "seconds": round(outcome.seconds, 3),
                        "answer": outcome.answer if outcome.answer is not None else outcome.error,
                    }
                k += 1
                records.append({"mode": mode, "trial": trial, "primitive": pid, **pair})
                print(json.dumps(records[-1]), file=sys.stderr, flush=True)
    report = {"runtimes": {r: runtime_label(r) for r in runtimes}, "records": records}
    if args.out:
        Path(args.out).write_text(json.dumps(report, indent=1))
    a, b = runtimes
    print(f"| mode | runtime | correct | median s per condition | median ratio {a}/{b} | same answers |")
    print("|---|---|---|---|---|---|")
    for mode in args.mode or ["generation", "generalization"]:
        rows = [x for x in records if x["mode"] == mode]
        ratio = statistics.median(x[a]["seconds"] / x[b]["seconds"] for x in rows)
        same = sum(x[a]["answer"] == x[b]["answer"] for x in rows)
        for r in runtimes:
            correct = sum(x[r]["correct"] for x in rows)
            median = statistics.median(x[r]["seconds"] for x in rows)
            print(f"| {mode} | {runtime_label(r)} | {correct}/{len(rows)} | {median:.2f} | {ratio:.2f} | "
                  f"{same}/{len(rows)} |")  # fmt: skip
        for x in rows:
            if x[a]["answer"] != x[b]["answer"]:
                print(f"differs: {mode} trial {x['trial']} {x['primitive']}: {a} {x[a]['correct']}, "
                      f"{b} {x[b]['correct']}")  # fmt: skip


def one_process(runtime: str, prefix_dir: str, threads: int | None) -> None:
    """In a new process: load, then the first condition; prints seconds and peak memory as JSON."""
    start = time.perf_counter()
    b = backend(runtime, Path(prefix_dir), threads)
    b._load()
    load = time.perf_counter() - start
    start = time.perf_counter()
    ConditionGenerator(b).generate(FIRST_TASK)
    first = time.perf_counter() - start
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(json.dumps({"load": load, "first": first, "prefix_hits": b.prefix_hits, "peak_mib": peak}))


def processes(args: argparse.Namespace) -> None:
    runtimes = list(EMBEDDED_RUNTIMES)
    rows: dict[tuple[str, str], list[dict]] = {}
    for k in range(args.rounds):
        for r in runtimes if k % 2 == 0 else runtimes[::-1]:
            with tempfile.TemporaryDirectory() as states:
                for case in ("no prefix states", "prefix states on disk"):
                    cmd = [sys.executable, __file__, "--one", r, states]
                    cmd += ["--threads", str(args.threads)] if args.threads else []
                    out = subprocess.run(cmd, capture_output=True, text=True, check=True).stdout
                    rows.setdefault((r, case), []).append(json.loads(out.strip().splitlines()[-1]))
                    print(r, case, rows[(r, case)][-1], file=sys.stderr, flush=True)
    print("| runtime | first condition of a process | median s | model load s | prefix hits | peak RSS MiB |")
    print("|---|---|---|---|---|---|")
    for (r, case), xs in rows.items():
        med = {key: statistics.median(x[key] for x in xs) for key in ("first", "load", "peak_mib")}
        hits = [x["prefix_hits"] for x in xs]
        print(f"| {runtime_label(r)} | {case} | {med['first']:.2f} | {med['load']:.2f} | {hits} | "
              f"{med['peak_mib']:.0f} |")  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--table2", action="store_true")
    parser.add_argument("--process", action="store_true")
    parser.add_argument("--one", nargs=2, metavar=("RUNTIME", "PREFIX_DIR"), help=argparse.SUPPRESS)
    parser.add_argument("--trials", type=int, default=3)
    parser.add_argument("--mode", action="append", choices=["generation", "generalization"])
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--threads", type=int, help="CPU threads of each model (default: every core)")
    parser.add_argument("--out")
    args = parser.parse_args()
    if args.one:
        one_process(*args.one, args.threads)
    elif args.process:
        processes(args)
    else:
        table2(args)


if __name__ == "__main__":
    main()
