"""The xllamacpp embedded runtime: its prompt format, its listener (no TCP port, a key), its drafts, its
error when libgomp is missing, and that its answers are never taken for another runtime's."""

from __future__ import annotations

import contextlib
import http.client
import os
import socket
import subprocess
import sys
from pathlib import Path

import pytest

from taskcond.generator import ConditionGenerator
from taskcond.llm.base import ChatMessage, ChatRequest, LLMError, Sampling
from taskcond.llm.cache import CachedBackend
from taskcond.llm.embedded import EmbeddedBackend
from taskcond.llm.xllamacpp_backend import LIBGOMP_HINT, XLlamaCppBackend, chatml_prompt
from taskcond.primitives import parse_task
from taskcond.results import llm_fields

MESSAGES = [
    {"role": "system", "content": "Be brief."},
    {"role": "user", "content": "Name a fruit.\n\nOne word."},
    {"role": "assistant", "content": "Plum"},
    {"role": "user", "content": "Another."},
]


@pytest.fixture
def xbackend(embedded_backend):
    assert isinstance(embedded_backend, XLlamaCppBackend)  # the marker deselects these tests otherwise
    return embedded_backend


@pytest.mark.native_runtime
def test_the_prompt_is_llama_cpp_pythons_chatml():
    from llama_cpp import llama_chat_format

    for messages in (MESSAGES, MESSAGES[1:], [*MESSAGES, {"role": "assistant", "content": ""}]):
        assert chatml_prompt(messages) == llama_chat_format.format_chatml(messages=messages).prompt


def test_answers_and_results_name_the_runtime(tmp_path, monkeypatch):
    """A response cached by one runtime is never an answer of the other, and results say which made them."""
    request = ChatRequest((ChatMessage("user", "hi"),))
    x = CachedBackend(XLlamaCppBackend(), tmp_path)
    native = CachedBackend(EmbeddedBackend(), tmp_path)
    assert x.key(request) != native.key(request)
    labels = {}
    for runtime in ("xllamacpp", "llama-cpp-python"):
        monkeypatch.setenv("TASKCOND_EMBEDDED_RUNTIME", runtime)
        labels[runtime] = llm_fields("embedded")["llm"]
    models = "embedded:generation=qwen2.5-coder-0.5b,generalization=qwen2.5-coder-1.5b"
    assert labels["xllamacpp"].startswith(f"{models}@xllamacpp-")
    assert labels["llama-cpp-python"].startswith(f"{models}@llama-cpp-python")
    monkeypatch.setenv("TASKCOND_EMBEDDED_RUNTIME", "llama")
    with pytest.raises(
        LLMError, match="unknown embedded runtime 'llama'; valid: llama-cpp-python, xllamacpp"
    ):
        llm_fields("embedded")


def test_a_missing_libgomp_is_one_line_saying_what_to_install(tmp_path):
    """A libgomp.so.1 that cannot be loaded (here an empty file found first) ends the CLI with one line."""
    (tmp_path / "libgomp.so.1").write_bytes(b"")
    env = {**os.environ, "LD_LIBRARY_PATH": str(tmp_path), "TASKCOND_EMBEDDED_RUNTIME": "xllamacpp"}
    cmd = [sys.executable, "-m", "taskcond.cli", "conditions", "grasp bowl", "--no-cache"]
    done = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=120)
    assert done.returncode != 0
    assert done.stderr.strip() == f"error: [embedded] {LIBGOMP_HINT}"


def _listening_tcp_inodes() -> set[str]:
    inodes = set()
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        for line in Path(table).read_text().splitlines()[1:]:
            fields = line.split()
            if fields[3] == "0A":  # LISTEN
                inodes.add(fields[9])
    return inodes


@pytest.mark.llm
@pytest.mark.xllamacpp_runtime
def test_the_listener_is_a_private_unix_socket_that_wants_the_key(xbackend):
    own = set()
    for fd in os.listdir("/proc/self/fd"):
        with contextlib.suppress(OSError):  # the directory's own descriptor is gone
            own.add(os.readlink(f"/proc/self/fd/{fd}"))
    sockets = {s.removeprefix("socket:[").rstrip("]") for s in own if s.startswith("socket:[")}
    assert not sockets & _listening_tcp_inodes(), "no TCP port is listened on"
    assert os.stat(os.path.dirname(xbackend._socket)).st_mode & 0o777 == 0o700
    for key, status in ((None, 401), ("wrong", 401), (xbackend._key, 200)):
        conn = http.client.HTTPConnection("localhost")
        conn.sock = socket.socket(socket.AF_UNIX)
        conn.sock.connect(xbackend._socket)
        headers = {"Authorization": f"Bearer {key}"} if key else {}
        conn.request("POST", "/tokenize", body='{"content": "hi"}', headers=headers)
        assert conn.getresponse().status == status
        conn.close()


@pytest.mark.llm
@pytest.mark.xllamacpp_runtime
def test_drafts_keep_the_greedy_answer(xbackend):
    """n-gram drafts change how many evaluations an answer takes, not the answer: a generation prompt,
    whose answer the repeated own example shows, is mostly accepted from drafts, and a server without
    drafts (a second one: llama.cpp sets speculation when it starts) gives the same answer."""
    messages = ConditionGenerator(xbackend).messages("code", parse_task("move bowl into top drawer"))
    request = ChatRequest(messages, stop=("\n\n",))
    xbackend.forget()
    accepted = xbackend.accepted
    with_drafts = xbackend.chat(request)
    assert xbackend.accepted - accepted >= with_drafts.completion_tokens // 2
    plain = XLlamaCppBackend(draft=False)
    assert plain.chat(request).text == with_drafts.text
    assert plain.accepted == 0


@pytest.mark.llm
@pytest.mark.xllamacpp_runtime
def test_a_grammar_constrains_the_answer_and_a_bad_one_is_one_line(xbackend):
    request = ChatRequest(
        (ChatMessage("user", "Is the sky blue?"),), Sampling(max_tokens=4), grammar='root ::= "yes" | "no"'
    )
    assert xbackend.chat(request).text in ("yes", "no")
    bad = ChatRequest(request.messages, request.sampling, grammar="root ::= (")
    with pytest.raises(LLMError, match="invalid GBNF grammar") as info:
        xbackend.chat(bad)
    assert "\n" not in str(info.value)
