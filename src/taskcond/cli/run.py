"""``taskcond run``: one episode of a suite task, a primitive task or a free instruction."""

from __future__ import annotations

import json
from dataclasses import asdict
from pathlib import Path
from typing import Annotated

import typer

import taskcond.cli.robosuite as robosuite
import taskcond.cli.viz as cli_viz
from taskcond.cli.common import (
    LlmOption,
    MethodOption,
    NoiseOption,
    ObjectsOption,
    PlannerOption,
    PrimitivesOption,
    SkillsOption,
    StartOption,
    WorldOption,
    _declare,
    _declare_objects,
    _library,
    _sim_import,
    fail,
)
from taskcond.execution.failures import FailureKind
from taskcond.llm.base import LLMError


def _slug(text: str) -> str:
    return "-".join("".join(c if c.isalnum() else " " for c in text.lower()).split())[:60] or "run"


# long: typer declares its 13 options in the signature
def run(
    spec: Annotated[
        str,
        typer.Argument(
            help='A suite task id (LHT1, grasp-bottle), a primitive task ("open box") or a free '
            'instruction ("pick up the bottle, put it into the box and close the box").'
        ),
    ],
    method: MethodOption = "llm",
    seed: Annotated[int, typer.Option("--seed", help="Seed of the scene and of the perception noise.")] = 0,
    video: Annotated[
        Path | None,
        typer.Option("--video", help="Video (.mp4/.gif); default runs/<task>-<method>-<seed>.mp4."),
    ] = None,
    no_video: Annotated[bool, typer.Option("--no-video", help="Do not record a video.")] = False,
    size: cli_viz.VideoSizeOption = "640x480",
    rerun: cli_viz.RerunRunOption = None,
    trace: Annotated[
        Path | None, typer.Option("--trace", help="JSON trace; default runs/<task>-<method>-<seed>.json.")
    ] = None,
    gui: Annotated[bool, typer.Option("--gui", help="Show the PyBullet GUI.")] = False,
    noise: NoiseOption = 0.005,
    llm: LlmOption = None,
    skills: SkillsOption = None,
    planner: PlannerOption = "conditions",
    start: StartOption = "task",
    primitives: PrimitivesOption = None,
    objects: ObjectsOption = None,
    world: WorldOption = "kitchen",
) -> None:
    """Perform a long-horizon task: conditions, the look-ahead planner, Alg. 1 pre-condition satisfaction,
    Alg. 2 DMP control; a free instruction is judged by its goal predicates (exit 0 only on success): the
    goal its words say when they are a wording of the combination benchmark ("stack the bowl on the box":
    ``bowl above box``), else the goal its plan derives."""
    if robosuite.check_world(world):
        if video is not None and video.suffix.lower() not in (".mp4", ".gif"):
            fail(f"--video {video}: use a .mp4 or .gif file name")
        shot = None if no_video else (video or Path("runs") / f"robosuite-{_slug(spec)}-{method}-{seed}.mp4")
        return robosuite.run(spec, method, seed, shot, trace, noise, llm, skills, planner, start)
    _sim_import()
    _declare(primitives)
    _declare_objects(objects)
    from taskcond.application.condition_sources import make_source
    from taskcond.application.episode import PLANNERS, run_episode
    from taskcond.application.evaluate import execution_config
    from taskcond.application.library import default_library_dir
    from taskcond.execution.executor import METHODS
    from taskcond.tasks.free import STARTS

    if method not in METHODS:
        fail(f"--method {method!r}: use one of {', '.join(METHODS)}")
    if planner not in PLANNERS:
        fail(f"--planner {planner!r}: use one of {', '.join(PLANNERS)}")
    if start not in STARTS:
        fail(f"--start {start!r}: use one of {', '.join(STARTS)}")
    if video is not None and video.suffix.lower() not in (".mp4", ".gif"):
        fail(f"--video {video}: use a .mp4 or .gif file name")
    video_size = cli_viz.video_size(size)
    cli_viz.rerun_ready(rerun)

    plan = _resolve(spec, llm)
    library = _library(skills)
    try:
        source = make_source(method, library, llm)  # type: ignore[arg-type]
    except (LLMError, ValueError) as exc:
        fail(str(exc))
    where = "" if start == "task" else f"-{start}"
    stem = Path("runs") / f"{_slug(plan.label)}-{method}{where}-{seed}"
    video_path = None if no_video else (video or stem.with_suffix(".mp4"))
    trace_path = trace or stem.with_suffix(".json")

    config = execution_config(skills or default_library_dir(), noise, llm, planner=planner, start=start)
    goal = _words_goal(plan)
    result = run_episode(
        plan,
        method,  # type: ignore[arg-type]
        seed,
        library,
        source,
        noise,
        video_path,
        gui,
        _show,
        planner=planner,
        on_plan=_planned,
        start_state=start,
        video_size=video_size,
        observers=cli_viz.run_observers(rerun),
        goal=goal,
    )
    _write_trace(trace_path, plan, config, result)
    if result.failure == FailureKind.IMPOSSIBLE:
        fail(f"cannot do {plan.label!r}: {result.reason}; nothing moved (trace: {trace_path})")
    outcome = "succeeded" if result.success else f"FAILED ({result.reason})"
    if result.fallen:  # the goal may hold while the arm knocked a neighbour over: say so
        verb = "lies" if len(result.fallen) == 1 else "lie"
        outcome += f", and {', '.join(result.fallen)} {verb} knocked over at the end"
    typer.echo(
        f"{plan.label}: {outcome}; {result.sim_seconds:.1f} s simulated, {result.wall_seconds:.1f} s wall"
    )
    typer.echo(
        f"trace: {trace_path}"
        + (f"; video: {video_path}" if video_path else "")
        + (f"; recording: {rerun} (open with `rerun {rerun}`)" if rerun else "")
    )
    if not result.success:
        raise typer.Exit(1)


def _words_goal(plan):
    """The goal a decomposed instruction's words say when they are a wording of the combination benchmark
    (:func:`taskcond.combinations.goal_of_words`), else None (the goal the plan derives)."""
    if not plan.decomposed or plan.scene != "kitchen":
        return None
    from taskcond.combinations import generate, goal_of_words
    from taskcond.sim.roles import scene_roles

    return goal_of_words(plan.label, generate(scene_roles()))


def _resolve(spec: str, llm: str | None):
    """The plan of ``spec`` (:func:`~taskcond.application.plans.plan_run`, a free instruction decomposed by
    the LLM of ``llm``), printed; a one-line error for what cannot be run."""
    from taskcond.application.plans import llm_decomposer, plan_run, refused_task
    from taskcond.decompose import DecompositionError
    from taskcond.worlds.kitchen import scene_objects

    def announce(scene: str) -> None:
        typer.echo(f"decomposing the instruction with the LLM ({scene} scene) ...", err=True)

    try:
        plan = plan_run(spec, llm_decomposer(llm, announce, tell=lambda text: typer.echo(text, err=True)))
    except (DecompositionError, LLMError, ValueError) as exc:
        fail(str(exc))
    if plan.task_id is None and not plan.decomposed:  # one primitive task the suite does not have
        refused = refused_task(spec, *scene_objects(plan.scene))
        if refused is not None:
            fail(f"{refused}; nothing was run")
    typer.echo(f"task: {plan.label}" + (" (decomposed by the LLM)" if plan.decomposed else ""))
    for k, step in enumerate(plan.steps, start=1):
        typer.echo(f"  {k}. {step}")
    return plan


def _show(event) -> None:
    """One event as a console line, indented by its depth."""
    typer.echo(f"{event.time:7.2f}s {'  ' * event.depth}{event.message}")


def _planned(repair, goal) -> None:
    """The planner's repair (or that it changed nothing, or what it left to Alg. 1) and the goal."""
    if repair is not None and repair.changes:
        typer.echo("plan repaired by the planner:")
        for k, step in enumerate(repair.steps, start=1):
            typer.echo(f"  {k}. {step}")
        for change in repair.changes:
            typer.echo(f"  - {change}")
    elif repair is not None and repair.impossible is None:
        typer.echo("plan checked by the planner: no change")
    for left in () if repair is None else repair.unresolved:
        typer.echo(f"  (left to Alg. 1: {left})")
    typer.echo(f"goal: {', '.join(map(str, goal)) or 'none (no predicate to check)'}")


def _write_trace(path: Path, plan, config, result) -> None:
    """The episode's JSON trace: its plan, the run's configuration and digest, and the result."""
    plan_fields = {
        "label": plan.label,
        "task_id": plan.task_id,
        "steps": list(plan.steps),
        "scene": plan.scene,
    }
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(
        json.dumps(
            {"plan": plan_fields} | {"config": config.to_dict(), "digest": config.digest} | asdict(result),
            indent=1,
        ),
        encoding="utf-8",
    )
