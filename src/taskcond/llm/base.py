"""The chat interface every LLM backend implements, and its errors.

A backend answers one chat request (a list of messages plus sampling settings and an optional grammar)
with one text. Backends know nothing about task conditions; the condition generator
(:mod:`taskcond.generator`) knows nothing about the backends' wire formats.
"""

from __future__ import annotations

import os
from dataclasses import asdict, dataclass, field
from typing import Literal, Protocol

Role = Literal["system", "user", "assistant"]


def cpu_count() -> int:
    """Cores this process may run on: its CPU affinity, which a container or ``taskset`` may set below
    the machine's ``os.cpu_count()``. llama.cpp's threads wait for each other at every operation, so more
    threads than cores slows every answer down."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1


class LLMError(RuntimeError):
    """An LLM backend failed: unreachable, rejected the key, timed out, refused or answered nonsense.

    The message names the backend and what came back, in one line, and never contains the API key.
    """

    def __init__(self, message: str, backend: str) -> None:
        super().__init__(f"[{backend}] {message}")
        self.backend = backend


@dataclass(frozen=True)
class ChatMessage:
    role: Role
    content: str


@dataclass(frozen=True)
class Sampling:
    """Sampling settings; ``temperature=0`` is greedy decoding. ``seed`` makes sampling repeatable where
    the backend supports it."""

    temperature: float = 0.0
    top_p: float = 1.0
    max_tokens: int = 256
    seed: int = 0


@dataclass(frozen=True)
class ChatRequest:
    """One chat completion request.

    Attributes:
        messages: the conversation so far, ending with a user message.
        sampling: sampling settings.
        grammar: an optional GBNF grammar the answer must follow (used by backends that support
            constrained decoding; others ignore it and rely on validation).
        stop: strings that end the answer.
        shared_messages: how many leading messages many requests share (the job, vocabulary and
            examples of a prompt): a hint that lets a backend keep their evaluated prefix across runs (the
            embedded backend's prefix cache). It never changes the answer, so it is not part of the cache
            key.
    """

    messages: tuple[ChatMessage, ...]
    sampling: Sampling = field(default_factory=Sampling)
    grammar: str | None = None
    stop: tuple[str, ...] = ()
    shared_messages: int = 0

    def key_material(self) -> dict:
        """Everything that determines the answer, for the response cache key."""
        return {
            "messages": [asdict(m) for m in self.messages],
            "sampling": asdict(self.sampling),
            "grammar": self.grammar,
            "stop": list(self.stop),
        }


@dataclass(frozen=True)
class ChatResponse:
    text: str
    cached: bool = False
    prompt_tokens: int = 0
    completion_tokens: int = 0
    seconds: float = 0.0


class ChatBackend(Protocol):
    """What the condition generator needs from an LLM."""

    name: str
    """Backend kind, e.g. ``"embedded"`` or ``"openai"``."""
    model: str
    """Model identifier, part of the cache key."""

    def chat(self, request: ChatRequest) -> ChatResponse: ...
