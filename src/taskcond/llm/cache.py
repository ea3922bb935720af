"""On-disk response cache: a repeated request is answered from disk, free and identical.

The key is the SHA-256 of the backend kind, the model, the whole request (messages, sampling settings,
grammar, stop strings) and the cache format version, and of the backend's ``runtime`` where it has one (the
xllamacpp embedded runtime and its version; the llama-cpp-python runtime has none, so that the answers it
cached before the runtimes were told apart keep their keys); one small JSON file per answer.
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
import time
from pathlib import Path

from taskcond.llm.base import ChatBackend, ChatRequest, ChatResponse

CACHE_FORMAT = 1


class CachedBackend:
    """Wraps a backend; same interface. The wrapped backend is only called on a cache miss."""

    def __init__(self, backend: ChatBackend, directory: Path) -> None:
        self.backend = backend
        self.name = backend.name
        self.model = backend.model
        self.directory = Path(directory)

    def key(self, request: ChatRequest) -> str:
        material = {
            "format": CACHE_FORMAT,
            "backend": self.backend.name,
            "model": self.backend.model,
            "endpoint": getattr(self.backend, "endpoint", None),
            "request": request.key_material(),
        }
        runtime = getattr(self.backend, "runtime", None)
        if runtime is not None:
            material["runtime"] = runtime
        return hashlib.sha256(json.dumps(material, sort_keys=True).encode()).hexdigest()

    def _path(self, key: str) -> Path:
        return self.directory / key[:2] / f"{key}.json"

    def chat(self, request: ChatRequest) -> ChatResponse:
        start = time.perf_counter()
        path = self._path(self.key(request))
        try:
            text = json.loads(path.read_text(encoding="utf-8"))["text"]
        except (OSError, ValueError, KeyError):
            pass
        else:
            return ChatResponse(text=text, cached=True, seconds=time.perf_counter() - start)
        response = self.backend.chat(request)
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=".tmp")
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            json.dump({"text": response.text, "model": self.backend.model}, fh)
        os.replace(tmp, path)
        return response
