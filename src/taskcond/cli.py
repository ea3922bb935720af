"""The ``taskcond`` command line: conditions, tasks, oracle runs and evaluations.

Bad input (an unknown task, verb, object, primitive or backend; an LLM that fails) ends with a one-line
``error:`` message on stderr and exit code 2, never a traceback.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Annotated, NoReturn

import typer

from taskcond.conditions import ConditionError
from taskcond.llm.base import LLMError
from taskcond.primitives import PRIMITIVES, TaskNameError, parse_task

app = typer.Typer(
    help="Long-horizon manipulation guided by LLM-generated task conditions (arXiv 2310.02264).",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)
eval_app = typer.Typer(
    help="Measure the framework: condition generation/generalization (Table II).", no_args_is_help=True
)
app.add_typer(eval_app, name="eval")

LlmOption = Annotated[
    str | None,
    typer.Option(
        "--llm",
        help="Backend: embedded, embedded:MODEL (qwen2.5-coder-1.5b, qwen2.5-coder-0.5b), openai, "
        "openai:MODEL. Default: $TASKCOND_LLM, the config file, else embedded.",
    ),
]
SamplesOption = Annotated[
    int, typer.Option("--samples", min=1, help="Self-consistency: answers per chat, majority per condition.")
]
NoCacheOption = Annotated[
    bool, typer.Option("--no-cache", help="Do not read or write the on-disk response cache.")
]
JsonOption = Annotated[bool, typer.Option("--json", help="Print JSON instead of text.")]


def fail(message: str) -> NoReturn:
    typer.echo(f"error: {message}", err=True)
    raise typer.Exit(2)


def _generator(llm: str | None, samples: int, no_cache: bool, grammar: str = "fallback"):
    from dataclasses import replace

    from taskcond.generator import ConditionGenerator
    from taskcond.llm.config import LLMConfig, make_backend

    config = LLMConfig.load(llm)
    if no_cache:
        config = replace(config, cache=False)
    return ConditionGenerator(make_backend(config), samples=samples, grammar=grammar)


@app.command()
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
) -> None:
    """Generate the task condition of TASK with the LLM (paper §III-B/C) and print it."""
    try:
        if grammar not in ("fallback", "always", "never"):
            fail(f"--grammar {grammar!r}: use fallback, always or never")
        gen = _generator(llm, samples, no_cache, grammar=grammar)
        result = gen.generate(task, exclude=exclude or (), seed=seed)
    except (TaskNameError, ConditionError, LLMError) as exc:
        fail(str(exc))
    if as_json:
        typer.echo(result.condition.to_json())
    else:
        typer.echo(result.condition.to_text())
        source = "cache" if result.cached else f"{gen.backend.name}:{gen.backend.model}"
        typer.echo(f"# {result.mode}, {result.seconds:.2f} s, from {source}", err=True)


@app.command()
def tasks(as_json: JsonOption = False) -> None:
    """List the primitives with their task-name patterns and the suite's tasks (--json: the suite's tasks)."""
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
        typer.echo(f"  {p.id:14s} {p.pattern}{aliases}")
    if suite:
        typer.echo("\nSuite tasks (id: objects or primitive tasks):")
        for t in suite:
            detail = ", ".join(t.objects) if t.kind == "primitive" else " -> ".join(t.primitive)
            typer.echo(f"  {t.id:32s} {detail}")
    else:
        typer.echo("\n(the PyBullet task suite needs the [sim] extra: pip install 'taskcond[sim]')")


@app.command()
def oracle(
    task: Annotated[
        str, typer.Argument(help="Suite task id (see `taskcond tasks`), e.g. grasp-bottle or LHT1.")
    ],
    episodes: Annotated[int, typer.Option("--episodes", min=1, help="Number of seeded episodes.")] = 10,
    seed: Annotated[
        int, typer.Option("--seed", help="Seed of the first episode; episode k uses seed + k.")
    ] = 0,
    as_json: JsonOption = False,
    video: Annotated[
        Path | None, typer.Option("--video", help="Record the first episode to this .mp4 or .gif.")
    ] = None,
) -> None:
    """Run the scripted oracle of TASK and report its success rate."""
    try:
        from taskcond.tasks.oracle import run_oracle
    except ImportError as exc:
        fail(f"the task suite needs the [sim] extra ({exc.name} missing): pip install 'taskcond[sim]'")
    if video is not None and video.suffix.lower() not in (".mp4", ".gif"):
        fail(f"--video {video}: use a .mp4 or .gif file name")
    try:
        report = run_oracle(task, episodes=episodes, seed=seed, video=video)
    except ValueError as exc:
        fail(str(exc))
    out = {
        "task": report.task,
        "episodes": report.episodes,
        "successes": report.successes,
        "steps_per_second": round(report.steps_per_second, 1),
        "failures": dict(report.failures),
    }
    if as_json:
        typer.echo(json.dumps(out))
    else:
        typer.echo(
            f"{report.task}: {report.successes}/{report.episodes} succeeded "
            f"({report.steps_per_second:.0f} steps/s); failures: {dict(report.failures) or 'none'}"
        )


@eval_app.command("conditions")
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
) -> None:
    """Generation (all examples) and generalization (leave-one-out) accuracy per primitive (Table II)."""
    from tqdm import tqdm

    from taskcond.evaluation import evaluate_conditions
    from taskcond.primitives import get_primitive

    try:
        pids = [get_primitive(p).id for p in primitive] if primitive else list(PRIMITIVES)
        gen = _generator(llm, samples, no_cache)
    except (TaskNameError, LLMError) as exc:
        fail(str(exc))
    bar = tqdm(total=2 * trials * len(pids), desc="conditions", unit="cond", file=sys.stderr, disable=None)
    result = evaluate_conditions(gen, trials=trials, primitives=pids, progress=lambda _o: bar.update())
    bar.close()
    if as_json:
        typer.echo(json.dumps(result.to_dict(), indent=2))
    else:
        typer.echo(result.table())
        typer.echo(
            f"\nmodel {result.model}; median seconds per condition: "
            f"generation {result.median_seconds('generation'):.2f}, "
            f"generalization {result.median_seconds('generalization'):.2f}"
        )


if __name__ == "__main__":
    app()
