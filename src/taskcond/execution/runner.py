"""Episodes of the condition-guided executor in the suite: ``taskcond run`` and ``taskcond eval
primitives|long-horizon`` (paper §V, Tables III and IV).

An episode resets a suite task with a seed, checks and repairs its primitive task names (a primitive task's
own name, a long-horizon task's sequence, or the LLM's decomposition of a free instruction) with the
look-ahead planner (:mod:`taskcond.execution.planner`, unless ``planner="none"``: the paper's behaviour),
runs them through the :class:`~taskcond.execution.executor.Executor`, and judges success with the task's
ground-truth check, or for a free instruction with its goal predicates (:func:`~taskcond.execution.planner.
goal_of`) judged by the ground truth. Every episode records the predicates that hold at its end.
Evaluations run episodes in worker processes (one per core) or as Ray tasks, append every finished episode
to a JSON-lines results file at once, and skip the episodes already in it, so an interrupted evaluation
resumes where it stopped. The file records the run's configuration (:class:`~taskcond.results.RunConfig`)
and holds that configuration's episodes only.
"""

from __future__ import annotations

import multiprocessing
import os
import time
from collections import Counter, defaultdict
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from taskcond.conditions import Predicate, TaskCondition
from taskcond.envs.kitchen import KitchenEnv
from taskcond.execution.executor import METHODS, ConditionSource, Event, ExecutionConfig, Executor, Method
from taskcond.execution.kitchen import (
    STARTS,
    FreeTask,
    KitchenWorld,
    RandomStart,
    final_predicates,
    instruction_scene,
    learn_library,
    primitive_task_ids,
    scene_objects,
)
from taskcond.execution.planner import Repair, goal_of, repair
from taskcond.execution.skills import LIBRARY_FORMAT, SkillError, SkillLibrary
from taskcond.execution.sources import EnvConditions, GroundedConditions, LLMConditions
from taskcond.llm.models import cache_dir
from taskcond.primitives import TaskNameError, parse_task
from taskcond.results import (
    Job,
    ResultsFile,
    RunConfig,
    code_version,
    directory_digest,
    file_digest,
    llm_fields,
)
from taskcond.sim.recording import VideoRecorder
from taskcond.sim.scene import ALIASES
from taskcond.tasks.registry import UnknownTaskError, get_task, list_tasks, make
from taskcond.viz.episode import EpisodeInfo, EpisodeObserver, ObservedWorld, Observers

PLANNERS = ("conditions", "none")
"""``conditions``: the look-ahead planner repairs the plan before execution (beyond the paper); ``none``:
the plan runs as given, Alg. 1 alone satisfies pre-conditions (the paper's behaviour)."""

IMAGE_IL = "image-il"
"""The paper's image-based imitation-learning baseline (:mod:`taskcond.il`): a method of evaluations, not of
the executor."""
EVAL_METHODS: tuple[str, ...] = (*METHODS, IMAGE_IL)
"""Methods an evaluation runs: the executor's (:data:`~taskcond.execution.executor.METHODS`) and the
baseline."""

DEFAULT_NOISE = 0.005
"""Default perception noise σ (m) on object centres and boxes in runs and evaluations (§III-A.2)."""


ORACLE_REVISION = 4
"""Revision of the suite's oracles the default skill library is learned from; raised whenever their
demonstrations change (2: the bowl and the mug held by their wall, the toothpaste near its top; 3: the
vessels' walls of 24 segments instead of 12, a release that grips again when the fingers stay jammed; 4:
the dual-arm scene's cabinet farther back, the cloth grasped with the fingertips 9 mm above the table
and a wider anchoring margin),
so that a library learned from older demonstrations is not picked up by default."""


def default_library_dir() -> Path:
    """Where ``taskcond learn`` stores the skill library:
    ``<cache dir>/skills/v<format>-oracles<revision>`` (:data:`ORACLE_REVISION`)."""
    return cache_dir() / "skills" / f"v{LIBRARY_FORMAT}-oracles{ORACLE_REVISION}"


def load_library(
    directory: Path | None = None,
    learn_if_missing: bool = True,
    progress: Callable[[str, bool], None] | None = None,
) -> SkillLibrary:
    """The skill library at ``directory`` (default :func:`default_library_dir`); learned from the oracle
    demonstrations first if it does not exist yet and ``learn_if_missing``."""
    directory = directory or default_library_dir()
    try:
        return SkillLibrary.load(directory)
    except SkillError:
        if not learn_if_missing or (directory / "library.json").exists():
            raise
    return learn_library(directory, progress=progress)


# --------------------------------------------------------------------------------------------- plans
@dataclass(frozen=True)
class RunPlan:
    """What an episode runs.

    Attributes:
        label: what was asked (a suite id or an instruction).
        task_id: the suite task whose initial state and success check apply; None for a free instruction
            (judged by its goal predicates).
        steps: primitive task names in order.
        decomposed: the steps come from the LLM's decomposition of a free instruction.
        scene: a free instruction's scene (:data:`taskcond.execution.kitchen.SCENES`); a suite task has
            its own.
    """

    label: str
    task_id: str | None
    steps: tuple[str, ...]
    decomposed: bool = False
    scene: str = "kitchen"


def plan_run(spec: str, decomposer: Callable[[str, str], list[str]] | None = None) -> RunPlan:
    """Resolve ``spec``: a suite id (``LHT1``, ``grasp-bottle``), a primitive task name of the suite
    (``"grasp bottle"``), another primitive task name on objects of its scene (a declared primitive, or
    objects no suite task has: one step in the scene :func:`~taskcond.execution.kitchen.instruction_scene`
    picks), else a free instruction that ``decomposer`` turns into primitive task names (called with the
    instruction and its scene). A primitive task name on an object its scene lacks (``put the botle into
    the box``) goes to ``decomposer`` when there is one: the LLM reads a misspelling as the object meant.

    Raises:
        ValueError: an empty or blank ``spec``; a free instruction without a decomposer.
    """
    if not spec.strip():
        raise ValueError(
            "empty instruction; give a suite task id (see `taskcond tasks`), a primitive task such as "
            "'open box', or an instruction such as 'put the bottle into the box'"
        )
    try:
        info = get_task(spec.strip()).info
    except UnknownTaskError:
        pass
    else:
        steps = info.primitive if info.kind == "long-horizon" else (info.task_name,)
        return RunPlan(spec.strip(), info.id, tuple(steps))
    try:
        name = parse_task(spec).name
    except TaskNameError:
        name = None
    for info in list_tasks():
        if info.kind == "primitive" and info.task_name == name:
            return RunPlan(spec, info.id, (info.task_name,))
    scene = instruction_scene(spec)
    if name is not None and (
        decomposer is None or set(parse_task(name).objects) <= set(scene_objects(scene)[0])
    ):
        return RunPlan(spec, None, (name,), scene=scene)  # a primitive task the suite does not have
    if decomposer is None:
        raise ValueError(f"{spec!r} is neither a suite task id nor a primitive task of the suite")
    return RunPlan(spec, None, tuple(decomposer(spec, scene)), decomposed=True, scene=scene)


def llm_decomposer(
    llm: str | None = None, announce: Callable[[str], None] | None = None, threads: int | None = None
) -> Callable[[str, str], list[str]]:
    """The ``decomposer`` of :func:`plan_run` with the LLM of ``llm`` (the ``--llm`` spec; answers cached;
    an embedded model on ``threads`` CPU threads, None: every core):
    an instruction that reads as one primitive task the scene cannot do is refused first
    (:func:`refused_task`); ``announce`` is told the scene before the LLM is asked.

    The decomposer raises DecompositionError (no valid plan, or refused) and LLMError."""
    from taskcond.execution.decompose import DecompositionError, decompose
    from taskcond.llm.config import LLMConfig, make_backend

    backends: list[Any] = []

    def decomposer(instruction: str, scene: str) -> list[str]:
        objects, affords = scene_objects(scene)
        refused = refused_task(instruction, objects, affords)
        if refused is not None:
            raise DecompositionError(f"{refused}; nothing was run")
        if announce is not None:
            announce(scene)
        if not backends:
            backends.append(make_backend(replace(LLMConfig.load(llm), threads=threads)))
        return decompose(instruction, backends[0], objects, affords, aliases=ALIASES)

    return decomposer


def instruction_plan(text: str, decomposer: Callable[[str, str], list[str]]) -> RunPlan:
    """A benchmark instruction's plan: ``decomposer``'s (the LLM's) steps for it, even where its words name
    one primitive task (``taskcond run`` runs "put the bottle into the box" as that suite task, which ends
    holding the bottle; the benchmark asks the LLM, which writes the release a user means), run as a free
    instruction in its scene and judged by its goal.

    Raises:
        ValueError: an empty instruction.
    """
    if not text.strip():
        raise ValueError("empty instruction")
    scene = instruction_scene(text)
    return RunPlan(text, None, tuple(decomposer(text, scene)), decomposed=True, scene=scene)


def refused_task(
    instruction: str, objects: Iterable[str], affords: Callable[[str, tuple[str, ...]], str | None]
) -> str | None:
    """Why an instruction that reads as one primitive task on objects of the scene cannot be done there
    (``put the box into the bottle``: the box cannot be picked up), or None. Asked before the LLM
    decomposes it, which would otherwise answer a different task (the bottle into the box). An
    instruction naming an object the scene lacks is left to the LLM (it may be a misspelling)."""
    try:
        task = parse_task(instruction.strip().rstrip(".!?"))
    except TaskNameError:
        return None
    if not set(task.objects) <= set(objects):
        return None
    reason = affords(task.primitive.id, task.objects)
    return None if reason is None else f"cannot {task.name!r}: {reason}"


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
        repair: the planner's repair (:meth:`~taskcond.execution.planner.Repair.to_dict`), or None
            (``planner="none"``, no conditions, or the planner could not get a condition).
        goal: the goal predicates (the suite task's post-conditions; a free instruction's given goal, or
            else :func:`~taskcond.execution.planner.goal_of` of its plan before repair).
        goal_missing: the goal predicates that do not hold at the end (ground truth).
        plan_goal: with a given goal, the goal :func:`~taskcond.execution.planner.goal_of` derives from the
            plan (what the plan itself claims to achieve); else empty.
        plan_goal_held: whether every ``plan_goal`` predicate holds at the end (None without a given goal).
        start: ``task`` or ``random`` (:data:`~taskcond.execution.kitchen.STARTS`).
        final_predicates: every relation and state that holds at the end (ground truth), sorted.
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
    events: list[dict[str, Any]] = field(default_factory=list)
    conditions: dict[str, Any] = field(default_factory=dict)
    left_out: str | None = None

    def summary(self) -> dict[str, Any]:
        """The JSON-lines record of an evaluation (no trace, no final predicates; the repair's changes)."""
        out = asdict(self)
        del out["events"], out["conditions"], out["final_predicates"]
        out["repair"] = None if self.repair is None else self.repair["changes"]
        return out


def run_episode(
    plan: RunPlan,
    method: Method,
    seed: int,
    library: SkillLibrary,
    source: ConditionSource | None,
    noise: float = DEFAULT_NOISE,
    video: Path | None = None,
    gui: bool = False,
    on_event: Callable[[Event], None] | None = None,
    config: ExecutionConfig | None = None,
    planner: str = "conditions",
    on_plan: Callable[[Repair | None, tuple[Predicate, ...]], None] | None = None,
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
    :func:`~taskcond.execution.kitchen.random_start` (a suite task keeps what its start needs,
    :class:`~taskcond.execution.kitchen.RandomStart`). ``goal`` (a free instruction only) replaces the goal
    derived from the plan as the success criterion; the derived one is recorded beside it.

    Raises:
        ValueError: an unknown planner or start; a goal given for a suite task.
    """
    if planner not in PLANNERS:
        raise ValueError(f"unknown planner {planner!r}; valid: {', '.join(PLANNERS)}")
    if start_state not in STARTS:
        raise ValueError(f"unknown start {start_state!r}; valid: {', '.join(STARTS)}")
    if goal is not None and plan.task_id is not None:
        raise ValueError(f"suite task {plan.task_id} has its own success check; a goal is for instructions")
    start = time.perf_counter()
    if plan.task_id is None:
        env = KitchenEnv(FreeTask(plan.label, plan.steps, plan.scene, start_state), gui=gui)
    elif start_state == "random":
        env = KitchenEnv(RandomStart(get_task(plan.task_id)), gui=gui)
    else:
        env = make(plan.task_id, gui=gui)
    if video is not None:
        from taskcond.viz.captions import VIDEO_SIZE, CaptionedVideo

        observers = (*observers, CaptionedVideo(video, video_size or VIDEO_SIZE))
    watch = Observers(observers) if observers else None
    fixed: Repair | None = None
    result = None
    try:
        env.reset(seed=seed)
        world: KitchenWorld | ObservedWorld = KitchenWorld(env, noise_sigma=noise, seed=seed)
        if watch is not None:
            world = ObservedWorld(world, watch)  # type: ignore[arg-type]
            watch.start(env, world, EpisodeInfo(plan.label, method, seed, plan.steps))
            on_event, on_plan = watch.chain(on_event, "on_event"), watch.chain(on_plan, "on_plan")
        conditions = _memo(source) if source is not None else None
        planning = time.perf_counter()
        if conditions is not None and planner != "none":
            try:
                fixed = repair(plan.steps, world.observe().predicates, conditions, world.affords)
            except (ValueError, RuntimeError, OSError):
                fixed = None  # a condition the source cannot give: the executor reports it on its step
        planning = time.perf_counter() - planning
        derived = _goal(plan, env, conditions)
        given = goal is not None
        plan_goal = derived if given else ()
        goal = goal if goal is not None else derived
        if on_plan is not None:
            on_plan(fixed, goal)
        steps = plan.steps if fixed is None else fixed.steps
        if fixed is None or fixed.impossible is None:
            executor = Executor(world, library, method, source, config, on_event, watch)
            result = executor.run(steps)
        if watch is not None:
            watch.ended()
        missing = [str(q) for q in goal if not env.truth.holds(q)]
        plan_goal_held = all(map(env.truth.holds, plan_goal)) if given else None
        if plan.task_id is None:
            success = result is not None and result.failure is None and not missing
        else:
            success = bool(env.task.success(env))
        final = final_predicates(env)
        sim_seconds = world.time
        env_seconds = world.env_seconds
    except BaseException:
        if watch is not None:
            watch.close()
        raise
    finally:
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
            if missing
            else "the run completed but the task's success check failed"
        )
    episode = EpisodeResult(
        task=plan.label,
        method=method,
        seed=seed,
        success=success,
        failure=None if success else failure,
        reason=None if success else reason,
        steps=list(steps),
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
        plan_goal=[str(q) for q in plan_goal],
        plan_goal_held=plan_goal_held,
        start=start_state,
        final_predicates=final,
        events=[] if result is None else [e.to_dict() for e in result.events],
        conditions={} if result is None else {k: v.to_dict() for k, v in result.conditions.items()},
    )
    if watch is not None:
        watch.finish(episode)
        watch.close()
    return episode


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


NOVEL_METHODS = ("llm", "llm+demo")
"""Methods a novel-primitive episode can run: the ones whose conditions come from the LLM."""


NOVEL_PRIMITIVE_STREAM = 20
"""Second word of the seed of the left-out primitive's draw (:func:`left_out_primitive`), so that it is
independent of the other draws seeded by the episode's seed (reset, perception noise)."""


def left_out_primitive(task_id: str, seed: int) -> str:
    """The primitive left out of the LLM's examples in the novel-primitive episode ``seed`` of the
    long-horizon task ``task_id`` (paper §V, Table IV "generalize to novel primitive tasks": "a randomly
    selected unseen primitive task"): drawn uniformly from the task's distinct primitives, in the order
    they first appear, by a generator seeded with the episode's seed and :data:`NOVEL_PRIMITIVE_STREAM`.

    Raises:
        ValueError: ``task_id`` is not a long-horizon task of the suite.
    """
    info = get_task(task_id).info
    if info.kind != "long-horizon":
        raise ValueError(f"{task_id} is a primitive task; novel-primitive episodes are long-horizon tasks")
    primitives = list(dict.fromkeys(parse_task(name).primitive.id for name in info.primitive))
    rng = np.random.default_rng([seed, NOVEL_PRIMITIVE_STREAM])
    return primitives[int(rng.integers(len(primitives)))]


def novel_primitive_source(source: ConditionSource, task_id: str, seed: int) -> tuple[ConditionSource, str]:
    """The condition source of the novel-primitive episode ``seed`` of ``task_id``, and the primitive it
    leaves out (:func:`left_out_primitive`): ``source`` (LLM conditions, grounded or not) with that
    primitive's examples left out of every prompt and the examples of its own tasks shuffled by the
    episode's seed, so that each episode draws its own generalization (cached per draw).

    Raises:
        ValueError: ``source`` does not ask the LLM; ``task_id`` is not long-horizon.
    """
    if not isinstance(source, LLMConditions | GroundedConditions):
        raise ValueError(
            f"novel-primitive episodes need LLM conditions (method {' or '.join(NOVEL_METHODS)}), not "
            f"{source.name}"
        )
    primitive = left_out_primitive(task_id, seed)
    return source.leaving_out(primitive, seed), primitive


def make_source(
    method: Method,
    library: SkillLibrary,
    llm: str | None = None,
    cache: bool = True,
    threads: int | None = None,
) -> ConditionSource | None:
    """The condition source of ``method``: None (DMP only), FromEnv, the LLM of ``llm`` (the ``--llm``
    spec; default: $TASKCOND_LLM, the config file, else embedded; an embedded model on ``threads`` CPU
    threads, None: every core), or that LLM grounded in the library's demonstrations (``llm+demo``)."""
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}; valid: {', '.join(METHODS)}")
    if method == "none":
        return None
    if method == "env":
        return EnvConditions(library)
    from taskcond.generator import ConditionGenerator
    from taskcond.llm.config import LLMConfig, make_backend

    config = replace(LLMConfig.load(llm), threads=threads)
    if not cache:
        config = replace(config, cache=False)
    generator = ConditionGenerator(make_backend(config))
    if method == "llm+demo":
        return GroundedConditions(generator, library)
    return LLMConditions(generator)


# ------------------------------------------------------------------------------------------ evaluation
def eval_task_ids(kind: str) -> list[str]:
    """Suite ids of ``kind``: ``primitives`` (every primitive task, the dual-arm fold included) or
    ``long-horizon``."""
    if kind == "primitives":
        return primitive_task_ids()
    if kind == "long-horizon":
        return [t.id for t in list_tasks() if t.kind == "long-horizon"]
    raise ValueError(f"unknown evaluation {kind!r}; valid: primitives, long-horizon")


def jobs_for(tasks: Iterable[str], methods: Iterable[str], episodes: int, seed: int = 1000) -> list[Job]:
    """Episodes ``seed``, ``seed + 1``, ... of every task and method (seeds differ from the
    demonstrations', which start at 0)."""
    return [Job(t, m, seed + k) for t in tasks for m in methods for k in range(episodes)]


def execution_config(
    library_dir: Path | None,
    noise: float,
    llm: str | None = None,
    execution: ExecutionConfig | None = None,
    planner: str = "conditions",
    start: str = "task",
    instructions: Path | None = None,
    il_dir: Path | None = None,
    novel_primitive: bool = False,
) -> RunConfig:
    """The :class:`~taskcond.results.RunConfig` of episodes run with the skill library at ``library_dir``,
    perception noise ``noise``, LLM conditions from ``llm`` (the ``--llm`` spec; resolved as
    :func:`make_source` does), the executor constants ``execution`` (default ones when None), the plan
    repair ``planner``, the start state ``start``, the instructions file ``instructions`` (the
    instruction benchmark), when the baseline runs, its checkpoint ``il_dir`` (``library_dir`` None: no
    episode uses the skill library), and whether each episode leaves out one primitive's examples
    (``novel_primitive``, :func:`novel_primitive_source`).

    Raises:
        LLMError: ``llm`` names no known backend or model.
    """
    return RunConfig(
        kind="execution",
        **llm_fields(llm),
        noise=noise,
        skills=directory_digest(library_dir) if library_dir is not None and library_dir.exists() else None,
        execution=asdict(execution or ExecutionConfig()),
        planner=planner,
        start=start,
        instructions=None if instructions is None else file_digest(instructions),
        il=directory_digest(il_dir) if il_dir is not None and il_dir.exists() else None,
        novel_primitive=novel_primitive,
        code=code_version(),
    )


_WORKER: dict[str, Any] = {}


@dataclass(frozen=True)
class WorkerArgs:
    """What an evaluation's worker needs (:func:`_init_worker`).

    Attributes:
        library_dir: the skill library.
        llm: the ``--llm`` spec (None: the default).
        noise: perception noise (m).
        planner: ``conditions`` or ``none``.
        start: ``task`` or ``random``.
        instructions: the instructions file (None for suite tasks).
        il_dir: the baseline's checkpoint directory (None when it does not run).
        novel_primitive: each episode leaves one primitive out of the LLM's examples.
        llm_threads: CPU threads of the worker's embedded LLM (None: every core; :func:`llm_threads`).
        rerun: a directory for a Rerun recording of each failed episode (None: none;
            :class:`~taskcond.viz.rerun_recording.EvalRecordings`).
        rerun_all: keep the recording of every episode there, not only of the failed ones.
    """

    library_dir: str
    llm: str | None
    noise: float
    planner: str = "conditions"
    start: str = "task"
    instructions: str | None = None
    il_dir: str | None = None
    novel_primitive: bool = False
    llm_threads: int | None = None
    rerun: str | None = None
    rerun_all: bool = False


def llm_threads(workers: int, backend: str = "local") -> int | None:
    """CPU threads of each worker's embedded LLM: the cores shared out among ``workers`` local processes,
    one for a Ray task (it holds one CPU), None (every core) for one process. llama.cpp's threads wait for
    each other at every operation, so two processes that each use every core slow each other down."""
    if backend == "ray":
        return 1
    return None if workers <= 1 else max(1, (os.cpu_count() or 1) // workers)


def _init_worker(args: WorkerArgs) -> None:
    from taskcond.instructions import load_instructions

    instructions = args.instructions
    _WORKER.clear()
    _WORKER.update(
        args=args,
        library_dir=args.library_dir,
        llm=args.llm,
        llm_threads=args.llm_threads,
        noise=args.noise,
        sources={},
        planner=args.planner,
        start=args.start,
        instructions={} if instructions is None else {i.id: i for i in load_instructions(Path(instructions))},
        decomposer=llm_decomposer(args.llm, threads=args.llm_threads),
        il_dir=args.il_dir,
        novel_primitive=args.novel_primitive,
        recordings=None if args.rerun is None else _recordings(Path(args.rerun), args.rerun_all),
    )


def _recordings(directory: Path, every: bool) -> Any:
    from taskcond.viz.rerun_recording import EvalRecordings

    return EvalRecordings(directory, every)


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
    failure, reason = run.failure, run.detail or run.failure
    if failure is None and not success:
        failure = "not_succeeded"
        reason = (
            f"the goal does not hold: {', '.join(missing)}"
            if missing
            else "the run completed but the task's success check failed"
        )
    return EpisodeResult(
        task=plan.label,
        method=IMAGE_IL,
        seed=seed,
        success=success,
        failure=None if success else failure,
        reason=None if success else reason,
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


def _run_job(job: Job, observers: Sequence[EpisodeObserver] = ()) -> dict[str, Any]:
    """One episode as a results record: a suite task, or with an instructions file the instruction of
    that id (its plan from the LLM, judged by its goal; a plan the LLM cannot give is a failed episode,
    ``decomposition``), watched by ``observers`` and, with :attr:`WorkerArgs.rerun`, recorded (the
    record's ``rerun`` names a recording kept). An exception is returned as a ``crashed`` record (not a
    result: a resumed evaluation runs it again)."""
    from taskcond.execution.decompose import DecompositionError

    recording = None if _WORKER.get("recordings") is None else _WORKER["recordings"].recording(job)
    if recording is not None:
        observers = (*observers, recording)
    sources: dict[str, ConditionSource | None] = _WORKER["sources"]
    method: Method = job.method  # type: ignore[assignment]
    instruction = _WORKER["instructions"].get(job.task)
    try:
        if job.method == IMAGE_IL:
            if "policy" not in _WORKER:
                _WORKER["policy"] = load_policy(Path(_WORKER["il_dir"]))
            return run_policy_episode(plan_run(job.task), job.seed, _WORKER["policy"]).summary()
        if "library" not in _WORKER:  # loaded on first use: the baseline's episodes do not need it
            _WORKER["library"] = SkillLibrary.load(_WORKER["library_dir"])
        library: SkillLibrary = _WORKER["library"]
        if method not in sources:
            sources[method] = make_source(method, library, _WORKER["llm"], threads=_WORKER["llm_threads"])
        source, left_out = sources[method], None
        if _WORKER["novel_primitive"]:
            source, left_out = novel_primitive_source(source, job.task, job.seed)  # type: ignore[arg-type]
        if instruction is None:
            plan, goal, extra = plan_run(job.task), None, {}
        else:
            extra = {"task": instruction.id, "instruction": instruction.text}
            try:
                plan = instruction_plan(instruction.text, _WORKER["decomposer"])
            except DecompositionError as exc:
                return unplanned(job, instruction, str(exc), _WORKER["planner"], _WORKER["start"])
            goal = instruction.goal
        result = run_episode(
            plan,
            method,
            job.seed,
            library,
            source,
            _WORKER["noise"],
            planner=_WORKER["planner"],
            start_state=_WORKER["start"],
            goal=goal,
            observers=observers,
        )
        result.left_out = left_out
        kept = {} if recording is None else _WORKER["recordings"].keep(recording, bool(result.success))
        return result.summary() | extra | kept
    except Exception as exc:
        kept = {} if recording is None else _WORKER["recordings"].keep(recording, False)
        return {
            "task": job.task,
            "method": job.method,
            "seed": job.seed,
            "crashed": True,
            "error": f"{type(exc).__name__}: {' '.join(str(exc).split())[:300]}",
        } | kept


def unplanned(job: Job, instruction: Any, reason: str, planner: str, start: str) -> dict[str, Any]:
    """The record of an instruction episode that never ran: the LLM gave no valid plan (or the words name
    a task the scene cannot do). A failure of the method, not a crash."""
    return {
        "task": instruction.id,
        "instruction": instruction.text,
        "method": job.method,
        "seed": job.seed,
        "success": False,
        "failure": "decomposition",
        "reason": reason,
        "steps": [],
        "planner": planner,
        "start": start,
        "goal": [str(q) for q in instruction.goal],
        "goal_missing": [str(q) for q in instruction.goal],
        "plan_goal": [],
        "plan_goal_held": None,
    }


def run_job(job: Job, init_args: WorkerArgs, observers: Sequence[EpisodeObserver] = ()) -> dict[str, Any]:
    """:func:`_run_job` in a process that keeps its skill library, condition sources and policy between
    calls with the same ``init_args`` (:class:`WorkerArgs`): a Ray task's entry point, and a stored
    episode's replay (:mod:`taskcond.viz.replay`), watched by ``observers``."""
    if _WORKER.get("args") != init_args:
        _init_worker(init_args)
    return _run_job(job, observers)


BACKENDS = ("local", "ray")
"""Where evaluation episodes run: ``local`` (worker processes on this machine) or ``ray`` (Ray tasks)."""


def run_jobs(
    jobs: list[Job],
    init_args: WorkerArgs,
    workers: int = 1,
    backend: str = "local",
    ray_address: str | None = None,
) -> Iterator[dict[str, Any]]:
    """The records of ``jobs`` in the order they finish: in this process (``workers`` 1), in ``workers``
    spawned processes, or as Ray tasks (:mod:`taskcond.execution.ray_backend`)."""
    if backend not in BACKENDS:
        raise ValueError(f"unknown backend {backend!r}; valid: {', '.join(BACKENDS)}")
    if not jobs:
        return
    if backend == "ray":
        from taskcond.execution.ray_backend import run_on_ray

        yield from run_on_ray(jobs, init_args, workers, ray_address)
    elif workers <= 1:
        _init_worker(init_args)
        for job in jobs:
            yield _run_job(job)
    else:
        ctx = multiprocessing.get_context("spawn")
        with ctx.Pool(workers, _init_worker, (init_args,)) as pool:
            yield from pool.imap_unordered(_run_job, jobs)


def evaluate(
    jobs: list[Job],
    results: ResultsFile,
    library_dir: Path,
    workers: int = 1,
    llm: str | None = None,
    noise: float = DEFAULT_NOISE,
    progress: Callable[[dict[str, Any]], None] | None = None,
    planner: str = "conditions",
    backend: str = "local",
    ray_address: str | None = None,
    start: str = "task",
    instructions: Path | None = None,
    il_dir: Path | None = None,
    novel_primitive: bool = False,
    rerun: Path | None = None,
    rerun_all: bool = False,
) -> list[dict[str, Any]]:
    """Run the jobs that ``results`` (the file of this configuration) does not hold yet with ``planner``
    from ``start`` (a job's task an instruction id of the file ``instructions``, if given; the baseline's
    checkpoint ``il_dir`` for its jobs; each leaving out one primitive's examples with ``novel_primitive``,
    :func:`novel_primitive_source`; a Rerun recording of each failed episode, or of every one with
    ``rerun_all``, in the directory ``rerun``), appending each record as its episode ends; returns every
    result of ``jobs``. Crashed episodes are appended marked ``crashed`` and are not results: the next call
    runs them again."""
    wanted = {j.key for j in jobs}
    done = results.done(Job.key_of)
    todo = [j for j in jobs if j.key not in done]
    args = WorkerArgs(
        str(library_dir),
        llm,
        noise,
        planner,
        start,
        None if instructions is None else str(instructions),
        None if il_dir is None else str(il_dir),
        novel_primitive,
        llm_threads(workers, backend),
        None if rerun is None else str(rerun),
        rerun_all,
    )
    for rec in run_jobs(todo, args, workers, backend, ray_address):
        results.append(rec)
        if progress is not None:
            progress(rec)
    return [r for r in results.results() if Job.key_of(r) in wanted]


def summarize(records: Iterable[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per task and method: episodes, successes, failures by reason, median wall seconds per episode; for
    novel-primitive episodes also ``left_out``: per left-out primitive, episodes and successes."""
    groups: dict[tuple[str, str], list[dict[str, Any]]] = defaultdict(list)
    for rec in records:
        groups[(rec["task"], rec["method"])].append(rec)
    rows = []
    for (task, method), recs in groups.items():
        failures = Counter(r.get("failure") or "not_succeeded" for r in recs if not r.get("success"))
        walls = [r["wall_seconds"] for r in recs if "wall_seconds" in r]
        row = {
            "task": task,
            "method": method,
            "episodes": len(recs),
            "successes": sum(bool(r.get("success")) for r in recs),
            "failures": dict(failures),
            "median_wall_seconds": round(float(np.median(walls)), 3) if walls else None,
        }
        if any(r.get("left_out") for r in recs):
            left_out: dict[str, dict[str, int]] = defaultdict(lambda: {"episodes": 0, "successes": 0})
            for r in recs:
                left_out[r["left_out"]]["episodes"] += 1
                left_out[r["left_out"]]["successes"] += bool(r.get("success"))
            row["left_out"] = dict(left_out)
        rows.append(row)
    return rows


def cpu_count() -> int:
    """Cores available to this process."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1


__all__ = [
    "BACKENDS",
    "DEFAULT_NOISE",
    "EVAL_METHODS",
    "IMAGE_IL",
    "NOVEL_METHODS",
    "ORACLE_REVISION",
    "PLANNERS",
    "EpisodeResult",
    "Job",
    "RunPlan",
    "WorkerArgs",
    "cpu_count",
    "default_library_dir",
    "eval_task_ids",
    "evaluate",
    "execution_config",
    "instruction_plan",
    "jobs_for",
    "left_out_primitive",
    "llm_decomposer",
    "load_library",
    "load_policy",
    "make_source",
    "novel_primitive_source",
    "plan_run",
    "refused_task",
    "run_episode",
    "run_job",
    "run_jobs",
    "run_policy_episode",
    "summarize",
    "unplanned",
]
