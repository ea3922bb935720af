"""Where the skill library lives, and loading it (learned from the suite's oracles on first use)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from taskcond.application.demonstrations import learn_library
from taskcond.execution.skills import LIBRARY_FORMAT, SkillError, SkillLibrary
from taskcond.llm.models import cache_dir
from taskcond.tasks.oracle import ORACLE_REVISION


def default_library_dir() -> Path:
    """Where ``taskcond learn`` stores the skill library:
    ``<cache dir>/skills/v<format>-oracles<revision>`` (:data:`ORACLE_REVISION`)."""
    return cache_dir() / "skills" / f"v{LIBRARY_FORMAT}-oracles{ORACLE_REVISION}"


def load_library(
    directory: Path | None = None,
    learn_if_missing: bool = True,
    progress: Callable[[str, bool], None] | None = None,
    workers: int = 1,
) -> SkillLibrary:
    """The skill library at ``directory`` (default :func:`default_library_dir`); learned from the oracle
    demonstrations first if it does not exist yet and ``learn_if_missing``, by ``workers`` processes
    (:func:`~taskcond.application.demonstrations.learn_library`)."""
    directory = directory or default_library_dir()
    try:
        return SkillLibrary.load(directory)
    except SkillError:
        if not learn_if_missing or (directory / "library.json").exists():
            raise
    return learn_library(directory, progress=progress, workers=workers)
