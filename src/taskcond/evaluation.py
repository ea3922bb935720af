"""Evaluation of condition generation and generalization (the paper's Table II protocol, §V-A).

For every primitive and trial, one task with varied object names is generated twice: with every example
shown (*generation*) and with the primitive's own examples left out (*generalization*: the code form in
prompt versions v6 and v7, the chain-of-thought chats in v1–v5). A condition counts as correct only if every
field equals the reference condition (the primitive's example instantiated for the task's objects),
order-insensitive. Trials also vary the order of the examples in the prompts, so repeated trials are not
repeated prompts. The model's zero-shot state probe (:mod:`taskcond.probe`) can go with the result, to
read the generalization figure against.
"""

from __future__ import annotations

import time
from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from statistics import median

from taskcond.conditions import TaskCondition, is_spatial
from taskcond.examples import reference_condition
from taskcond.generator import ConditionGenerator
from taskcond.grounding import DemoEvidence, Grounded, ground
from taskcond.llm.base import LLMError
from taskcond.primitives import PRIMITIVES, ParsedTask
from taskcond.probe import ProbeResult

EVAL_OBJECTS: dict[str, tuple[tuple[str, ...], ...]] = {
    "grasp": (("bowl",), ("coffee mug",), ("spatula",), ("toothpaste",), ("red cube",)),
    "release": (("mug",), ("bowl",), ("spatula",), ("soda can",), ("toothpaste",)),
    "open": (("top drawer",), ("microwave",), ("bottom drawer",), ("lunch box",), ("cabinet door",)),
    "close": (("microwave",), ("top drawer",), ("bottom drawer",), ("lunch box",), ("fridge",)),
    "tilt": (("bottle",), ("coffee mug",), ("bowl",), ("teapot",), ("cup",)),
    "fold": (("towel",), ("cloth",), ("napkin",), ("shirt",), ("blanket",)),
    "move": (("spatula",), ("bottle",), ("coffee mug",), ("bowl",), ("toothpaste",)),
    "move_on_top": (
        ("bowl", "box"),
        ("mug", "plate"),
        ("spatula", "cloth"),
        ("bottle", "tray"),
        ("cup", "table"),
    ),
    "move_into": (
        ("toothpaste", "mug"),
        ("bowl", "bottom drawer"),
        ("bottle", "lunch box"),
        ("spatula", "top drawer"),
        ("cup", "microwave"),
    ),
    "move_in_front": (
        ("bottle", "box"),
        ("mug", "microwave"),
        ("bowl", "cabinet"),
        ("spatula", "toothpaste"),
        ("coffee mug", "plate"),
    ),
}
"""Object names per primitive for the evaluation: different from the examples' objects, multi-word
names included. Trial ``i`` uses entry ``i % 5``."""


@dataclass
class Outcome:
    """One generated condition scored against its reference; ``seconds`` of wall time spent on it, also
    when no valid answer came (``error``).

    For a generalization answer grounded in the suite's demonstration of its primitive: ``grounded``
    whether the grounded condition matches the reference, ``repairs`` what grounding changed,
    ``extra_relations`` the grounded condition's spatial relations the reference lacks, and
    ``incidental`` those of them grounding added (the paper's FromEnv relations it must not bring back).
    """

    primitive: str
    mode: str
    task: str
    correct: bool
    seconds: float
    error: str | None = None
    answer: str | None = None
    grounded: bool | None = None
    grounded_answer: str | None = None
    repairs: list[str] = field(default_factory=list)
    extra_relations: list[str] = field(default_factory=list)
    incidental: list[str] = field(default_factory=list)


@dataclass
class PrimitiveScore:
    primitive: str
    trials: int = 0
    correct: int = 0
    failures: Counter = field(default_factory=Counter)

    @property
    def rate(self) -> float:
        return self.correct / self.trials if self.trials else 0.0


@dataclass
class ConditionEvaluation:
    """Per-primitive scores for generation and generalization, plus every outcome."""

    model: str
    trials: int
    generation: dict[str, PrimitiveScore]
    generalization: dict[str, PrimitiveScore]
    outcomes: list[Outcome]
    prompt_version: str = ""
    samples: int = 1
    probe: ProbeResult | None = None
    """The model's zero-shot state probe (:mod:`taskcond.probe`), when measured: how much of the
    primitives' object states it knows without examples, beside the generalization figure."""
    grounded: dict[str, PrimitiveScore] = field(default_factory=dict)
    """Generalization answers grounded in the demonstration of their primitive (empty if not measured)."""

    def median_seconds(self, mode: str) -> float:
        times = [o.seconds for o in self.outcomes if o.mode == mode and o.error is None]
        return median(times) if times else float("nan")

    def to_dict(self) -> dict:
        def scores(d: dict[str, PrimitiveScore]) -> dict:
            return {
                p: {"trials": s.trials, "correct": s.correct, "rate": s.rate, "failures": dict(s.failures)}
                for p, s in d.items()
            }

        out = {
            "model": self.model,
            "prompt_version": self.prompt_version,
            "samples": self.samples,
            "trials": self.trials,
            "generation": scores(self.generation),
            "generalization": scores(self.generalization),
            "median_seconds": {m: self.median_seconds(m) for m in ("generation", "generalization")},
            "state_probe": self.probe.to_dict() if self.probe is not None else None,
        }
        if self.grounded:
            out["generalization_grounded"] = scores(self.grounded)
            out["extra_relations"] = sum(len(o.extra_relations) for o in self.outcomes)
            out["incidental_relations"] = sum(len(o.incidental) for o in self.outcomes)
        out["outcomes"] = [asdict(o) for o in self.outcomes]
        return out

    def table(self) -> str:
        """A markdown table laid out like the paper's Table II."""

        def cell(correct: int, trials: int) -> str:
            return f"{correct / trials:.0%} ({correct}/{trials})" if trials else "not measured"

        columns = [self.generation, self.generalization]
        head = "| PT Name | Generation (LLM) | Generalization (LLM) |"
        if self.grounded:
            columns.append(self.grounded)
            head += " Generalization, grounded (LLM + demo) |"
        rows = [head, "|---" * (len(columns) + 1) + "|"]
        for pid, prim in PRIMITIVES.items():
            if pid in self.generation:
                cells = [cell(d[pid].correct, d[pid].trials) for d in columns]
                rows.append(f"| {prim.title} | {' | '.join(cells)} |")
        totals = [
            cell(sum(s.correct for s in d.values()), sum(s.trials for s in d.values())) for d in columns
        ]
        rows.append(f"| **all** | {' | '.join(totals)} |")
        return "\n".join(rows)


def evaluate_conditions(
    generator: ConditionGenerator,
    trials: int = 5,
    primitives: Sequence[str] | None = None,
    modes: Sequence[str] = ("generation", "generalization"),
    progress: Callable[[Outcome], None] | None = None,
    evidence: Callable[[ParsedTask], DemoEvidence] | None = None,
) -> ConditionEvaluation:
    """Run the Table II protocol; ``progress`` is called after each generated condition.

    With ``evidence`` (what the suite's demonstration of a task's primitive shows, renamed to the task's
    objects), every generalization answer is also grounded in it (:func:`taskcond.grounding.ground`) and
    scored against the same reference: the "generalization, grounded" column.

    An LLM failure (no valid answer within the retry bound, endpoint errors) counts as an incorrect
    condition with its reason; it never aborts the evaluation.
    """
    pids = list(primitives or (p for p in PRIMITIVES if not PRIMITIVES[p].declared))
    result = ConditionEvaluation(
        model=generator.model,
        trials=trials,
        generation={p: PrimitiveScore(p) for p in pids},
        generalization={p: PrimitiveScore(p) for p in pids},
        outcomes=[],
        prompt_version=generator.prompt_version,
        samples=generator.samples,
        grounded={p: PrimitiveScore(p) for p in pids} if evidence is not None else {},
    )
    for mode in modes:  # trial by trial: the prompts of one trial share the most (one example order)
        for trial in range(trials):
            for pid in pids:
                outcome = score_trial(generator, pid, mode, trial, evidence)
                score = getattr(result, mode)[pid]
                score.trials += 1
                if outcome.correct:
                    score.correct += 1
                else:
                    score.failures["no valid answer" if outcome.error else "wrong condition"] += 1
                if mode == "generalization" and evidence is not None:
                    result.grounded[pid].trials += 1
                    if outcome.grounded:
                        result.grounded[pid].correct += 1
                    else:
                        result.grounded[pid].failures[
                            "no valid answer" if outcome.error else "wrong condition"
                        ] += 1
                result.outcomes.append(outcome)
                if progress is not None:
                    progress(outcome)
    return result


def score_trial(
    generator: ConditionGenerator,
    primitive: str,
    mode: str,
    trial: int,
    evidence: Callable[[ParsedTask], DemoEvidence] | None = None,
) -> Outcome:
    """Trial ``trial`` of the Table II protocol for ``primitive`` in ``mode`` (``generation`` or
    ``generalization``): the task of :data:`EVAL_OBJECTS` entry ``trial % 5``, the example order and the
    sampling seeded by ``trial``. An LLM failure is an incorrect outcome with its reason. With
    ``evidence``, a generalization answer is also grounded in it and scored (:func:`_score_grounded`)."""
    objects = EVAL_OBJECTS[primitive][trial % len(EVAL_OBJECTS[primitive])]
    task = ParsedTask(PRIMITIVES[primitive], objects)
    exclude = (primitive,) if mode == "generalization" else ()
    start = time.perf_counter()
    try:
        gen = generator.generate(task, exclude=exclude, order_seed=trial, seed=trial)
    except LLMError as exc:
        return Outcome(primitive, mode, task.name, False, time.perf_counter() - start, str(exc))
    reference = reference_condition(task)
    answer = gen.condition
    outcome = Outcome(
        primitive, mode, task.name, answer.matches(reference), gen.seconds, answer=answer.to_text()
    )
    if mode == "generalization" and evidence is not None:
        _score_grounded(outcome, ground(answer, evidence(task)), reference)
    return outcome


def _score_grounded(outcome: Outcome, grounded: Grounded, reference: TaskCondition) -> None:
    """Fill the grounded fields of ``outcome``: match, repairs, and relations beyond the reference."""
    cond = grounded.condition
    original = {*grounded.original.pre_conditions, *grounded.original.post_conditions}
    extra = [
        p
        for p in (*cond.pre_conditions, *cond.post_conditions)
        if is_spatial(p) and p not in {*reference.pre_conditions, *reference.post_conditions}
    ]
    outcome.grounded = cond.matches(reference)
    outcome.grounded_answer = cond.to_text()
    outcome.repairs = [str(r) for r in grounded.repairs]
    outcome.extra_relations = [str(p) for p in extra]
    outcome.incidental = [str(p) for p in extra if p not in original]
