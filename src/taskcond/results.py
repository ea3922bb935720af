"""Results that say how they were made: the configuration of a run (:class:`RunConfig`), its digest, and
JSON-lines results files that hold the records of one configuration only (:class:`ResultsFile`).

A results file starts with a header line ``{"taskcond_results": 1, "digest": ..., "config": {...}}``;
every later line is one record (an episode, a generated condition) carrying the same ``digest``. Opening
a file written under another configuration raises :class:`ConfigMismatchError`, naming the fields that
differ, so that results of different configurations are never mixed, and a resumed run reuses only
records of its own configuration. A record marked ``"crashed": true`` (an exception, not a task failure)
is kept for diagnosis but is not a result: a resumed run does it again.
"""

from __future__ import annotations

import hashlib
import json
import subprocess
from collections.abc import Callable, Hashable, Iterator
from dataclasses import asdict, dataclass, field, fields
from functools import cache
from importlib import metadata
from pathlib import Path
from typing import Any

HEADER_KEY = "taskcond_results"
RESULTS_FORMAT = 1


@dataclass(frozen=True)
class RunConfig:
    """Everything that changes the results of an evaluation, a reproduction or a single run.

    Attributes:
        kind: ``execution`` (episodes in the suite: Tables III and IV, ``taskcond run``) or
            ``conditions`` (generated conditions scored against the references: Table II).
        llm: the LLM backend and model, ``embedded:MODEL@RUNTIME-VERSION`` (the llama.cpp runtime, e.g.
            ``xllamacpp-2026.10.11549``), for the default each mode's model
            (``embedded:generation=qwen2.5-coder-0.5b,generalization=qwen2.5-coder-1.5b@RUNTIME-VERSION``),
            or ``openai:MODEL@BASE_URL``.
        llm_model_hash: SHA-256 prefix of the embedded model's GGUF file (pinned; the default's two, comma
            separated, in the order of ``llm``); None for a remote model, whose weights the client cannot
            see.
        prompt_version: the prompt set of the condition generator (``taskcond/prompts/<version>``).
        generator: the generator's other settings (self-consistency samples, grammar use).
        noise: perception noise σ, metres (execution only).
        start: how episodes start: ``task`` (the suite task's own start state) or ``random`` (a drawn
            start state, :func:`taskcond.tasks.free.random_start`).
        planner: plan repair before execution: ``conditions`` (the look-ahead planner,
            :mod:`taskcond.execution.planner`) or ``none`` (the paper's sequence as given).
        novel_primitive: each episode leaves one primitive of its long-horizon task out of the LLM's
            examples, drawn from the episode's seed (Table IV, "generalize to novel primitive tasks";
            :func:`taskcond.application.condition_sources.novel_primitive_source`).
        skills: the skill library, ``<directory name>@<SHA-256 prefix of its files>`` (None when unused).
        instructions: the instructions file of ``taskcond eval instructions``, ``<file name>@<SHA-256
            prefix>`` (None otherwise).
        il: the image-based baseline's checkpoint (:mod:`taskcond.il`), ``<directory name>@<SHA-256 prefix
            of its files>``; None when the baseline does not run (then left out of :meth:`to_dict`, so the
            digests of configurations without it are those of earlier versions).
        execution: the constants of Alg. 1 and Alg. 2 (:class:`~taskcond.execution.config.ExecutionConfig`
            as a dict; empty for ``conditions``).
        code: ``git describe`` of the package's checkout (``-dirty+<diff hash>`` with local changes), else
            ``taskcond <package version>``.
        objects: the declaration files of user objects in the scene (``--objects``), each
            ``<resolved path>@<SHA-256 prefix of it and of the model files it names>``; None without any
            (left out of :meth:`to_dict`).
        world: the world episodes ran in and its simulator's versions when it is not the PyBullet kitchen
            (``robosuite 1.5.1, mujoco 3.3.2``); None for the kitchen (left out of :meth:`to_dict`).
    """

    kind: str
    llm: str | None
    llm_model_hash: str | None
    prompt_version: str | None
    generator: dict[str, Any] = field(default_factory=dict)
    noise: float | None = None
    start: str = "task"
    planner: str = "none"
    novel_primitive: bool = False
    skills: str | None = None
    instructions: str | None = None
    execution: dict[str, Any] = field(default_factory=dict)
    code: str = ""
    il: str | None = None
    world: str | None = None
    objects: tuple[str, ...] | None = None

    def to_dict(self) -> dict[str, Any]:
        """The fields as a dict, without those added later (:data:`_LATER_FIELDS`) while they hold their
        default, so results files written before they existed keep their digest; in its JSON form (tuples
        as lists), so it equals the header a results file read back holds."""
        out = asdict(self)
        for name, default in _LATER_FIELDS.items():
            if out[name] == default:
                del out[name]
        return json.loads(json.dumps(out))

    @property
    def digest(self) -> str:
        """First 16 hex digits of the SHA-256 of the canonical JSON form: equal configurations, equal
        digests, in any process."""
        text = json.dumps(self.to_dict(), sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()[:16]

    def differences(self, other: dict[str, Any]) -> list[str]:
        """``field: ours → theirs`` for every field (nested fields dotted) that differs from ``other``
        (a :meth:`to_dict` form, e.g. a results file's header)."""
        return [f"{k}: {b!r} (file) vs {a!r} (now)" for k, a, b in _diff(self.to_dict(), other)]


_LATER_FIELDS: dict[str, Any] = {
    "il": None,
    "novel_primitive": False,
    "instructions": None,
    "world": None,
    "objects": None,
}
"""Fields of :class:`RunConfig` added after results files existed, with the default they are left out at."""


def _diff(a: Any, b: Any, prefix: str = "") -> Iterator[tuple[str, Any, Any]]:
    if isinstance(a, dict) and isinstance(b, dict):
        for key in sorted(set(a) | set(b)):
            yield from _diff(a.get(key), b.get(key), f"{prefix}{key}.")
    elif a != b:
        yield prefix.rstrip("."), a, b


@cache
def code_version() -> str:
    """The code that produced a result: the abbreviated hash of the last commit that changed this package's
    files when they are tracked by a git checkout (a commit of documentation or benchmarks alone leaves it,
    so a results file resumes across it), with ``-dirty+<hash of the package's uncommitted changes>``
    appended when they differ from it (two different uncommitted states differ); else ``taskcond
    <version>`` from the installed metadata."""
    return checkout_version(Path(__file__).resolve().parent) or _installed_version()


def checkout_version(root: Path) -> str | None:
    """:func:`code_version` of the package directory ``root`` in a git checkout, or None when its files are
    not tracked by one."""

    def git(*args: str) -> str | None:
        try:
            out = subprocess.run(
                ["git", "-C", str(root), *args], capture_output=True, text=True, timeout=20, check=True
            )
        except (OSError, subprocess.SubprocessError):
            return None
        return out.stdout

    if git("ls-files", "--error-unmatch", "__init__.py") is not None:
        described = (git("log", "-1", "--format=%h", "--", ".") or "").strip()
        if described:
            changes = git("status", "--porcelain", "--", ".") or ""
            if changes.strip():
                diff = (git("diff", "HEAD", "--", ".") or "") + (
                    git("ls-files", "--others", "--exclude-standard", "--", ".") or ""
                )
                described += "-dirty+" + hashlib.sha256(diff.encode()).hexdigest()[:8]
            return described
    return None


def _installed_version() -> str:
    try:
        return f"taskcond {metadata.version('taskcond')}"
    except metadata.PackageNotFoundError:
        return "taskcond (unknown version)"


def directory_digest(directory: Path) -> str:
    """``<name>@<SHA-256 prefix>`` over the relative paths and bytes of every file under ``directory``."""
    digest = hashlib.sha256()
    for path in sorted(p for p in directory.rglob("*") if p.is_file()):
        digest.update(str(path.relative_to(directory)).encode() + b"\0")
        digest.update(path.read_bytes())
    return f"{directory.name}@{digest.hexdigest()[:12]}"


def file_digest(path: Path) -> str:
    """``<name>@<SHA-256 prefix>`` of the bytes of the file ``path``."""
    return f"{path.name}@{hashlib.sha256(path.read_bytes()).hexdigest()[:12]}"


def llm_fields(spec: str | None, generator: Any = None) -> dict[str, Any]:
    """The LLM fields of a :class:`RunConfig` for the ``--llm`` spec as resolved by
    :meth:`~taskcond.llm.config.LLMConfig.load` (which raises LLMError on a bad spec): backend and model
    and the model's pinned hash as the backend's registry entry labels them
    (:func:`~taskcond.llm.config.backend_label`), and the settings of the condition generator
    ``generator`` (its defaults when None)."""
    from taskcond.generator import ConditionGenerator
    from taskcond.llm.config import LLMConfig, backend_label

    name, digest = backend_label(LLMConfig.load(spec))
    settings = {
        f.name: f.default if generator is None else getattr(generator, f.name)
        for f in fields(ConditionGenerator)
        if f.name not in ("backend", "generation_backend")
    }
    return {
        "llm": name,
        "llm_model_hash": digest,
        "prompt_version": settings.pop("prompt_version"),
        "generator": settings,
    }


@dataclass(frozen=True)
class Job:
    """One unit of work of an evaluation or a reproduced table: an episode (suite id, execution method,
    reset seed) or a scored condition (primitive id, generation mode, trial index)."""

    task: str
    method: str
    seed: int

    @property
    def key(self) -> tuple[str, str, int]:
        return (self.task, self.method, self.seed)

    @staticmethod
    def key_of(record: dict[str, Any]) -> tuple[str, str, int]:
        """The :attr:`key` of the job a results record belongs to."""
        return (record["task"], record["method"], record["seed"])

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


class ConfigMismatchError(ValueError):
    """A results file holds records of another configuration (or of no recorded configuration)."""


class ResultsFile:
    """A JSON-lines results file bound to one :class:`RunConfig`.

    Opening it checks the header against ``config`` (writing the header when the file is new or empty);
    :meth:`results` are the records of finished work, :meth:`append` adds one record at once (flushed, so
    an interruption loses at most the record being written).

    Raises:
        ConfigMismatchError: the file holds another configuration, or records without a header.
    """

    def __init__(self, path: Path, config: RunConfig) -> None:
        self.path = path
        self.config = config
        lines = self._lines()
        if not lines:
            path.parent.mkdir(parents=True, exist_ok=True)
            header = {HEADER_KEY: RESULTS_FORMAT, "digest": config.digest, "config": config.to_dict()}
            path.write_text(json.dumps(header) + "\n", encoding="utf-8")
            return
        header = lines[0]
        if HEADER_KEY not in header:
            raise ConfigMismatchError(
                f"{path} holds results without a recorded configuration (written by an older taskcond); "
                "use another --out or delete it"
            )
        if header.get("digest") != config.digest:
            diffs = config.differences(header.get("config", {}))
            raise ConfigMismatchError(
                f"{path} holds results of another configuration ({'; '.join(diffs) or 'digest differs'}); "
                "use another --out, or the same settings to resume"
            )
        if not path.read_text(encoding="utf-8").endswith("\n"):  # a torn last line: end it, so the
            with path.open("a", encoding="utf-8") as fh:  # next record starts on a line of its own
                fh.write("\n")

    def _lines(self) -> list[dict[str, Any]]:
        if not self.path.exists():
            return []
        records = []
        for line in self.path.read_text(encoding="utf-8").splitlines():
            try:
                records.append(json.loads(line))
            except json.JSONDecodeError:  # a torn last line (an interrupted write)
                continue
        return records

    def results(self) -> list[dict[str, Any]]:
        """Every finished record of this configuration; crashed ones are left out."""
        digest = self.config.digest
        return [r for r in self._lines()[1:] if r.get("digest") == digest and not r.get("crashed")]

    def crashes(self) -> list[dict[str, Any]]:
        """Records of work that raised an exception (retried by the next run)."""
        return [r for r in self._lines()[1:] if r.get("crashed")]

    def done(self, key: Callable[[dict[str, Any]], Hashable]) -> set[Hashable]:
        return {key(r) for r in self.results()}

    def append(self, record: dict[str, Any]) -> dict[str, Any]:
        record = record | {"digest": self.config.digest}
        with self.path.open("a", encoding="utf-8") as fh:
            fh.write(json.dumps(record) + "\n")
        return record


__all__ = [
    "ConfigMismatchError",
    "Job",
    "ResultsFile",
    "RunConfig",
    "code_version",
    "directory_digest",
    "file_digest",
    "llm_fields",
]
