"""The command line over robosuite (``taskcond tasks|oracle|learn|run|eval ... --world robosuite``): the
logic behind the options :mod:`taskcond.cli` dispatches here. Every function prints its result and exits
like the kitchen's commands: a one-line ``error:`` and exit code 2 on bad input, exit code 1 when a run
did not reach its goal.
"""

from __future__ import annotations

import json
import os
import sys
from dataclasses import asdict
from pathlib import Path
from typing import Any

import typer

from taskcond.cli.common import fail
from taskcond.worlds.robosuite import RobosuiteUnavailableError, require_robosuite

WORLDS = ("kitchen", "robosuite")
"""Worlds of ``--world``: the PyBullet kitchen (default) and robosuite."""


def check_world(world: str) -> bool:
    """Whether ``world`` is robosuite (after checking it is a world and robosuite is installed)."""
    if world not in WORLDS:
        fail(f"--world {world!r}: use one of {', '.join(WORLDS)}")
    if world == "kitchen":
        return False
    try:
        require_robosuite()
    except RobosuiteUnavailableError as exc:
        fail(str(exc))
    return True


def _task(task_id: str):  # type: ignore[no-untyped-def]
    from taskcond.worlds.robosuite.tasks import UnknownRobosuiteTaskError, get_task

    try:
        return get_task(task_id)
    except UnknownRobosuiteTaskError as exc:
        fail(str(exc))


def tasks(as_json: bool) -> None:
    """``taskcond tasks --world robosuite``: robosuite's environments and their primitive steps."""
    from taskcond.primitives import parse_task
    from taskcond.worlds.robosuite.tasks import TASKS

    if as_json:
        rows = [
            {
                "id": t.id,
                "kind": t.kind,
                "primitive": [parse_task(s).primitive.id for s in t.steps],
                "steps": list(t.steps),
                "world": "robosuite",
            }
            for t in TASKS.values()
        ]
        typer.echo(json.dumps(rows, indent=2))
        return
    typer.echo("robosuite tasks (environment: primitive tasks; judged by robosuite's _check_success):")
    for t in TASKS.values():
        typer.echo(f"  {t.id:18s} {' -> '.join(t.steps)}")


def oracle(task_id: str, episodes: int, seed: int, as_json: bool, video: Path | None) -> None:
    """``taskcond oracle --world robosuite ENV``: the scripted oracle's success rate."""
    from taskcond.sim.recording import VideoRecorder
    from taskcond.worlds.robosuite.scene import make_env, reset
    from taskcond.worlds.robosuite.tasks import down, oracle
    from taskcond.worlds.robosuite.world import RobosuiteWorld

    task = _task(task_id)
    env = make_env(task.id, video=video is not None)
    failed: list[int] = []
    try:
        for k in range(episodes):
            recorder = VideoRecorder(video) if video is not None and k == 0 else None
            try:
                scene = reset(env, seed + k)
                world = RobosuiteWorld(scene, recorder=recorder)
                quat = down(scene)
                for step in task.steps:
                    for position, orientation, gripper in oracle(scene, step, quat):
                        world.step(position, orientation, gripper)
                if not scene.success():
                    failed.append(seed + k)
            finally:
                if recorder is not None:
                    recorder.close()
    finally:
        env.close()
    out = {
        "task": task.id,
        "world": "robosuite",
        "episodes": episodes,
        "successes": episodes - len(failed),
        "failed_seeds": failed,
    }
    if as_json:
        typer.echo(json.dumps(out))
    else:
        typer.echo(
            f"{task.id}: {out['successes']}/{episodes} succeeded (robosuite's _check_success)"
            + (f"; failed seeds: {', '.join(map(str, failed))}" if failed else "")
        )


def learn(out: Path | None, task_ids: list[str] | None, seed: int) -> None:
    """``taskcond learn --world robosuite``: oracle demonstrations and the skills learned from them."""
    from tqdm import tqdm

    from taskcond.worlds.robosuite.demos import DEMONSTRATED, default_library_dir, learn_library

    ids = task_ids or list(DEMONSTRATED)
    for tid in ids:
        _task(tid)
    directory = out or default_library_dir()
    bar = tqdm(total=len(ids), desc="demonstrations", unit="task", file=sys.stderr, disable=None)
    failed: list[str] = []

    def told(task_id: str, ok: bool) -> None:
        bar.update()
        if not ok:
            failed.append(task_id)

    library = learn_library(directory, ids, seed=seed, progress=told)
    bar.close()
    typer.echo(f"{len(library)} skills from {len(ids)} robosuite tasks in {directory}")
    if failed:
        typer.echo(f"oracle failed on every try for: {', '.join(failed)} (their last try was kept)", err=True)


def library(skills: Path | None):  # type: ignore[no-untyped-def]
    """The robosuite skill library at ``skills`` (default the cache's), learned first if missing."""
    from taskcond.execution.skills import SkillError, SkillLibrary
    from taskcond.worlds.robosuite.demos import default_library_dir, learn_library

    directory = skills or default_library_dir()
    if not (directory / "library.json").exists():
        if skills is not None:
            fail(f"no skill library at {directory}; create it with `taskcond learn --world robosuite`")
        typer.echo(f"learning the robosuite skill library into {directory} (once, a few minutes)", err=True)
        return learn_library(directory)
    try:
        return SkillLibrary.load(directory)
    except SkillError as exc:
        fail(str(exc))


def scene_for(instruction: str) -> str:
    """The robosuite environment whose scene a free instruction names most objects of (PickPlace for the
    bins and its objects); the first in :data:`~taskcond.worlds.robosuite.tasks.TASKS` on a tie.

    Raises:
        typer.Exit: it names none.
    """
    from taskcond.decompose import mentions
    from taskcond.worlds.robosuite.tasks import TASKS

    def named(task_id: str) -> int:
        objects = {o for step in TASKS[task_id].steps for o in _objects(step)}
        return sum(mentions(instruction, (o,)) for o in objects)

    best = max(TASKS, key=named)
    if named(best) == 0:
        fail(
            f"{instruction!r} is neither a robosuite task ({', '.join(TASKS)}) nor an instruction naming "
            "one of their objects"
        )
    return best


def _objects(step: str) -> tuple[str, ...]:
    from taskcond.primitives import parse_task

    return parse_task(step).objects


def _decompose(instruction: str, task_id: str, llm: str | None) -> tuple[str, ...]:
    """The LLM's primitive steps for ``instruction`` on the objects of ``task_id``'s scene."""
    from taskcond.decompose import DecompositionError, decompose
    from taskcond.llm.base import LLMError
    from taskcond.llm.config import LLMConfig, make_backend
    from taskcond.worlds.robosuite.scene import make_env, reset
    from taskcond.worlds.robosuite.world import RobosuiteWorld

    env = make_env(task_id)
    try:
        world = RobosuiteWorld(reset(env, 0))
        objects, affords = world.objects, world.affords
    finally:
        env.close()
    typer.echo(f"decomposing the instruction with the LLM ({task_id} scene) ...", err=True)
    try:
        return tuple(decompose(instruction, make_backend(LLMConfig.load(llm)), objects, affords))
    except (DecompositionError, LLMError) as exc:
        fail(str(exc))


# long: robosuite's `taskcond run` in one piece: resolve, plan, execute, print, trace
def run(
    spec: str,
    method: str,
    seed: int,
    video: Path | None,
    trace: Path | None,
    noise: float,
    llm: str | None,
    skills: Path | None,
    planner: str,
    start: str,
) -> None:
    """``taskcond run --world robosuite ENV|INSTRUCTION``: one condition-guided episode."""
    from taskcond.application.condition_sources import make_source
    from taskcond.application.episode import PLANNERS
    from taskcond.application.robosuite import STARTS, run_config, run_episode
    from taskcond.execution.executor import METHODS
    from taskcond.llm.base import LLMError
    from taskcond.worlds.robosuite.demos import default_library_dir
    from taskcond.worlds.robosuite.scene import renderer_error
    from taskcond.worlds.robosuite.tasks import TASKS

    if method not in METHODS:
        fail(f"--method {method!r}: use one of {', '.join(METHODS)}")
    if planner not in PLANNERS:
        fail(f"--planner {planner!r}: use one of {', '.join(PLANNERS)}")
    if start not in STARTS:
        fail(f"--start {start!r}: use one of {', '.join(STARTS)}")
    steps = None
    if spec.strip() in TASKS:
        task = TASKS[spec.strip()]
    else:
        task = TASKS[scene_for(spec)]
        steps = _decompose(spec, task.id, llm)
    typer.echo(f"task: {spec} (robosuite {task.id})" + (" (decomposed by the LLM)" if steps else ""))
    for k, step in enumerate(steps or task.steps, start=1):
        typer.echo(f"  {k}. {step}")
    if video is not None and (why := renderer_error()) is not None:
        typer.echo(
            f"no video: MuJoCo cannot render offscreen here (MUJOCO_GL={os.environ['MUJOCO_GL']}: {why})"
        )
        video = None
    skills_library = library(skills)
    try:
        source = make_source(method, skills_library, llm)  # type: ignore[arg-type]
    except (LLMError, ValueError) as exc:
        fail(str(exc))
    stem = Path("runs") / f"robosuite-{_slug(spec)}-{method}-{seed}"
    trace = trace or stem.with_suffix(".json")

    def show(event: Any) -> None:
        typer.echo(f"{event.time:7.2f}s {'  ' * event.depth}{event.message}")

    def planned(repair: Any, goal: Any) -> None:
        if repair is not None and repair.changes:
            typer.echo("plan repaired by the planner: " + "; ".join(map(str, repair.changes)))
        if goal:
            typer.echo(f"goal: {', '.join(map(str, goal))}")

    result = run_episode(
        task,
        method,
        seed,
        skills_library,
        source,
        noise,
        video,
        show,
        planner=planner,  # type: ignore[arg-type]
        on_plan=planned,
        start_state=start,
        steps=steps,
    )
    config = run_config(skills or default_library_dir(), noise, llm, planner, start)
    trace.parent.mkdir(parents=True, exist_ok=True)
    trace.write_text(
        json.dumps({"config": config.to_dict(), "digest": config.digest} | asdict(result), indent=1),
        encoding="utf-8",
    )
    outcome = "succeeded" if result.success else f"FAILED ({result.reason})"
    typer.echo(f"{spec}: {outcome}; {result.sim_seconds:.1f} s simulated, {result.wall_seconds:.1f} s wall")
    typer.echo(f"trace: {trace}" + (f"; video: {video}" if video else ""))
    if result.failure == "impossible":
        raise typer.Exit(2)
    if not result.success:
        raise typer.Exit(1)


# long: robosuite's `taskcond eval` in one piece: configuration, resume, episodes, table
def evaluate(
    kind: str,
    episodes: int,
    methods: list[str] | None,
    as_json: bool,
    out: Path | None,
    task_ids: list[str] | None,
    seed: int,
    noise: float,
    llm: str | None,
    skills: Path | None,
    planner: str,
    start: str,
) -> None:
    """``taskcond eval primitives|long-horizon --world robosuite``: success rates with Wilson intervals,
    robosuite's one-primitive tasks (Lift, Door) or its multi-step ones."""
    from taskcond.application.evaluate import summarize
    from taskcond.application.robosuite import evaluate as run_all
    from taskcond.application.robosuite import run_config
    from taskcond.execution.executor import METHODS
    from taskcond.reproduce import wilson_interval
    from taskcond.results import ConfigMismatchError, ResultsFile
    from taskcond.worlds.robosuite.demos import default_library_dir
    from taskcond.worlds.robosuite.tasks import TASKS

    methods = methods or ["llm", "env", "none"]
    bad = [m for m in methods if m not in METHODS]
    if bad:
        fail(f"--method {bad[0]!r} in robosuite: use one of {', '.join(METHODS)}")
    wanted = "primitive" if kind == "primitives" else "long-horizon"
    ids = [t.id for t in TASKS.values() if t.kind == wanted]
    if task_ids:
        unknown = [t for t in task_ids if t not in ids]
        if unknown:
            fail(f"{unknown[0]!r} is not a robosuite {kind} task; valid: {', '.join(ids)}")
        ids = task_ids
    skills_library = library(skills)
    out = out or Path("runs") / f"eval-robosuite-{kind}.jsonl"
    config = run_config(skills or default_library_dir(), noise, llm, planner, start)
    try:
        results = ResultsFile(out, config)
    except ConfigMismatchError as exc:
        fail(str(exc))

    def told(record: dict[str, Any]) -> None:
        state = "crashed" if record.get("crashed") else ("ok" if record.get("success") else "failed")
        typer.echo(f"  {record['task']} {record['method']} seed {record['seed']}: {state}", err=True)

    records = run_all(
        [TASKS[t] for t in ids],
        methods,
        episodes,
        results,
        skills_library,
        llm,
        noise,
        planner,
        start,
        seed,
        told,
    )
    rows = summarize(records)
    for row in rows:
        row["wilson95"] = [round(x, 3) for x in wilson_interval(row["successes"], row["episodes"])]
    if as_json:
        typer.echo(json.dumps({"world": "robosuite", "results": rows}, indent=2))
        return
    typer.echo(f"{'task':20s} {'method':8s} {'success':>9s} {'95% Wilson':>14s}  failures")
    for row in rows:
        low, high = row["wilson95"]
        rate = f"{row['successes']}/{row['episodes']}"
        typer.echo(
            f"{row['task']:20s} {row['method']:8s} {rate:>9s} {f'[{low:.2f}, {high:.2f}]':>14s}  "
            f"{row['failures'] or ''}"
        )
    typer.echo(f"\n{len(records)} episodes in {out}; configuration {config.digest}")


def _slug(text: str) -> str:
    return "-".join("".join(c if c.isalnum() else " " for c in text.lower()).split())[:60]


__all__ = ["WORLDS", "check_world", "evaluate", "learn", "oracle", "run", "tasks"]
