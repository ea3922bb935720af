"""Backends for the validator's paths: a real backend with chosen answers spoiled, for the paths that need a
malformed answer from the real model (malformed LLM output is expected input), and a scripted replay for the
prompt layouts and retries that need one exact answer."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

from taskcond.llm.base import ChatBackend, ChatRequest, ChatResponse


@dataclass
class Spoiled:
    """``backend``, except that request ``k`` (counted from 0) is answered ``bad`` without asking the model
    where ``spoil(k)`` holds; every request is kept in :attr:`requests`."""

    backend: ChatBackend
    bad: str
    spoil: Callable[[int], bool] = lambda k: k == 0
    requests: list[ChatRequest] = field(default_factory=list)

    @property
    def name(self) -> str:
        return self.backend.name

    @property
    def model(self) -> str:
        return self.backend.model

    def chat(self, request: ChatRequest) -> ChatResponse:
        self.requests.append(request)
        if self.spoil(len(self.requests) - 1):
            return ChatResponse(self.bad)
        return self.backend.chat(request)


@dataclass
class Replay:
    """A backend that answers from a script, recording what it was asked."""

    answers: list[str]
    name: str = "replay"
    model: str = "script"
    requests: list[ChatRequest] = field(default_factory=list)

    def chat(self, request: ChatRequest) -> ChatResponse:
        self.requests.append(request)
        return ChatResponse(self.answers.pop(0))
