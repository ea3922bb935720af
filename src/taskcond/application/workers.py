"""A worker process of an evaluation: it keeps its skill library, condition sources and policy between the
episodes it runs (:func:`run_job`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from taskcond.application.baseline import IMAGE_IL, load_policy, run_policy_episode
from taskcond.application.condition_sources import make_source, novel_primitive_source
from taskcond.application.episode import run_episode
from taskcond.application.plans import instruction_plan, instruction_scene, llm_decomposer, plan_run
from taskcond.execution.executor import ConditionSource, SourceKind
from taskcond.execution.failures import FailureKind
from taskcond.execution.skills import SkillLibrary
from taskcond.llm.base import cpu_count
from taskcond.results import Job
from taskcond.viz.episode import EpisodeObserver

_WORKER: dict[str, Any] = {}


@dataclass(frozen=True)
class WorkerArgs:
    """What an evaluation's worker needs (:func:`init_worker`).

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
        objects: declaration files of user objects (``--objects``) the worker declares before its episodes.
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
    objects: tuple[str, ...] = ()


def llm_threads(workers: int, backend: str = "local") -> int | None:
    """CPU threads of each worker's embedded LLM: the cores shared out among ``workers`` local processes,
    one for a Ray task (it holds one CPU), None (every core) for one process. llama.cpp's threads wait for
    each other at every operation, so two processes that each use every core slow each other down."""
    if backend == "ray":
        return 1
    return None if workers <= 1 else max(1, cpu_count() // workers)


def init_worker(args: WorkerArgs) -> None:
    from taskcond.instructions import load_instructions
    from taskcond.sim.objects import load_objects

    for path in args.objects:
        load_objects(path)

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


# long: one episode as a record: baseline, suite task or instruction, recorded or not, crash caught
def run_initialized(job: Job, observers: Sequence[EpisodeObserver] = ()) -> dict[str, Any]:
    """One episode as a results record: a suite task, or with an instructions file the instruction of
    that id in the wording the job's seed picks (:meth:`~taskcond.instructions.Instruction.text_for`; its
    plan from the LLM, judged by its goal; a plan the LLM cannot give is a failed episode,
    ``decomposition``), watched by ``observers`` and, with :attr:`WorkerArgs.rerun`, recorded (the
    record's ``rerun`` names a recording kept). An exception is returned as a ``crashed`` record (not a
    result: a resumed evaluation runs it again)."""
    from taskcond.decompose import DecompositionError

    recording = None if _WORKER.get("recordings") is None else _WORKER["recordings"].recording(job)
    if recording is not None:
        observers = (*observers, recording)

    sources: dict[str, ConditionSource | None] = _WORKER["sources"]
    method: SourceKind = job.method  # type: ignore[assignment]
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
            text = instruction.text_for(job.seed)
            extra = {"task": instruction.id, "instruction": text}
            try:
                plan = instruction_plan(text, _WORKER["decomposer"])
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


def needs_own_process(jobs: Sequence[Job], args: WorkerArgs) -> list[bool]:
    """For each of ``jobs``, whether its episode must run in a fresh process of its own to be repeatable:
    its scene (a suite task's, or the one its instruction's wording picks) is not
    :attr:`~taskcond.sim.scene.SceneConfig.repeatable_in_process` (the cloth's scene)."""
    from taskcond.instructions import load_instructions
    from taskcond.sim.scene import SceneConfig, dual_arm_config
    from taskcond.tasks.registry import UnknownTaskError, get_task

    instructions = (
        {} if args.instructions is None else {i.id: i for i in load_instructions(Path(args.instructions))}
    )

    def scene(job: Job) -> SceneConfig:
        if job.task in instructions:
            dual = instruction_scene(instructions[job.task].text_for(job.seed)) == "dual-arm"
            return dual_arm_config() if dual else SceneConfig()
        try:
            return get_task(job.task).scene_config(None) or SceneConfig()
        except UnknownTaskError:
            return dual_arm_config() if instruction_scene(job.task) == "dual-arm" else SceneConfig()

    return [not scene(job).repeatable_in_process for job in jobs]


def unplanned(job: Job, instruction: Any, reason: str, planner: str, start: str) -> dict[str, Any]:
    """The record of an instruction episode that never ran: the LLM gave no valid plan (or the words name
    a task the scene cannot do). A failure of the method, not a crash."""
    return {
        "task": instruction.id,
        "instruction": instruction.text_for(job.seed),
        "method": job.method,
        "seed": job.seed,
        "success": False,
        "failure": FailureKind.DECOMPOSITION,
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
    """:func:`run_initialized` in a process that keeps its skill library, condition sources and policy
    between calls with the same ``init_args`` (:class:`WorkerArgs`): a Ray task's entry point, and a stored
    episode's replay (:mod:`taskcond.application.replay`), watched by ``observers``."""
    if _WORKER.get("args") != init_args:
        init_worker(init_args)
    return run_initialized(job, observers)
