"""``taskcond eval combinations``: the combination benchmark (issue 31), every primitive task the kitchen
makes feasible and seeded sequences of them (:mod:`taskcond.combinations`), run through the instruction
benchmark's machinery (progress, resume, configuration, Ray) and printed per primitive by object."""

from __future__ import annotations

import json
from collections import defaultdict
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

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
    _check_start,
    _declare_objects,
    _sim_import,
    fail,
)
from taskcond.cli.evaluate import GoalMethodsOption, goal_methods, run_goal_benchmark

if TYPE_CHECKING:
    from taskcond.combinations import Combination, Generated, Refusal


def _generated(objects: list[Path] | None) -> Generated:
    """The scene's combinations (:func:`taskcond.combinations.generate`) from its object roles, the objects
    declared in ``objects`` (``--objects``, :func:`~taskcond.cli.common._declare_objects`) among them."""
    from taskcond.combinations import TemplateError, generate
    from taskcond.sim.roles import scene_roles

    _declare_objects(objects)
    try:
        return generate(scene_roles())
    except (TemplateError, ValueError) as exc:
        fail(str(exc))


def _check_choices(primitive: list[str], obj: list[str], generated: Generated) -> None:
    """One-line errors for a --primitive or --object the generated tasks do not have."""
    prims = sorted({s.primitive for c in generated.combinations for s in c.steps})
    objs = sorted({o for c in generated.combinations for s in c.steps for o in s.objects})
    for p in primitive:
        if p not in prims:
            fail(f"--primitive {p!r}: use one of {', '.join(prims)}")
    for o in obj:
        if o not in objs:
            fail(f"--object {o!r}: use one of {', '.join(objs)} (spaces as in the scene: 'top drawer')")


def _listing(
    chosen: Sequence[Combination], refused: Sequence[Refusal], pairs: int, as_json: bool, show_refused: bool
) -> None:
    """``--list`` (the chosen tasks with their wordings and goals) or ``--refused``, as text or JSON."""
    if as_json:
        out = {
            "combinations": [
                {
                    "id": c.id,
                    "steps": [s.name for s in c.steps],
                    "wordings": c.wordings,
                    "goal": [str(q) for q in c.goal],
                }
                for c in chosen
            ],
            "refused": [{"task": r.task, "reason": r.reason} for r in refused],
            "consistent_pairs": pairs,
        }
        typer.echo(json.dumps(out, indent=2))
        return
    if show_refused:
        for r in refused:
            typer.echo(f"refused  {r.task}: {r.reason}")
        return
    for c in chosen:
        typer.echo(f"{c.id}\n  goal: {', '.join(map(str, c.goal))}")
        for w in c.wordings:
            typer.echo(f"  - {w}")
    typer.echo(
        f"\n{len(chosen)} tasks; {len(refused)} pairings refused (--refused lists them with their reasons); "
        f"sequences are a seeded sample of the consistent ones ({pairs} of two steps)"
    )


def fell(record: dict) -> bool:
    """An episode in which an object fell over: one lies at the end (``fallen``), or a grasp met it lying."""
    return bool(record.get("fallen")) or record.get("failure") == "fallen"


def table(records: list[dict], combinations: Sequence[Combination]) -> dict:
    """Per cell (primitive [target] by object) and per sequence length: episodes, successes; per clause
    template of the single steps; overall; the ``fallen`` count."""
    by_id = {c.id: c for c in combinations}
    cells: dict[tuple[str, str], list[int]] = defaultdict(lambda: [0, 0])
    wordings: dict[tuple[str, str], list[int]] = defaultdict(lambda: [0, 0])
    for r in records:
        c = by_id.get(r["task"])
        if c is None:
            continue
        ok = int(bool(r.get("success")))
        for key in (c.cell, (c.cell[0], "all")) if c.cell[1] != "all" else (c.cell,):
            cells[key][0] += ok
            cells[key][1] += 1
        if len(c.steps) == 1 and r.get("instruction") in c.wordings:
            w = wordings[(c.steps[0].primitive, c.templates[c.wordings.index(r["instruction"])])]
            w[0] += ok
            w[1] += 1
    n = len([r for r in records if r["task"] in by_id])
    return {
        "cells": [
            {"row": k[0], "object": k[1], "successes": v[0], "episodes": v[1]} for k, v in cells.items()
        ],
        "wordings": [
            {"primitive": p, "wording": k, "successes": v[0], "episodes": v[1]}
            for (p, k), v in sorted(wordings.items())
        ],
        "successes": sum(bool(r.get("success")) for r in records if r["task"] in by_id),
        "episodes": n,
        "fallen": sum(fell(r) for r in records if r["task"] in by_id),
    }


def _print_table(summary: dict, combinations: Sequence[Combination]) -> None:
    """Rows primitive (and target), columns object, each cell successes/episodes; then the overall line."""
    rows = list(dict.fromkeys(c.cell[0] for c in combinations))
    objects = list(dict.fromkeys(c.cell[1] for c in combinations if c.cell[1] != "all"))
    cells = {(c["row"], c["object"]): c for c in summary["cells"]}
    width = max(len(r) for r in rows) + 2
    typer.echo(f"{'':{width}s}" + "".join(f"{o[:11]:>12s}" for o in [*objects, "all"]))
    for row in rows:
        if not any((row, o) in cells for o in [*objects, "all"]):
            continue
        line = f"{row:{width}s}"
        for o in [*objects, "all"]:
            cell = cells.get((row, o))
            line += f"{'' if cell is None else str(cell['successes']) + '/' + str(cell['episodes']):>12s}"
        typer.echo(line)
    ok, n, fallen = summary["successes"], summary["episodes"], summary["fallen"]
    typer.echo(
        f"\noverall: {ok}/{n} episodes reached their goal ({100 * ok / max(n, 1):.0f}%); "
        f"fallen: {fallen}/{n} ({100 * fallen / max(n, 1):.1f}%) episodes in which an object fell over"
    )
    if summary["wordings"]:
        typer.echo("by wording (single steps, per clause of the templates):")
        for w in summary["wordings"]:
            typer.echo(f"  {w['primitive']:14s} {w['wording']!r:44s} {w['successes']}/{w['episodes']}")


# long: typer declares the command's 22 options in the signature
def eval_combinations(
    start: StartOption = "random",
    episodes: Annotated[
        int,
        typer.Option(
            "--episodes",
            min=1,
            help="Seeded episodes (starts) per task; consecutive seeds say a task in each of its wordings "
            "in turn.",
        ),
    ] = 3,
    objects: ObjectsOption = None,
    primitive: Annotated[
        list[str] | None,
        typer.Option("--primitive", help="Only tasks with a step of these primitives (repeatable)."),
    ] = None,
    obj: Annotated[
        list[str] | None, typer.Option("--object", help="Only tasks naming these objects (repeatable).")
    ] = None,
    max_steps: Annotated[
        int, typer.Option("--max-steps", min=1, max=3, help="Only tasks of at most this many steps (1-3).")
    ] = 3,
    list_only: Annotated[
        bool,
        typer.Option("--list", help="Print the generated tasks with their wordings and goals; run nothing."),
    ] = False,
    refused: Annotated[
        bool, typer.Option("--refused", help="Print the refused pairings with their reasons; run nothing.")
    ] = False,
    method: GoalMethodsOption = None,
    workers: WorkersOption = None,
    as_json: JsonOption = False,
    out: Annotated[
        Path | None,
        typer.Option(
            "--out",
            help="JSON-lines results, appended per episode; the generated tasks are written beside it "
            "(.tasks.toml; their digest is part of the configuration) and a run with the same "
            "configuration resumes. Default runs/eval-combinations[-random].jsonl.",
        ),
    ] = None,
    seed: Annotated[int, typer.Option("--seed", help="Seed of the first episode of each task.")] = 1000,
    noise: NoiseOption = 0.005,
    llm: LlmOption = None,
    skills: SkillsOption = None,
    planner: PlannerOption = "conditions",
    backend: BackendOption = "local",
    ray_address: RayAddressOption = None,
    rerun: cli_viz.RerunEvalOption = None,
    rerun_all: cli_viz.RerunAllOption = False,
) -> None:
    """Every primitive task the scene makes feasible, and seeded sequences of two and three, each said in
    several wordings and judged by its template's goal (beyond the paper): a table per primitive by object,
    with a fallen rate. Pairings that cannot work are refused with a reason (--refused), not run."""
    from taskcond.combinations import select

    _check_start(start)
    methods = goal_methods(method)
    generated = _generated(objects)
    _check_choices(primitive or [], obj or [], generated)
    chosen = select(generated.combinations, primitive or [], obj or [], max_steps)
    if list_only or refused:
        _listing(chosen, generated.refused, generated.pairs, as_json, refused)
        return
    if not chosen:
        fail("no generated task has all of the chosen --primitive, --object and --max-steps; see --list")
    _sim_import()
    from taskcond.combinations import write_instructions

    out = out or Path("runs") / f"eval-combinations{'' if start == 'task' else '-' + start}.jsonl"
    tasks_file = out.with_suffix(".tasks.toml")
    write_instructions(
        generated.combinations, tasks_file
    )  # every task: a restriction keeps the configuration
    settings = ExecutionSettings(
        workers, noise, llm, skills, backend, ray_address, planner, start, rerun=rerun, rerun_all=rerun_all
    )
    ids = [c.id for c in chosen]
    records, config = run_goal_benchmark(
        "combinations", ids, methods, episodes, seed, out, tasks_file, settings
    )
    summaries = {m: table([r for r in records if r["method"] == m], chosen) for m in methods}
    if as_json:
        report = {
            "methods": summaries,
            "refused": [{"task": r.task, "reason": r.reason} for r in generated.refused],
        }
        typer.echo(json.dumps(report | {"config": config}, indent=2))
        return
    for m, summary in summaries.items():
        typer.echo(f"method {m}:")
        _print_table(summary, chosen)
    typer.echo(
        f"{len(chosen)} tasks ({sum(len(c.steps) > 1 for c in chosen)} sequences, a seeded sample of the "
        f"consistent ones); {len(generated.refused)} pairings refused (--refused); {len(records)} episodes "
        f"in {out}; configuration {config['digest']} (code {config['code']}, start {start}, "
        f"planner {planner})"
    )
