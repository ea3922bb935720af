"""Episodes of the condition-guided executor in robosuite (``taskcond run|eval --world robosuite``), judged
by robosuite's own ``_check_success``.

An episode resets robosuite's environment with robosuite's placement initializer for its seed, repairs the
task's primitive steps with the look-ahead planner (with conditions), runs them through the same
:class:`~taskcond.execution.executor.Executor` as the kitchen, on a
:class:`~taskcond.worlds.robosuite.world.RobosuiteWorld`, and asks robosuite whether the task succeeded.
The result is the kitchen's :class:`~taskcond.application.episode.EpisodeResult`; evaluations append each
episode to a JSON-lines results file whose configuration records the world and its versions.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable
from dataclasses import asdict
from pathlib import Path
from typing import Any

from taskcond.application.condition_sources import make_source
from taskcond.application.episode import DEFAULT_NOISE, PLANNERS, EpisodeResult
from taskcond.conditions import Predicate
from taskcond.execution.executor import ConditionSource, Event, ExecutionConfig, Executor, SourceKind
from taskcond.execution.planner import PlanRepair, goal_of, repair
from taskcond.execution.skills import SkillLibrary
from taskcond.results import Job, ResultsFile, RunConfig, code_version, directory_digest, llm_fields
from taskcond.sim.recording import VideoRecorder
from taskcond.worlds.robosuite import versions
from taskcond.worlds.robosuite.scene import make_env, reset
from taskcond.worlds.robosuite.tasks import RobosuiteTask
from taskcond.worlds.robosuite.world import HAND, RobosuiteWorld

WORLD = "robosuite"
EXECUTION = ExecutionConfig(track_target=True)
"""The executor's constants in robosuite: the kitchen's, and a target-anchored piece's goal follows the
mean of the target's perceived centres (:attr:`~taskcond.execution.config.ExecutionConfig.track_target`)."""
STARTS = ("task", "random")
"""Start states: in robosuite every task's own start is drawn by robosuite's placement initializer (its
default initial-state randomization), so ``task`` and ``random`` are the same draw for a seed."""


def final_predicates(world: RobosuiteWorld) -> list[str]:
    """Every relation and state that holds at the end, from the true (noise-free) boxes, sorted."""
    truth = RobosuiteWorld(world.scene)
    return sorted(str(q) for q in truth.observe().predicates)


# long: one robosuite episode from reset to result, as the kitchen's run_episode before its split (issue 30)
def run_episode(
    task: RobosuiteTask,
    method: SourceKind,
    seed: int,
    library: SkillLibrary,
    source: ConditionSource | None,
    noise: float = DEFAULT_NOISE,
    video: Path | None = None,
    on_event: Callable[[Event], None] | None = None,
    config: ExecutionConfig | None = None,
    planner: str = "conditions",
    on_plan: Callable[[PlanRepair | None, tuple[Predicate, ...]], None] | None = None,
    start_state: str = "task",
    steps: tuple[str, ...] | None = None,
) -> EpisodeResult:
    """Reset robosuite's ``task.id`` for ``seed``, repair the steps with the planner and execute them with
    ``method``; success is robosuite's ``_check_success``. ``steps`` (a free instruction's decomposition in
    this task's scene) replace the task's own; the episode is then judged by their goal
    (:func:`~taskcond.execution.planner.goal_of`) on the true state at the end, since robosuite's check
    judges its own task, not the instruction.

    Raises:
        ValueError: an unknown planner or start state.
    """
    if planner not in PLANNERS:
        raise ValueError(f"unknown planner {planner!r}; valid: {', '.join(PLANNERS)}")
    if start_state not in STARTS:
        raise ValueError(f"unknown start {start_state!r}; valid: {', '.join(STARTS)}")
    start = time.perf_counter()
    instruction = steps is not None
    steps = task.steps if steps is None else steps
    env = make_env(task.id, video=video is not None)
    recorder = VideoRecorder(video) if video is not None else None
    fixed: PlanRepair | None = None
    result = None
    try:
        scene = reset(env, seed)
        world = RobosuiteWorld(scene, noise_sigma=noise, seed=seed, recorder=recorder)
        planning = time.perf_counter()
        if source is not None and planner != "none":
            try:
                fixed = repair(steps, world.observe().predicates, source.condition, world.affords)
            except (ValueError, RuntimeError, OSError):
                fixed = None  # the executor reports the condition it cannot get on its step
        planning = time.perf_counter() - planning
        goal = _goal(steps, source) if instruction else ()
        if on_plan is not None:
            on_plan(fixed, goal)
        run_steps = steps if fixed is None else fixed.steps
        if fixed is None or fixed.impossible is None:
            result = Executor(world, library, method, source, config or EXECUTION, on_event, hand=HAND).run(
                run_steps
            )
        final = final_predicates(world)
        missing = [str(q) for q in goal if str(q) not in final]
        if instruction:
            success = result is not None and result.failure is None and not missing
        else:
            success = scene.success()
        sim_seconds, env_seconds = world.time, world.env_seconds
    finally:
        if recorder is not None:
            recorder.close()
        env.close()
    if result is None:
        assert fixed is not None and fixed.impossible is not None
        failure, reason = "impossible", fixed.impossible
    else:
        failure, reason = result.failure_kind, result.failure
    if failure is None and not success:
        failure = "not_succeeded"
        reason = (
            f"the goal does not hold: {', '.join(missing)}"
            if instruction
            else "the run completed but robosuite's _check_success is False"
        )
    return EpisodeResult(
        task=task.id,
        method=method,
        seed=seed,
        success=success,
        failure=None if success else failure,
        reason=None if success else reason,
        steps=list(run_steps),
        sim_seconds=round(sim_seconds, 3),
        wall_seconds=round(time.perf_counter() - start, 3),
        env_seconds=round(env_seconds, 3),
        adjustments=0 if result is None else result.adjustments,
        raised=0 if result is None else result.raised,
        planner=planner,
        plan_seconds=round(planning, 4),
        repair=None if fixed is None else fixed.to_dict(),
        goal=[str(q) for q in goal],
        goal_missing=missing,
        start=start_state,
        final_predicates=final,
        events=[] if result is None else [e.to_dict() for e in result.events],
        conditions={} if result is None else {k: v.to_dict() for k, v in result.conditions.items()},
    )


def _goal(steps: tuple[str, ...], source: ConditionSource | None) -> tuple[Predicate, ...]:
    """A free instruction's goal: the composed effects of its steps (from their conditions if any)."""
    if source is None:
        return goal_of(steps)
    try:
        return goal_of(steps, source.condition)
    except (ValueError, RuntimeError, OSError):
        return goal_of(steps)


def run_config(
    library_dir: Path, noise: float, llm: str | None, planner: str = "conditions", start: str = "task"
) -> RunConfig:
    """The results file's configuration of robosuite episodes: the world and its simulator's versions, the
    skill library's digest, the noise, the LLM, the executor's constants and the planner."""
    installed = versions()
    return RunConfig(
        kind="execution",
        **llm_fields(llm),
        noise=noise,
        skills=directory_digest(library_dir) if library_dir.exists() else None,
        execution=asdict(EXECUTION),
        planner=planner,
        start=start,
        world=f"{WORLD} {installed['robosuite']}, mujoco {installed['mujoco']}",
        code=code_version(),
    )


def evaluate(
    tasks: Iterable[RobosuiteTask],
    methods: Iterable[str],
    episodes: int,
    results: ResultsFile,
    library: SkillLibrary,
    llm: str | None,
    noise: float,
    planner: str = "conditions",
    start: str = "task",
    seed: int = 1000,
    progress: Callable[[dict[str, Any]], None] | None = None,
) -> list[dict[str, Any]]:
    """Run in this process the episodes (seeds ``seed``, ``seed + 1``, ...) of every task and method that
    ``results`` does not hold yet, appending each record as it ends; returns every record asked for."""
    tasks = list(tasks)
    by_id = {t.id: t for t in tasks}
    jobs = [Job(t.id, m, seed + k) for t in tasks for m in methods for k in range(episodes)]
    done = results.done(Job.key_of)
    sources: dict[str, ConditionSource | None] = {}
    for job in jobs:
        if job.key in done:
            continue
        method = SourceKind(job.method)
        if method not in sources:
            sources[method] = make_source(method, library, llm)
        try:
            record = run_episode(
                by_id[job.task],
                method,
                job.seed,
                library,
                sources[method],
                noise,
                planner=planner,
                start_state=start,
            ).summary()
        except Exception as exc:  # a crash is recorded, not a result: a resumed evaluation runs it again
            record = {
                "task": job.task,
                "method": job.method,
                "seed": job.seed,
                "crashed": True,
                "error": f"{type(exc).__name__}: {' '.join(str(exc).split())[:300]}",
            }
        record["world"] = WORLD
        results.append(record)
        if progress is not None:
            progress(record)
    wanted = {j.key for j in jobs}
    return [r for r in results.results() if Job.key_of(r) in wanted]


__all__ = ["EXECUTION", "STARTS", "WORLD", "evaluate", "final_predicates", "run_config", "run_episode"]
