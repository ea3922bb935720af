"""Speed of the embedded condition generator on this machine.

Measures, in one run: assembling and verifying the GGUF (first use), loading the model, the time per whole
task condition (both chats) uncached for generation and for generalization (leave-one-out, chain-of-thought
prompt), and the time per condition answered from the on-disk response cache. Prints a markdown table.
With ``--accuracy`` it instead runs the Table II protocol (``taskcond eval conditions``) uncached with
generator settings the command line does not expose (prompt version, example order), printing every
wrong condition beside its reference.

    .venv/bin/python benchmarks/bench_llm.py [--model qwen2.5-coder-1.5b] [--repeats 3]
    .venv/bin/python benchmarks/bench_llm.py --accuracy [--prompt-version v1] [--example-order similar]
        [--samples 1] [--trials 3] [--mode generation|generalization] [--primitive ID ...]
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path
from typing import get_args

from taskcond.evaluation import evaluate_conditions
from taskcond.examples import reference_condition
from taskcond.generator import PROMPT_VERSION, ConditionGenerator, ExampleOrder
from taskcond.llm.cache import CachedBackend
from taskcond.llm.config import embedded_backend
from taskcond.llm.models import DEFAULT_EMBEDDED_MODEL, get_embedded_model, model_path
from taskcond.primitives import PRIMITIVES, parse_task

TASKS = [
    "move bottle into box",
    "grasp bowl",
    "open top drawer",
    "move mug in front of bowl",
    "release cup",
    "close microwave",
    "tilt coffee mug",
    "move spatula on top of cloth",
    "fold towel",
    "move toothpaste to position",
]


def accuracy(args: argparse.Namespace) -> None:
    """The Table II protocol, uncached, with the given generator settings; wrong answers printed."""
    gen = ConditionGenerator(
        embedded_backend(args.model),
        samples=args.samples,
        prompt_version=args.prompt_version,
        example_order=args.example_order,
    )
    results = []
    generate = gen.generate

    def recording(*a, **kw):
        results.append(generate(*a, **kw))
        return results[-1]

    gen.generate = recording  # type: ignore[method-assign]

    def progress(o) -> None:
        mode = "gen" if o.mode == "generation" else "loo"
        line = f"{'ok ' if o.correct else 'BAD'} {mode} {o.task} {o.seconds:.1f} s"
        if o.error:
            line += f" error: {o.error[:160]}"
        elif not o.correct:
            got = results[-1].condition
            ref = reference_condition(parse_task(o.task))
            line += f"\n    got {' '.join(got.to_json().split())}\n    ref {' '.join(ref.to_json().split())}"
        print(line, flush=True)

    start = time.perf_counter()
    result = evaluate_conditions(
        gen,
        trials=args.trials,
        primitives=args.primitive,
        modes=args.mode or ("generation", "generalization"),
        progress=progress,
    )
    print(
        f"\nprompts {args.prompt_version}, order {args.example_order}, samples {args.samples}, "
        f"{time.perf_counter() - start:.0f} s\n"
    )
    print(result.table())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", default=DEFAULT_EMBEDDED_MODEL, help="embedded model name")
    ap.add_argument("--repeats", type=int, default=3, help="cached-lookup repetitions per task")
    ap.add_argument("--accuracy", action="store_true", help="measure accuracy (Table II) instead of speed")
    ap.add_argument("--prompt-version", default=PROMPT_VERSION, help="prompt directory (accuracy)")
    ap.add_argument(
        "--example-order",
        default=ConditionGenerator.example_order,
        choices=get_args(ExampleOrder),
        help="order of the examples in the prompts (see ConditionGenerator.example_order)",
    )
    ap.add_argument("--samples", type=int, default=1, help="self-consistency samples per chat (accuracy)")
    ap.add_argument("--trials", type=int, default=3, help="trials per primitive and mode (accuracy)")
    ap.add_argument(
        "--mode", action="append", choices=["generation", "generalization"], help="only this mode"
    )
    ap.add_argument("--primitive", action="append", help="only this primitive (repeatable)")
    args = ap.parse_args()
    if args.accuracy:
        accuracy(args)
        return

    spec = get_embedded_model(args.model)
    with tempfile.TemporaryDirectory() as tmp:
        start = time.perf_counter()
        model_path(spec, Path(tmp))
        assemble = time.perf_counter() - start
    with tempfile.TemporaryDirectory() as cache:
        backend = embedded_backend(args.model, prefix_dir=Path(cache) / "prefixes")
        backend._load()
        gen = ConditionGenerator(CachedBackend(backend, Path(cache) / "responses"))
        # the first condition of a process evaluates the shared prompt prefixes and keeps them on disk; the
        # first one of a later process (here: the same one with its memory of prompts dropped) reads them
        cold = gen.generate("grasp bottle").seconds
        backend.forget()
        warm = gen.generate("release bottle")
        warm_start = warm.seconds
        assert backend.prefix_hits == len(warm.transcripts)  # one state read per chat
        before = backend.drafted, backend.accepted
        generation = [gen.generate(t).seconds for t in TASKS]
        proposed, kept = backend.drafted - before[0], backend.accepted - before[1]
        # the same prompts again, past the response cache, alternately without and with drafts, each from
        # the shared prefix's state on disk (as a new process starts), so both evaluate the same tokens
        raw = ConditionGenerator(backend)
        plain, with_drafts = [], []
        for t in TASKS:
            for draft, times in ((False, plain), (True, with_drafts)):
                backend.draft = draft
                backend.forget()
                times.append(raw.generate(t).seconds)
        loo = [gen.generate(t, exclude=[parse_task(t).primitive.id]).seconds for t in TASKS]
        cached = []
        for _ in range(args.repeats):
            for t in TASKS:
                result = gen.generate(t)
                assert result.cached
                cached.append(result.seconds)
    n, med = len(TASKS), statistics.median
    rows = [
        ("assemble + SHA-256 check of the GGUF (first use only)", f"{assemble:.1f} s"),
        ("model load (2 llama.cpp contexts, mmap)", f"{backend.load_seconds:.2f} s"),
        ("first condition of a process, no prefix states on disk", f"{cold:.2f} s"),
        ("first condition of a later process, prefix states on disk", f"{warm_start:.2f} s"),
        (f"generation, uncached, median of {n} (max)", f"{med(generation):.2f} s ({max(generation):.2f})"),
        ("generation, draft tokens kept / proposed", f"{kept} / {proposed}"),
        (
            f"generation from the prefix states, median of {n}: without drafts / with drafts (median ratio)",
            f"{med(plain):.2f} s / {med(with_drafts):.2f} s "
            f"({med(a / b for a, b in zip(plain, with_drafts, strict=True)):.2f})",
        ),
        (
            f"generalization (leave-one-out), uncached, median of {n} (max)",
            f"{med(loo):.2f} s ({max(loo):.2f})",
        ),
        (f"cached, median of {len(cached)} (max)", f"{med(cached) * 1e3:.2f} ms ({max(cached) * 1e3:.2f})"),
    ]
    print(f"model {args.model}, {len(PRIMITIVES)} primitives\n")
    print("| measure | value |\n|---|---|")
    for name, value in rows:
        print(f"| {name} | {value} |")


if __name__ == "__main__":
    main()
