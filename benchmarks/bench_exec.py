"""Benchmark of condition-guided execution (paper §III-E, Alg. 1 and 2): episodes per minute per core and
the executor's overhead beside the physics it steps.

Run: ``.venv/bin/python benchmarks/bench_exec.py [--episodes N] [--tasks LHT1 LHT3]``. One process; every
episode is profiled with cProfile, which splits its wall time into

* physics: ``pybullet.stepSimulation``;
* environment: the rest of ``KitchenEnv`` (building the scene, reset, and per step IK, blow-up and
  success checks);
* executor: everything else: DMP rollouts, contacts checked every control step, environment information,
  condition sources (LLM conditions come from the on-disk cache after the first episode), Alg. 1.

The overhead figure is executor / physics (median over episodes). Prints a markdown table.
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import statistics

from taskcond.application.condition_sources import make_source
from taskcond.application.episode import run_episode
from taskcond.application.library import load_library
from taskcond.application.plans import plan_run


def profile_episode(task: str, method: str, seed: int, library, source) -> dict[str, float]:
    """Wall, physics, environment and executor seconds of one episode, and its success."""
    profiler = cProfile.Profile()
    profiler.enable()
    result = run_episode(plan_run(task), method, seed, library, source)  # type: ignore[arg-type]
    profiler.disable()
    stats = pstats.Stats(profiler).stats  # type: ignore[attr-defined]
    physics = sum(v[3] for k, v in stats.items() if k[2] == "<built-in method pybullet.stepSimulation>")
    env = sum(
        v[3]
        for k, v in stats.items()
        if k[0].endswith("envs/kitchen.py") and k[2] in ("__init__", "reset", "step", "close")
    )
    total = result.wall_seconds
    return {
        "wall": total,
        "physics": physics,
        "environment": env - physics,
        "executor": total - env,
        "success": float(bool(result.success)),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--episodes", type=int, default=5, help="episodes per task and method")
    ap.add_argument("--tasks", nargs="+", default=["LHT1", "LHT3"], help="suite task ids")
    ap.add_argument("--methods", nargs="+", default=["none", "env", "llm"], help="execution methods")
    args = ap.parse_args()
    library = load_library()
    print(
        "| task | method | episodes | success | episodes/min/core | physics s | env s | executor s |", end=""
    )
    print(" executor/physics |")
    print("|---|---|---|---|---|---|---|---|---|")
    for task in args.tasks:
        for method in args.methods:
            source = make_source(method, library)  # type: ignore[arg-type]
            run_episode(plan_run(task), method, 999, library, source)  # type: ignore[arg-type] # warm caches
            rows = [profile_episode(task, method, 2000 + k, library, source) for k in range(args.episodes)]

            def med(key: str, rows=rows) -> float:
                return statistics.median(r[key] for r in rows)

            ratio = statistics.median(r["executor"] / r["physics"] for r in rows)
            print(
                f"| {task} | {method} | {len(rows)} | {sum(r['success'] for r in rows):.0f}/{len(rows)} | "
                f"{60.0 / med('wall'):.1f} | {med('physics'):.3f} | {med('environment'):.3f} | "
                f"{med('executor'):.3f} | {100 * ratio:.0f}% |",
                flush=True,
            )


if __name__ == "__main__":
    main()
