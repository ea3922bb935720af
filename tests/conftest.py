"""Shared fixtures. Every test runs the project, not the user's settings (:func:`_project_only`); the
embedded model is loaded once per test session (it is the expensive part)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from taskcond.llm.models import cache_dir

USER_SETTINGS = (
    "TASKCOND_LLM",
    "TASKCOND_PRIMITIVES",
    "TASKCOND_OBJECTS",
    "TASKCOND_ASSET_DIR",
    "RAY_ADDRESS",
)
"""Variables by which a user chooses an LLM, declares primitives, moves the generated assets or names a
Ray cluster: unset for the tests, with every ``OPENAI_*`` variable."""


@pytest.fixture(scope="session", autouse=True)
def _project_only(tmp_path_factory: pytest.TempPathFactory):
    """Isolate the test session from the user's home and environment.

    * ``TASKCOND_CONFIG`` points at a file that does not exist, so no ``config.toml`` of the user's is read;
    * ``TASKCOND_CACHE_DIR`` is a new directory per session: every LLM answer is asked of the model again
      (nothing is served from an earlier run's response cache or saved prefix states), and a skill library
      is learned by the test that needs it (the suite's fixtures learn theirs into temporary directories);
    * the user's LLM, declared primitives, asset directory, ``OPENAI_*`` and ``RAY_ADDRESS`` are unset
      (``TASKCOND_EMBEDDED_RUNTIME`` is kept: it chooses which of the project's llama.cpp runtimes the
      session tests, :func:`pytest_collection_modifyitems`).

    One thing stays shared: the assembled embedded model, ``<the user's cache dir>/models`` (linked into the
    session's cache). It is never stale: it is checked against its pinned SHA-256 when assembled, and a
    stamp of its size, mtime and digest is checked at every load (:func:`taskcond.llm.models.model_path`).
    """
    shared_models = cache_dir() / "models"  # resolved before the user's variables are dropped
    shared_models.mkdir(parents=True, exist_ok=True)
    session_cache = tmp_path_factory.mktemp("taskcond-cache")
    (session_cache / "models").symlink_to(shared_models, target_is_directory=True)
    patch = pytest.MonkeyPatch()
    patch.setenv("TASKCOND_CONFIG", str(session_cache / "no-config.toml"))
    patch.setenv("TASKCOND_CACHE_DIR", str(session_cache))
    for name in [*USER_SETTINGS, *(k for k in os.environ if k.startswith("OPENAI_"))]:
        patch.delenv(name, raising=False)
    yield Path(session_cache)
    patch.undo()


RUNTIME_MARKERS = {"native_runtime": "llama-cpp-python", "xllamacpp_runtime": "xllamacpp"}
"""Markers of tests of one embedded runtime's own decoding, with the runtime each needs."""


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Deselect (not skip) the tests of an embedded runtime the session does not run: the session runs
    the default runtime, or ``$TASKCOND_EMBEDDED_RUNTIME`` (the one way to test the other runtime)."""
    from taskcond.llm.config import embedded_runtime

    runtime = embedded_runtime()
    other = [
        i
        for i in items
        if any(RUNTIME_MARKERS[m] != runtime for m in RUNTIME_MARKERS if i.get_closest_marker(m))
    ]
    if other:
        config.hook.pytest_deselected(items=other)
        items[:] = [i for i in items if i not in other]


@pytest.fixture(scope="session")
def embedded_backend(_project_only):
    """The real embedded llama.cpp backend with the default model on the default runtime (the first
    installed of llama-cpp-python and xllamacpp, or ``$TASKCOND_EMBEDDED_RUNTIME``), without the response
    cache: the very backend the command line builds in this session (its prefix states in the session's
    cache), so that a test driving the command line in-process shares its loaded model
    (:func:`taskcond.llm.config.embedded_backend`) instead of loading a second one."""
    return _loaded_backend("generalization")


@pytest.fixture(scope="session")
def small_backend(_project_only):
    """The real embedded backend of the default's generation conditions (the 0.5B model,
    :data:`taskcond.llm.models.MODE_MODELS`), as :func:`embedded_backend` is the default model's."""
    return _loaded_backend("generation")


def _loaded_backend(mode: str):
    """The command line's embedded backend of ``mode``'s model, its model loaded."""
    from taskcond.llm.config import BACKENDS, BackendKind, LLMConfig

    backend = BACKENDS[BackendKind.EMBEDDED].build(LLMConfig.load(None).for_mode(mode))
    backend._load()
    return backend


@pytest.fixture(autouse=True)
def _one_model(request: pytest.FixtureRequest) -> None:
    """A test marked ``llm`` holds the session's :func:`embedded_backend` and :func:`small_backend`, so
    that the command line it may drive in-process gets those loaded models instead of loading others (one
    load per model and session; a backend is shared while held,
    :func:`taskcond.llm.config.embedded_backend`)."""
    if request.node.get_closest_marker("llm"):
        request.getfixturevalue("embedded_backend")
        request.getfixturevalue("small_backend")


@pytest.fixture(scope="session")
def cached_llm(embedded_backend, _project_only):
    """:func:`embedded_backend` behind the session's response cache, as the command line builds it
    (``<session cache>/responses``): for tests whose subject is what conditions do rather than how the
    model writes them, the model answers each distinct request once per session (LHT1's ``grasp bottle``
    is asked by several tests). Every session asks it again: its cache directory is new."""
    from taskcond.llm.config import LLMConfig, make_backend

    backend = make_backend(LLMConfig.load(None))
    assert backend.backend is embedded_backend  # one loaded model
    return backend


def pytest_sessionfinish(session: pytest.Session) -> None:
    """With ``TASKCOND_TEST_NO_SKIP`` set (``make test`` sets it: it installs every extra), a skipped test
    fails the session, so that an extra that went missing cannot pass quietly."""
    reporter = session.config.pluginmanager.get_plugin("terminalreporter")
    skipped = reporter.stats.get("skipped", []) if reporter else []
    if os.environ.get("TASKCOND_TEST_NO_SKIP") and skipped:
        reporter.write_line(f"error: {len(skipped)} skipped; make test installs every extra", red=True)
        session.exitstatus = pytest.ExitCode.TESTS_FAILED
