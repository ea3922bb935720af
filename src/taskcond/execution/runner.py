"""Episodes of the condition-guided executor in the suite: ``taskcond run`` and ``taskcond eval
primitives|long-horizon`` (paper §V, Tables III and IV).

An episode resets a suite task with a seed, runs its primitive task names (a primitive task's own name, a
long-horizon task's sequence, or the LLM's decomposition of a free instruction) through the
:class:`~taskcond.execution.executor.Executor`, and judges success with the task's ground-truth check.
Evaluations run episodes in worker processes (one per core), append every finished episode to a JSON-lines
file at once, and skip the episodes already in it, so an interrupted evaluation resumes where it stopped.
"""

from __future__ import annotations

import json
import multiprocessing
import os
import time
from collections import Counter, defaultdict
from collections.abc import Callable, Iterable
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from taskcond.execution.executor import METHODS, ConditionSource, Event, ExecutionConfig, Executor, Method
from taskcond.execution.kitchen import FreeTask, KitchenWorld, learn_library, primitive_task_ids
from taskcond.execution.skills import LIBRARY_FORMAT, SkillError, SkillLibrary
from taskcond.execution.sources import EnvConditions, GroundedConditions, LLMConditions
from taskcond.llm.models import cache_dir
from taskcond.primitives import TaskNameError, parse_task
from taskcond.sim.recording import VideoRecorder
from taskcond.tasks.env import KitchenEnv
from taskcond.tasks.registry import UnknownTaskError, get_task, list_tasks, make

DEFAULT_NOISE = 0.005
"""Default perception noise σ (m) on object centres and boxes in runs and evaluations (§III-A.2)."""


ORACLE_REVISION = 3
"""Revision of the suite's oracles the default skill library is learned from; raised whenever their
demonstrations change (2: the bowl and the mug held by their wall, the toothpaste near its top; 3: the
vessels' walls of 24 segments instead of 12, a release that grips again when the fingers stay jammed),
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
            (the default scene, no success check).
        steps: primitive task names in order.
        decomposed: the steps come from the LLM's decomposition of a free instruction.
    """

    label: str
    task_id: str | None
    steps: tuple[str, ...]
    decomposed: bool = False


def plan_run(spec: str, decomposer: Callable[[str], list[str]] | None = None) -> RunPlan:
    """Resolve ``spec``: a suite id (``LHT1``, ``grasp-bottle``), a primitive task name of the suite
    (``"grasp bottle"``), another primitive task name (a declared primitive, or objects no suite task has:
    one step in the default scene), else a free instruction that ``decomposer`` turns into primitive task
    names.

    Raises:
        ValueError: a free instruction without a decomposer.
    """
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
    if name is not None:  # a primitive task the suite does not have (a declared primitive, other objects)
        return RunPlan(spec, None, (name,))
    if decomposer is None:
        raise ValueError(f"{spec!r} is neither a suite task id nor a primitive task of the suite")
    return RunPlan(spec, None, tuple(decomposer(spec)), decomposed=True)


# ------------------------------------------------------------------------------------------ episodes
@dataclass
class EpisodeResult:
    """One episode.

    Attributes:
        task: suite id, or the instruction.
        method: ``none``, ``env``, ``llm`` or ``llm+demo``.
        seed: the reset seed (also seeds the perception noise).
        success: the ground-truth check; for a primitive task outside the suite, whether its
            post-conditions were met; None for a free instruction or without conditions.
        failure: short reason class when not successful (the executor's failure kind, or
            ``not_succeeded`` when the run completed but the check failed).
        reason: the one-line reason.
        steps: the primitive task names run.
        sim_seconds: simulated time.
        wall_seconds: wall-clock time of the episode.
        env_seconds: wall-clock time inside the environment's step (IK and physics).
        adjustments: Alg. 2 collision adjustments.
        raised: primitives raised by Alg. 1.
        events: the trace.
        conditions: task name → condition used (JSON form).
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
    events: list[dict[str, Any]] = field(default_factory=list)
    conditions: dict[str, Any] = field(default_factory=dict)

    def summary(self) -> dict[str, Any]:
        """The JSON-lines record of an evaluation (no trace)."""
        out = asdict(self)
        del out["events"], out["conditions"]
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
) -> EpisodeResult:
    """Reset the plan's task with ``seed`` and execute its steps with ``method``."""
    start = time.perf_counter()
    if plan.task_id is None:
        env = KitchenEnv(FreeTask(plan.label, plan.steps), gui=gui)
    else:
        env = make(plan.task_id, gui=gui)
    recorder = VideoRecorder(video) if video is not None else None
    try:
        env.reset(seed=seed)
        world = KitchenWorld(env, noise_sigma=noise, seed=seed, recorder=recorder)
        executor = Executor(world, library, method, source, config, on_event)
        result = executor.run(plan.steps)
        if plan.task_id is not None:
            success: bool | None = bool(env.task.success(env))
        elif plan.decomposed or method == "none":
            success = None
        else:  # one primitive task outside the suite: judged by its own post-conditions
            success = result.completed and _post_conditions_met(result.events)
        sim_seconds = world.time
        env_seconds = world.env_seconds
    finally:
        if recorder is not None:
            recorder.close()
        env.close()
    failure, reason = result.failure_kind, result.failure
    if failure is None and success is False:
        failure, reason = "not_succeeded", "the run completed but the task's success check failed"
    return EpisodeResult(
        task=plan.label,
        method=method,
        seed=seed,
        success=success,
        failure=None if success else failure,
        reason=None if success else reason,
        steps=list(plan.steps),
        sim_seconds=round(sim_seconds, 3),
        wall_seconds=round(time.perf_counter() - start, 3),
        env_seconds=round(env_seconds, 3),
        adjustments=result.adjustments,
        raised=result.raised,
        events=[e.to_dict() for e in result.events],
        conditions={k: v.to_dict() for k, v in result.conditions.items()},
    )


def _post_conditions_met(events: list[Event]) -> bool:
    """Whether the last top-level primitive ended with its post-conditions met (or skipped as done)."""
    ends = [e.kind for e in events if e.depth == 0 and e.kind in ("post", "skip", "post_missing")]
    return bool(ends) and ends[-1] in ("post", "skip")


def make_source(
    method: Method, library: SkillLibrary, llm: str | None = None, cache: bool = True
) -> ConditionSource | None:
    """The condition source of ``method``: None (DMP only), FromEnv, the LLM of ``llm`` (the ``--llm``
    spec; default: $TASKCOND_LLM, the config file, else embedded), or that LLM grounded in the library's
    demonstrations (``llm+demo``)."""
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}; valid: {', '.join(METHODS)}")
    if method == "none":
        return None
    if method == "env":
        return EnvConditions(library)
    from taskcond.generator import ConditionGenerator
    from taskcond.llm.config import LLMConfig, make_backend

    config = LLMConfig.load(llm)
    if not cache:
        config = replace(config, cache=False)
    generator = ConditionGenerator(make_backend(config))
    if method == "llm+demo":
        return GroundedConditions(generator, library)
    return LLMConditions(generator)


# ------------------------------------------------------------------------------------------ evaluation
@dataclass(frozen=True)
class Job:
    """One evaluation episode: suite id, method, seed."""

    task: str
    method: str
    seed: int

    @property
    def key(self) -> tuple[str, str, int]:
        return (self.task, self.method, self.seed)


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


def read_results(path: Path) -> list[dict[str, Any]]:
    """The records of a JSON-lines results file; a torn last line (an interrupted write) is skipped."""
    if not path.exists():
        return []
    records = []
    for line in path.read_text(encoding="utf-8").splitlines():
        try:
            records.append(json.loads(line))
        except json.JSONDecodeError:
            continue
    return records


_WORKER: dict[str, Any] = {}


def _init_worker(library_dir: str, llm: str | None, noise: float) -> None:
    _WORKER.update(library=SkillLibrary.load(library_dir), llm=llm, noise=noise, sources={})


def _run_job(job: Job) -> dict[str, Any]:
    library: SkillLibrary = _WORKER["library"]
    sources: dict[str, ConditionSource | None] = _WORKER["sources"]
    method: Method = job.method  # type: ignore[assignment]
    try:
        if method not in sources:
            sources[method] = make_source(method, library, _WORKER["llm"])
        result = run_episode(plan_run(job.task), method, job.seed, library, sources[method], _WORKER["noise"])
        return result.summary()
    except Exception as exc:  # an episode that crashes is a failed episode with its reason
        return {
            "task": job.task,
            "method": job.method,
            "seed": job.seed,
            "success": False,
            "failure": f"crash:{type(exc).__name__}",
            "reason": " ".join(str(exc).split())[:300],
        }


def evaluate(
    jobs: list[Job],
    out: Path,
    library_dir: Path,
    workers: int = 1,
    llm: str | None = None,
    noise: float = DEFAULT_NOISE,
    progress: Callable[[dict[str, Any]], None] | None = None,
) -> list[dict[str, Any]]:
    """Run the jobs not yet in ``out`` (JSON lines, appended as each episode ends) in ``workers``
    processes; returns every record of ``out`` that belongs to ``jobs``."""
    wanted = {j.key for j in jobs}
    done = {(r["task"], r["method"], r["seed"]) for r in read_results(out)}
    todo = [j for j in jobs if j.key not in done]
    out.parent.mkdir(parents=True, exist_ok=True)
    with out.open("a", encoding="utf-8") as fh:

        def record(rec: dict[str, Any]) -> None:
            fh.write(json.dumps(rec) + "\n")
            fh.flush()
            if progress is not None:
                progress(rec)

        if workers <= 1:
            _init_worker(str(library_dir), llm, noise)
            for job in todo:
                record(_run_job(job))
        elif todo:
            ctx = multiprocessing.get_context("spawn")
            with ctx.Pool(workers, _init_worker, (str(library_dir), llm, noise)) as pool:
                for rec in pool.imap_unordered(_run_job, todo):
                    record(rec)
    return [r for r in read_results(out) if (r["task"], r["method"], r["seed"]) in wanted]


def summarize(records: Iterable[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per task and method: episodes, successes, failures by reason, mean wall seconds per episode."""
    groups: dict[tuple[str, str], list[dict[str, Any]]] = defaultdict(list)
    for rec in records:
        groups[(rec["task"], rec["method"])].append(rec)
    rows = []
    for (task, method), recs in groups.items():
        failures = Counter(r.get("failure") or "not_succeeded" for r in recs if not r.get("success"))
        walls = [r["wall_seconds"] for r in recs if "wall_seconds" in r]
        rows.append(
            {
                "task": task,
                "method": method,
                "episodes": len(recs),
                "successes": sum(bool(r.get("success")) for r in recs),
                "failures": dict(failures),
                "median_wall_seconds": round(float(np.median(walls)), 3) if walls else None,
            }
        )
    return rows


def cpu_count() -> int:
    """Cores available to this process."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1


__all__ = [
    "DEFAULT_NOISE",
    "ORACLE_REVISION",
    "EpisodeResult",
    "Job",
    "RunPlan",
    "cpu_count",
    "default_library_dir",
    "eval_task_ids",
    "evaluate",
    "jobs_for",
    "load_library",
    "make_source",
    "plan_run",
    "read_results",
    "run_episode",
    "summarize",
]
