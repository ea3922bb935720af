"""Scripted oracles (experts) of the task suite (paper §IV): run a task's oracle trajectories in its
environment and count successes. The trajectories are the demonstrations DMPs are fitted to (§III-E).
"""

from __future__ import annotations

import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

from taskcond.envs.kitchen import KitchenEnv
from taskcond.sim.recording import VideoRecorder
from taskcond.tasks.motion_plan import MotionPlan
from taskcond.tasks.registry import make

SETTLE_STEPS = 10
"""Control steps the last action is held after the oracle's trajectories, before success is judged."""
VIDEO_EVERY = 2
"""Record every n-th control step."""

ORACLE_REVISION = 5
"""Revision of the oracles' demonstrations, part of the default skill library's directory name
(:func:`taskcond.application.library.default_library_dir`) and of the baseline's data key; raised whenever
the demonstrations change, so that a library learned from older ones is not picked up by default (the
history of the revisions is in BENCHMARKS.md)."""


@dataclass
class OracleReport:
    """Outcome of :func:`run_oracle`.

    Attributes:
        task: registry id.
        episodes, successes: counts.
        steps_per_second: environment (control) steps per wall-clock second over all episodes.
        failures: failure reason → count (``not_succeeded`` when the episode ran to its end without success,
            else the environment's blow-up reason or ``truncated``).
        failed_seeds: the seed of each failed episode, in order, to replay it (``--episodes 1 --seed S``).
        trajectories: the executed oracle trajectory of each episode, concatenated (demonstrations).
    """

    task: str
    episodes: int
    successes: int
    steps_per_second: float
    failures: dict[str, int] = field(default_factory=dict)
    failed_seeds: list[int] = field(default_factory=list)
    trajectories: list[MotionPlan] = field(default_factory=list, repr=False)

    @property
    def success_rate(self) -> float:
        return self.successes / self.episodes if self.episodes else 0.0


def _concatenate(parts: list) -> MotionPlan:
    """Join executed trajectories of one kind (single-arm :class:`MotionPlan` or dual-arm
    :class:`~taskcond.tasks.dual_arm.DualArmMotionPlan`)."""
    return type(parts[0]).concatenate(parts) if parts else MotionPlan.concatenate(parts)


def run_episode(
    env: KitchenEnv, seed: int, recorder: VideoRecorder | None = None
) -> tuple[bool, str | None, MotionPlan, int]:
    """Reset with ``seed`` and execute the task's oracle; returns (success, failure reason, executed
    trajectory, control steps). Dual-arm tasks return a
    :class:`~taskcond.tasks.dual_arm.DualArmMotionPlan` as the executed trajectory."""
    env.reset(seed=seed)
    executed: list = []
    steps = 0
    info: dict = {"success": env.task.success(env), "failure": None}
    action = None
    for traj in env.task.plans(env):
        executed.append(traj)
        for i in range(len(traj)):
            action = traj.action(i)
            _, _, terminated, _, info = env.step(action)
            steps += 1
            if recorder is not None and steps % VIDEO_EVERY == 0:
                recorder.add(env.render())
            if terminated:
                return False, info["failure"], _concatenate(executed), steps
    for _ in range(SETTLE_STEPS if action is not None else 0):
        _, _, terminated, _, info = env.step(action)
        steps += 1
        if terminated:
            return False, info["failure"], _concatenate(executed), steps
    if info["success"]:
        return True, None, _concatenate(executed), steps
    return False, "not_succeeded", _concatenate(executed), steps


def run_oracle(
    task_id: str,
    episodes: int = 100,
    seed: int = 0,
    video: str | Path | None = None,
    keep_trajectories: bool = False,
) -> OracleReport:
    """Run the oracle of ``task_id`` on ``episodes`` seeded episodes (seeds ``seed``, ``seed + 1``, ...).

    ``video``: path (.mp4/.gif) to record the first episode to.
    """
    env = make(task_id)
    failures: Counter[str] = Counter()
    failed_seeds: list[int] = []
    successes = total_steps = 0
    trajectories = []
    start = time.perf_counter()
    try:
        for k in range(episodes):
            recorder = VideoRecorder(video) if video is not None and k == 0 else None
            try:
                ok, reason, traj, steps = run_episode(env, seed + k, recorder)
            finally:
                if recorder is not None:
                    recorder.close()
            total_steps += steps
            successes += ok
            if reason is not None:
                failures[reason] += 1
                failed_seeds.append(seed + k)
            if keep_trajectories:
                trajectories.append(traj)
    finally:
        env.close()
    elapsed = time.perf_counter() - start
    return OracleReport(
        task_id,
        episodes,
        successes,
        total_steps / max(elapsed, 1e-9),
        dict(failures),
        failed_seeds,
        trajectories,
    )


__all__ = ["OracleReport", "run_episode", "run_oracle"]
