"""The embedded backend: llama.cpp (``llama-cpp-python``) running a GGUF model that PyPI packages ship.

Offline: nothing is downloaded at run time. The model is loaded lazily on the first request that misses
the response cache, so fully cached runs never pay the load. Shared prompt prefixes are reused: the backend
keeps a few llama.cpp contexts over the one memory-mapped model, and sends each request to the context
whose last prompt shares the longest prefix with it, so the two chats of the condition generator (each
with its long job-vocabulary-examples prefix) never evict each other and a new task name only evaluates
its own few tokens. With a prefix directory, the evaluated prefix a request marks as shared
(:attr:`~taskcond.llm.base.ChatRequest.shared_messages`) is also kept on disk as a llama.cpp state, so a
new process starts from it instead of evaluating hundreds of tokens again. Answers are constrained by a
GBNF grammar when the request carries one.

A prompt is always evaluated in the same pieces, whatever was evaluated before it: its tokens are cut
into segments before every message but an answer (a user turn and its answer are one segment) and after every
token that ends a blank line (an example of a one-message prompt), and each segment is evaluated on its
own, in batches of :data:`BATCH`.
llama.cpp's results depend slightly on how a prompt is split into batches; with this split, a prefix kept
in memory or on disk holds exactly what evaluating the whole prompt would, so an answer never depends on
the requests before it, and a reused prefix ends at any message or example rather than at a multiple of
the batch size.

Greedy answers without a grammar are decoded with drafts looked up in the prompt (prompt-lookup decoding,
Saxena 2023; speculative decoding, Leviathan et al. 2023): the continuation of the prompt's longest earlier
match of the answer's last tokens is proposed and checked in one batch, and every proposed token the model
would have chosen is kept. A condition the examples already show (generation) is copied nearly whole
this way, in a few batches instead of one evaluation per token. The answer is the greedy one, up to the
floating-point differences between evaluating a token in a batch or alone, which can tip a near tie (in
a free reasoning line more often than in a condition copied from an example; BENCHMARKS.md, Speed). Drafts
depend only on the prompt and the answer so far, so an answer is still a function of its prompt.
"""

from __future__ import annotations

import contextlib
import ctypes
import hashlib
import itertools
import json
import os
import tempfile
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from taskcond.llm.base import ChatRequest, ChatResponse, LLMError, cpu_count
from taskcond.llm.models import DEFAULT_EMBEDDED_MODEL, get_embedded_model, model_path

CONTEXTS = 2
"""llama.cpp contexts kept (one per concurrent conversation; the weights are shared through mmap)."""
BATCH = 64
"""Tokens per llama.cpp batch of a prompt segment (the batch size that was measured: BENCHMARKS.md, Speed)."""
PREFIX_CACHE_BYTES = 1 << 30
"""Most bytes of prefix states kept on disk; the least recently used ones go first (a state holds one
chat's evaluated prefix; sizes in BENCHMARKS.md, Speed)."""
DRAFT_MAX = 48
"""Most tokens proposed in one draft: a longer draft the model rejects early costs more than it saves (costs
of a batch against single tokens in BENCHMARKS.md, Speed)."""
DRAFT_MIN_MATCH = 3
"""Fewest tokens the answer's end must share with an earlier place in the prompt before that place's
continuation is proposed; a draft is twice as long as the match, at least 4 tokens, at most
:data:`DRAFT_MAX`."""
STATE_FORMAT = 1
"""Version of a prefix state file (the SHA-256 of a llama.cpp state, then the state), part of its key."""


def _common_prefix_length(a: Sequence[object], b: Sequence[object]) -> int:
    """Length of the longest common prefix of two strings or token lists."""
    n = min(len(a), len(b))
    for i in range(n):
        if a[i] != b[i]:
            return i
    return n


def segment_starts(
    tokens: Sequence[int], im_start: int, user: int, ends_blank_line: Callable[[int], bool]
) -> list[int]:
    """Where a ChatML prompt's segments start: 0, before every ``<|im_start|>`` (token ``im_start``) but one
    that follows a user message (a user turn and the answer to it are one segment; ``user`` is the token of
    the role name), after every token ending a blank line. Each position depends only on the tokens up to
    it, so two prompts with a common prefix are cut alike within it."""
    starts = [0]
    after_user = False
    for i in range(1, len(tokens)):
        if (tokens[i] == im_start and not after_user) or ends_blank_line(tokens[i - 1]):
            starts.append(i)
        if tokens[i - 1] == im_start:
            after_user = tokens[i] == user
    return starts


def read_state(path: Path) -> bytes | None:
    """The llama.cpp state kept in ``path`` by :func:`write_state` (its SHA-256, 32 bytes, then the
    state), or ``None`` when there is none. A file cut short or damaged is deleted and never handed to
    llama.cpp (whose restore can abort the process on a damaged state): the prefix is evaluated again."""
    try:
        blob = path.read_bytes()
    except OSError:
        return None
    digest, data = blob[:32], blob[32:]
    if hashlib.sha256(data).digest() != digest:
        path.unlink(missing_ok=True)
        return None
    return data


def write_state(path: Path, data: bytes | memoryview) -> bool:
    """Keep ``data`` (a llama.cpp state) in ``path`` behind its SHA-256, written whole or not at all;
    ``False`` when the directory cannot be written (full, read-only): the states only save time."""
    tmp = None
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=".tmp")
        with os.fdopen(fd, "wb") as fh:
            fh.write(hashlib.sha256(data).digest())
            fh.write(data)
        os.replace(tmp, path)
    except OSError:
        if tmp is not None:
            Path(tmp).unlink(missing_ok=True)
        return False
    return True


def prune_states(directory: Path, pattern: str, most_bytes: int, keep: Path) -> None:
    """Delete the least recently used files matching ``pattern`` in ``directory`` beyond ``most_bytes``
    bytes (by modification time; ``keep``, just written, stays). Another process may prune at the same
    time: a file already gone is skipped."""
    stats = []
    for state in directory.glob(pattern):
        with contextlib.suppress(OSError):
            stats.append((state.stat(), state))
    total = 0
    for st, state in sorted(stats, key=lambda entry: entry[0].st_mtime, reverse=True):
        total += st.st_size
        if total > most_bytes and state != keep:
            state.unlink(missing_ok=True)


def amx_built_in(llama_cpp: Any) -> bool:
    """Whether the installed llama.cpp was compiled with AMX matrix kernels (a native build on an Intel
    CPU with AMX, e.g. Sapphire Rapids)."""
    return b"AMX_INT8 = 1" in llama_cpp.llama_print_system_info()


@contextlib.contextmanager
def _without_amx(llama_cpp: Any):
    """Load models without llama.cpp's extra weight buffers when its AMX kernels are built in.

    llama.cpp repacks the weights into an AMX buffer on such a build, and the first evaluation then
    crashes the process with a segmentation fault on some machines (this project's among them; upstream
    ggml-org/llama.cpp#20824, open). ``use_extra_bufts = False`` keeps the weights in ordinary CPU buffers.
    llama-cpp-python builds its model parameters inside ``Llama.__init__`` from
    ``llama_model_default_params``, so that function is wrapped for the duration of the load. ``make
    install`` builds llama.cpp without AMX in the first place (Makefile, ``NO_AMX``)."""
    if not amx_built_in(llama_cpp):
        yield
        return
    module = llama_cpp.llama_cpp
    default = module.llama_model_default_params

    def params():
        p = default()
        p.use_extra_bufts = False
        return p

    module.llama_model_default_params = params
    try:
        yield
    finally:
        module.llama_model_default_params = default


class EmbeddedBackend:
    """llama.cpp in-process. ``model`` is a name of :data:`taskcond.llm.models.EMBEDDED_MODELS`.

    Attributes:
        draft: decode greedy answers without a grammar with drafts looked up in the prompt (the same
            answer in fewer model evaluations); ``drafted`` and ``accepted`` count the tokens proposed and
            kept.
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
        self.n_ctx = n_ctx
        self.n_threads = n_threads or cpu_count()
        self.prefix_dir = Path(prefix_dir) if prefix_dir is not None else None
        self.prefix_bytes = prefix_bytes
        self.prefix_hits = 0
        self.draft = draft
        self.drafted = self.accepted = 0
        self._contexts: list[Any] = []
        self._last_prompt: list[str] = []
        self._evaluated: list[int] = []
        self._grammars: dict[str, Any] = {}
        self._breaks: dict[int, bool] = {}
        self._im_start = self._user = -1
        self.load_seconds = 0.0

    def _load(self) -> list[Any]:
        if self._contexts:
            return self._contexts
        try:
            import llama_cpp
        except ImportError:
            raise LLMError(
                "llama-cpp-python is missing; install it with pip install 'taskcond[embedded-native]' (or "
                "use the default runtime: unset TASKCOND_EMBEDDED_RUNTIME)",
                backend=self.name,
            ) from None
        path = model_path(self.spec)
        start = time.perf_counter()
        with _without_amx(llama_cpp):
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
        self._evaluated = [0] * CONTEXTS
        self._lru = list(range(CONTEXTS))
        first = self._contexts[0]
        self._im_start = first.tokenize(b"<|im_start|>", add_bos=False, special=True)[0]
        self._user = first.tokenize(b"user", add_bos=False, special=False)[0]
        self.load_seconds = time.perf_counter() - start
        return self._contexts

    def forget(self) -> None:
        """Drop every evaluated prompt from memory (the prefix states on disk stay)."""
        for k, llm in enumerate(self._contexts):
            llm.reset()
            self._last_prompt[k] = ""
            self._evaluated[k] = 0

    def _context_for(self, prompt: str) -> int:
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
        return best

    def _grammar(self, text: str) -> Any:
        if text not in self._grammars:
            import llama_cpp

            try:
                self._grammars[text] = llama_cpp.LlamaGrammar.from_string(text, verbose=False)
            except ValueError as exc:
                raise LLMError(f"invalid GBNF grammar: {exc}", backend=self.name) from None
        return self._grammars[text]

    def _tokens(self, llm: Any, messages: list[dict[str, str]]) -> list[int]:
        """The prompt's tokens, as llama-cpp-python's chat completion makes them (ChatML)."""
        from llama_cpp import llama_chat_format

        formatted = llama_chat_format.format_chatml(messages=messages)
        return llm.tokenize(
            formatted.prompt.encode("utf-8"), add_bos=not formatted.added_special, special=True
        )

    def _ends_blank_line(self, llm: Any, token: int) -> bool:
        if token not in self._breaks:
            self._breaks[token] = b"\n\n" in llm.detokenize([token], special=True)
        return self._breaks[token]

    def segment_starts(self, llm: Any, tokens: Sequence[int]) -> list[int]:
        """Where the prompt's segments start (:func:`segment_starts`)."""
        return segment_starts(tokens, self._im_start, self._user, lambda t: self._ends_blank_line(llm, t))

    def _prepare(self, slot: int, tokens: list[int], starts: list[int], shared_messages: int) -> None:
        """Evaluate every segment of the prompt but the last (which the chat completion evaluates), from
        the longest prefix the context holds or, for a shared prefix, the prefix directory holds."""
        llm = self._contexts[slot]
        held = min(self._evaluated[slot], llm.n_tokens)
        same = _common_prefix_length(llm.input_ids[:held].tolist(), tokens)
        last = starts[-1]
        reuse = max(s for s in starts if s <= min(same, last))
        message_starts = [i for i, t in enumerate(tokens) if t == self._im_start]
        hint = message_starts[shared_messages] if 0 < shared_messages < len(message_starts) else 0
        hint = hint if 0 < hint <= last and self.prefix_dir is not None else 0
        if reuse < hint:
            if self._read_state(llm, tokens[:hint]):
                reuse = hint
                self.prefix_hits += 1
            else:  # a state llama.cpp refused leaves the context empty
                reuse = min(reuse, llm.n_tokens)
        llm.n_tokens = reuse
        for a, b in itertools.pairwise(starts):
            if a >= reuse:
                llm.eval(tokens[a:b])
                if b == hint:
                    self._write_state(llm, tokens[:hint])
        # the last segment is evaluated by the caller, in one piece too; what it generates is not kept
        self._evaluated[slot] = len(tokens)

    def _state_path(self, tokens: Sequence[int]) -> Path:
        import llama_cpp

        assert self.prefix_dir is not None
        meta = {
            "format": STATE_FORMAT,
            "model": self.spec.sha256,
            "llama_cpp": llama_cpp.__version__,
            "n_ctx": self.n_ctx,
            "n_batch": BATCH,
            "n_threads": self.n_threads,
        }
        digest = hashlib.sha256(json.dumps(meta, sort_keys=True).encode())
        digest.update(json.dumps(list(tokens)).encode())
        return self.prefix_dir / f"{digest.hexdigest()}.state"

    def _read_state(self, llm: Any, tokens: Sequence[int]) -> bool:
        """Load the state of exactly ``tokens`` evaluated, if the prefix directory has it. A state that
        llama.cpp refuses empties the context (``n_tokens`` 0)."""
        import llama_cpp

        path = self._state_path(tokens)
        data = read_state(path)
        if data is None:
            return False
        buf = (ctypes.c_uint8 * len(data)).from_buffer_copy(data)
        if llama_cpp.llama_state_set_data(llm._ctx.ctx, buf, len(data)) != len(data):
            llm.reset()
            llm._ctx.kv_cache_clear()
            path.unlink(missing_ok=True)
            return False
        llm.input_ids[: len(tokens)] = tokens
        llm.n_tokens = len(tokens)
        with contextlib.suppress(OSError):  # another process may have just dropped it
            os.utime(path)
        return True

    def _write_state(self, llm: Any, tokens: Sequence[int]) -> None:
        """Keep the context's state (``tokens`` evaluated) in the prefix directory, then drop the least
        recently used states beyond :attr:`prefix_bytes`. The states only save time: a directory that
        cannot be written (full, read-only) or that another process prunes at the same time keeps none."""
        import llama_cpp

        path = self._state_path(tokens)
        if path.exists():
            return
        size = llama_cpp.llama_state_get_size(llm._ctx.ctx)
        buf = (ctypes.c_uint8 * size)()
        n = llama_cpp.llama_state_get_data(llm._ctx.ctx, buf, size)
        if not write_state(path, memoryview(buf)[:n]):
            return
        prune_states(path.parent, "*.state", self.prefix_bytes, keep=path)

    def _decode(self, llm: Any, batch: list[int], logits_from: int) -> list[int]:
        """Evaluate ``batch`` after the context's tokens and return the greedy choice after each of its
        tokens from index ``logits_from`` on."""
        import llama_cpp
        import numpy as np

        llm._ctx.kv_cache_seq_rm(-1, llm.n_tokens, -1)
        llm._batch.set_batch(batch=batch, n_past=llm.n_tokens, logits_all=False)
        for i in range(logits_from, len(batch)):
            llm._batch.batch.logits[i] = True
        llm._ctx.decode(llm._batch)
        llm.input_ids[llm.n_tokens : llm.n_tokens + len(batch)] = batch
        llm.n_tokens += len(batch)
        n_vocab = llm.n_vocab()
        return [
            int(np.argmax(np.ctypeslib.as_array(llama_cpp.llama_get_logits_ith(llm._ctx.ctx, i), (n_vocab,))))
            for i in range(logits_from, len(batch))
        ]

    @staticmethod
    def lookup(tokens: Sequence[int], starts: dict[tuple[int, ...], list[int]]) -> list[int]:
        """The draft after ``tokens``: the continuation of the earlier place that shares the longest
        suffix with them (at least :data:`DRAFT_MIN_MATCH` tokens; the latest of equals), twice as long as
        that match, at least 4 and at most :data:`DRAFT_MAX` tokens; ``[]`` without such a place.
        ``starts`` maps every :data:`DRAFT_MIN_MATCH`-gram to the positions after its occurrences."""
        n = len(tokens)
        best, where = 0, -1
        for end in starts.get(tuple(tokens[n - DRAFT_MIN_MATCH :]), ()):
            if end >= n:
                continue
            length = DRAFT_MIN_MATCH
            while length < end and tokens[end - length - 1] == tokens[n - length - 1]:
                length += 1
            if length >= best:
                best, where = length, end
        if where < 0:
            return []
        return list(tokens[where : where + min(DRAFT_MAX, max(4, 2 * best))])

    def _greedy(self, llm: Any, tokens: list[int], last: int, request: ChatRequest) -> tuple[str, int]:
        """Greedy decoding with drafts from the prompt (:meth:`lookup`): the last segment of the prompt
        (from ``last``) is evaluated in batches of :data:`BATCH` as a whole prompt would be, then each
        step proposes a draft after the token just chosen, evaluates both in one batch and keeps the
        draft's tokens up to the first one the model would not have chosen, plus the model's own choice
        there. Stops as llama-cpp-python's completion does: at an end-of-generation token, a stop string
        (cut off) or ``max_tokens``. Returns the answer and how many tokens it took."""
        import llama_cpp

        vocab = llm._model.vocab
        k = DRAFT_MIN_MATCH
        seq = list(tokens)
        starts: dict[tuple[int, ...], list[int]] = {}
        for i in range(k, len(seq) + 1):
            starts.setdefault(tuple(seq[i - k : i]), []).append(i)
        for a in range(last, len(tokens), BATCH):
            choice = self._decode(llm, tokens[a : a + BATCH], min(BATCH, len(tokens) - a) - 1)
        answer: list[int] = []
        stops = [s.encode("utf-8") for s in request.stop]
        text = b""
        queue = choice[-1:]  # tokens chosen, the last of them not evaluated yet
        while True:
            for token in queue:
                if llama_cpp.llama_vocab_is_eog(vocab, token):
                    return text.decode("utf-8", errors="ignore"), len(answer)
                answer.append(token)
                seq.append(token)
                starts.setdefault(tuple(seq[-k:]), []).append(len(seq))
                text = llm.detokenize(answer, prev_tokens=tokens)
                cut = [text.index(s) for s in stops if s in text]
                if cut:
                    return text[: min(cut)].decode("utf-8", errors="ignore"), len(answer)
                if len(answer) >= request.sampling.max_tokens or llm.n_tokens >= llm.n_ctx():
                    return text.decode("utf-8", errors="ignore"), len(answer)  # or the context is full
            room = min(BATCH - 1, llm.n_ctx() - llm.n_tokens - 1)
            draft = self.lookup(seq, starts)[:room] if self.draft else []
            choice = self._decode(llm, [answer[-1], *draft], 0)
            kept = 0
            while kept < len(draft) and choice[kept] == draft[kept]:
                kept += 1
            self.drafted += len(draft)
            self.accepted += kept
            llm.n_tokens -= len(draft) - kept
            queue = [*draft[:kept], choice[kept]]

    def chat(self, request: ChatRequest) -> ChatResponse:
        slot = self._context_for("\n".join(m.content for m in request.messages))
        llm = self._contexts[slot]
        messages = [{"role": m.role, "content": m.content} for m in request.messages]
        start = time.perf_counter()
        s = request.sampling
        if self.spec.chat_format == "chatml":  # the only prompt format of the shipped models
            tokens = self._tokens(llm, messages)
            starts = self.segment_starts(llm, tokens)
            self._prepare(slot, tokens, starts, request.shared_messages)
            if s.temperature == 0 and not request.grammar:
                text, n = self._greedy(llm, tokens, starts[-1], request)
                return ChatResponse(
                    text=text,
                    prompt_tokens=len(tokens),
                    completion_tokens=n,
                    seconds=time.perf_counter() - start,
                )
        else:
            llm.n_tokens = 0
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
