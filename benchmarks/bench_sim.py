"""Benchmark of the PyBullet kitchen task suite (paper §IV).

Measures, and prints as a markdown table:

* simulation throughput (physics steps/s) of the suite's scene driven through ``KitchenEnv.step`` vs raw
  PyBullet stepping the same bodies in the same client with the same motor commands, side by side;
* reset time, camera time per 320×240 observation, resident memory per environment;
* oracle success rates over ``--episodes`` seeded episodes per task.

Usage: ``python benchmarks/bench_sim.py [--episodes 100] [--tasks grasp-bottle LHT1 ...]``.
"""

from __future__ import annotations

import argparse
import resource
import time

import numpy as np
import pybullet as p

from taskcond.tasks.oracle import run_oracle
from taskcond.tasks.registry import make, task_ids


def _rss_mb() -> float:
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def throughput(task_id: str = "move_into-bottle-box", steps: int = 150) -> dict[str, float]:
    """Physics steps/s through the env (IK + control + checks) and raw ``stepSimulation`` on the same
    client and bodies, alternating so both see the same load."""
    env = make(task_id, seed=0)
    env.reset()
    obs = env._obs()
    action = np.concatenate([obs["ee_position"], obs["ee_orientation"], [1.0]])
    t_env = t_raw = 0.0
    for _ in range(5):
        t0 = time.perf_counter()
        for _ in range(steps // 5):
            env.step(action)
        t_env += time.perf_counter() - t0
        t0 = time.perf_counter()
        for _ in range(steps // 5 * env.substeps):
            p.stepSimulation(physicsClientId=env.scene.client)
        t_raw += time.perf_counter() - t0
    n = steps // 5 * 5 * env.substeps
    env.close()
    return {"env": n / t_env, "raw": n / t_raw}


def timings(task_id: str = "grasp-bottle", n: int = 10) -> dict[str, float]:
    before = _rss_mb()
    env = make(task_id, seed=0, render_mode="rgb_array")
    env.reset()
    mem = _rss_mb() - before
    t0 = time.perf_counter()
    for k in range(n):
        env.reset(seed=k)
    reset = (time.perf_counter() - t0) / n
    t0 = time.perf_counter()
    for _ in range(n):
        env.render()
    cam = (time.perf_counter() - t0) / n
    env.close()
    return {"reset_s": reset, "camera_s": cam, "memory_mb": mem}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--episodes", type=int, default=100)
    ap.add_argument("--tasks", nargs="*", default=None, help="registry ids (default: all)")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()

    tp = throughput()
    tm = timings()
    print("| metric | value |\n|---|---|")
    print(f"| env physics steps/s (incl. IK, control, checks) | {tp['env']:.0f} |")
    print(f"| raw PyBullet steps/s, same bodies | {tp['raw']:.0f} |")
    print(f"| env / raw | {100 * tp['env'] / tp['raw']:.0f}% |")
    print(f"| reset time | {1000 * tm['reset_s']:.1f} ms |")
    print(f"| camera 320x240 per observation | {1000 * tm['camera_s']:.1f} ms |")
    print(f"| memory per environment | {tm['memory_mb']:.1f} MB |")
    print()
    print("| task | episodes | success rate | control steps/s | failures |\n|---|---|---|---|---|")
    for task_id in args.tasks or task_ids():
        r = run_oracle(task_id, args.episodes, seed=args.seed)
        fails = ", ".join(f"{k}: {v}" for k, v in sorted(r.failures.items())) or "-"
        rate = f"{100 * r.success_rate:.0f}%"
        print(f"| {task_id} | {r.episodes} | {rate} | {r.steps_per_second:.0f} | {fails} |", flush=True)


if __name__ == "__main__":
    main()
