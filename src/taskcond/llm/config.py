"""Choosing and configuring the LLM backend: the ``--llm`` option, environment variables and a config file.

Precedence: the ``--llm`` option, then ``$TASKCOND_LLM``, then the config file, then the embedded default.
A backend spec is ``embedded``, ``embedded:MODEL``, ``openai`` or ``openai:MODEL``.

The config file is ``$TASKCOND_CONFIG`` or ``~/.config/taskcond/config.toml``::

    [llm]
    backend = "openai:gpt-4o-mini"       # or "embedded", "embedded:qwen2.5-coder-0.5b"
    base_url = "http://127.0.0.1:8000/v1"
    api_key_env = "OPENAI_API_KEY"       # name of the variable holding the key (the key itself never here)
    timeout = 60
    grammar_field = "grammar"            # constrained decoding on llama.cpp servers
    cache = true
    runtime = "xllamacpp"                # the embedded backend's llama.cpp: xllamacpp or llama-cpp-python

For the OpenAI backend, ``OPENAI_BASE_URL`` and ``TASKCOND_OPENAI_MODEL`` override the file; for the
embedded one, ``TASKCOND_EMBEDDED_RUNTIME`` overrides ``runtime``. Without either, the embedded runtime is
the first of :data:`EMBEDDED_RUNTIMES` that is installed.
"""

from __future__ import annotations

import importlib.util
import os
import tomllib
import weakref
from collections.abc import Callable
from dataclasses import dataclass, replace
from enum import StrEnum
from importlib import metadata
from pathlib import Path

from taskcond.llm.base import ChatBackend, LLMError
from taskcond.llm.cache import CachedBackend
from taskcond.llm.models import DEFAULT_EMBEDDED_MODEL, MODE_MODELS, MODE_MODELS_NAME, Mode, cache_dir


class BackendKind(StrEnum):
    """The LLM backends, the part of a ``--llm`` spec before ``:`` (each an entry of :data:`BACKENDS`)."""

    EMBEDDED = "embedded"
    """A GGUF model run in-process by llama.cpp (:mod:`taskcond.llm.models`)."""
    OPENAI = "openai"
    """An OpenAI-compatible chat-completions server."""


DEFAULT_OPENAI_MODEL = "gpt-4o-mini"
EMBEDDED_RUNTIMES = {"llama-cpp-python": "llama_cpp", "xllamacpp": "xllamacpp"}
"""The embedded backend's llama.cpp runtimes, the preferred first, each with its import name:
llama-cpp-python (compiled for this CPU on install, ``[embedded-native]``, ``make install-native``) when it
is installed, else xllamacpp (a prebuilt wheel, ``[embedded]``, installed by default). The native build
uses every instruction the CPU has; xllamacpp's kernels stop at AVX2, which made leave-one-out conditions
1.6 times slower on an AVX-512 machine (BENCHMARKS.md, "Embedded runtimes")."""


def embedded_runtime(requested: str | None = None) -> str:
    """The embedded runtime: ``requested`` when given (else ``$TASKCOND_EMBEDDED_RUNTIME``), else the first
    of :data:`EMBEDDED_RUNTIMES` that is installed, else xllamacpp (whose absence the backend reports)."""
    chosen = requested or os.environ.get("TASKCOND_EMBEDDED_RUNTIME")
    if chosen:
        if chosen not in EMBEDDED_RUNTIMES:
            raise LLMError(
                f"unknown embedded runtime {chosen!r}; valid: {', '.join(EMBEDDED_RUNTIMES)}",
                backend="config",
            )
        return chosen
    installed = [name for name, module in EMBEDDED_RUNTIMES.items() if importlib.util.find_spec(module)]
    return installed[0] if installed else "xllamacpp"


def runtime_label(runtime: str) -> str:
    """``RUNTIME-VERSION`` of an embedded runtime (``RUNTIME`` alone when it is not installed), as results
    record it."""
    try:
        return f"{runtime}-{metadata.version(runtime)}"
    except metadata.PackageNotFoundError:
        return runtime


@dataclass(frozen=True)
class LLMConfig:
    """Resolved backend settings."""

    backend: str = "embedded"
    model: str | None = None
    base_url: str | None = None
    api_key_env: str = "OPENAI_API_KEY"
    timeout: float = 60.0
    grammar_field: str | None = None
    cache: bool = True
    cache_dir: Path | None = None
    threads: int | None = None
    """CPU threads of the embedded model (None: every core)."""
    runtime: str | None = None
    """The embedded backend's llama.cpp runtime, a key of :data:`EMBEDDED_RUNTIMES` (None for openai)."""

    @classmethod
    def load(cls, spec: str | None = None, config_file: Path | None = None) -> LLMConfig:
        """Resolve settings from ``spec`` (the ``--llm`` value), the environment and the config file."""
        path = config_file or Path(
            os.environ.get("TASKCOND_CONFIG", Path.home() / ".config" / "taskcond" / "config.toml")
        )
        table: dict = {}
        if path.is_file():
            try:
                table = tomllib.loads(path.read_text(encoding="utf-8")).get("llm", {})
            except tomllib.TOMLDecodeError as exc:
                raise LLMError(f"config file {path} is not valid TOML: {exc}", backend="config") from None
        known = {"backend", "base_url", "api_key_env", "timeout", "grammar_field", "cache", "runtime"}
        unknown = set(table) - known
        if unknown:
            raise LLMError(
                f"config file {path}: unknown [llm] keys {sorted(unknown)}; valid: {sorted(known)}",
                backend="config",
            )
        chosen = spec or os.environ.get("TASKCOND_LLM") or table.get("backend") or "embedded"
        kind, _, model = chosen.partition(":")
        if kind == BackendKind.EMBEDDED and model == MODE_MODELS_NAME:
            model = ""  # the default's models, as a result names them
        if kind not in BACKENDS:
            valid = ", ".join(f"{k}, {k}:MODEL" for k in BACKENDS)
            raise LLMError(f"unknown backend {chosen!r}; valid: {valid}", backend="config")
        cfg = cls(
            backend=kind,
            model=model or None,
            base_url=table.get("base_url"),
            api_key_env=table.get("api_key_env", "OPENAI_API_KEY"),
            timeout=float(table.get("timeout", 60.0)),
            grammar_field=table.get("grammar_field"),
            cache=bool(table.get("cache", True)),
        )
        return BACKENDS[BackendKind(kind)].resolve(cfg, table)

    def for_mode(self, mode: Mode) -> LLMConfig:
        """The configuration of the model that answers ``mode``'s conditions: the embedded backend without
        a chosen model has one per mode (:data:`~taskcond.llm.models.MODE_MODELS`); a chosen model
        (``embedded:MODEL``, ``openai[:MODEL]``) answers both."""
        if self.backend != BackendKind.EMBEDDED or self.model:
            return self
        return replace(self, model=MODE_MODELS[mode])


_IN_USE: weakref.WeakValueDictionary[tuple, ChatBackend] = weakref.WeakValueDictionary()
"""The embedded backends some caller still holds, by (runtime, model, threads, prefix directory)."""


def embedded_backend(
    model: str = DEFAULT_EMBEDDED_MODEL,
    n_threads: int | None = None,
    prefix_dir: Path | None = None,
    runtime: str | None = None,
) -> ChatBackend:
    """The embedded backend of ``model`` on ``runtime`` (:func:`embedded_runtime` when None), without the
    response cache and loaded on its first request.

    A process holds one model per configuration: while any caller still holds the backend of the same
    runtime, model, threads and prefix directory, that backend is returned again instead of loading the
    model (1.1 GB) a second time; it is dropped once nobody holds it. Its answers do not depend on the
    requests before them (:meth:`~taskcond.llm.xllamacpp_backend.XLlamaCppBackend.chat`), so sharing it
    changes no answer.
    """
    runtime = embedded_runtime(runtime)
    key = (runtime, model, n_threads, None if prefix_dir is None else Path(prefix_dir))
    backend = _IN_USE.get(key)
    if backend is None:
        if runtime == "xllamacpp":
            from taskcond.llm.xllamacpp_backend import XLlamaCppBackend

            backend = XLlamaCppBackend(model, n_threads=n_threads, prefix_dir=prefix_dir)
        else:
            from taskcond.llm.embedded import EmbeddedBackend

            backend = EmbeddedBackend(model, n_threads=n_threads, prefix_dir=prefix_dir)
        _IN_USE[key] = backend
    return backend


def _resolve_embedded(cfg: LLMConfig, table: dict) -> LLMConfig:
    """The embedded runtime: ``$TASKCOND_EMBEDDED_RUNTIME``, the file's ``runtime``, else installed."""
    runtime = os.environ.get("TASKCOND_EMBEDDED_RUNTIME") or table.get("runtime")
    return replace(cfg, runtime=embedded_runtime(runtime))


def _build_embedded(config: LLMConfig) -> ChatBackend:
    runtime = config.runtime or embedded_runtime()
    prefixes = (config.cache_dir or cache_dir()) / "prefixes" / runtime if config.cache else None
    model = config.model or DEFAULT_EMBEDDED_MODEL
    return embedded_backend(model, config.threads, prefixes, runtime)


def _label_embedded(config: LLMConfig) -> tuple[str, str | None]:
    """``embedded:MODEL@RUNTIME`` and the model's hash; without a chosen model, each mode's
    (``embedded:generation=MODEL,generalization=MODEL@RUNTIME`` and ``HASH,HASH``)."""
    from taskcond.llm.models import get_embedded_model

    runtime = runtime_label(config.runtime or embedded_runtime())
    if config.model:
        model = get_embedded_model(config.model)
        return f"embedded:{model.name}@{runtime}", model.sha256[:16]
    models = [get_embedded_model(name) for name in MODE_MODELS.values()]
    return f"embedded:{MODE_MODELS_NAME}@{runtime}", ",".join(m.sha256[:16] for m in models)


def _resolve_openai(cfg: LLMConfig, table: dict) -> LLMConfig:
    """``$OPENAI_BASE_URL`` over the file's ``base_url``; the model of the spec, else
    ``$TASKCOND_OPENAI_MODEL``, else :data:`DEFAULT_OPENAI_MODEL`."""
    return replace(
        cfg,
        base_url=os.environ.get("OPENAI_BASE_URL") or cfg.base_url,
        model=cfg.model or os.environ.get("TASKCOND_OPENAI_MODEL") or DEFAULT_OPENAI_MODEL,
    )


def _build_openai(config: LLMConfig) -> ChatBackend:
    from taskcond.llm.openai_backend import OpenAIBackend

    key = os.environ.get(config.api_key_env)
    if not key:
        if not config.base_url:
            raise LLMError(
                f"no API key: set {config.api_key_env}, or OPENAI_BASE_URL for a local server",
                backend="openai",
            )
        key = "none"  # local OpenAI-compatible servers accept any key
    return OpenAIBackend(
        model=config.model or DEFAULT_OPENAI_MODEL,
        base_url=config.base_url,
        api_key=key,
        timeout=config.timeout,
        grammar_field=config.grammar_field,
    )


def _label_openai(config: LLMConfig) -> tuple[str, str | None]:
    return f"openai:{config.model}" + (f"@{config.base_url}" if config.base_url else ""), None


@dataclass(frozen=True)
class Backend:
    """One LLM backend of :data:`BACKENDS`.

    Attributes:
        resolve: the backend's own settings from the environment and the config file's ``[llm]`` table,
            given the generic ones (:meth:`LLMConfig.load`).
        build: the backend (:func:`make_backend`, before its response cache).
        label: how results name it (``RunConfig.llm``, e.g. ``embedded:qwen2.5-coder-1.5b@xllamacpp-...``
            or ``openai:MODEL@BASE_URL``) and the pinned hash of its model file (None for a remote model).
    """

    resolve: Callable[[LLMConfig, dict], LLMConfig]
    build: Callable[[LLMConfig], ChatBackend]
    label: Callable[[LLMConfig], tuple[str, str | None]]


BACKENDS: dict[BackendKind, Backend] = {
    BackendKind.EMBEDDED: Backend(_resolve_embedded, _build_embedded, _label_embedded),
    BackendKind.OPENAI: Backend(_resolve_openai, _build_openai, _label_openai),
}
"""The one registry from an LLM backend to its settings, its factory and its label in results."""


def make_backend(config: LLMConfig) -> ChatBackend:
    """Build the configured backend (:data:`BACKENDS`), wrapped in the on-disk response cache unless
    ``config.cache`` is off."""
    backend = BACKENDS[BackendKind(config.backend)].build(config)
    if config.cache:
        return CachedBackend(backend, (config.cache_dir or cache_dir()) / "responses")
    return backend


def backend_label(config: LLMConfig) -> tuple[str, str | None]:
    """How results name the backend of ``config`` and its model's pinned hash (:attr:`Backend.label`)."""
    return BACKENDS[BackendKind(config.backend)].label(config)
