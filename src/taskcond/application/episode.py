"""Episodes of the condition-guided executor in the suite: ``taskcond run`` and ``taskcond eval
primitives|long-horizon`` (paper §V, Tables III and IV).

An episode resets a suite task with a seed, checks and repairs its primitive task names (a primitive task's
own name, a long-horizon task's sequence, or the LLM's decomposition of a free instruction) with the
look-ahead planner (:mod:`taskcond.execution.planner`, unless ``planner="none"``: the paper's behaviour),
runs them through the :class:`~taskcond.execution.executor.Executor`, and judges success with the task's
ground-truth check, or for a free instruction with its goal predicates (:func:`~taskcond.execution.planner.
goal_of`) judged by the ground truth. Every episode records the predicates that hold at its end.
Evaluations of many episodes are :mod:`taskcond.application.evaluate`.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from taskcond.application.kinds import Planner
from taskcond.application.plans import RunPlan
from taskcond.conditions import Predicate, TaskCondition
from taskcond.envs.kitchen import KitchenEnv
from taskcond.execution.config import ExecutionConfig
from taskcond.execution.events import Event
from taskcond.execution.executor import ConditionSource, ExecutionResult, Executor, SourceKind
from taskcond.execution.failures import FailureKind
from taskcond.execution.planner import PlanRepair, goal_of, repair
from taskcond.execution.skills import SkillLibrary
from taskcond.tasks.free import STARTS, FreeTask, RandomStart, fallen_objects, final_predicates
from taskcond.tasks.registry import get_task, make
from taskcond.viz.episode import EpisodeInfo, EpisodeObserver, ObservedWorld, Observers
from taskcond.worlds.kitchen import KitchenWorld

PLANNERS: tuple[Planner, ...] = tuple(Planner)
"""Every planner choice."""


DEFAULT_NOISE = 0.005
"""Default perception noise σ (m) on object centres and boxes in runs and evaluations (§III-A.2)."""


# ------------------------------------------------------------------------------------------ episodes
@dataclass
class EpisodeResult:
    """One episode.

    Attributes:
        task: suite id, or the instruction.
        method: ``none``, ``env``, ``llm`` or ``llm+demo``.
        seed: the reset seed (also seeds the perception noise).
        success: the ground-truth check: the suite task's, or for a free instruction every goal predicate
            holds and the executor did not stop.
        failure: short reason class when not successful (the executor's failure kind; ``impossible``
            when the planner found the plan cannot be done and nothing moved; ``not_succeeded`` when the
            run completed but the check failed).
        reason: the one-line reason.
        steps: the primitive task names run (after the planner's repair).
        sim_seconds: simulated time.
        wall_seconds: wall-clock time of the episode.
        env_seconds: wall-clock time inside the environment's step (IK and physics).
        adjustments: Alg. 2 collision adjustments.
        raised: primitives raised by Alg. 1.
        planner: :data:`PLANNERS` entry used.
        plan_seconds: wall-clock time of the planner (conditions it had to fetch included).
        repair: the planner's repair (:meth:`~taskcond.execution.planner.PlanRepair.to_dict`), or None
            (``planner="none"``, no conditions, or the planner could not get a condition).
        goal: the goal predicates (the suite task's post-conditions; a free instruction's given goal, or
            else :func:`~taskcond.execution.planner.goal_of` of its plan before repair).
        goal_missing: the goal predicates that do not hold at the end (ground truth).
        plan_goal: with a given goal, the goal :func:`~taskcond.execution.planner.goal_of` derives from the
            plan (what the plan itself claims to achieve); else empty.
        plan_goal_held: whether every ``plan_goal`` predicate holds at the end (None without a given goal).
        start: ``task`` or ``random`` (:data:`~taskcond.tasks.free.STARTS`).
        final_predicates: every relation and state that holds at the end (ground truth), sorted.
        fallen: the free objects that lie fallen over at the end and no gripper holds
            (:func:`~taskcond.tasks.free.fallen_objects`), sorted; empty when none fell.
        events: the trace.
        conditions: task name → condition used (JSON form).
        left_out: in a novel-primitive episode (Table IV, third block), the primitive whose examples the
            LLM's prompts left out (:func:`left_out_primitive`); None otherwise.
    """

    task: str
    method: str
    seed: int
    success: bool | None
    failure: str | None
    reason: str | None
    steps: list[str]
    sim_seconds: float
    wall_seconds: float
    env_seconds: float
    adjustments: int
    raised: int
    planner: str = "conditions"
    plan_seconds: float = 0.0
    repair: dict[str, Any] | None = None
    goal: list[str] = field(default_factory=list)
    goal_missing: list[str] = field(default_factory=list)
    plan_goal: list[str] = field(default_factory=list)
    plan_goal_held: bool | None = None
    start: str = "task"
    final_predicates: list[str] = field(default_factory=list)
    fallen: list[str] = field(default_factory=list)
    events: list[dict[str, Any]] = field(default_factory=list)
    conditions: dict[str, Any] = field(default_factory=dict)
    left_out: str | None = None

    def summary(self) -> dict[str, Any]:
        """The JSON-lines record of an evaluation (no trace, no final predicates; the repair's changes)."""
        out = asdict(self)
        del out["events"], out["conditions"], out["final_predicates"]
        out["repair"] = None if self.repair is None else self.repair["changes"]
        return out


# long: 14 parameters and their docstring; the body is the episode's one sequence of about 45 lines
def run_episode(
    plan: RunPlan,
    method: SourceKind,
    seed: int,
    library: SkillLibrary,
    source: ConditionSource | None,
    noise: float = DEFAULT_NOISE,
    video: Path | None = None,
    gui: bool = False,
    on_event: Callable[[Event], None] | None = None,
    config: ExecutionConfig | None = None,
    planner: str = "conditions",
    on_plan: Callable[[PlanRepair | None, tuple[Predicate, ...]], None] | None = None,
    start_state: str = "task",
    goal: tuple[Predicate, ...] | None = None,
    video_size: tuple[int, int] | None = None,
    observers: Sequence[EpisodeObserver] = (),
) -> EpisodeResult:
    """Reset the plan's task with ``seed``, repair its steps with the planner (with conditions and
    ``planner="conditions"``), and execute them with ``method``. ``on_plan`` is told the repair and the
    goal before anything moves. ``video``: a captioned video of ``video_size`` (width, height) pixels
    (:class:`~taskcond.viz.captions.CaptionedVideo`); ``observers`` (a Rerun recording) watch the episode
    (:mod:`taskcond.viz.episode`); without either nothing is computed for them. ``start_state="random"``
    draws the start from
    :func:`~taskcond.tasks.free.random_start` (a suite task keeps what its start needs,
    :class:`~taskcond.tasks.free.RandomStart`). ``goal`` (a free instruction only) replaces the goal
    derived from the plan as the success criterion; the derived one is recorded beside it.

    Raises:
        ValueError: an unknown planner or start; a goal given for a suite task.
    """
    _check(plan, planner, start_state, goal)
    start = time.perf_counter()
    env = _environment(plan, start_state, gui)
    if video is not None:
        from taskcond.viz.captions import VIDEO_SIZE, CaptionedVideo

        observers = (*observers, CaptionedVideo(video, video_size or VIDEO_SIZE))
    watch = Observers(observers) if observers else None
    try:
        env.reset(seed=seed)
        world: KitchenWorld | ObservedWorld = KitchenWorld(env, noise_sigma=noise, seed=seed)
        if watch is not None:
            world = ObservedWorld(world, watch)  # type: ignore[arg-type]
            watch.start(env, world, EpisodeInfo(plan.label, method, seed, plan.steps))
            on_event, on_plan = watch.chain(on_event, "on_event"), watch.chain(on_plan, "on_plan")
        conditions = _memo(source) if source is not None else None
        fixed, planning = _repaired(plan, world, conditions, planner)
        derived = _goal(plan, env, conditions)
        given = goal is not None
        plan_goal = derived if given else ()
        goal = goal if goal is not None else derived
        if on_plan is not None:
            on_plan(fixed, goal)
        steps = plan.steps if fixed is None else fixed.steps
        result = None
        if fixed is None or fixed.impossible is None:
            result = Executor(world, library, method, source, config, on_event, watch).run(steps)
        missing = [str(q) for q in goal if not env.truth.holds(q)]
        if plan.task_id is None:
            success = result is not None and result.failure is None and not missing
        else:
            success = bool(env.task.success(env))
        if watch is not None:
            watch.ended(success)
        outcome = _Outcome(
            steps=steps,
            fixed=fixed,
            result=result,
            planning=planning,
            goal=goal,
            plan_goal=plan_goal,
            missing=missing,
            plan_goal_held=all(map(env.truth.holds, plan_goal)) if given else None,
            success=success,
            final=final_predicates(env),
            fallen=fallen_objects(env),
            sim_seconds=world.time,
            env_seconds=world.env_seconds,
        )
    except BaseException:
        if watch is not None:
            watch.close()
        raise
    finally:
        env.close()
    episode = outcome.episode(plan.label, method, seed, planner, start_state, time.perf_counter() - start)
    if watch is not None:
        watch.finish(episode)
        watch.close()
    return episode


def _check(plan: RunPlan, planner: str, start_state: str, goal: tuple[Predicate, ...] | None) -> None:
    """Raises ValueError for an unknown planner or start, or a goal given for a suite task."""
    if planner not in PLANNERS:
        raise ValueError(f"unknown planner {planner!r}; valid: {', '.join(PLANNERS)}")
    if start_state not in STARTS:
        raise ValueError(f"unknown start {start_state!r}; valid: {', '.join(STARTS)}")
    if goal is not None and plan.task_id is not None:
        raise ValueError(f"suite task {plan.task_id} has its own success check; a goal is for instructions")


def _environment(plan: RunPlan, start_state: str, gui: bool) -> KitchenEnv:
    """The environment of the plan's task (a free instruction's :class:`FreeTask`) from ``start_state``."""
    if plan.task_id is None:
        return KitchenEnv(FreeTask(plan.label, plan.steps, plan.scene, start_state), gui=gui)
    if start_state == "random":
        return KitchenEnv(RandomStart(get_task(plan.task_id)), gui=gui)
    return make(plan.task_id, gui=gui)


def _repaired(
    plan: RunPlan, world: KitchenWorld, conditions: Callable[[str], TaskCondition] | None, planner: str
) -> tuple[PlanRepair | None, float]:
    """The planner's repair of the plan's steps against the world's start (None without conditions, with
    ``planner="none"``, or when a condition cannot be had), and the seconds it took."""
    planning = time.perf_counter()
    fixed = None
    if conditions is not None and planner != "none":
        try:
            fixed = repair(plan.steps, world.observe().predicates, conditions, world.affords)
        except (ValueError, RuntimeError, OSError):
            fixed = None  # a condition the source cannot give: the executor reports it on its step
    return fixed, time.perf_counter() - planning


def judged(
    failure: FailureKind | str | None, reason: str | None, success: bool, missing: list[str]
) -> tuple[FailureKind | str | None, str | None]:
    """An episode's failure kind and reason: the run's own, else ``not_succeeded`` when the run completed
    but the check failed (naming the goal predicates ``missing``), else none when it succeeded."""
    if failure is None and not success:
        failure = FailureKind.NOT_SUCCEEDED
        reason = (
            f"the goal does not hold: {', '.join(missing)}"
            if missing
            else "the run completed but the task's success check failed"
        )
    return (None, None) if success else (failure, reason)


@dataclass
class _Outcome:
    """What an episode's run left, before it is written up as an :class:`EpisodeResult`."""

    steps: tuple[str, ...]
    fixed: PlanRepair | None
    result: ExecutionResult | None
    planning: float
    goal: tuple[Predicate, ...]
    plan_goal: tuple[Predicate, ...]
    missing: list[str]
    plan_goal_held: bool | None
    success: bool
    final: list[str]
    fallen: list[str]
    sim_seconds: float
    env_seconds: float

    def episode(
        self, label: str, method: str, seed: int, planner: str, start: str, wall_seconds: float
    ) -> EpisodeResult:
        result, fixed = self.result, self.fixed
        if result is None:
            assert fixed is not None and fixed.impossible is not None
            failure, reason = judged(FailureKind.IMPOSSIBLE, fixed.impossible, self.success, self.missing)
        else:
            failure, reason = judged(result.failure_kind, result.failure, self.success, self.missing)
        return EpisodeResult(
            task=label,
            method=method,
            seed=seed,
            success=self.success,
            failure=failure,
            reason=reason,
            steps=list(self.steps),
            sim_seconds=round(self.sim_seconds, 3),
            wall_seconds=round(wall_seconds, 3),
            env_seconds=round(self.env_seconds, 3),
            adjustments=0 if result is None else result.adjustments,
            raised=0 if result is None else result.raised,
            planner=planner,
            plan_seconds=round(self.planning, 4),
            repair=None if fixed is None else fixed.to_dict(),
            goal=[str(q) for q in self.goal],
            goal_missing=self.missing,
            plan_goal=[str(q) for q in self.plan_goal],
            plan_goal_held=self.plan_goal_held,
            start=start,
            final_predicates=self.final,
            fallen=self.fallen,
            events=[] if result is None else [e.to_dict() for e in result.events],
            conditions={} if result is None else {k: v.to_dict() for k, v in result.conditions.items()},
        )


def _memo(source: ConditionSource) -> Callable[[str], TaskCondition]:
    """``source.condition`` remembered per task name for the planner of one episode."""
    seen: dict[str, TaskCondition] = {}

    def condition(task: str) -> TaskCondition:
        if task not in seen:
            seen[task] = source.condition(task)
        return seen[task]

    return condition


def _goal(
    plan: RunPlan, env: KitchenEnv, conditions: Callable[[str], TaskCondition] | None
) -> tuple[Predicate, ...]:
    """A suite task's post-conditions, or a free instruction's goal: :func:`goal_of` of its plan as the
    instruction gave it (what the planner inserts is a means, not part of the goal), from the
    conditions if there are any, else from the task names alone."""
    if plan.task_id is not None:
        return tuple(env.task.post_conditions())
    try:
        return goal_of(plan.steps, conditions)
    except (ValueError, RuntimeError, OSError):
        return goal_of(plan.steps)
