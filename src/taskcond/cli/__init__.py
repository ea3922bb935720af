"""The ``taskcond`` command line: conditions, tasks, oracle runs and evaluations.

Bad input (an unknown task, verb, object, primitive or backend; an LLM that fails) ends with a one-line
``error:`` message on stderr and exit code 2, never a traceback.
"""

from __future__ import annotations

from typing import NoReturn

import typer

from taskcond.cli import combinations, conditions, evaluate, reproduce, run, skills, viz

app = typer.Typer(
    help="Long-horizon manipulation guided by LLM-generated task conditions (arXiv 2310.02264).",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)
eval_app = typer.Typer(
    help="Measure the framework: condition generation/generalization (Table II), primitive and "
    "long-horizon execution (Tables III, IV).",
    no_args_is_help=True,
)
app.add_typer(eval_app, name="eval")

app.command()(conditions.conditions)
app.command()(conditions.tasks)
app.command()(skills.oracle)
app.command()(skills.learn)
app.command()(skills.record)
app.command()(run.run)
app.command()(reproduce.reproduce)
app.command(help="Run one stored episode of a results file again, to a Rerun recording or a video.")(
    viz.replay
)
eval_app.command("conditions")(conditions.eval_conditions)
eval_app.command("instructions")(evaluate.eval_instructions)
eval_app.command("combinations")(combinations.eval_combinations)
eval_app.command("primitives", help="Success rate of every primitive task per execution method (Table III).")(
    evaluate.eval_command("primitives")
)
eval_app.command(
    "long-horizon", help="Success rate of the long-horizon tasks per execution method (Table IV)."
)(evaluate.eval_command("long-horizon"))


def main(args: list[str] | None = None) -> NoReturn:
    """The console entry point: :data:`app`, with click's usage errors (a missing argument, an option
    out of its range, an unknown option) as one ``error:`` line naming the help to read and exit code 2,
    like every other bad input, instead of click's framed message."""
    try:  # typer >= 0.22 carries its own copy of click
        from typer._click import exceptions as click
    except ImportError:
        from click import exceptions as click

    command = typer.main.get_command(app)
    try:
        code = command.main(args=args, prog_name="taskcond", standalone_mode=False)
    except click.NoArgsIsHelpError as exc:
        exc.show()
        raise SystemExit(2) from None
    except click.UsageError as exc:
        where = f"; see '{exc.ctx.command_path} --help'" if exc.ctx is not None else ""
        message = " ".join(exc.format_message().split()).rstrip(".")
        typer.echo(f"error: {message}{where}", err=True)
        raise SystemExit(2) from None
    except click.ClickException as exc:
        typer.echo(f"error: {' '.join(exc.format_message().split())}", err=True)
        raise SystemExit(exc.exit_code) from None
    except typer.Abort:
        typer.echo("aborted", err=True)
        raise SystemExit(130) from None
    raise SystemExit(code if isinstance(code, int) else 0)
