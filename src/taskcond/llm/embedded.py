"""The embedded backend: llama.cpp (``llama-cpp-python``) running a GGUF model that PyPI packages ship.

Offline: nothing is downloaded at run time. The model is loaded lazily on the first request that misses
the response cache, so fully cached runs never pay the load. Shared prompt prefixes (the job description,
vocabulary and examples of a chat) are kept as llama.cpp states in RAM, so a new task name only evaluates
its own few tokens. Answers are constrained by a GBNF grammar when the request carries one.
"""

from __future__ import annotations

import os
import time
from typing import Any

from taskcond.llm.base import ChatRequest, ChatResponse, LLMError
from taskcond.llm.models import DEFAULT_EMBEDDED_MODEL, get_embedded_model, model_path

PREFIX_CACHE_BYTES = 1 << 30
"""RAM for cached prompt-prefix states (a state of a 700-token prompt of the 1.5B model is ~20 MB)."""


class EmbeddedBackend:
    """llama.cpp in-process. ``model`` is a name of :data:`taskcond.llm.models.EMBEDDED_MODELS`."""

    name = "embedded"

    def __init__(self, model: str = DEFAULT_EMBEDDED_MODEL, n_ctx: int = 4096, n_threads: int | None = None):
        self.spec = get_embedded_model(model)
        self.model = model
        self.n_ctx = n_ctx
        self.n_threads = n_threads or os.cpu_count() or 1
        self._llm: Any = None
        self._grammars: dict[str, Any] = {}
        self.load_seconds = 0.0

    def _load(self) -> Any:
        if self._llm is not None:
            return self._llm
        try:
            import llama_cpp
        except ImportError:
            raise LLMError(
                f"llama-cpp-python is missing; install it with pip install 'taskcond[{self.spec.extra}]'",
                backend=self.name,
            ) from None
        path = model_path(self.spec)
        start = time.perf_counter()
        self._llm = llama_cpp.Llama(
            model_path=str(path),
            n_ctx=self.n_ctx,
            n_threads=self.n_threads,
            n_threads_batch=self.n_threads,
            chat_format=self.spec.chat_format,
            verbose=False,
        )
        self._llm.set_cache(llama_cpp.LlamaRAMCache(capacity_bytes=PREFIX_CACHE_BYTES))
        self.load_seconds = time.perf_counter() - start
        return self._llm

    def _grammar(self, text: str) -> Any:
        if text not in self._grammars:
            import llama_cpp

            try:
                self._grammars[text] = llama_cpp.LlamaGrammar.from_string(text, verbose=False)
            except ValueError as exc:
                raise LLMError(f"invalid GBNF grammar: {exc}", backend=self.name) from None
        return self._grammars[text]

    def chat(self, request: ChatRequest) -> ChatResponse:
        llm = self._load()
        s = request.sampling
        start = time.perf_counter()
        out = llm.create_chat_completion(
            messages=[{"role": m.role, "content": m.content} for m in request.messages],
            temperature=s.temperature,
            top_p=s.top_p,
            top_k=0 if s.temperature > 0 else 1,
            max_tokens=s.max_tokens,
            seed=s.seed,
            stop=list(request.stop) or None,
            grammar=self._grammar(request.grammar) if request.grammar else None,
        )
        usage = out.get("usage", {})
        return ChatResponse(
            text=out["choices"][0]["message"]["content"] or "",
            prompt_tokens=usage.get("prompt_tokens", 0),
            completion_tokens=usage.get("completion_tokens", 0),
            seconds=time.perf_counter() - start,
        )
