"""Benchmark of the DMP module (paper §III-D, §III-E): learning time, rollout time, reproduction error.

Run: ``.venv/bin/python benchmarks/bench_dmp.py``. Prints a markdown table. The demonstration is a
synthetic 2 s reach with a 0.15 m lift (minimum-jerk profile, at rest at both ends); with 6
dimensions the last three are Euler angles (rad). Times are the median of several repeats.
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable

import numpy as np

from taskcond.dmp import DMPRollout, learn_dmp, rollout

DURATION = 2.0


def demonstration(n_samples: int, n_dims: int) -> tuple[np.ndarray, np.ndarray]:
    """(times (n,) s, positions (n, d)) of the synthetic demonstration."""
    t = np.linspace(0.0, DURATION, n_samples)
    s = t / DURATION
    min_jerk = 10 * s**3 - 15 * s**4 + 6 * s**5
    y0 = np.array([0.4, -0.1, 0.3, 0.0, np.pi, 0.2])[:n_dims]
    goal = np.array([0.6, 0.2, 0.1, 0.3, np.pi - 0.4, -0.5])[:n_dims]
    positions = y0 + (goal - y0) * min_jerk[:, None]
    positions[:, 2] += 0.15 * np.sin(np.pi * s) ** 4
    return t, positions


def median_seconds(function: Callable[[], object], repeats: int) -> float:
    samples = []
    for _ in range(repeats):
        start = time.perf_counter()
        function()
        samples.append(time.perf_counter() - start)
    return statistics.median(samples)


def main() -> None:
    rows = []
    for n_samples, n_dims in [(201, 3), (201, 6), (2001, 3)]:
        t, positions = demonstration(n_samples, n_dims)
        learn_s = median_seconds(lambda t=t, positions=positions: learn_dmp(t, positions), repeats=20)
        params = learn_dmp(t, positions)
        dt = t[1] - t[0]
        runner = DMPRollout(params, positions[0], positions[-1])
        reproduced = np.vstack([positions[:1], [runner.step(dt)[0] for _ in range(n_samples - 1)]])
        error = np.linalg.norm(reproduced[:, :3] - positions[:, :3], axis=1)
        y0, goal = positions[0], positions[-1]
        rollout_s = median_seconds(lambda p=params, y0=y0, g=goal: rollout(p, y0, g, n_steps=1000), repeats=5)
        step_runner = DMPRollout(params, y0, goal)
        step_s = median_seconds(lambda r=step_runner: r.step(1 / 240), repeats=2000)
        rows.append(
            (
                f"{n_samples} × {n_dims}",
                f"{learn_s * 1e3:.2f}",
                f"{step_s * 1e6:.0f}",
                f"{rollout_s * 1e3:.1f}",
                f"{error.max() * 1e3:.3f}",
                f"{np.sqrt(np.mean(error**2)) * 1e3:.3f}",
            )
        )
    header = (
        "demo samples × dims",
        "learn (ms)",
        "step dt=1/240 s (µs)",
        "1000-step rollout (ms)",
        "reproduction max (mm)",
        "reproduction RMS (mm)",
    )
    print("| " + " | ".join(header) + " |")
    print("|" + "|".join("---" for _ in header) + "|")
    for row in rows:
        print("| " + " | ".join(row) + " |")
    print(
        f"\nN = 100 bases, α_y = 60, β_y = 15, α_x = 1, τ = {DURATION} s; reproduction stepped at the "
        "demo's sample period, error = Euclidean position error over x, y, z; the 1000-step rollout "
        "covers τ (dt = 2 ms)."
    )


if __name__ == "__main__":
    main()
