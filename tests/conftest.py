"""Shared fixtures. The embedded model is loaded once per test session (it is the expensive part)."""

from __future__ import annotations

import pytest


@pytest.fixture(scope="session")
def embedded_backend():
    """The real embedded llama.cpp backend with the default model, without the response cache."""
    from taskcond.llm.embedded import EmbeddedBackend

    backend = EmbeddedBackend()
    backend._load()
    return backend
