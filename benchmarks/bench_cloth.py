"""Cloth and dual-arm numbers (issue 4): fold oracle and LHT4 oracle success over seeded episodes, the fold
measure's spread, the cloth's simulation speed (physics steps per second of the dual-arm scene with the
cloth, flat and while folding), one fold episode's wall time, and the spatula resting on the cloth at 1 and
at 2 physics sub-steps per 240 Hz step (blow-ups, and its bottom's height over the cloth's nodes beneath).

    .venv/bin/python benchmarks/bench_cloth.py [--fold-episodes 50] [--lht4-episodes 50] [--rest-trials 10]
        [--seed 0]

Targets: fold ≥ 95 % of 50 episodes, LHT4 ≥ 90 %, one fold episode < 60 s.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import pybullet as p

from taskcond.tasks.fold import measure
from taskcond.tasks.oracle import run_episode
from taskcond.tasks.registry import make


def oracle(task_id: str, episodes: int, seed: int) -> tuple[int, list[float], list, dict[str, int]]:
    """Successes, wall seconds per episode, fold measures and failure reasons of ``episodes`` episodes."""
    env = make(task_id)
    successes, seconds, measures, failures = 0, [], [], {}
    try:
        for k in range(episodes):
            start = time.perf_counter()
            ok, reason, _, _ = run_episode(env, seed + k)
            seconds.append(time.perf_counter() - start)
            successes += ok
            measures.append(measure(env))
            if reason is not None:
                failures[reason] = failures.get(reason, 0) + 1
    finally:
        env.close()
    return successes, seconds, measures, failures


def spatula_rest(substeps: int, trials: int, seconds: float = 3.0) -> tuple[int, list[float]]:
    """Drop the spatula 3 mm onto the flat cloth's centre (turned by a seeded random yaw) at ``substeps``
    physics sub-steps per 240 Hz step and let it rest ``seconds``; over ``trials`` seeds: how many blew up
    (a node moved more than 5 cm, or a position is not finite) and, for the others, the height (m) of the
    spatula's bottom above the highest cloth node beneath it."""
    env = make("LHT4")
    blowups, gaps = 0, []
    try:
        client = env.scene.client
        for k in range(trials):
            obs, _ = env.reset(seed=k)
            p.setPhysicsEngineParameter(numSubSteps=substeps, physicsClientId=client)
            flat = obs["cloth_nodes"]
            yaw = float(env.np_random.uniform(-np.pi, np.pi))
            env.scene.place("spatula", flat[:, :2].mean(axis=0), yaw, z=float(flat[:, 2].max()) + 0.003)
            env.settle(seconds)
            nodes = env.scene.cloth_nodes()
            lo, hi = env.scene.aabb("spatula")
            if not np.isfinite(nodes).all() or not np.isfinite(lo).all() or np.abs(nodes - flat).max() > 0.05:
                blowups += 1
                continue
            beneath = np.all((nodes[:, :2] >= lo[:2]) & (nodes[:, :2] <= hi[:2]), axis=1)
            gaps.append(float(lo[2] - nodes[beneath, 2].max()))
    finally:
        env.close()
    return blowups, gaps


def cloth_speed(steps: int = 480) -> tuple[float, float, int]:
    """Physics steps per second of the dual-arm scene with the cloth lying flat, and while both grippers
    hold the cloth's edge up (the fold's arc: stretched, self-colliding); nodes of the cloth."""
    env = make("fold-cloth")
    try:
        env.reset(seed=0)
        client = env.scene.client
        start = time.perf_counter()
        for _ in range(steps):
            p.stepSimulation(physicsClientId=client)
        flat = steps / (time.perf_counter() - start)
        trajectory = next(env.task.plans(env))
        half = len(trajectory) // 2
        for i in range(half):  # up to the top of the arc, cloth held
            env.step(trajectory.action(i))
        start = time.perf_counter()
        for _ in range(steps):
            p.stepSimulation(physicsClientId=client)
        held = steps / (time.perf_counter() - start)
        nodes = len(env.scene.cloth_nodes())
    finally:
        env.close()
    return flat, held, nodes


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fold-episodes", type=int, default=50, help="seeded fold-cloth oracle episodes")
    parser.add_argument("--lht4-episodes", type=int, default=50, help="seeded LHT4 oracle episodes")
    parser.add_argument(
        "--rest-trials", type=int, default=10, help="spatula-on-cloth trials per sub-step count (0: skip)"
    )
    parser.add_argument("--seed", type=int, default=0, help="seed of the first episode")
    args = parser.parse_args()

    flat, held, nodes = cloth_speed()
    print(
        f"cloth: {nodes} nodes; physics steps/s (240 Hz steps) flat {flat:.0f}, held up mid-fold {held:.0f}"
    )
    for substeps in (1, 2) if args.rest_trials > 0 else ():
        blowups, gaps = spatula_rest(substeps, args.rest_trials)
        gap = f"{np.min(gaps) * 1000:.1f} .. {np.max(gaps) * 1000:.1f} mm" if gaps else "-"
        print(
            f"spatula resting on the cloth, {substeps} sub-step(s) per 240 Hz step: "
            f"{blowups}/{args.rest_trials} blow-ups; bottom above the nodes beneath {gap}",
            flush=True,
        )
    print()
    print(
        "| task | episodes | success | wall s / episode (mean, max) | double-layer fraction (min, mean) "
        "| edge distance mm (mean, max) | horizontal edge miss mm (mean, max) | failures |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for task_id, episodes in (("fold-cloth", args.fold_episodes), ("LHT4", args.lht4_episodes)):
        if episodes <= 0:
            continue
        ok, seconds, measures, failures = oracle(task_id, episodes, args.seed)
        double = np.array([m.double_fraction for m in measures])
        edge = np.array([m.edge_distance for m in measures]) * 1000
        offset = np.array([m.edge_offset for m in measures]) * 1000
        print(
            f"| {task_id} | {episodes} | {ok}/{episodes} ({ok / episodes:.0%}) "
            f"| {np.mean(seconds):.1f}, {np.max(seconds):.1f} | {double.min():.2f}, {double.mean():.2f} "
            f"| {edge.mean():.1f}, {edge.max():.1f} | {offset.mean():.1f}, {offset.max():.1f} "
            f"| {failures or '-'} |",
            flush=True,
        )


if __name__ == "__main__":
    main()
