"""``taskcond eval primitives|long-horizon|instructions``: episodes of the executor and the baseline (Tables
III and IV, the instruction benchmark).
"""

from __future__ import annotations

import json
import sys
from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

import taskcond.cli.robosuite as robosuite
import taskcond.cli.viz as cli_viz
from taskcond.cli.common import (
    BackendOption,
    ExecutionSettings,
    JsonOption,
    LlmOption,
    NoiseOption,
    ObjectsOption,
    PlannerOption,
    RayAddressOption,
    SkillsOption,
    StartOption,
    WorkersOption,
    WorldOption,
    _check_start,
    _crashed,
    _declare_objects,
    _library,
    _sim_import,
    fail,
)
from taskcond.cli.skills import _il_policy
from taskcond.conditions import ConditionError
from taskcond.llm.base import LLMError
from taskcond.primitives import TaskNameError

if TYPE_CHECKING:
    from taskcond.results import Job


# long: the resume/progress/crash loop the eval commands share, its options checked and its bars drawn
def _run_episodes(
    jobs, out: Path, settings: ExecutionSettings, desc: str, instructions: Path | None = None
) -> tuple[list[dict], dict]:
    """Run ``jobs`` into the results file ``out`` (resuming it) with a progress bar; returns the results
    and the run's configuration (with its digest). A job's task is a suite id, or with ``instructions``
    (an instructions file, already checked) an instruction's id: every instruction is decomposed here
    first (the LLM's answers cached for the workers). Ends with exit 2 when ``out`` holds another
    configuration; crashed episodes are reported on stderr and left out (the next call runs them again),
    see :func:`_crashed`."""
    from tqdm import tqdm

    from taskcond.application.baseline import IMAGE_IL
    from taskcond.application.condition_sources import prefetch_conditions
    from taskcond.application.episode import PLANNERS
    from taskcond.application.evaluate import BACKENDS, evaluate, execution_config
    from taskcond.application.library import default_library_dir
    from taskcond.llm.base import cpu_count
    from taskcond.results import ConfigMismatchError, Job, ResultsFile

    if settings.backend not in BACKENDS:
        fail(f"--backend {settings.backend!r}: use one of {', '.join(BACKENDS)}")
    if settings.planner not in PLANNERS:
        fail(f"--planner {settings.planner!r}: use one of {', '.join(PLANNERS)}")
    cli_viz.rerun_ready(settings.rerun, suffix=None)
    library_dir = settings.skills or default_library_dir()
    library = _library(settings.skills) if any(j.method != IMAGE_IL for j in jobs) else None
    il_dir = _il_policy() if any(j.method == IMAGE_IL for j in jobs) else None
    try:
        config = execution_config(
            library_dir if library is not None else None,
            settings.noise,
            settings.llm,
            planner=settings.planner,
            start=settings.start,
            instructions=instructions,
            il_dir=il_dir,
            novel_primitive=settings.novel_primitive,
        )
        results = ResultsFile(out, config)
    except (ConfigMismatchError, LLMError) as exc:
        fail(str(exc))
    done = results.done(Job.key_of)
    todo = [j for j in jobs if j.key not in done]
    steps = _instruction_steps(instructions, todo, settings.llm) if instructions else {}
    try:
        prefetch_conditions(
            todo,
            library,
            settings.llm,
            steps if instructions else None,
            settings.novel_primitive,
            progress=_progress,
        )
    except (LLMError, TaskNameError, ConditionError, ValueError) as exc:
        fail(str(exc))
    bar = tqdm(total=len(jobs), desc=desc, unit="episode", file=sys.stderr, disable=None)
    bar.update(len(jobs) - len(todo))
    crashed: list[dict] = []

    def told(rec: dict) -> None:
        bar.update()
        if rec.get("crashed"):
            crashed.append(rec)

    try:
        records = evaluate(
            jobs,
            results,
            library_dir,
            settings.workers or cpu_count(),
            settings.llm,
            settings.noise,
            progress=told,
            planner=settings.planner,
            backend=settings.backend,
            ray_address=settings.ray_address,
            start=settings.start,
            instructions=instructions,
            il_dir=il_dir,
            novel_primitive=settings.novel_primitive,
            rerun=settings.rerun,
            rerun_all=settings.rerun_all,
        )
    except RuntimeError as exc:  # Ray missing or unreachable
        fail(str(exc))
    bar.close()
    _crashed(crashed)
    ran = {j.key for j in todo}
    kept = [r["rerun"] for r in records if r.get("rerun") and Job.key_of(r) in ran]
    if settings.rerun is not None:
        typer.echo(f"{len(kept)} recording(s) in {settings.rerun} (open one with `rerun FILE.rrd`)", err=True)
    config = results.config
    return records, config.to_dict() | {"digest": config.digest, "crashed": len(crashed)}


def _progress(items: list, desc: str, unit: str) -> Iterable:
    """``items`` with a progress bar on stderr (none when stderr is no terminal)."""
    from tqdm import tqdm

    return tqdm(items, desc=desc, unit=unit, file=sys.stderr, disable=None)


def _instruction_steps(
    path: Path, jobs: list[Job], llm: str | None
) -> dict[tuple[str, str, int], tuple[str, ...]]:
    """Job key → its primitive tasks, for the ``jobs`` on instructions of ``path``: the LLM's
    decomposition of the wording each job's seed picks, asked once per wording here (cached; the workers
    read the cache). A wording the LLM gives no plan for is left out: its episodes record the failure."""
    from tqdm import tqdm

    from taskcond.application.plans import instruction_plan, llm_decomposer
    from taskcond.decompose import DecompositionError
    from taskcond.instructions import load_instructions

    decomposer = llm_decomposer(llm)
    by_id = {i.id: i for i in load_instructions(path)}
    texts = {j.key: by_id[j.task].text_for(j.seed) for j in jobs if j.task in by_id}
    plans: dict[str, tuple[str, ...]] = {}
    for text in tqdm(
        sorted(set(texts.values())), desc="decomposing", unit="wording", file=sys.stderr, disable=None
    ):
        try:
            plans[text] = instruction_plan(text, decomposer).steps
        except DecompositionError:
            continue
        except LLMError as exc:
            fail(str(exc))
    return {key: plans[text] for key, text in texts.items() if text in plans}


def _eval_execution(
    kind: str,
    episodes: int,
    method: list[str] | None,
    as_json: bool,
    out: Path | None,
    task: list[str] | None,
    seed: int,
    settings: ExecutionSettings,
) -> None:
    _sim_import()
    from taskcond.application.condition_sources import NOVEL_METHODS
    from taskcond.application.evaluate import EVAL_METHODS, eval_task_ids, jobs_for, summarize

    novel = settings.novel_primitive
    if novel and kind != "long-horizon":
        fail("--novel-primitive applies to `taskcond eval long-horizon` only")
    methods = method or (list(NOVEL_METHODS) if novel else ["llm", "env", "none"])
    valid = NOVEL_METHODS if novel else EVAL_METHODS
    bad = [m for m in methods if m not in valid]
    if bad:
        what = " with --novel-primitive (its conditions come from the LLM)" if novel else ""
        fail(f"--method {bad[0]!r}{what}: use one of {', '.join(valid)}")
    if "image-il" in methods and settings.start != "task":
        fail(
            "--method image-il runs from the tasks' own start states only (it was trained on them): "
            "use --start task"
        )
    ids = eval_task_ids(kind)
    if task:
        unknown = [t for t in task if t not in ids]
        if unknown:
            fail(f"{unknown[0]!r} is not a {kind} task of the evaluation; valid: {', '.join(ids)}")
        ids = task
    jobs = jobs_for(ids, methods, episodes, seed)
    where = ("" if settings.start == "task" else f"-{settings.start}") + ("-novel-primitive" if novel else "")
    out = out or Path("runs") / f"eval-{kind}{where}.jsonl"
    records, config = _run_episodes(jobs, out, settings, kind)
    if config["crashed"]:
        raise typer.Exit(1)
    rows = summarize(records)
    walls = [r["wall_seconds"] for r in records if "wall_seconds" in r]
    if as_json:
        typer.echo(json.dumps({"results": rows}, indent=2))
        return
    if novel:
        _print_novel(rows, records)
    else:
        typer.echo(f"{'task':34s} {'method':8s} {'success':>9s}  failures")
        for row in rows:
            rate = f"{row['successes']}/{row['episodes']}"
            typer.echo(f"{row['task']:34s} {row['method']:8s} {rate:>9s}  {row['failures'] or ''}")
    if walls:
        typer.echo(
            f"\n{len(records)} episodes in {out}; {60.0 / (sum(walls) / len(walls)):.1f} episodes per minute "
            f"per core (mean episode wall time); configuration {config['digest']} (code {config['code']})"
        )


def _print_novel(rows: list[dict], records: list[dict]) -> None:
    """The novel-primitive table: per task and method the successes, per left-out primitive
    (successes/episodes), and each failure's seed, left-out primitive and reason."""
    typer.echo(f"{'task':6s} {'method':9s} {'success':>8s}  by left-out primitive")
    for row in rows:
        rate = f"{row['successes']}/{row['episodes']}"
        parts = [f"{p} {v['successes']}/{v['episodes']}" for p, v in sorted(row.get("left_out", {}).items())]
        typer.echo(f"{row['task']:6s} {row['method']:9s} {rate:>8s}  {', '.join(parts)}")
    failed = sorted(
        (r for r in records if not r.get("success")), key=lambda r: (r["task"], r["method"], r["seed"])
    )
    if failed:
        typer.echo("\nfailures (task, method, seed, left out: reason):")
    for r in failed:
        reason = " ".join(str(r.get("reason") or r.get("failure")).split())[:110]
        typer.echo(f"  {r['task']} {r['method']} {r['seed']}, {r.get('left_out')} left out: {reason}")


# long: typer declares the eval commands' 17 options in the signature
def eval_command(kind: str):
    # long: typer declares its 17 options in the signature
    def command(
        episodes: Annotated[
            int, typer.Option("--episodes", min=1, help="Seeded episodes per task and method.")
        ] = 10,
        method: Annotated[
            list[str] | None,
            typer.Option(
                "--method",
                help="Methods to compare (repeatable): llm, llm+demo, env, none, image-il (the image-based "
                "imitation-learning baseline; needs the il extra). Default llm, env, none (with "
                "--novel-primitive: llm, llm+demo).",
            ),
        ] = None,
        workers: WorkersOption = None,
        as_json: JsonOption = False,
        out: Annotated[
            Path | None,
            typer.Option(
                "--out",
                help="JSON-lines results, appended per episode; it records the configuration, and a run "
                "with the same configuration resumes from it (another configuration is an error). "
                "Default runs/eval-primitives.jsonl, runs/eval-long-horizon.jsonl or "
                "runs/eval-long-horizon-novel-primitive.jsonl.",
            ),
        ] = None,
        task: Annotated[
            list[str] | None, typer.Option("--task", help="Only these suite task ids (repeatable).")
        ] = None,
        seed: Annotated[int, typer.Option("--seed", help="Seed of the first episode of each task.")] = 1000,
        noise: NoiseOption = 0.005,
        llm: LlmOption = None,
        skills: SkillsOption = None,
        planner: PlannerOption = "conditions",
        start: StartOption = "task",
        backend: BackendOption = "local",
        ray_address: RayAddressOption = None,
        novel_primitive: Annotated[
            bool,
            typer.Option(
                "--novel-primitive",
                help="Long-horizon tasks only: Table IV's novel primitive tasks: each episode leaves one "
                "primitive of its task, drawn from the episode's seed, out of the LLM's examples "
                "(generalization, example order seeded by the episode). Methods llm and llm+demo (default "
                "both).",
            ),
        ] = False,
        world: WorldOption = "kitchen",
        rerun: cli_viz.RerunEvalOption = None,
        rerun_all: cli_viz.RerunAllOption = False,
        objects: ObjectsOption = None,
    ) -> None:
        if robosuite.check_world(world):
            return robosuite.evaluate(
                kind, episodes, method, as_json, out, task, seed, noise, llm, skills, planner, start
            )
        _check_start(start)
        _sim_import()
        _declare_objects(objects)
        settings = ExecutionSettings(
            workers,
            noise,
            llm,
            skills,
            backend,
            ray_address,
            planner,
            start,
            novel_primitive=novel_primitive,
            rerun=rerun,
            rerun_all=rerun_all,
        )
        _eval_execution(kind, episodes, method, as_json, out, task, seed, settings)

    return command


GoalMethodsOption = Annotated[
    list[str] | None,
    typer.Option("--method", help="Methods to compare (repeatable): llm, llm+demo, env, none. Default llm."),
]
"""``--method`` of the benchmarks judged by goal predicates (instructions, combinations)."""


def goal_methods(method: list[str] | None) -> list[str]:
    """The ``--method`` values of a goal benchmark (default llm); a one-line error for an unknown one."""
    from taskcond.execution.executor import METHODS

    methods = method or ["llm"]
    bad = [m for m in methods if m not in METHODS]
    if bad:
        fail(f"--method {bad[0]!r}: use one of {', '.join(METHODS)}")
    return methods


def run_goal_benchmark(
    desc: str,
    ids: list[str],
    methods: list[str],
    episodes: int,
    seed: int,
    out: Path,
    tasks_file: Path,
    settings: ExecutionSettings,
) -> tuple[list[dict], dict]:
    """Run every id of ``tasks_file`` (an instructions file) in ``ids`` by every method for ``episodes``
    seeds from ``seed`` into the results file ``out`` (:func:`_run_episodes`); returns the records and
    the configuration, or exits 1 when an episode crashed (reported on stderr)."""
    from taskcond.application.evaluate import jobs_for

    jobs = jobs_for(ids, methods, episodes, seed)
    records, config = _run_episodes(jobs, out, settings, desc, instructions=tasks_file.resolve())
    if config["crashed"]:
        raise typer.Exit(1)
    return records, config


# long: typer declares its 14 options in the signature
def eval_instructions(
    file: Annotated[
        Path | None,
        typer.Option(
            "--file",
            help="Instructions with their goal predicates (TOML; format in taskcond.instructions). Default: "
            "the package's benchmark (data/instructions.toml).",
        ),
    ] = None,
    episodes: Annotated[int, typer.Option("--episodes", min=1, help="Seeded episodes per instruction.")] = 10,
    method: GoalMethodsOption = None,
    instruction: Annotated[
        list[str] | None, typer.Option("--instruction", help="Only these instruction ids (repeatable).")
    ] = None,
    workers: WorkersOption = None,
    as_json: JsonOption = False,
    out: Annotated[
        Path | None,
        typer.Option(
            "--out",
            help="JSON-lines results, appended per episode; a run with the same configuration (the "
            "instructions file's digest included) resumes from it. Default "
            "runs/eval-instructions[-random].jsonl.",
        ),
    ] = None,
    seed: Annotated[
        int, typer.Option("--seed", help="Seed of the first episode of each instruction.")
    ] = 1000,
    start: StartOption = "task",
    noise: NoiseOption = 0.005,
    llm: LlmOption = None,
    skills: SkillsOption = None,
    planner: PlannerOption = "conditions",
    backend: BackendOption = "local",
    ray_address: RayAddressOption = None,
    rerun: cli_viz.RerunEvalOption = None,
    rerun_all: cli_viz.RerunAllOption = False,
    objects: ObjectsOption = None,
) -> None:
    """Free instructions from random starts (beyond the paper): each decomposed by the LLM (cached) as in
    `taskcond run`, run per method, judged by its shipped goal predicates (ground truth); the record also
    says whether the goal the plan itself implies held."""
    _sim_import()
    _declare_objects(objects)
    from taskcond.application.evaluate import summarize
    from taskcond.application.plans import instruction_scene
    from taskcond.instructions import InstructionError, check_objects, default_file, load_instructions
    from taskcond.worlds.kitchen import scene_objects

    _check_start(start)
    methods = goal_methods(method)
    path = file or default_file()
    try:
        chosen = load_instructions(path)
    except InstructionError as exc:
        fail(str(exc))
    for ins in chosen:
        objects, _ = scene_objects(instruction_scene(ins.text))
        reason = check_objects(ins, objects, ("gripper", "kinova gripper"))
        if reason is not None:
            fail(f"{path}: {reason}")
    if instruction:
        ids = [i.id for i in chosen]
        unknown = [i for i in instruction if i not in ids]
        if unknown:
            fail(f"no instruction {unknown[0]!r} in {path}; valid: {', '.join(ids)}")
        chosen = [i for i in chosen if i.id in instruction]
    where = "" if start == "task" else f"-{start}"
    out = out or Path("runs") / f"eval-instructions{where}.jsonl"
    settings = ExecutionSettings(
        workers, noise, llm, skills, backend, ray_address, planner, start, rerun=rerun, rerun_all=rerun_all
    )
    ids = [i.id for i in chosen]
    records, config = run_goal_benchmark("instructions", ids, methods, episodes, seed, out, path, settings)
    rows = summarize(records)
    by_id = {i.id: i for i in chosen}
    for row in rows:
        recs = [r for r in records if r["task"] == row["task"] and r["method"] == row["method"]]
        row["instruction"] = by_id[row["task"]].text
        row["goal"] = [str(q) for q in by_id[row["task"]].goal]
        row["steps"] = recs[0].get("steps", []) if recs else []
        row["plan_goal_held"] = sum(bool(r.get("plan_goal_held")) for r in recs)
        row["reasons"] = sorted({r["reason"] for r in recs if not r.get("success") and r.get("reason")})
    total = {
        m: [sum(r[k] for r in rows if r["method"] == m) for k in ("successes", "episodes")] for m in methods
    }
    if as_json:
        typer.echo(json.dumps({"results": rows, "total": total, "config": config}, indent=2))
        return
    typer.echo(f"{'instruction':30s} {'method':6s} {'success':>7s} {'plan':>5s}  failures")
    for row in rows:
        rate = f"{row['successes']}/{row['episodes']}"
        held = row["plan_goal_held"]
        typer.echo(f"{row['task']:30s} {row['method']:6s} {rate:>7s} {held:>5d}  {row['failures'] or ''}")
    for m, (ok, n) in total.items():
        typer.echo(f"\n{m}: {ok}/{n} episodes reached their goal ({100 * ok / max(n, 1):.0f}%)")
    typer.echo(
        f"'plan': episodes whose plan's own derived goal held. {len(records)} episodes in {out}; "
        f"configuration {config['digest']} (code {config['code']}, start {start}, planner {planner})"
    )
