"""Episodes of the paper's image-based imitation-learning baseline (:mod:`taskcond.il`)."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from taskcond.application.episode import EpisodeResult, judged
from taskcond.application.kinds import EvalMethod
from taskcond.application.plans import RunPlan
from taskcond.sim.recording import VideoRecorder
from taskcond.tasks.free import final_predicates
from taskcond.tasks.registry import make

IMAGE_IL = EvalMethod.IMAGE_IL


def load_policy(directory: Path) -> Any:
    """The baseline's trained policy (:class:`taskcond.il.train.TrainedPolicy`) in ``directory``.

    Raises:
        ILUnavailableError: the ``[il]`` extra is missing.
        PolicyError: no checkpoint there.
    """
    from taskcond.il import require_il

    require_il()
    from taskcond.il.train import TrainedPolicy

    return TrainedPolicy.load(directory)


def run_policy_episode(plan: RunPlan, seed: int, policy: Any, video: Path | None = None) -> EpisodeResult:
    """Reset the plan's suite task with ``seed`` and run its primitive task names with the baseline's
    ``policy`` (:func:`taskcond.il.rollout.run_policy`); success is the task's own check.

    Raises:
        ValueError: a free instruction (the baseline runs the suite's tasks only).
        PolicyError: a step the policy was not trained on.
    """
    from taskcond.il.rollout import run_policy

    if plan.task_id is None:
        raise ValueError(f"--method {IMAGE_IL} runs suite tasks only, not {plan.label!r}")
    start = time.perf_counter()
    env = make(plan.task_id)
    recorder = VideoRecorder(video) if video is not None else None
    try:
        obs, _ = env.reset(seed=seed)
        run = run_policy(env, obs, policy, plan.steps, recorder)
        goal = tuple(env.task.post_conditions())
        missing = [str(q) for q in goal if not env.truth.holds(q)]
        success = run.failure is None and bool(env.task.success(env))
        final = final_predicates(env)
        sim_seconds = run.control_steps * env.dt
    finally:
        if recorder is not None:
            recorder.close()
        env.close()
    failure, reason = judged(run.failure, run.detail or run.failure, success, missing)
    return EpisodeResult(
        task=plan.label,
        method=IMAGE_IL,
        seed=seed,
        success=success,
        failure=failure,
        reason=reason,
        steps=run.steps,
        sim_seconds=round(sim_seconds, 3),
        wall_seconds=round(time.perf_counter() - start, 3),
        env_seconds=round(run.env_seconds, 3),
        adjustments=0,
        raised=0,
        planner="none",
        goal=[str(q) for q in goal],
        goal_missing=missing,
        final_predicates=final,
    )
