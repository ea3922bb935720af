"""From a stored episode to its recording in one command (``taskcond replay``): run one episode of a
results file of ``taskcond eval`` again, from the configuration its header records and the episode's seed,
through the same code path as the evaluation (:func:`taskcond.application.workers.run_job`), with observers (a
Rerun recording, a captioned video), and compare the outcome with the stored one.

Episodes are seeded (the reset, the perception noise, a novel-primitive draw) and the simulation is
deterministic, and LLM answers come from the on-disk cache, so a replay under the recorded configuration
reproduces the stored record; a difference is reported field by field (:data:`COMPARED`) and is a bug to
find. What the replay cannot make equal to the recording is said beforehand: another skill library, other
executor constants, an instructions file of another digest, another code version.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from taskcond.application.baseline import IMAGE_IL
from taskcond.application.library import default_library_dir
from taskcond.application.workers import WorkerArgs, needs_own_process, run_job
from taskcond.execution.config import ExecutionConfig
from taskcond.results import HEADER_KEY, Job, code_version, directory_digest, file_digest
from taskcond.sim.cloth import self_colliding_loaded
from taskcond.viz.episode import EpisodeObserver

COMPARED = (
    "success",
    "failure",
    "reason",
    "steps",
    "sim_seconds",
    "adjustments",
    "raised",
    "goal_missing",
    "left_out",
)
"""Fields of an episode's record a replay must reproduce."""


class ReplayError(ValueError):
    """The episode cannot be replayed (no such file or episode, another kind of results, an instructions
    file that cannot be found); the message says what is valid."""


@dataclass(frozen=True)
class StoredEpisode:
    """One episode of a results file.

    Attributes:
        path: the results file.
        config: its recorded configuration (:class:`~taskcond.results.RunConfig` as a dict).
        record: the episode's record.
    """

    path: Path
    config: dict[str, Any]
    record: dict[str, Any]

    @property
    def id(self) -> str:
        return episode_id(self.record)


def episode_id(record: dict[str, Any]) -> str:
    """An episode's id in a results file: ``<task>:<method>:<seed>``."""
    return f"{record['task']}:{record['method']}:{record['seed']}"


def stored_episodes(path: Path) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """The configuration and the finished episodes (crashed ones left out) of the results file ``path``.

    Raises:
        ReplayError: no such file, or no results header.
    """
    import json

    try:
        lines = path.read_text(encoding="utf-8").splitlines()
    except OSError as exc:
        raise ReplayError(f"cannot read {path}: {exc.strerror}") from None
    records = []
    for line in lines:
        try:
            records.append(json.loads(line))
        except json.JSONDecodeError:
            continue
    if not records or HEADER_KEY not in records[0]:
        raise ReplayError(f"{path} is not a results file of `taskcond eval` (no configuration header)")
    header = records[0]
    episodes = [
        r
        for r in records[1:]
        if r.get("digest") == header.get("digest") and not r.get("crashed") and "seed" in r
    ]
    return header.get("config", {}), episodes


def find_episode(path: Path, episode: str) -> StoredEpisode:
    """The episode ``episode`` of the results file ``path``: its id ``<task>:<method>:<seed>``, or
    ``<task>:<seed>`` when one method ran, or its 1-based position among the file's episodes.

    Raises:
        ReplayError: no such episode (the message lists valid ids), or an ambiguous one.
    """
    config, episodes = stored_episodes(path)
    if not episodes:
        raise ReplayError(f"{path} holds no finished episode")
    if episode.isdigit():
        k = int(episode)
        if not 1 <= k <= len(episodes):
            raise ReplayError(f"episode {k}: {path} holds episodes 1 to {len(episodes)}")
        return StoredEpisode(path, config, episodes[k - 1])
    exact = [r for r in episodes if episode_id(r) == episode]
    short = [r for r in episodes if f"{r['task']}:{r['seed']}" == episode]
    found = exact or short
    if len(found) == 1:
        return StoredEpisode(path, config, found[0])
    if found:
        raise ReplayError(
            f"episode {episode!r} is ambiguous; give its method: {', '.join(map(episode_id, found))}"
        )
    failed = [episode_id(r) for r in episodes if not r.get("success")]
    listed = (failed or [episode_id(r) for r in episodes])[:8]
    raise ReplayError(
        f"no episode {episode!r} in {path}; ids are TASK:METHOD:SEED, e.g. {', '.join(listed)}"
        + (" (failed ones)" if failed else "")
    )


@dataclass
class Replay:
    """A replayed episode.

    Attributes:
        stored: the episode as stored.
        record: the replay's record.
        differences: ``field: stored … / replayed …`` for each field of :data:`COMPARED` that differs (the
            replay's crash, if it raised).
        warnings: what differs from the recorded configuration (library, executor constants, code).
    """

    stored: StoredEpisode
    record: dict[str, Any]
    differences: list[str]
    warnings: list[str]

    @property
    def reproduced(self) -> bool:
        return not self.differences


def replay(
    stored: StoredEpisode,
    library_dir: Path | None = None,
    llm: str | None = None,
    instructions: Path | None = None,
    observers: Sequence[EpisodeObserver] = (),
) -> Replay:
    """Run ``stored`` again under its recorded configuration, watched by ``observers``, with the skill
    library at ``library_dir`` (default: the user cache's), the LLM ``llm`` (default: the recorded
    backend and model) and, for an instruction episode, the instructions file ``instructions`` (default:
    the package's benchmark, which must be the recorded one).

    Raises:
        ReplayError: an episode of the image-based baseline or of another kind of results; an
            instructions file other than the recorded one not given.
    """
    config, record = stored.config, stored.record
    if config.get("kind") != "execution":
        raise ReplayError(f"{stored.path} holds {config.get('kind')!r} results, not episodes")
    if record["method"] == IMAGE_IL:
        raise ReplayError(f"{stored.id}: episodes of --method {IMAGE_IL} are not replayed (no executor)")
    library_dir = library_dir or default_library_dir()
    warnings = _differences(config, library_dir)
    path = _instructions(config, instructions, warnings)
    args = WorkerArgs(
        library_dir=str(library_dir),
        llm=llm or (config.get("llm") or "embedded").split("@")[0],
        noise=config["noise"],
        planner=config.get("planner", "conditions"),
        start=config.get("start", "task"),
        instructions=None if path is None else str(path),
        novel_primitive=bool(config.get("novel_primitive", False)),
    )
    job = Job(record["task"], record["method"], record["seed"])
    if self_colliding_loaded() and needs_own_process([job], args)[0]:
        warnings.append(
            "this process has simulated the cloth before: a cloth episode reproduces only in a fresh "
            "process (each `taskcond replay` is one)"
        )
    new = run_job(job, args, observers)
    if new.get("crashed"):
        return Replay(stored, new, [f"the replay crashed: {new['error']}"], warnings)
    differences = [
        f"{name}: stored {record.get(name)!r} / replayed {new.get(name)!r}"
        for name in COMPARED
        if record.get(name) != new.get(name)
    ]
    return Replay(stored, new, differences, warnings)


def _differences(config: dict[str, Any], library_dir: Path) -> list[str]:
    """What differs between the recorded configuration and this replay's: the skill library, the
    executor constants, the code."""
    out = []
    skills = config.get("skills")
    if skills is not None and (not library_dir.exists() or directory_digest(library_dir) != skills):
        here = directory_digest(library_dir) if library_dir.exists() else "missing"
        out.append(f"the skill library differs from the recorded one ({skills}; here {here})")
    execution = config.get("execution")
    if execution and _json(execution) != _json(asdict(ExecutionConfig())):
        out.append("the executor's constants differ from the recorded ones (ExecutionConfig changed)")
    code = config.get("code")
    if code and code != code_version():
        out.append(f"recorded with code {code}, replayed with {code_version()}")
    return out


def _instructions(config: dict[str, Any], given: Path | None, warnings: list[str]) -> Path | None:
    """The instructions file of an instruction episode's replay (None for suite tasks)."""
    from taskcond.instructions import default_file

    recorded = config.get("instructions")
    if recorded is None:
        return None
    path = given or default_file()
    if not path.exists():
        raise ReplayError(f"no instructions file {path}")
    if file_digest(path) != recorded:
        if given is None:
            raise ReplayError(
                f"the episodes were run with the instructions file {recorded}, not the package's "
                f"{file_digest(path)}; pass it with --instructions FILE"
            )
        warnings.append(f"the instructions file differs from the recorded one ({recorded})")
    return path.resolve()


def _json(value: Any) -> Any:
    import json

    return json.loads(json.dumps(value))


__all__ = [
    "COMPARED",
    "Replay",
    "ReplayError",
    "StoredEpisode",
    "episode_id",
    "find_episode",
    "replay",
    "stored_episodes",
]
