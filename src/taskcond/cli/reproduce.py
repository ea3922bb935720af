"""``taskcond reproduce``: the paper's tables at their default counts."""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path
from typing import Annotated

import typer

from taskcond.cli.common import (
    BackendOption,
    ExecutionSettings,
    LlmOption,
    NoiseOption,
    PlannerOption,
    RayAddressOption,
    SkillsOption,
    WorkersOption,
    _crashed,
    _generator,
    _library,
    _require_demonstrations,
    _sim_import,
    fail,
)
from taskcond.cli.evaluate import _run_episodes
from taskcond.llm.base import LLMError
from taskcond.reproduce import CONDITION_COLUMNS, EXECUTION_COLUMNS, GROUNDED_COLUMN, ROBOSUITE_TABLE


def _reproduce_conditions(spec, trials, out: Path, llm: str | None, skills: Path | None):
    """Table II's trials into ``out`` (resuming it); returns the results and the configuration."""
    from tqdm import tqdm

    from taskcond.application.library import default_library_dir
    from taskcond.reproduce import condition_trial_runner
    from taskcond.results import (
        ConfigMismatchError,
        Job,
        ResultsFile,
        RunConfig,
        code_version,
        directory_digest,
        llm_fields,
    )

    library = _library(skills)
    library_dir = skills or default_library_dir()
    grounded = {t.task for t in trials if t.method == "generalization-grounded"}
    _require_demonstrations(library, grounded, "or leave it out with --column or --row")
    try:
        config = RunConfig(
            kind="conditions", **llm_fields(llm), skills=directory_digest(library_dir), code=code_version()
        )
        results = ResultsFile(out, config)
    except (ConfigMismatchError, LLMError) as exc:
        fail(str(exc))
    done = results.done(Job.key_of)
    # by mode and trial: the prompts of one trial's order share their examples, which llama.cpp reuses
    todo = sorted((t for t in trials if t.key not in done), key=lambda t: (t.method, t.seed))
    run = condition_trial_runner(lambda: _generator(llm, 1, False), lambda: library)
    bar = tqdm(total=len(trials), desc=spec.name, unit="condition", file=sys.stderr, disable=None)
    bar.update(len(trials) - len(todo))
    crashed = []
    for trial in todo:
        try:
            results.append(run(trial))
        except Exception as exc:
            rec = trial.to_dict() | {"crashed": True}
            crashed.append(results.append(rec | {"error": f"{type(exc).__name__}: {exc}"[:300]}))
        bar.update()
    bar.close()
    _crashed(crashed)
    return results.results(), config.to_dict() | {"digest": config.digest, "crashed": len(crashed)}


# long: typer declares its options in the signature; the tables' loop is reproduce.py's
def reproduce(
    table: Annotated[
        str,
        typer.Argument(
            help="table2, table3, table4 or all (the paper's); robosuite: robosuite's tasks by method, "
            "judged by robosuite's _check_success (needs the robosuite extra; episodes run in this process)."
        ),
    ],
    out: Annotated[
        Path,
        typer.Option(
            "--out",
            help="Directory for tableN.md/.json/.png and the resumable results tableN.jsonl (a rerun with "
            "the same configuration resumes; another configuration is an error).",
        ),
    ],
    episodes: Annotated[
        int | None,
        typer.Option(
            "--episodes",
            min=1,
            help="Episodes (Table II: trials) per task and method; default per table: Table II 2 trials "
            "per primitive, Table III 2 episodes per primitive task (37 of them), Table IV 5 per "
            "long-horizon task.",
        ),
    ] = None,
    workers: WorkersOption = None,
    row: Annotated[
        list[str] | None,
        typer.Option(
            "--row", help="Only these rows (repeatable): a primitive id (grasp, ...) or LHT1..LHT2*."
        ),
    ] = None,
    column: Annotated[
        list[str] | None,
        typer.Option(
            "--column",
            help="Only these columns (repeatable): "
            + ", ".join(c.key for c in CONDITION_COLUMNS)
            + " (Table II); "
            + ", ".join(c.key for c in EXECUTION_COLUMNS)
            + f" (Tables III, IV); {GROUNDED_COLUMN.key} (Table IV). The others show as not run.",
        ),
    ] = None,
    backend: BackendOption = "local",
    ray_address: RayAddressOption = None,
    noise: NoiseOption = 0.005,
    llm: LlmOption = None,
    skills: SkillsOption = None,
    planner: PlannerOption = "none",
) -> None:
    """Run the paper's Tables II-IV with our numbers beside the paper's, Wilson 95% intervals, plots.
    The paper's protocol runs each sequence as given (``--planner none``, the default here)."""
    import time

    from taskcond.reproduce import only_columns, only_rows, table_specs, trials_for, write_table

    settings = ExecutionSettings(workers, noise, llm, skills, backend, ray_address, planner)
    if table == ROBOSUITE_TABLE:
        if (workers or 1) > 1 or backend != "local" or ray_address is not None:
            fail(
                "robosuite's table runs its episodes in this process: --workers, --backend and "
                "--ray-address do not apply to it (valid: --episodes, --row, --column, --noise, --llm, "
                "--skills, --planner)"
            )
        _reproduce_robosuite(out, episodes, row, column, settings)
        return
    _sim_import()
    specs = table_specs()
    names = list(specs) if table == "all" else [table]
    if any(n not in specs for n in names):
        fail(f"table {table!r}: use one of {', '.join(specs)}, all or {ROBOSUITE_TABLE}")
    chosen = []
    for name in names:
        try:
            spec = only_rows(specs[name], row) if row else specs[name]
            chosen.append(only_columns(spec, column) if column else spec)
        except ValueError as exc:
            if len(names) == 1 or (name == names[-1] and not chosen):
                fail(str(exc))
            # else --row or --column names rows or columns of another table of "all"
    chosen = [_without_il(spec) for spec in chosen]
    out.mkdir(parents=True, exist_ok=True)
    crashed = 0
    for spec in chosen:
        name = spec.name
        n = episodes or spec.default_episodes
        trials = trials_for(spec, n)
        start = time.perf_counter()
        if spec.kind == "conditions":
            records, config = _reproduce_conditions(spec, trials, out / f"{name}.jsonl", llm, skills)
        else:
            records, config = _run_episodes(trials, out / f"{name}.jsonl", settings, name)
            novel = trials_for(spec, n, novel_primitive=True)
            if novel:  # another configuration, so another results file
                more, novel_config = _run_episodes(
                    novel,
                    out / f"{name}-novel-primitive.jsonl",
                    replace(settings, novel_primitive=True),
                    f"{name} novel primitive",
                )
                records = records + more
                config["crashed"] += novel_config["crashed"]
                config["novel_primitive_digest"] = novel_config["digest"]
        seconds = time.perf_counter() - start
        crashed += config["crashed"]
        used = sum(not r.get("skipped") for r in records)
        footer = (
            f"{used} trials, {n} per task and method (seeds {spec.seed}+); this invocation "
            f"{seconds / 60:.1f} min; configuration {config['digest']} (code {config['code']}, LLM "
            f"{config['llm']}, noise {config['noise']})"
            + (
                f"; novel-primitive episodes: configuration {config['novel_primitive_digest']} "
                f"({name}-novel-primitive.jsonl)"
                if "novel_primitive_digest" in config
                else ""
            )
            + "; confidence intervals: Wilson score, 95%."
        )
        extra = {"episodes": n, "seconds": round(seconds, 1), "config": config}
        write_table(spec, records, n, out, extra, footer)
        typer.echo((out / f"{name}.md").read_text(encoding="utf-8"))
        typer.echo(f"wrote {out / name}.md, .json, .png", err=True)
    if crashed:
        raise typer.Exit(1)


def _reproduce_robosuite(
    out: Path, episodes: int | None, row: list[str] | None, column: list[str] | None, settings
) -> None:
    """``taskcond reproduce robosuite``: every supported robosuite task by method (seeds 1000+) into
    ``out/robosuite.jsonl`` (resumable; the configuration records the world's versions), written as
    ``robosuite.md/.json/.png`` with Wilson 95% intervals."""
    import time

    from taskcond.application.robosuite import evaluate, run_config
    from taskcond.cli.robosuite import library
    from taskcond.reproduce import only_columns, only_rows, robosuite_table
    from taskcond.results import ConfigMismatchError, ResultsFile
    from taskcond.worlds.robosuite import RobosuiteUnavailableError, require_robosuite
    from taskcond.worlds.robosuite.demos import default_library_dir
    from taskcond.worlds.robosuite.tasks import TASKS

    try:
        require_robosuite()
        spec = robosuite_table()
        spec = only_rows(spec, row) if row else spec
        spec = only_columns(spec, column) if column else spec
    except (RobosuiteUnavailableError, ValueError) as exc:
        fail(str(exc))
    n = episodes or spec.default_episodes
    skills_dir = settings.skills or default_library_dir()
    config = run_config(skills_dir, settings.noise, settings.llm, settings.planner)
    out.mkdir(parents=True, exist_ok=True)
    try:
        results = ResultsFile(out / f"{spec.name}.jsonl", config)
    except ConfigMismatchError as exc:
        fail(str(exc))
    block = spec.blocks[0]
    start = time.perf_counter()
    records = evaluate(
        [TASKS[r.key] for r in block.rows],
        list(block.methods.values()),
        n,
        results,
        library(settings.skills),
        settings.llm,
        settings.noise,
        settings.planner,
        seed=spec.seed,
        progress=lambda r: typer.echo(
            f"  {r['task']} {r['method']} seed {r['seed']}: {'ok' if r.get('success') else 'failed'}",
            err=True,
        ),
    )
    _write_robosuite(spec, records, n, out, config, time.perf_counter() - start)


def _write_robosuite(spec, records: list, n: int, out: Path, config, seconds: float) -> None:
    """Write and print robosuite's table; exit 1 if an episode crashed."""
    from taskcond.reproduce import write_table

    crashed = sum(bool(r.get("crashed")) for r in records)
    footer = (
        f"{len(records)} episodes, {n} per task and method (seeds {spec.seed}+); this invocation "
        f"{seconds / 60:.1f} min; configuration {config.digest} ({config.world}, code {config.code}, LLM "
        f"{config.llm}, noise {config.noise}, planner {config.planner}); confidence intervals: Wilson "
        "score, 95%."
    )
    extra = {"episodes": n, "seconds": round(seconds, 1), "config": config.to_dict() | {"crashed": crashed}}
    write_table(spec, records, n, out, extra, footer)
    typer.echo((out / f"{spec.name}.md").read_text(encoding="utf-8"))
    typer.echo(f"wrote {out / spec.name}.md, .json, .png", err=True)
    if crashed:
        raise typer.Exit(1)


def _without_il(spec):
    """``spec`` with the image-based baseline's column not run (and said why) when the [il] extra is
    missing."""
    from dataclasses import replace

    from taskcond.il import ILUnavailableError, require_il

    try:
        require_il()
    except ILUnavailableError as exc:
        blocks = tuple(
            replace(
                b,
                methods={k: m for k, m in b.methods.items() if m != "image-il"},
                pending={**b.pending, **{k: str(exc) for k, m in b.methods.items() if m == "image-il"}},
            )
            for b in spec.blocks
        )
        if blocks != spec.blocks:
            typer.echo(f"{spec.name}: the image-il column is not run: {exc}", err=True)
        return replace(spec, blocks=blocks)
    return spec
