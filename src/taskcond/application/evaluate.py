"""Evaluations (paper §V, Tables III and IV): episodes of tasks and methods run in worker processes (one per
core) or as Ray tasks; every finished episode is appended to a JSON-lines results file at once and the
episodes already in it are skipped, so an interrupted evaluation resumes where it stopped. The file records
the run's configuration (:class:`~taskcond.results.RunConfig`) and holds that configuration's episodes only.
"""

from __future__ import annotations

import multiprocessing
from collections import Counter, defaultdict
from collections.abc import Callable, Iterable, Iterator
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np

from taskcond.application.episode import DEFAULT_NOISE
from taskcond.application.kinds import EvalMethod
from taskcond.application.ray_backend import run_on_ray
from taskcond.application.workers import (
    WorkerArgs,
    init_worker,
    llm_threads,
    needs_own_process,
    run_initialized,
)
from taskcond.execution.config import ExecutionConfig
from taskcond.results import (
    Job,
    ResultsFile,
    RunConfig,
    code_version,
    directory_digest,
    file_digest,
    llm_fields,
)
from taskcond.sim.objects import loaded_files, objects_files
from taskcond.tasks.registry import list_tasks, primitive_task_ids

EVAL_METHODS: tuple[EvalMethod, ...] = tuple(EvalMethod)
"""Methods an evaluation runs: the executor's condition sources and the baseline."""


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
    repair ``planner``, the start state ``start``, the declared objects' files
    (:func:`~taskcond.sim.objects.objects_files`), the instructions file ``instructions`` (the
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
        objects=tuple(objects_files()) or None,
        code=code_version(),
    )


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
    spawned processes, or as Ray tasks (:mod:`taskcond.application.ray_backend`). An episode that is
    repeatable only in a fresh process (:func:`~taskcond.application.workers.needs_own_process`: the
    cloth's) gets one, after the others, so that its replay (:mod:`taskcond.application.replay`)
    reproduces it."""
    if backend not in BACKENDS:
        raise ValueError(f"unknown backend {backend!r}; valid: {', '.join(BACKENDS)}")
    if not jobs:
        return
    own = needs_own_process(jobs, init_args)
    if backend == "ray":
        yield from run_on_ray(jobs, init_args, workers, ray_address, own)
        return
    shared, alone = (
        [j for j, o in zip(jobs, own, strict=True) if not o],
        [j for j, o in zip(jobs, own, strict=True) if o],
    )
    if shared and workers <= 1:
        init_worker(init_args)
        for job in shared:
            yield run_initialized(job)
    ctx = multiprocessing.get_context("spawn")
    for batch, per_process in ((shared if workers > 1 else [], None), (alone, 1)):
        if batch:
            processes = max(1, min(workers, len(batch)))
            with ctx.Pool(processes, init_worker, (init_args,), maxtasksperchild=per_process) as pool:
                yield from pool.imap_unordered(run_initialized, batch)


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
        tuple(loaded_files()),
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
