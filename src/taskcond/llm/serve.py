"""llama.cpp's OpenAI-compatible HTTP server on an embedded model, from the prebuilt xllamacpp runtime:
a real endpoint for the ``openai`` backend (the tests use it), with nothing to compile.

    python -m taskcond.llm.serve [--model qwen2.5-coder-1.5b] [--port 8000] [--api-key-env OPENAI_API_KEY]

It listens on 127.0.0.1 only and refuses every request but ``/health`` and ``/models`` without the key
held by ``--api-key-env`` (it does not start without one); then point the backend at it with
``OPENAI_BASE_URL=http://127.0.0.1:PORT/v1 taskcond ... --llm openai:MODEL`` and the same key in
``OPENAI_API_KEY``. Its chat template is the model's own (Qwen2.5's ChatML). Runs until SIGINT or SIGTERM.
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
import threading

from taskcond.llm.base import LLMError, cpu_count
from taskcond.llm.models import DEFAULT_EMBEDDED_MODEL, EMBEDDED_MODELS, get_embedded_model, model_path
from taskcond.llm.xllamacpp_backend import load_xllamacpp

HOST = "127.0.0.1"


def serve(model: str, port: int, api_key: str, n_ctx: int = 4096, threads: int | None = None) -> None:
    """Serve ``model`` on ``HOST:port`` with ``api_key`` until SIGINT or SIGTERM."""
    if not api_key:
        raise LLMError("no API key: the server never runs without one", backend="serve")
    xllamacpp = load_xllamacpp()
    p = xllamacpp.CommonParams()
    p.model.path = str(model_path(get_embedded_model(model)))
    p.model_alias = {model}
    p.hostnames = [HOST]
    p.port = port
    p.api_keys = [api_key]
    p.n_ctx = n_ctx
    p.n_parallel = 1
    p.cpuparams.n_threads = p.cpuparams_batch.n_threads = threads or cpu_count()
    p.ui = False
    p.verbosity = -1
    stop = threading.Event()
    server = xllamacpp.Server(p)
    for sig in (signal.SIGINT, signal.SIGTERM):  # the server's own handlers would not wake this thread
        signal.signal(sig, lambda *_: stop.set())
    print(f"serving {model} on {server.listening_address}/v1", flush=True)
    stop.wait()
    del server


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--model", default=DEFAULT_EMBEDDED_MODEL, choices=list(EMBEDDED_MODELS))
    parser.add_argument("--port", type=int, default=8000)
    parser.add_argument("--api-key-env", default="OPENAI_API_KEY", help="variable holding the key")
    parser.add_argument("--n-ctx", type=int, default=4096)
    parser.add_argument("--threads", type=int)
    args = parser.parse_args()
    try:
        serve(args.model, args.port, os.environ.get(args.api_key_env, ""), args.n_ctx, args.threads)
    except LLMError as exc:
        hint = f" (set {args.api_key_env})" if "API key" in str(exc) else ""
        print(f"error: {exc}{hint}", file=sys.stderr)
        sys.exit(2)


if __name__ == "__main__":
    main()
