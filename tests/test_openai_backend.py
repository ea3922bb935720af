"""The OpenAI-compatible backend against a real server on 127.0.0.1 (llama.cpp's own server running the
embedded model, from the prebuilt xllamacpp runtime: ``python -m taskcond.llm.serve``), through the
official ``openai`` SDK; plus its error paths and the config resolution."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import time
import urllib.request

import pytest

from taskcond.examples import reference_condition
from taskcond.generator import ConditionGenerator
from taskcond.llm.base import ChatMessage, ChatRequest, LLMError
from taskcond.llm.config import LLMConfig, make_backend
from taskcond.primitives import parse_task

SECRET = "sk-test-do-not-print-1234567890"


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture(scope="module")
def server():
    """``taskcond.llm.serve`` on a free loopback port, with the key ``SECRET``; stopped after the module's
    tests."""
    pytest.importorskip("xllamacpp", reason="needs the [embedded] extra")
    port = _free_port()
    cmd = [sys.executable, "-m", "taskcond.llm.serve", "--port", str(port), "--api-key-env", "SERVER_KEY"]
    env = {**os.environ, "SERVER_KEY": SECRET}
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    url = f"http://127.0.0.1:{port}/v1"
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        try:
            urllib.request.urlopen(f"http://127.0.0.1:{port}/health", timeout=2)  # 503 while loading
            break
        except OSError:
            if proc.poll() is not None:
                pytest.fail(f"taskcond.llm.serve exited with {proc.returncode}")
            time.sleep(0.5)
    else:
        proc.kill()
        pytest.fail("taskcond.llm.serve did not start within 120 s")
    yield url
    proc.terminate()
    proc.wait(timeout=30)


def _backend(monkeypatch, url: str | None, grammar_field: str | None = None, timeout: float = 120):
    monkeypatch.setenv("OPENAI_API_KEY", SECRET)
    if url:
        monkeypatch.setenv("OPENAI_BASE_URL", url)
    cfg = LLMConfig.load("openai:local-model")
    from dataclasses import replace

    return make_backend(replace(cfg, cache=False, grammar_field=grammar_field, timeout=timeout))


@pytest.mark.server
def test_generation_through_a_real_openai_compatible_server(server, monkeypatch):
    backend = _backend(monkeypatch, server, grammar_field="grammar")
    result = ConditionGenerator(backend).generate("move bottle into box")
    ref = reference_condition(parse_task("move bottle into box"))
    assert not result.cached and result.attempts >= 1  # the default prompts (v8): one code chat
    assert [t.chat for t in result.transcripts] == ["code"]
    assert set(result.condition.relevant_objects) == set(ref.relevant_objects)
    assert result.condition.mentioned_objects() <= {"bottle", "box", "gripper"}
    assert set(result.condition.pre_conditions) & set(ref.pre_conditions)


@pytest.mark.server
def test_without_a_grammar_the_validator_still_guarantees_the_form(server, monkeypatch):
    """No grammar is sent: every answer goes through the validator (with retries), and what comes out is a
    well-formed condition about the task's own objects (a seen primitive: the reference's meaning)."""
    backend = _backend(monkeypatch, server, grammar_field=None)
    result = ConditionGenerator(backend, grammar="never", max_retries=3).generate("grasp bowl")
    assert len(result.transcripts[0].answers) == len(result.transcripts[0].errors) + 1
    assert set(result.condition.relevant_objects) == {"bowl", "gripper"}
    assert result.condition.mentioned_objects() <= {"bowl", "gripper"}
    assert set(result.condition.post_conditions) >= set(
        reference_condition(parse_task("grasp bowl")).post_conditions
    )


@pytest.mark.server
def test_the_server_refuses_a_wrong_key(server):
    from taskcond.llm.openai_backend import OpenAIBackend

    backend = OpenAIBackend(model="local-model", base_url=server, api_key="sk-wrong", max_retries=0)
    with pytest.raises(LLMError, match="rejected the API key"):
        backend.chat(ChatRequest((ChatMessage("user", "hi"),)))


@pytest.mark.server
def test_unreachable_endpoint_is_a_one_line_error_without_the_key(monkeypatch):
    backend = _backend(monkeypatch, f"http://127.0.0.1:{_free_port()}/v1", timeout=5)
    request = ChatRequest((ChatMessage("user", "hi"),))
    with pytest.raises(LLMError, match=r"\[openai\] cannot reach endpoint http://127.0.0.1:\d+/v1") as info:
        backend.chat(request)
    assert SECRET not in str(info.value) and "\n" not in str(info.value)


def test_missing_key_without_local_endpoint_is_refused(monkeypatch):
    monkeypatch.delenv("OPENAI_API_KEY", raising=False)
    monkeypatch.delenv("OPENAI_BASE_URL", raising=False)
    monkeypatch.setenv("TASKCOND_CONFIG", os.devnull)
    with pytest.raises(LLMError, match="no API key: set OPENAI_API_KEY"):
        make_backend(LLMConfig.load("openai"))


def test_backend_spec_and_config_file(tmp_path, monkeypatch):
    monkeypatch.delenv("TASKCOND_LLM", raising=False)
    monkeypatch.delenv("OPENAI_BASE_URL", raising=False)
    monkeypatch.delenv("TASKCOND_OPENAI_MODEL", raising=False)
    cfg_file = tmp_path / "config.toml"
    cfg_file.write_text(
        '[llm]\nbackend = "openai:my-model"\nbase_url = "http://127.0.0.1:9/v1"\ntimeout = 5\n'
    )
    cfg = LLMConfig.load(None, cfg_file)
    assert (cfg.backend, cfg.model, cfg.base_url, cfg.timeout) == (
        "openai",
        "my-model",
        "http://127.0.0.1:9/v1",
        5.0,
    )
    assert LLMConfig.load("embedded:qwen2.5-coder-0.5b", cfg_file).model == "qwen2.5-coder-0.5b"
    monkeypatch.setenv("TASKCOND_LLM", "embedded")
    assert LLMConfig.load(None, cfg_file).backend == "embedded"
    with pytest.raises(LLMError, match="unknown backend 'gpt'; valid: embedded"):
        LLMConfig.load("gpt", cfg_file)
    cfg_file.write_text("[llm]\nbackend = 3 = 4\n")
    with pytest.raises(LLMError, match="not valid TOML"):
        LLMConfig.load(None, cfg_file)
    cfg_file.write_text('[llm]\napi_key = "sk-x"\n')
    with pytest.raises(LLMError, match=r"unknown \[llm\] keys \['api_key'\]"):
        LLMConfig.load(None, cfg_file)


def test_every_backend_is_one_registry_entry_that_labels_results_by_its_own_name(monkeypatch):
    """One registry (llm.config.BACKENDS) from backend to settings, factory and result label: every backend
    kind has an entry, the spec's error lists them all, and each result label names its own backend (a
    third backend is no longer labelled 'openai')."""
    from taskcond.llm.config import BACKENDS, BackendKind, backend_label
    from taskcond.results import llm_fields

    monkeypatch.delenv("OPENAI_BASE_URL", raising=False)
    assert list(BACKENDS) == list(BackendKind)
    for kind in BackendKind:
        cfg = LLMConfig.load(kind.value)
        assert cfg.backend == kind
        label, digest = backend_label(cfg)
        assert label.startswith(f"{kind.value}:") and llm_fields(kind.value)["llm"] == label
        assert (digest is None) == (kind is BackendKind.OPENAI)
    assert backend_label(LLMConfig.load("openai:m"))[0] == "openai:m"
    with pytest.raises(LLMError, match=", ".join(f"{k}, {k}:MODEL" for k in BackendKind)):
        LLMConfig.load("third")
