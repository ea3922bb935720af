"""Speed of the embedded condition generator on this machine.

Measures, in one run: assembling and verifying the GGUF (first use), loading the model, the time per whole
task condition (both chats) uncached for generation and for generalization (leave-one-out, chain-of-thought
prompt), and the time per condition answered from the on-disk response cache. Prints a markdown table.

    .venv/bin/python benchmarks/bench_llm.py [--model qwen2.5-coder-1.5b] [--repeats 3]
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

from taskcond.generator import ConditionGenerator
from taskcond.llm.cache import CachedBackend
from taskcond.llm.embedded import EmbeddedBackend
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


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", default=DEFAULT_EMBEDDED_MODEL, help="embedded model name")
    ap.add_argument("--repeats", type=int, default=3, help="cached-lookup repetitions per task")
    args = ap.parse_args()

    spec = get_embedded_model(args.model)
    with tempfile.TemporaryDirectory() as tmp:
        start = time.perf_counter()
        model_path(spec, Path(tmp))
        assemble = time.perf_counter() - start
    backend = EmbeddedBackend(args.model)
    backend._load()
    with tempfile.TemporaryDirectory() as cache:
        gen = ConditionGenerator(CachedBackend(backend, Path(cache)))
        gen.generate("grasp bottle")  # warm the shared prompt prefixes, as any run after its first condition
        generation = [gen.generate(t).seconds for t in TASKS]
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
        (f"generation, uncached, median of {n} (max)", f"{med(generation):.2f} s ({max(generation):.2f})"),
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
