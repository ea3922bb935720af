"""``taskcond oracle``, ``taskcond learn`` and ``taskcond record``: the suite's oracles, the skill library and
the image-based baseline's policy, demonstration files.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Annotated

import typer

import taskcond.cli.robosuite as robosuite
from taskcond.cli.common import (
    JsonOption,
    ObjectsOption,
    PrimitivesOption,
    WorkersOption,
    WorldOption,
    _declare,
    _declare_objects,
    _default_library_dir,
    _library,
    _sim_import,
    fail,
)


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
    world: WorldOption = "kitchen",
) -> None:
    """Run the scripted oracle of TASK and report its success rate."""
    if video is not None and video.suffix.lower() not in (".mp4", ".gif"):
        fail(f"--video {video}: use a .mp4 or .gif file name")
    if robosuite.check_world(world):
        return robosuite.oracle(task, episodes, seed, as_json, video)
    try:
        from taskcond.tasks.oracle import run_oracle
    except ImportError as exc:
        fail(f"the task suite needs the [sim] extra ({exc.name} missing): pip install 'taskcond[sim]'")
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
        "failed_seeds": report.failed_seeds,
    }
    if as_json:
        typer.echo(json.dumps(out))
    else:
        typer.echo(
            f"{report.task}: {report.successes}/{report.episodes} succeeded "
            f"({report.steps_per_second:.0f} steps/s); failures: {dict(report.failures) or 'none'}"
            + (f" (seeds {', '.join(map(str, report.failed_seeds))})" if report.failed_seeds else "")
        )


# long: typer declares its options in the signature
def learn(
    out: Annotated[
        Path | None, typer.Option("--out", help="Directory of the library (default: the user cache).")
    ] = None,
    task: Annotated[
        list[str] | None,
        typer.Option(
            "--task", help="Only these suite tasks (repeatable; default all primitives and LHT1-LHT4)."
        ),
    ] = None,
    seed: Annotated[int, typer.Option("--seed", help="Seed of the first demonstration of each task.")] = 0,
    demo: Annotated[
        list[Path] | None,
        typer.Option(
            "--demo",
            help="Learn from this demonstration file instead (repeatable; format in the README, "
            "`taskcond record` writes one): its skill is added to the library.",
        ),
    ] = None,
    primitives: PrimitivesOption = None,
    objects: ObjectsOption = None,
    method: Annotated[
        str,
        typer.Option(
            "--method",
            help="What to learn: dmp (the skill library) or image-il (the image-based imitation-learning "
            "baseline: oracle demonstrations rendered, a policy trained; needs the il extra, about 45 min "
            "on one core).",
        ),
    ] = "dmp",
    world: WorldOption = "kitchen",
    workers: WorkersOption = None,
) -> None:
    """Record oracle demonstrations and store the skill library: DMPs and FromEnv conditions (§III-D); or
    learn the skills of demonstration files (--demo); or train the image-based baseline (--method
    image-il)."""
    if robosuite.check_world(world):
        if demo or method != "dmp":
            fail("--world robosuite learns DMP skills from its oracles; --demo and --method do not apply")
        return robosuite.learn(out, task, seed)
    _sim_import()
    _declare(primitives)
    _declare_objects(objects)
    if method not in ("dmp", "image-il"):
        fail(f"--method {method!r}: use dmp or image-il")
    if method == "image-il":
        if demo or task or out:
            fail(
                "--method image-il learns from the suite's oracles into the cache; --demo, --task and --out "
                "do not apply"
            )
        _il_policy(learn_if_missing=True)
        return
    from tqdm import tqdm

    from taskcond.application.demonstrations import CONTEXTS, learn_library
    from taskcond.application.library import default_library_dir
    from taskcond.llm.base import cpu_count
    from taskcond.tasks.registry import UnknownTaskError, get_task, primitive_task_ids

    if demo:
        if task:
            fail("give either --task (oracle demonstrations) or --demo (demonstration files), not both")
        _learn_files(demo, out)
        return
    ids = task or [*primitive_task_ids(), *CONTEXTS]
    try:
        for tid in ids:
            get_task(tid)
    except UnknownTaskError as exc:
        fail(str(exc))
    directory = out or default_library_dir()
    bar = tqdm(total=len(ids), desc="demonstrations", unit="task", file=sys.stderr, disable=None)
    failed: list[str] = []

    def told(task_id: str, ok: bool) -> None:
        bar.update()
        if not ok:
            failed.append(task_id)

    try:
        library = learn_library(directory, ids, seed=seed, progress=told, workers=workers or cpu_count())
    except ValueError as exc:
        fail(str(exc))
    bar.close()
    typer.echo(f"{len(library)} skills from {len(ids)} tasks in {directory}")
    if failed:
        typer.echo(f"oracle failed on every try for: {', '.join(failed)} (their last try was kept)", err=True)


def _il_policy(learn_if_missing: bool = True) -> Path:
    """The directory of the baseline's checkpoint (default specs), trained first with progress bars when
    missing and ``learn_if_missing``; exit 2 with one line when the [il] extra is missing."""
    from tqdm import tqdm

    from taskcond.il import ILUnavailableError, require_il
    from taskcond.il.config import TrainSpec, data_dir, policy_dir
    from taskcond.il.dataset import DataSpec, collect

    try:
        require_il()
    except ILUnavailableError as exc:
        fail(str(exc))
    directory = policy_dir()
    if (directory / "policy.json").exists():
        typer.echo(f"image-il policy: {directory}", err=True)
        return directory
    if not learn_if_missing:
        fail(f"no image-il policy in {directory}; train it with `taskcond learn --method image-il`")
    from taskcond.application.demonstrations import CONTEXTS
    from taskcond.il.train import learn_policy
    from taskcond.tasks.registry import primitive_task_ids

    data, spec = DataSpec(), TrainSpec()
    ids = [*primitive_task_ids(), *CONTEXTS]
    typer.echo(f"training the image-il policy into {directory} (once, about 45 min on one core)", err=True)
    bar = tqdm(
        total=sum(map(data.episodes_of, ids)),
        desc="demonstrations",
        unit="demo",
        file=sys.stderr,
        disable=None,
    )
    try:
        samples = collect(data_dir(data), ids, data, lambda _task: bar.update())
    except RuntimeError as exc:
        fail(str(exc))
    bar.close()
    bar = tqdm(total=spec.steps, desc="training", unit="step", file=sys.stderr, disable=None)

    def told(step: int, loss: float) -> None:
        bar.update(step - bar.n)
        bar.set_postfix(loss=f"{loss:.4f}")

    _, history = learn_policy(directory, samples, data, spec, told)
    bar.close()
    typer.echo(
        f"image-il policy: {len(samples)} samples of {len(samples.names)} primitive task names, "
        f"{spec.steps} steps in {history['seconds'] / 60:.1f} min, final loss {history['loss'][-1]:.4f}; "
        f"{directory}"
    )
    return directory


def _learn_files(files: list[Path], out: Path | None) -> None:
    """``taskcond learn --demo``: replay each file in its scene, learn its skill, add it to the library."""
    from taskcond.application.demonstrations import replay_demonstration
    from taskcond.execution.demofile import DemoFileError, load_trajectory
    from taskcond.execution.skills import SkillLibrary, learn_skill

    # a new --out directory holds just these skills; the default library gets the oracles' skills first
    fresh = out is not None and not (out / "library.json").exists()
    library = SkillLibrary() if fresh else _library(out)
    directory = out or _default_library_dir()
    for path in files:
        try:
            demonstration = replay_demonstration(load_trajectory(path))
            skill = learn_skill(demonstration)
        except (DemoFileError, ValueError) as exc:
            fail(str(exc))
        library.add(skill)
        cond = skill.condition
        typer.echo(
            f"learned {skill.task_id} ({skill.primitive}, DMP pieces: {len(skill.segments)}, "
            f"{skill.duration:.1f} s) from {path}"
        )
        if skill.evidence is not None and cond is not None:
            typer.echo(
                f"  FromEnv: pre [{', '.join(map(str, cond.pre_conditions))}] post "
                f"[{', '.join(map(str, cond.post_conditions))}]"
            )
    library.save(directory)
    typer.echo(f"{len(library)} skills in {directory}")


def record(
    task: Annotated[
        str, typer.Argument(help="Suite primitive task id (see `taskcond tasks`), e.g. grasp-bottle.")
    ],
    out: Annotated[Path, typer.Option("--out", help="Demonstration file to write (.json).")],
    seed: Annotated[int, typer.Option("--seed", help="Seed of the scene.")] = 0,
) -> None:
    """Record the oracle of a suite primitive task as a demonstration file (what `learn --demo` reads)."""
    _sim_import()
    from taskcond.application.demonstrations import record_trajectory

    if out.suffix.lower() != ".json":
        fail(f"--out {out}: a demonstration file is .json")
    try:
        recorded, ok = record_trajectory(task, seed)
    except ValueError as exc:
        fail(str(exc))
    recorded.save(out)
    typer.echo(
        f"{out}: {recorded.task_name!r}, {len(recorded.times)} samples, {recorded.times[-1]:.1f} s"
        + ("" if ok else " (the oracle failed on this seed)")
    )
    if not ok:
        raise typer.Exit(1)
