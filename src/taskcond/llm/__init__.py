"""LLM backends for condition generation: an embedded llama.cpp model (the offline default), any
OpenAI-compatible endpoint, and an on-disk response cache in front of either."""

from taskcond.llm.base import ChatBackend, ChatMessage, ChatRequest, ChatResponse, LLMError, Sampling
from taskcond.llm.config import LLMConfig, make_backend

__all__ = [
    "ChatBackend",
    "ChatMessage",
    "ChatRequest",
    "ChatResponse",
    "LLMConfig",
    "LLMError",
    "Sampling",
    "make_backend",
]
