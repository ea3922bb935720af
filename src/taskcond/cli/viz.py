"""The command line's recording options and ``taskcond replay`` (:mod:`taskcond.viz`); registered on
:data:`taskcond.cli.app`.

Bad input ends with a one-line ``error:`` and exit code 2, as everywhere in the command line.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

RerunRunOption = Annotated[
    Path | None,
    typer.Option(
        "--rerun",
        help="Record the episode to this Rerun file (.rrd; open it with `rerun FILE.rrd`): boxes perceived "
        "and true, arm paths, planned DMP paths and goals, goals Alg. 2 moved, contacts, camera, every "
        "event of the trace, relations as they change. Needs the viz extra.",
    ),
]
RerunEvalOption = Annotated[
    Path | None,
    typer.Option(
        "--rerun",
        help="Directory for a Rerun recording (.rrd) of each failed episode, named TASK-METHOD-SEED.rrd "
        "(its record's 'rerun' field names it). Needs the viz extra.",
    ),
]
RerunAllOption = Annotated[
    bool, typer.Option("--rerun-all", help="With --rerun: keep the recording of every episode.")
]
VideoSizeOption = Annotated[
    str, typer.Option("--video-size", help="Video size WIDTHxHEIGHT in pixels, e.g. 640x480 or 320x240.")
]


def video_size(text: str) -> tuple[int, int]:
    """``WIDTHxHEIGHT`` as (width, height); exit 2 with a one-line error when malformed."""
    from taskcond.cli.common import fail

    parts = text.lower().split("x")
    if len(parts) == 2 and all(p.strip().isdigit() for p in parts):
        width, height = (int(p) for p in parts)
        if 16 <= width <= 4096 and 16 <= height <= 4096:
            return width, height
    fail(f"--video-size {text!r}: use WIDTHxHEIGHT with 16 to 4096 pixels each, e.g. 640x480")


def rerun_ready(path: Path | None, suffix: str | None = ".rrd") -> None:
    """Exit 2 with a one-line error when ``path`` is given and the viz extra is missing or (with a
    ``suffix``) the file name does not end in it."""
    from taskcond.cli.common import fail
    from taskcond.viz import RerunUnavailableError, require_rerun

    if path is None:
        return
    if suffix is not None and path.suffix.lower() != suffix:
        fail(f"--rerun {path}: use a {suffix} file name")
    try:
        require_rerun()
    except RerunUnavailableError as exc:
        fail(str(exc))


# long: typer declares its options in the signature
def replay(
    results: Annotated[Path, typer.Argument(help="A JSON-lines results file of `taskcond eval`.")],
    episode: Annotated[
        str | None,
        typer.Option(
            "--episode",
            help="TASK:METHOD:SEED (or TASK:SEED, or the episode's 1-based position); without it the "
            "file's episodes are listed.",
        ),
    ] = None,
    rerun: RerunRunOption = None,
    video: Annotated[Path | None, typer.Option("--video", help="Captioned video (.mp4/.gif).")] = None,
    size: VideoSizeOption = "640x480",
    skills: Annotated[
        Path | None, typer.Option("--skills", help="Skill library directory (default: the user cache's).")
    ] = None,
    llm: Annotated[
        str | None, typer.Option("--llm", help="LLM backend (default: the recorded backend and model).")
    ] = None,
    instructions: Annotated[
        Path | None,
        typer.Option("--instructions", help="The instructions file of an `eval instructions` run."),
    ] = None,
) -> None:
    """Run one stored episode again from its recorded configuration and seed, to a Rerun recording or a
    captioned video, and say whether it reproduces the stored outcome (exit 0 when it does, 1 when not)."""
    from taskcond.cli.common import _sim_import, fail

    _sim_import()
    from taskcond.application.replay import ReplayError, episode_id, find_episode, stored_episodes
    from taskcond.application.replay import replay as run_replay
    from taskcond.llm.base import LLMError

    if episode is None:
        try:
            _, episodes = stored_episodes(results)
        except ReplayError as exc:
            fail(str(exc))
        for k, rec in enumerate(episodes, start=1):
            outcome = (
                "succeeded" if rec.get("success") else f"FAILED {rec.get('failure')}: {rec.get('reason')}"
            )
            typer.echo(f"{k:4d}  {episode_id(rec)}  {' '.join(str(outcome).split())[:100]}")
        return
    rerun_ready(rerun)
    if video is not None and video.suffix.lower() not in (".mp4", ".gif"):
        fail(f"--video {video}: use a .mp4 or .gif file name")
    observers = _observers(rerun, video, video_size(size))
    try:
        stored = find_episode(results, episode)
        typer.echo(f"replaying {stored.id} ({_outcome(stored.record)}) ...", err=True)
        done = run_replay(stored, skills, llm, instructions, observers)
    except (ReplayError, LLMError) as exc:
        fail(str(exc))
    finally:
        for observer in observers:
            observer.close()
    for warning in done.warnings:
        typer.echo(f"warning: {warning}", err=True)
    typer.echo(f"stored:   {_outcome(stored.record)}")
    typer.echo(f"replayed: {_outcome(done.record)}")
    for path, what in ((rerun, "recording"), (video, "video")):
        if path is not None:
            typer.echo(f"{what}: {path}")
    if not done.reproduced:
        typer.echo("the replay does NOT reproduce the stored episode (a bug to find):", err=True)
        for line in done.differences:
            typer.echo(f"  {line}", err=True)
        raise typer.Exit(1)
    typer.echo("the replay reproduces the stored episode")


def run_observers(rerun: Path | None) -> list:
    """The observers of ``taskcond run``: a Rerun recording to ``rerun``, if given."""
    return _observers(rerun, None, (0, 0))


def _observers(rerun: Path | None, video: Path | None, size: tuple[int, int]) -> list:
    from taskcond.viz.captions import CaptionedVideo

    observers: list = []
    if rerun is not None:
        from taskcond.viz.rerun_recording import RerunRecording

        observers.append(RerunRecording(rerun))
    if video is not None:
        observers.append(CaptionedVideo(video, size))
    return observers


def _outcome(record: dict) -> str:
    if record.get("success"):
        return f"succeeded, {record.get('sim_seconds')} s simulated"
    reason = " ".join(str(record.get("reason")).split())
    return f"FAILED ({record.get('failure')}): {reason}"


__all__ = [
    "RerunAllOption",
    "RerunEvalOption",
    "RerunRunOption",
    "VideoSizeOption",
    "replay",
    "rerun_ready",
    "run_observers",
    "video_size",
]
