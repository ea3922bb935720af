"""``make bench``: every benchmark of the project in turn, each printing a markdown table.

    .venv/bin/python -m benchmarks [--quick]

``--quick`` runs the slow ones at reduced scale (oracle episodes, relation scenes). Numbers go into
BENCHMARKS.md by hand, with the command that produced them.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).parent


def main() -> int:
    ap = argparse.ArgumentParser(description="Run all taskcond benchmarks.")
    ap.add_argument("--quick", action="store_true", help="reduced scale for a fast check")
    args = ap.parse_args()
    runs = [
        ["bench_llm.py"],
        ["bench_llm_workers.py"],
        ["probe_llm.py"],
        ["bench_dmp.py"],
        ["bench_kinova.py"] + (["--targets", "50"] if args.quick else []),
        ["bench_perception.py"] + (["--scenes", "5", "--noise-seeds", "10"] if args.quick else []),
        ["bench_sim.py", "--episodes", "5" if args.quick else "100"],
        ["bench_cloth.py"] + (["--fold-episodes", "3", "--lht4-episodes", "2"] if args.quick else []),
        ["bench_exec.py", "--episodes", "2" if args.quick else "10"],
        ["bench_recording.py", "--episodes", "2" if args.quick else "5"],
        ["bench_backends.py", "--episodes", "4" if args.quick else "20"],
        ["bench_il.py"],
        ["bench_objects.py", "--episodes", "2" if args.quick else "10"],
    ]
    failed = []
    for script, *extra in runs:
        print(f"\n## {script} {' '.join(extra)}\n", flush=True)
        code = subprocess.call([sys.executable, str(HERE / script), *extra])
        if code:
            failed.append(script)
    if failed:
        print(f"\nfailed: {', '.join(failed)}", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
