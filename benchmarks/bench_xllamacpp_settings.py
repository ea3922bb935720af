"""xllamacpp server settings, prompt versions and models side by side: one backend per setting, version and
model in one process, uncached, alternating per condition (who goes first rotates), so that all see the
same load on a shared machine.

Reports each setting's Table II accuracy, its median seconds per condition, and how many answers equal the
first setting's; ``--tokens`` also prints, per condition of each setting, the tokens evaluated before
the answering requests (the repeated own example and the tokens that cut a slot back), the question's
tokens evaluated by the answering requests, and the tokens generated, drafted and accepted, each with the
server's milliseconds, and each setting's medians of them.

    .venv/bin/python benchmarks/bench_xllamacpp_settings.py [--settings base fa_off poll0] [--trials 1]
        [--mode generation] [--tokens] [--prompt-versions v7 v8]
        [--models qwen2.5-coder-0.5b qwen2.5-coder-1.5b]
"""

from __future__ import annotations

import argparse
import json
import statistics
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import xllamacpp

from taskcond.evaluation import score_trial
from taskcond.generator import PROMPT_VERSION, ConditionGenerator, prompt_versions
from taskcond.llm.models import DEFAULT_EMBEDDED_MODEL, EMBEDDED_MODELS
from taskcond.llm.xllamacpp_backend import XLlamaCppBackend
from taskcond.primitives import PRIMITIVES


def _set(**values: Any) -> Callable[[Any], None]:
    def apply(p: Any) -> None:
        for name, value in values.items():
            if name == "poll":  # busy-waiting of the OpenMP threads, 0-100
                p.cpuparams.poll = p.cpuparams_batch.poll = value
            else:
                setattr(p, name, value)

    return apply


SETTINGS: dict[str, Callable[[Any], None]] = {
    "base": _set(),
    "fa_off": _set(flash_attn_type=0),  # -1 (auto) turns flash attention on on the CPU
    "poll0": _set(poll=0),
    "kv_q8": _set(cache_type_k=8, cache_type_v=8),  # GGML_TYPE_Q8_0
}


@dataclass
class Requests:
    """The server's timings of one condition's requests."""

    log: list[dict] = field(default_factory=list)

    def wrap(self, backend: XLlamaCppBackend) -> None:
        complete = backend._complete

        def logged(body: dict) -> dict:
            out = complete(body)
            self.log.append({"n_predict": body.get("n_predict"), **out.get("timings", {})})
            return out

        backend._complete = logged  # type: ignore[method-assign]

    def summary(self) -> dict[str, int]:
        evals = [t for t in self.log if t["n_predict"] == 0]
        answers = [t for t in self.log if t["n_predict"] != 0]
        return {
            "evaluated": sum(t.get("prompt_n", 0) for t in evals),
            "question": sum(t.get("prompt_n", 0) for t in answers),
            "generated": sum(t.get("predicted_n", 0) for t in answers),
            "drafted": sum(t.get("draft_n", 0) for t in answers),
            "accepted": sum(t.get("draft_n_accepted", 0) for t in answers),
            "evaluated_ms": round(sum(t.get("prompt_ms", 0) for t in evals)),
            "question_ms": round(sum(t.get("prompt_ms", 0) for t in answers)),
            "generated_ms": round(sum(t.get("predicted_ms", 0) for t in answers)),
        }


def backend_with(setting: str, model: str = DEFAULT_EMBEDDED_MODEL) -> XLlamaCppBackend:
    """A started backend of ``model`` whose server was made with ``setting`` applied to its parameters."""
    real = xllamacpp.Server

    def server(p: Any) -> Any:
        SETTINGS[setting](p)
        return real(p)

    xllamacpp.Server = server
    try:
        backend = XLlamaCppBackend(model)
        backend._load()
    finally:
        xllamacpp.Server = real
    return backend


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--settings", nargs="+", choices=list(SETTINGS), default=["base", "fa_off", "poll0"])
    ap.add_argument("--trials", type=int, default=1)
    ap.add_argument("--mode", default="generation", choices=["generation", "generalization"])
    ap.add_argument("--tokens", action="store_true", help="token counts per condition")
    ap.add_argument("--prompt-versions", nargs="+", choices=prompt_versions(), default=[PROMPT_VERSION])
    ap.add_argument("--models", nargs="+", choices=list(EMBEDDED_MODELS), default=[DEFAULT_EMBEDDED_MODEL])
    args = ap.parse_args()
    axes = (args.settings, args.prompt_versions, args.models)
    units = [(s, v, m) for s in args.settings for v in args.prompt_versions for m in args.models]
    names = [" ".join(x for x, axis in zip(u, axes, strict=True) if len(axis) > 1) or u[0] for u in units]
    backends = {n: backend_with(s, m) for n, (s, _, m) in zip(names, units, strict=True)}
    requests = {n: Requests() for n in names}
    for n in names:
        requests[n].wrap(backends[n])
    versions = {n: v for n, (_, v, _) in zip(names, units, strict=True)}
    generators = {n: ConditionGenerator(backends[n], prompt_version=versions[n]) for n in names}
    pids = [p for p in PRIMITIVES if not PRIMITIVES[p].declared]
    results: dict[str, list] = {n: [] for n in names}
    tokens: dict[str, list[dict[str, int]]] = {n: [] for n in names}
    for k, (trial, pid) in enumerate((t, p) for t in range(args.trials) for p in pids):
        row: dict[str, Any] = {"trial": trial, "primitive": pid}
        for n in names[k % len(names) :] + names[: k % len(names)]:
            requests[n].log.clear()
            outcome = score_trial(generators[n], pid, args.mode, trial)
            results[n].append(outcome)
            row[n] = [outcome.correct, round(outcome.seconds, 2)]
            if args.tokens:
                tokens[n].append(requests[n].summary())
                row[f"tokens {n}"] = tokens[n][-1]
        print(json.dumps(row), flush=True)
    print("| setting | correct | median s per condition | median s without the first | same answers |")
    print("|---|---|---|---|---|")
    for n in names:
        secs = [o.seconds for o in results[n]]
        same = sum(o.answer == f.answer for o, f in zip(results[n], results[names[0]], strict=True))
        correct = sum(o.correct for o in results[n])
        print(
            f"| {n} | {correct}/{len(secs)} | {statistics.median(secs):.2f} | "
            f"{statistics.median(secs[1:] or secs):.2f} | {same}/{len(secs)} |"
        )
    for n in names if args.tokens else ():
        later = tokens[n][1:] or tokens[n]  # the first condition also evaluates the shared prefix
        print(n, "median without the first:", {k: statistics.median(t[k] for t in later) for k in later[0]})


if __name__ == "__main__":
    main()
