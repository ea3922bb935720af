"""``taskcond conditions``, ``taskcond tasks`` and ``taskcond eval conditions`` (Table II)."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Annotated

import typer

import taskcond.cli.robosuite as robosuite
from taskcond.cli.common import (
    JsonOption,
    LlmOption,
    NoCacheOption,
    ObjectsOption,
    PrimitivesOption,
    PromptVersionOption,
    SamplesOption,
    SkillsOption,
    WorldOption,
    _declare,
    _declare_objects,
    _generator,
    _library,
    _require_demonstrations,
    _sim_import,
    fail,
)
from taskcond.conditions import ConditionError
from taskcond.generator import PROMPT_VERSION
from taskcond.llm.base import LLMError
from taskcond.primitives import PRIMITIVES, TaskNameError, parse_task


# long: typer declares its 9 options in the signature
def conditions(
    task: Annotated[str, typer.Argument(help='Primitive task name, e.g. "move bottle into box".')],
    as_json: JsonOption = False,
    exclude: Annotated[
        list[str] | None,
        typer.Option(
            "--exclude", help=f"Leave this primitive's examples out (repeatable): {', '.join(PRIMITIVES)}."
        ),
    ] = None,
    llm: LlmOption = None,
    samples: SamplesOption = 1,
    no_cache: NoCacheOption = False,
    grammar: Annotated[
        str,
        typer.Option(
            "--grammar",
            help="Constrained decoding: fallback (only after an invalid answer), always, or never.",
        ),
    ] = "fallback",
    seed: Annotated[int, typer.Option("--seed", help="Sampling seed.")] = 0,
    prompt_version: PromptVersionOption = PROMPT_VERSION,
    ground: Annotated[
        bool,
        typer.Option(
            "--ground",
            help="Ground the answer in the demonstration of its primitive from the skill library (the "
            "suite's, or one learned with `taskcond learn --demo`): the llm+demo condition source.",
        ),
    ] = False,
    explain: Annotated[
        bool,
        typer.Option("--explain", help="With --ground implied: print the LLM's answer and every repair."),
    ] = False,
    skills: Annotated[
        Path | None,
        typer.Option("--skills", help="Skill library for --ground (default: the user cache's)."),
    ] = None,
    primitives: PrimitivesOption = None,
    objects: ObjectsOption = None,
) -> None:
    """Generate the task condition of TASK with the LLM (paper §III-B/C) and print it; with --ground, checked
    against the demonstration of its primitive (beyond the paper)."""
    _declare(primitives)
    _declare_objects(objects)
    try:
        if grammar not in ("fallback", "always", "never"):
            fail(f"--grammar {grammar!r}: use fallback, always or never")
        parse_task(task)
        gen = _generator(llm, samples, no_cache, grammar=grammar, prompt_version=prompt_version)
        result = gen.generate(task, exclude=exclude or (), seed=seed)
    except (TaskNameError, ConditionError, LLMError) as exc:
        fail(str(exc))
    condition, repairs = result.condition, None
    if ground or explain:
        _sim_import()
        from taskcond.execution.skills import SkillError
        from taskcond.execution.sources import demonstration_evidence
        from taskcond.grounding import ground as ground_in

        try:
            grounded = ground_in(condition, demonstration_evidence(_library(skills), task))
        except SkillError as exc:
            fail(str(exc))
        condition, repairs = grounded.condition, grounded.repairs
    if as_json:
        out = condition.to_dict()
        if repairs is not None:
            out |= {"llm": result.condition.to_dict(), "repairs": [r.to_dict() for r in repairs]}
        typer.echo(json.dumps(out, indent=2))
        return
    if explain:
        typer.echo("# the LLM's answer:")
        typer.echo("\n".join(f"#   {line}" for line in result.condition.to_text().splitlines()))
        typer.echo(f"# grounded in the demonstration: {len(repairs or ())} repair(s)")
        for repair in repairs or ():
            typer.echo(f"#   {repair}")
    typer.echo(condition.to_text())
    source = "cache" if result.cached else result.model
    grounded_note = ", grounded in its demonstration" if repairs is not None else ""
    typer.echo(f"# {result.mode}{grounded_note}, {result.seconds:.2f} s, from {source}", err=True)


def tasks(
    as_json: JsonOption = False, primitives: PrimitivesOption = None, world: WorldOption = "kitchen"
) -> None:
    """List the primitives with their task-name patterns and the suite's tasks (--json: the suite's tasks)."""
    _declare(primitives)
    if robosuite.check_world(world):
        return robosuite.tasks(as_json)
    try:
        from taskcond.tasks.registry import list_tasks

        suite = list_tasks()
    except ImportError:
        suite = []
    if as_json:
        rows = []
        for t in suite:
            row = {"id": t.id, "kind": t.kind, "primitive": t.primitive, "objects": list(t.objects)}
            if t.kind == "long-horizon":  # its primitives in order, and the primitive tasks they come from
                row["primitive"] = [parse_task(step).primitive.id for step in t.primitive]
                row["steps"] = list(t.primitive)
            rows.append(row)
        if not suite:
            typer.echo("(no suite tasks: the task suite needs pip install 'taskcond[sim]')", err=True)
        typer.echo(json.dumps(rows, indent=2))
        return
    typer.echo("Primitives (id: pattern; aliases):")
    for p in PRIMITIVES.values():
        aliases = f"; {', '.join(p.aliases)}" if p.aliases else ""
        typer.echo(f"  {p.id:14s} {p.pattern}{aliases}{' (declared)' if p.declared else ''}")
    if suite:
        typer.echo("\nSuite tasks (id: objects or primitive tasks):")
        for t in suite:
            detail = ", ".join(t.objects) if t.kind == "primitive" else " -> ".join(t.primitive)
            typer.echo(f"  {t.id:32s} {detail}")
    else:
        typer.echo("\n(the PyBullet task suite needs the [sim] extra: pip install 'taskcond[sim]')")


# long: typer declares its options in the signature; Table II's loop is evaluation.py's
def eval_conditions(
    trials: Annotated[int, typer.Option("--trials", min=1, help="Trials per primitive and mode.")] = 5,
    as_json: JsonOption = False,
    llm: LlmOption = None,
    samples: SamplesOption = 1,
    no_cache: NoCacheOption = False,
    primitive: Annotated[
        list[str] | None,
        typer.Option("--primitive", help=f"Only these primitives (repeatable): {', '.join(PRIMITIVES)}."),
    ] = None,
    prompt_version: PromptVersionOption = PROMPT_VERSION,
    probe: Annotated[
        bool,
        typer.Option(
            "--probe/--no-probe",
            help="Also ask the model the zero-shot state probe (46 yes/no questions, cached) and print its "
            "score beside the generalization figure.",
        ),
    ] = True,
    mode: Annotated[
        list[str] | None,
        typer.Option(
            "--mode", help="Only these modes (repeatable): generation, generalization. Default both."
        ),
    ] = None,
    grounded: Annotated[
        bool | None,
        typer.Option(
            "--grounded/--no-grounded",
            help="Also ground every generalization answer in the suite's demonstration of its primitive "
            "(column 'generalization, grounded'; needs the [sim] extra and the skill library, learned on "
            "first use). Default: when the [sim] extra is installed.",
        ),
    ] = None,
    skills: SkillsOption = None,
) -> None:
    """Generation (all examples) and generalization (leave-one-out) accuracy per primitive (Table II),
    generalization grounded in the demonstrations, and the model's zero-shot state probe."""
    from tqdm import tqdm

    from taskcond.evaluation import evaluate_conditions
    from taskcond.primitives import get_primitive
    from taskcond.results import RunConfig, code_version, llm_fields

    modes = mode or ["generation", "generalization"]
    bad = [m for m in modes if m not in ("generation", "generalization")]
    if bad:
        fail(f"--mode {bad[0]!r}: use generation or generalization")
    try:
        pids = [get_primitive(p).id for p in primitive] if primitive else list(PRIMITIVES)
        gen = _generator(llm, samples, no_cache, prompt_version=prompt_version)
    except (TaskNameError, LLMError) as exc:
        fail(str(exc))
    if grounded is None:
        import importlib.util

        grounded = importlib.util.find_spec("pybullet") is not None
        if not grounded:
            typer.echo(
                "(no 'generalization, grounded' column: it needs pip install 'taskcond[sim]')", err=True
            )
    evidence = None
    if grounded and "generalization" in modes:
        from taskcond.execution.sources import demonstration_evidence

        _sim_import()
        library = _library(skills)
        _require_demonstrations(library, pids, "or leave the column out: --no-grounded")

        def evidence(task):
            return demonstration_evidence(library, task.name)

    total = len(modes) * trials * len(pids)
    bar = tqdm(total=total, desc="conditions", unit="cond", file=sys.stderr, disable=None)
    result = evaluate_conditions(
        gen, trials=trials, primitives=pids, modes=modes, progress=lambda _o: bar.update(), evidence=evidence
    )
    bar.close()
    config = RunConfig(kind="conditions", **llm_fields(llm, gen), code=code_version())
    if probe:
        from taskcond.probe import probe as state_probe

        try:  # beside the generalization figure: does the model know the primitives' states at all?
            result.probe = state_probe(gen.backend)
        except LLMError as exc:
            typer.echo(f"state probe not measured: {exc}", err=True)
    if as_json:
        made = {"config": config.to_dict(), "digest": config.digest}
        typer.echo(json.dumps(result.to_dict() | made, indent=2))
    else:
        typer.echo(result.table())
        medians = ", ".join(f"{m} {result.median_seconds(m):.2f}" for m in modes)
        typer.echo(
            f"\nmodel {result.model}; prompts {result.prompt_version}, samples {result.samples}; median "
            f"seconds per condition: {medians}; configuration {config.digest} (code {config.code})"
        )
        if result.probe is not None:
            typer.echo(
                f"{result.probe.summary()}: zero-shot yes/no questions on the primitives' object states "
                "(benchmarks/probe_llm.py); near chance, the model cannot know a left-out primitive's states"
            )
        if result.grounded:
            extra = sum(len(o.extra_relations) for o in result.outcomes)
            incidental = sum(len(o.incidental) for o in result.outcomes)
            repairs = sum(len(o.repairs) for o in result.outcomes)
            typer.echo(
                f"grounded in the suite's demonstrations: {repairs} repairs; relations beyond the reference "
                f"in grounded answers: {extra} ({incidental} added by grounding)"
            )
