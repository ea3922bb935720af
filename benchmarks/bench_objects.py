"""Benchmark of objects without a demonstration of their own (issue 31): grasps of the declared example
objects and of the suite's can from random starts, with the borrowed grasp's offset scaled to the perceived
box (the default) and as demonstrated (``--unscaled``: the A/B of the scaling).

Run: ``.venv/bin/python benchmarks/bench_objects.py [--episodes N] [--seed S] [--unscaled]``. Conditions
from the demonstrations (method env, no LLM), the default skill library (learned on first use), perception
noise σ = 5 mm. Prints one markdown row per object: successes, failures by kind, the skill each borrowed.
"""

from __future__ import annotations

import argparse
import statistics
from collections import Counter
from pathlib import Path

import numpy as np

import taskcond.execution.approach as approach
from taskcond.application.condition_sources import make_source
from taskcond.application.episode import run_episode
from taskcond.application.library import load_library
from taskcond.application.plans import plan_run
from taskcond.sim.objects import load_objects

EXAMPLES = Path(__file__).resolve().parents[1] / "examples" / "objects.toml"
OBJECTS = ("can", "soup can", "rubber duck", "jar")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=5)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--unscaled", action="store_true", help="The borrowed grasp as demonstrated.")
    args = parser.parse_args()
    if args.unscaled:
        approach._empty_hand_scale = lambda *_: np.ones(3)  # the A/B: no scaling
    load_objects(EXAMPLES)
    library = load_library()
    source = make_source("env", library)
    print("| object | success | failures | skill | median wall s |\n|---|---|---|---|---|")
    for name in OBJECTS:
        results = [
            run_episode(plan_run(f"grasp {name}"), "env", seed, library, source, start_state="random")
            for seed in range(args.seed, args.seed + args.episodes)
        ]
        skills = Counter(e.get("skill") for r in results for e in r.events if e["kind"] == "primitive")
        failures = Counter(str(r.failure) for r in results if not r.success)
        ok = sum(bool(r.success) for r in results)
        wall = statistics.median(r.wall_seconds for r in results)
        print(f"| {name} | {ok}/{len(results)} | {dict(failures) or '-'} | {dict(skills)} | {wall:.1f} |")


if __name__ == "__main__":
    main()
