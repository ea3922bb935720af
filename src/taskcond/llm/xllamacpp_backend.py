"""The embedded backend on a prebuilt llama.cpp: ``xllamacpp`` (Xorbits' binary wheel of llama.cpp's server).

Same model, same prompts, same cache behaviour as :class:`~taskcond.llm.embedded.EmbeddedBackend`
(``llama-cpp-python``, which compiles llama.cpp on install), but nothing to compile. xllamacpp embeds
llama.cpp's server: requests go to it in-process (``Server.handle_completions``); the few calls the Python
API lacks (tokenize, slot save and restore) go over its HTTP listener, which here is a Unix socket in a
directory only this user can enter (mode 0700), never a TCP port, and which refuses requests without a
random key made for this process (:meth:`XLlamaCppBackend._load`).

Prompts are the ChatML text llama-cpp-python's ``chatml`` format makes (:func:`chatml_prompt`), and they
are evaluated in the same segments as the native backend's (:func:`~taskcond.llm.embedded.segment_starts`):
each segment is a completion request for the prompt up to the segment's end with ``n_predict = 0``, on a
slot the server holds exactly the prompt's earlier segments in, so an answer does not depend on the
requests before it. The server's prompt cache keeps a slot's evaluated tokens between requests (two slots,
one per conversation, as the native backend's two contexts); llama.cpp's slot save and restore keep the
shared prefix of a request on disk for the next process (the native backend's prefix states). Greedy
answers without a grammar are decoded with llama.cpp's n-gram speculation on the prompt and the answer so
far (``ngram-mod``: a hashed map from the last :data:`DRAFT_MATCH` tokens to the next, drafting
:data:`DRAFT_MIN` to :data:`DRAFT_MAX` tokens and fewer after drafts that were mostly rejected; the same idea
as the native backend's prompt-lookup drafts, Saxena 2023; speculative decoding, Leviathan et al. 2023);
llama.cpp drafts every request, each draft checked by that request's own sampler and grammar. Figures in
BENCHMARKS.md, "Embedded runtimes".
"""

from __future__ import annotations

import contextlib
import hashlib
import http.client
import json
import os
import secrets
import shutil
import socket
import tempfile
import time
import weakref
from collections.abc import Sequence
from importlib import metadata
from pathlib import Path
from typing import Any

from taskcond.llm.base import ChatRequest, ChatResponse, LLMError, cpu_count
from taskcond.llm.embedded import (
    BATCH,
    CONTEXTS,
    PREFIX_CACHE_BYTES,
    _common_prefix_length,
    prune_states,
    read_state,
    segment_starts,
    write_state,
)
from taskcond.llm.models import DEFAULT_EMBEDDED_MODEL, get_embedded_model, model_path

RUNTIME = "xllamacpp"
"""The runtime's name in response-cache keys and results (``embedded:MODEL@xllamacpp-VERSION``)."""
DRAFT_MATCH = 8
"""Tokens an n-gram draft's key matches: a long key drafts where an answer copies its prompt (a generation
answer repeats its own example) and seldom on new text (a chain of thought), where a rejected draft costs
a batch evaluation."""
DRAFT_MIN, DRAFT_MAX = 4, 16
"""Fewest and most tokens one draft proposes; a draft and the token before it fit one batch
(:data:`~taskcond.llm.embedded.BATCH`). Chosen by measurement against ``ngram-simple`` with drafts of 48
(BENCHMARKS.md, "Embedded runtimes")."""
LIBGOMP_HINT = (
    "xllamacpp needs the system library libgomp.so.1 (GNU OpenMP); install it with "
    "'apt-get install libgomp1' (Debian, Ubuntu) or 'dnf install libgomp' (Fedora, RHEL)"
)


def runtime_version() -> str | None:
    """The installed xllamacpp's version, or None when it is not installed."""
    try:
        return metadata.version("xllamacpp")
    except metadata.PackageNotFoundError:
        return None


def chatml_prompt(messages: Sequence[dict[str, str]]) -> str:
    """The ChatML prompt of ``messages`` exactly as llama-cpp-python's ``chatml`` chat format writes it
    (``llama_chat_format.format_chatml``): the first system message (an empty one when there is none), then
    every user and assistant message, then the opened assistant turn."""
    system = next((m["content"] for m in messages if m["role"] == "system"), "")
    text = f"<|im_start|>system\n{system}<|im_end|>\n"
    for m in messages:
        if m["role"] in ("user", "assistant"):
            head = f"<|im_start|>{m['role']}\n"
            text += f"{head}{m['content']}<|im_end|>\n" if m["content"] else head
    return text + "<|im_start|>assistant\n"


class _UnixHTTPConnection(http.client.HTTPConnection):
    """An HTTP connection over a Unix socket."""

    def __init__(self, path: str, timeout: float) -> None:
        super().__init__("localhost", timeout=timeout)
        self.socket_path = path

    def connect(self) -> None:
        self.sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        self.sock.settimeout(self.timeout)
        self.sock.connect(self.socket_path)


def load_xllamacpp() -> Any:
    """Import xllamacpp, or raise a one-line :class:`LLMError` saying what to install."""
    try:
        import xllamacpp
    except ImportError as exc:
        if "libgomp" in str(exc):
            raise LLMError(LIBGOMP_HINT, backend="embedded") from None
        raise LLMError(
            "the embedded runtime xllamacpp is missing; install it with pip install 'taskcond[embedded]'",
            backend="embedded",
        ) from None
    return xllamacpp


class XLlamaCppBackend:
    """llama.cpp's server in-process, through xllamacpp. ``model`` is a name of
    :data:`taskcond.llm.models.EMBEDDED_MODELS`.

    Attributes:
        draft: decode with n-gram drafts from the prompt and the answer (set when the server starts: llama.cpp
            applies its speculation to every request, checked by the request's own sampler, grammar
            included); ``drafted`` and ``accepted`` count the tokens proposed and kept.
        prefix_dir: directory of the on-disk prefix states (``None``: none are kept), at most
            ``prefix_bytes`` bytes of them.
        prefix_hits: how many requests started from a prefix state read from disk.
    """

    name = "embedded"

    def __init__(
        self,
        model: str = DEFAULT_EMBEDDED_MODEL,
        n_ctx: int = 4096,
        n_threads: int | None = None,
        prefix_dir: Path | None = None,
        prefix_bytes: int = PREFIX_CACHE_BYTES,
        draft: bool = True,
    ):
        self.spec = get_embedded_model(model)
        self.model = model
        self.runtime = f"{RUNTIME}-{runtime_version()}"
        self.n_ctx = n_ctx
        self.n_threads = n_threads or cpu_count()
        self.prefix_dir = Path(prefix_dir) if prefix_dir is not None else None
        self.prefix_bytes = prefix_bytes
        self.prefix_hits = 0
        self.draft = draft
        self.drafted = self.accepted = 0
        self.load_seconds = 0.0
        self._server: Any = None
        self._socket = ""
        self._key = ""
        self._saves: Path | None = None
        self._last_prompt = [""] * CONTEXTS
        self._held: list[list[int]] = [[] for _ in range(CONTEXTS)]
        self._exact = [True] * CONTEXTS
        self._lru = list(range(CONTEXTS))
        self._breaks: dict[int, bool] = {}
        self._im_start = self._user = -1

    # -- the server --------------------------------------------------------------------------------------

    def _load(self) -> Any:
        """Start the server on the model (once). Its listener is a Unix socket in a fresh directory of mode
        0700 (no TCP port: nothing outside this machine, and no other user on it, can connect) and it
        refuses every request but ``/health`` and ``/models`` without this process's random key."""
        if self._server is not None:
            return self._server
        xllamacpp = load_xllamacpp()
        path = model_path(self.spec)
        start = time.perf_counter()
        private = tempfile.mkdtemp(prefix="taskcond-llm-")  # mode 0700
        self._saves = Path(private) / "slots"
        self._saves.mkdir()
        self._socket = os.path.join(private, "server.sock")
        self._key = secrets.token_urlsafe(32)
        p = xllamacpp.CommonParams()
        p.model.path = str(path)
        p.n_parallel = CONTEXTS
        p.n_ctx = self.n_ctx * CONTEXTS  # each slot gets n_ctx
        p.n_batch = p.n_ubatch = BATCH
        p.cpuparams.n_threads = p.cpuparams_batch.n_threads = self.n_threads
        p.hostnames = [self._socket]
        p.api_keys = [self._key]
        p.cache_prompt = True
        p.cache_ram_mib = 0  # no host prompt cache: a slot holds exactly what this backend sent it
        p.n_cache_reuse = 0
        p.slot_save_path = f"{self._saves}{os.sep}"  # the server appends the file name as it is
        p.ui = False
        p.warmup = False
        p.verbosity = -1
        if self.draft:
            sp = p.speculative
            sp.types = [xllamacpp.common_speculative_type.COMMON_SPECULATIVE_TYPE_NGRAM_MOD]
            sp.ngram_mod.n_match = DRAFT_MATCH
            sp.ngram_mod.n_min = DRAFT_MIN
            sp.ngram_mod.n_max = DRAFT_MAX
        try:
            self._server = xllamacpp.Server(p)
        except Exception as exc:
            shutil.rmtree(private, ignore_errors=True)
            raise LLMError(f"xllamacpp could not load {path}: {exc}", backend=self.name) from None
        weakref.finalize(self, shutil.rmtree, private, True)
        tokens = self._tokenize("<|im_start|>user")
        self._im_start, self._user = tokens[0][0], tokens[1][0]
        self.load_seconds = time.perf_counter() - start
        return self._server

    def _http(self, method: str, path: str, body: dict | None = None) -> dict:
        """One request to the server's listener, with the key."""
        conn = _UnixHTTPConnection(self._socket, timeout=600)
        try:
            conn.request(
                method,
                path,
                body=json.dumps(body or {}),
                headers={"Authorization": f"Bearer {self._key}", "Content-Type": "application/json"},
            )
            response = conn.getresponse()
            data = json.loads(response.read() or b"{}")
        finally:
            conn.close()
        if response.status != 200:
            message = data.get("error", {}).get("message", data) if isinstance(data, dict) else data
            raise LLMError(f"xllamacpp {path} answered HTTP {response.status}: {message}", self.name)
        return data

    def _tokenize(self, text: str) -> list[tuple[int, str]]:
        """Tokens of ``text`` with special tokens parsed, each with its text."""
        out = self._http("POST", "/tokenize", {"content": text, "parse_special": True, "with_pieces": True})
        return [(t["id"], t["piece"] if isinstance(t["piece"], str) else "") for t in out["tokens"]]

    def _complete(self, body: dict) -> dict:
        out = self._server.handle_completions({**body, "cache_prompt": True})
        if "choices" not in out:
            error = out.get("error", out)
            message = error.get("message", error) if isinstance(error, dict) else error
            if "grammar" in str(message).lower():
                raise LLMError(f"invalid GBNF grammar: {message}", backend=self.name)
            raise LLMError(f"xllamacpp failed: {message}", backend=self.name)
        return out

    def forget(self) -> None:
        """Drop every evaluated prompt from the server's slots (the prefix states on disk stay)."""
        if self._server is None:
            return
        for slot in range(CONTEXTS):
            self._http("POST", f"/slots/{slot}?action=erase")
            self._held[slot] = []
            self._exact[slot] = True
            self._last_prompt[slot] = ""

    # -- prompts -----------------------------------------------------------------------------------------

    def _slot_for(self, prompt: str) -> int:
        """The slot whose previous prompt shares the longest prefix with ``prompt``; when none shares at
        least half of it, the least recently used slot (the native backend's rule for its contexts)."""
        shared = [_common_prefix_length(prompt, last) for last in self._last_prompt]
        best = max(range(CONTEXTS), key=shared.__getitem__)
        if shared[best] < len(prompt) // 2:
            best = self._lru[0]
        self._lru.remove(best)
        self._lru.append(best)
        self._last_prompt[best] = prompt
        return best

    def _evaluate(self, slot: int, tokens: list[int]) -> None:
        """Have the slot evaluate ``tokens`` after what it holds (a request that generates nothing)."""
        self._complete({"prompt": tokens, "n_predict": 0, "temperature": 0, "id_slot": slot})
        self._held[slot] = list(tokens)
        self._exact[slot] = True

    def _state_name(self, tokens: Sequence[int]) -> str:
        meta = {
            "runtime": self.runtime,
            "model": self.spec.sha256,
            "n_ctx": self.n_ctx,
            "n_batch": BATCH,
            "n_threads": self.n_threads,
        }
        digest = hashlib.sha256(json.dumps(meta, sort_keys=True).encode())
        digest.update(json.dumps(list(tokens)).encode())
        return f"{digest.hexdigest()}.state"

    def _restore(self, slot: int, tokens: list[int]) -> bool:
        """Load the state of exactly ``tokens`` evaluated into the slot, if the prefix directory has it."""
        assert self.prefix_dir is not None and self._saves is not None
        name = self._state_name(tokens)
        stored = self.prefix_dir / name
        state = read_state(stored)
        if state is None:
            return False
        local = self._saves / name
        try:
            local.write_bytes(state)
            out = self._http("POST", f"/slots/{slot}?action=restore", {"filename": name})
        except (OSError, LLMError):
            out = {}
        finally:
            local.unlink(missing_ok=True)
        if out.get("n_restored") != len(tokens):  # damaged or cut short: evaluate the prefix again
            stored.unlink(missing_ok=True)
            self._http("POST", f"/slots/{slot}?action=erase")
            self._held[slot] = []
            self._exact[slot] = True
            return False
        self._held[slot] = list(tokens)
        self._exact[slot] = True
        with contextlib.suppress(OSError):  # another process may have just dropped it
            os.utime(stored)
        return True

    def _save(self, slot: int, tokens: list[int]) -> None:
        """Keep the slot's state (``tokens`` evaluated) in the prefix directory, within
        :attr:`prefix_bytes`. A directory that cannot be written only costs time."""
        assert self.prefix_dir is not None and self._saves is not None
        name = self._state_name(tokens)
        target = self.prefix_dir / name
        if target.exists():
            return
        local = self._saves / name
        try:
            self._http("POST", f"/slots/{slot}?action=save", {"filename": name})
            state = local.read_bytes()
        except (OSError, LLMError):
            return
        finally:
            local.unlink(missing_ok=True)
        if not write_state(target, state):
            return
        prune_states(self.prefix_dir, "*.state", self.prefix_bytes, keep=target)

    def _prepare(self, slot: int, tokens: list[int], starts: list[int], shared_messages: int) -> None:
        """Have the slot hold every segment of the prompt but the last, evaluated segment by segment from
        the longest segment-aligned prefix it holds or, for a shared prefix, the prefix directory holds;
        the last segment is evaluated by the request that answers."""
        held = self._held[slot]
        last = starts[-1]
        same = _common_prefix_length(held, tokens)
        reuse = max(s for s in starts if s <= min(same, last))
        message_starts = [i for i, t in enumerate(tokens) if t == self._im_start]
        hint = message_starts[shared_messages] if 0 < shared_messages < len(message_starts) else 0
        hint = hint if 0 < hint <= last and self.prefix_dir is not None else 0
        if reuse < hint:
            if self._restore(slot, tokens[:hint]):
                reuse = hint
                self.prefix_hits += 1
            elif not self._held[slot]:  # a state the server refused empties the slot
                reuse = 0
        if reuse < len(self._held[slot]) or not self._exact[slot]:
            # the slot must hold tokens[:reuse] and nothing after it, else the server would reuse more
            # than the segments: one other token after them cuts its prefix there
            if reuse == 0:
                self._http("POST", f"/slots/{slot}?action=erase")
            else:
                other = self._user if tokens[reuse] == self._im_start else self._im_start
                self._evaluate(slot, [*tokens[:reuse], other])
            self._held[slot] = tokens[:reuse]
            self._exact[slot] = reuse == 0  # the other token is still held
        for b in starts[1:]:
            if reuse < b <= last:
                self._evaluate(slot, tokens[:b])
                if b == hint:
                    self._save(slot, tokens[:b])

    def chat(self, request: ChatRequest) -> ChatResponse:
        self._load()
        messages = [{"role": m.role, "content": m.content} for m in request.messages]
        start = time.perf_counter()
        prompt = chatml_prompt(messages)
        slot = self._slot_for("\n".join(m.content for m in request.messages))
        pieces = self._tokenize(prompt)
        tokens = [t for t, _ in pieces]
        if len(tokens) >= self.n_ctx:
            raise LLMError(f"the prompt has {len(tokens)} tokens, the context {self.n_ctx}", self.name)
        for t, piece in pieces:
            self._breaks.setdefault(t, "\n\n" in piece)
        starts = segment_starts(tokens, self._im_start, self._user, self._breaks.__getitem__)
        self._prepare(slot, tokens, starts, request.shared_messages)
        s = request.sampling
        greedy = s.temperature == 0
        body: dict[str, Any] = {
            "prompt": tokens,
            "id_slot": slot,
            "n_predict": s.max_tokens,
            "temperature": s.temperature,
            "top_p": s.top_p,
            "top_k": 1 if greedy else 0,
            "seed": s.seed,
            "stop": list(request.stop),
        }
        if request.grammar:
            body["grammar"] = request.grammar
        out = self._complete(body)
        self._held[slot] = tokens  # and some of the answer
        self._exact[slot] = False
        usage = out.get("usage", {})
        timings = out.get("timings", {})
        self.drafted += timings.get("draft_n", 0)
        self.accepted += timings.get("draft_n_accepted", 0)
        return ChatResponse(
            text=out["choices"][0]["text"] or "",
            prompt_tokens=usage.get("prompt_tokens", len(tokens)),
            completion_tokens=usage.get("completion_tokens", 0),
            seconds=time.perf_counter() - start,
        )
