"""Benchmark of the image-based imitation-learning baseline (``--method image-il``, extra ``[il]``): its
demonstrations, training time, model size, loss curves and the cost of acting.

Run: ``.venv/bin/python benchmarks/bench_il.py [--plot benchmarks/il_loss.png]``. Trains the default policy
first if the cache has none (as ``taskcond learn --method image-il`` does: demonstrations, then training,
each timed), then prints a markdown table and writes the loss curves (total and terms, per
``LOG_EVERY`` steps, log scale) to the PNG. For a one-core figure run it under ``taskset -c 0``.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--plot", type=Path, default=Path(__file__).parent / "il_loss.png")
    ap.add_argument("--act", type=int, default=20, help="policy calls timed (render + network)")
    args = ap.parse_args()

    from taskcond.application.demonstrations import CONTEXTS
    from taskcond.il.config import TrainSpec, data_dir, policy_dir
    from taskcond.il.dataset import DataSpec, collect, observe_image, observe_state
    from taskcond.il.train import TrainedPolicy, learn_policy
    from taskcond.tasks.registry import make, primitive_task_ids

    data, spec = DataSpec(), TrainSpec()
    directory = policy_dir(data, spec)
    ids = [*primitive_task_ids(), *CONTEXTS]
    start = time.perf_counter()
    samples = collect(data_dir(data), ids, data)
    collect_seconds = time.perf_counter() - start
    if not (directory / "policy.json").exists():
        learn_policy(directory, samples, data, spec)
    history = json.loads((directory / "history.json").read_text())
    policy = TrainedPolicy.load(directory)
    import equinox as eqx
    import jax

    params = sum(x.size for x in jax.tree_util.tree_leaves(eqx.filter(policy.model, eqx.is_array)))
    env = make("grasp-bottle")
    obs, _ = env.reset(seed=1000)
    render, net = [], []
    for _ in range(args.act + 1):
        t = time.perf_counter()
        image = observe_image(env)
        render.append(time.perf_counter() - t)
        t = time.perf_counter()
        policy.act(image, observe_state(obs, env.target), 0.0, "grasp bottle")
        net.append(time.perf_counter() - t)
    env.close()
    data_bytes = sum(p.stat().st_size for p in data_dir(data).glob("*.npz"))
    rows = [
        (
            "demonstrations",
            f"{sum(map(data.episodes_of, ids))} ({data.episodes} per single-arm task, "
            f"{data.dual_arm_episodes} per dual-arm task; {len(ids)} suite tasks)",
        ),
        ("samples (one per 4 control steps)", f"{len(samples)} of {len(samples.names)} primitive task names"),
        (
            "demonstration cache",
            f"{data_bytes / 1e6:.0f} MB (collected {collect_seconds:.0f} s this run: 0 when cached)",
        ),
        ("training", f"{spec.steps} steps of {spec.batch}, {history['seconds'] / 60:.1f} min"),
        ("loss first / last log point", f"{history['loss'][0]:.3f} / {history['loss'][-1]:.4f}"),
        ("parameters", f"{params:,}"),
        ("checkpoint", f"{(directory / 'model.eqx').stat().st_size / 1e6:.2f} MB"),
        ("render 64×64 RGB-D, median", f"{1000 * np.median(render[1:]):.1f} ms"),
        ("network, one observation, median", f"{1000 * np.median(net[1:]):.1f} ms"),
    ]
    print("| | |\n|---|---|")
    for k, v in rows:
        print(f"| {k} | {v} |")
    plot(history, args.plot)
    print(f"\nloss curves: {args.plot}; checkpoint {directory.name}")


def plot(history: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4))
    for key, style in (("loss", "k-"), ("position", "C0-"), ("quaternion", "C1-"), ("gripper", "C2-")):
        ax.plot(history["step"], history[key], style, lw=1.2, label=key if key != "loss" else "total")
    ax.set_yscale("log")
    ax.set_xlabel("training step")
    ax.set_ylabel("training loss (mean over the last log interval)")
    ax.set_title("image-il: behaviour cloning loss (positions: normalized MSE; gripper: BCE)", fontsize=9)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    main()
