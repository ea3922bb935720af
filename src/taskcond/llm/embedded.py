"""The embedded backend: llama.cpp (``llama-cpp-python``) running a GGUF model that PyPI packages ship.

Offline: nothing is downloaded at run time. The model is loaded lazily on the first request that misses
the response cache, so fully cached runs never pay the load. Shared prompt prefixes are reused: the backend
keeps a few llama.cpp contexts over the one memory-mapped model, and sends each request to the context
whose last prompt shares the longest prefix with it, so the two chats of the condition generator (each
with its long job-vocabulary-examples prefix) never evict each other and a new task name only evaluates
its own few tokens. Answers are constrained by a GBNF grammar when the request carries one.
"""

from __future__ import annotations

import os
import time
from collections.abc import Sequence
from typing import Any

from taskcond.llm.base import ChatRequest, ChatResponse, LLMError
from taskcond.llm.models import DEFAULT_EMBEDDED_MODEL, get_embedded_model, model_path

CONTEXTS = 2
"""llama.cpp contexts kept (one per concurrent conversation; the weights are shared through mmap)."""
BATCH = 64
"""Tokens per llama.cpp batch: a reused prompt prefix is cut to a multiple of it (see
:meth:`EmbeddedBackend._align_reuse`), so a small batch keeps most of the prefix; on 2 cores prompt
evaluation is about as fast in batches of 64 as of 512."""


def _common_prefix_length(a: Sequence[object], b: Sequence[object]) -> int:
    """Length of the longest common prefix of two strings or token lists."""
    n = min(len(a), len(b))
    for i in range(n):
        if a[i] != b[i]:
            return i
    return n


class EmbeddedBackend:
    """llama.cpp in-process. ``model`` is a name of :data:`taskcond.llm.models.EMBEDDED_MODELS`."""

    name = "embedded"

    def __init__(self, model: str = DEFAULT_EMBEDDED_MODEL, n_ctx: int = 4096, n_threads: int | None = None):
        self.spec = get_embedded_model(model)
        self.model = model
        self.n_ctx = n_ctx
        self.n_threads = n_threads or os.cpu_count() or 1
        self._contexts: list[Any] = []
        self._last_prompt: list[str] = []
        self._grammars: dict[str, Any] = {}
        self.load_seconds = 0.0

    def _load(self) -> list[Any]:
        if self._contexts:
            return self._contexts
        try:
            import llama_cpp
        except ImportError:
            raise LLMError(
                f"llama-cpp-python is missing; install it with pip install 'taskcond[{self.spec.extra}]'",
                backend=self.name,
            ) from None
        path = model_path(self.spec)
        start = time.perf_counter()
        self._contexts = [
            llama_cpp.Llama(
                model_path=str(path),
                n_ctx=self.n_ctx,
                n_batch=BATCH,
                n_threads=self.n_threads,
                n_threads_batch=self.n_threads,
                chat_format=self.spec.chat_format,
                verbose=False,
            )
            for _ in range(CONTEXTS)
        ]
        self._last_prompt = [""] * CONTEXTS
        self._lru = list(range(CONTEXTS))
        self.load_seconds = time.perf_counter() - start
        return self._contexts

    def _context_for(self, prompt: str) -> Any:
        """The context whose previous prompt shares the longest prefix with ``prompt``; when none shares at
        least half of it, the least recently used context (so two conversations never evict each other)."""
        contexts = self._load()
        shared = [_common_prefix_length(prompt, last) for last in self._last_prompt]
        best = max(range(len(contexts)), key=shared.__getitem__)
        if shared[best] < len(prompt) // 2:
            best = self._lru[0]
        self._lru.remove(best)
        self._lru.append(best)
        self._last_prompt[best] = prompt
        return contexts[best]

    def _grammar(self, text: str) -> Any:
        if text not in self._grammars:
            import llama_cpp

            try:
                self._grammars[text] = llama_cpp.LlamaGrammar.from_string(text, verbose=False)
            except ValueError as exc:
                raise LLMError(f"invalid GBNF grammar: {exc}", backend=self.name) from None
        return self._grammars[text]

    def _align_reuse(self, llm: Any, messages: list[dict[str, str]]) -> None:
        """Keep only a multiple of llama.cpp's batch size of the cached prompt prefix that ``messages``
        share, so that the rest of the prompt is evaluated in the same batches as from an empty context.

        llama.cpp's results depend slightly on how a prompt is split into batches; reusing a prefix of
        arbitrary length would shift the split, and a greedy answer could then depend on which prompts
        came before it in the process (seen: the same request answered differently in two test runs).
        With batch-aligned reuse every answer equals the one from a fresh context, bit for bit.
        """
        from llama_cpp import llama_chat_format

        if self.spec.chat_format != "chatml":  # the only prompt format of the shipped models
            llm.n_tokens = 0
            return
        formatted = llama_chat_format.format_chatml(messages=messages)
        tokens = llm.tokenize(
            formatted.prompt.encode("utf-8"), add_bos=not formatted.added_special, special=True
        )
        shared = _common_prefix_length(llm.input_ids[: llm.n_tokens].tolist(), tokens)
        llm.n_tokens = min(shared, len(tokens) - 1) // llm.n_batch * llm.n_batch

    def chat(self, request: ChatRequest) -> ChatResponse:
        llm = self._context_for("\n".join(m.content for m in request.messages))
        messages = [{"role": m.role, "content": m.content} for m in request.messages]
        self._align_reuse(llm, messages)
        s = request.sampling
        start = time.perf_counter()
        out = llm.create_chat_completion(
            messages=messages,
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
