"""Fingerprints of seeded oracle episodes, to show that a refactoring left the simulation unchanged.

For every registry task (or those given), runs ``--episodes`` seeded oracle episodes
(:func:`taskcond.tasks.oracle.run_episode`, seeds ``--seed``, ``--seed + 1``, ...) and hashes (SHA-256) the
reset's observation and info, every step's observation, reward, terminated and truncated flags and info,
and at the episode's end every body's state: base pose and velocity, each joint's position, velocity and
applied motor torque, and the cloth's simulation-mesh nodes. Floats are hashed bit for bit.

Prints one line per episode (task, seed, success, control steps, hash) and with ``--json`` writes them to a
file. Run it before and after a change and compare (``--compare before.json``): identical hashes mean the
same trajectories, observations and final states, bit for bit.

Usage: ``python benchmarks/fingerprint_oracles.py [--episodes 2] [--seed 0] [--tasks grasp-bottle LHT1 ...]
[--json out.json] [--compare before.json]``. It only uses :func:`taskcond.tasks.registry.make`,
:func:`~taskcond.tasks.registry.task_ids` and :func:`~taskcond.tasks.oracle.run_episode`, so it runs
against older trees too (``PYTHONPATH=<tree>/src``).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pybullet as p

from taskcond.tasks.oracle import run_episode
from taskcond.tasks.registry import make, task_ids


@dataclass(frozen=True)
class Fingerprint:
    """One seeded oracle episode.

    Attributes:
        task: registry id.
        seed: the episode's reset seed.
        success: whether the oracle succeeded.
        steps: control steps taken.
        digest: SHA-256 (hex) of everything the episode showed and left (see the module docstring).
    """

    task: str
    seed: int
    success: bool
    steps: int
    digest: str


class _Hasher:
    """SHA-256 over a stream of values; floats and arrays by their float64 bytes, other values by ``repr``."""

    def __init__(self) -> None:
        self._h = hashlib.sha256()

    def add(self, value: Any) -> None:
        if isinstance(value, dict):
            for key in sorted(value):
                self._h.update(repr(key).encode())
                self.add(value[key])
        elif isinstance(value, np.ndarray):
            self._h.update(f"{value.dtype}{value.shape}".encode())
            self._h.update(np.ascontiguousarray(value).tobytes())
        elif isinstance(value, (list, tuple)):
            self._h.update(b"[")
            for item in value:
                self.add(item)
            self._h.update(b"]")
        elif isinstance(value, float):
            self._h.update(np.float64(value).tobytes())
        else:
            self._h.update(repr(value).encode())

    def hexdigest(self) -> str:
        return self._h.hexdigest()


def _final_state(env: Any) -> list[Any]:
    """Every body's base pose and velocity and its joints' position, velocity and motor torque; the cloth's
    nodes."""
    client = env.scene.client
    state: list[Any] = []
    for k in range(p.getNumBodies(physicsClientId=client)):
        body = p.getBodyUniqueId(k, physicsClientId=client)
        if body == env.scene.cloth:
            state.append(("cloth", env.scene.cloth_nodes()))
            continue
        state.append((body, p.getBasePositionAndOrientation(body, physicsClientId=client)))
        state.append(p.getBaseVelocity(body, physicsClientId=client))
        for joint in range(p.getNumJoints(body, physicsClientId=client)):
            position, velocity, _, torque = p.getJointState(body, joint, physicsClientId=client)
            state.append((joint, position, velocity, torque))
    return state


def fingerprint(env: Any, task: str, seed: int) -> Fingerprint:
    """Run one oracle episode of ``env`` with ``seed`` and hash what it showed and left."""
    hasher = _Hasher()
    reset, step = env.reset, env.step

    def recorded_reset(**kwargs: Any) -> Any:
        out = reset(**kwargs)
        hasher.add(("reset", *out))
        return out

    def recorded_step(action: np.ndarray) -> Any:
        out = step(action)
        hasher.add(("step", np.asarray(action, dtype=float), *out))
        return out

    env.reset, env.step = recorded_reset, recorded_step
    try:
        success, _, _, steps = run_episode(env, seed)
    finally:
        del env.reset, env.step
    hasher.add(_final_state(env))
    return Fingerprint(task, seed, bool(success), steps, hasher.hexdigest())


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--episodes", type=int, default=2, help="seeded episodes per task (default 2)")
    ap.add_argument("--seed", type=int, default=0, help="seed of each task's first episode (default 0)")
    ap.add_argument("--tasks", nargs="+", default=None, help="registry ids (default: every one)")
    ap.add_argument("--json", type=Path, default=None, help="write the fingerprints to this JSON file")
    ap.add_argument("--compare", type=Path, default=None, help="JSON of an earlier run to compare with")
    args = ap.parse_args()
    if args.episodes < 1:
        ap.error(f"--episodes must be at least 1, got {args.episodes}")
    tasks = args.tasks or task_ids()
    unknown = sorted(set(tasks) - set(task_ids()))
    if unknown:
        ap.error(f"unknown task(s) {', '.join(unknown)}; valid: {', '.join(task_ids())}")
    prints: list[Fingerprint] = []
    start = time.perf_counter()
    for task in tasks:
        env = make(task)
        try:
            for k in range(args.episodes):
                fp = fingerprint(env, task, args.seed + k)
                prints.append(fp)
                outcome = f"success {fp.success!s:5s}  steps {fp.steps:4d}"
                print(f"{fp.task:32s} seed {fp.seed:3d}  {outcome}  {fp.digest}", flush=True)
        finally:
            env.close()
    print(f"{len(prints)} episodes of {len(tasks)} tasks in {time.perf_counter() - start:.0f} s")
    if args.json is not None:
        args.json.write_text(json.dumps([asdict(fp) for fp in prints], indent=1) + "\n")
    if args.compare is None:
        return 0
    before = {(fp["task"], fp["seed"]): fp for fp in json.loads(args.compare.read_text())}
    differ = [fp for fp in prints if before.get((fp.task, fp.seed), {}).get("digest") != fp.digest]
    for fp in differ:
        print(f"differs: {fp.task} seed {fp.seed} ({before.get((fp.task, fp.seed))} -> {asdict(fp)})")
    print(f"{len(prints) - len(differ)} of {len(prints)} fingerprints identical to {args.compare}")
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())
