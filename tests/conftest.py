"""Shared fixtures. The embedded model is loaded once per test session (it is the expensive part)."""

from __future__ import annotations

import pytest


@pytest.fixture(scope="session")
def embedded_backend():
    """The real embedded llama.cpp backend with the default model on the default runtime (the first
    installed of xllamacpp and llama-cpp-python, or ``$TASKCOND_EMBEDDED_RUNTIME``), without the response
    cache."""
    from taskcond.llm.config import embedded_backend as make

    backend = make()
    backend._load()
    return backend
