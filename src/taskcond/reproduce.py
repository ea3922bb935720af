"""``taskcond reproduce``: the paper's Tables II–IV, each cell measured beside the paper's value.

A table is a :class:`TableSpec`: blocks of rows, and the columns each block fills with a *method* (an
execution method for Tables III and IV, a condition-generation mode for Table II). A column a block does
not list is the paper's '-' (infeasible); a column listed under ``pending`` is a method we cannot run yet
(the image-based baseline when the ``[il]`` extra is missing) and shows as "not run", never as a number.
Adding a row, block or column is one entry here: once the runner knows a method, moving its column key
from a block's ``pending`` to its ``methods`` makes ``taskcond reproduce`` run it, resume it and put it
beside the paper's value. A block with ``novel_primitive`` (Table IV's third) runs its episodes with one
primitive left out of the LLM's examples
(:func:`taskcond.application.condition_sources.novel_primitive_source`).

Results go to ``DIR/tableN.jsonl`` through :class:`~taskcond.results.ResultsFile` (configuration
recorded, resumable, crashed work retried; the novel-primitive episodes, another configuration, to
``DIR/tableN-novel-primitive.jsonl``), and each table is written as ``tableN.md`` (ours beside the
paper's value, Wilson 95% confidence intervals), ``tableN.json`` and ``tableN.png`` (bars with CI
whiskers, the paper's values as markers). The paper's values are in ``taskcond/data/paper_tables.json``.
"""

from __future__ import annotations

import json
import textwrap
from collections import Counter
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field, replace
from functools import cache
from importlib import resources
from pathlib import Path
from typing import Any

from taskcond.primitives import PRIMITIVES
from taskcond.results import Job


@dataclass(frozen=True)
class Column:
    """A column of a table.

    Attributes:
        key: our id of the column (also the key in ``tableN.json``).
        label: the header.
        paper: the paper's column it is compared with (a key of ``paper_tables.json``), None if the paper
            has none.
    """

    key: str
    label: str
    paper: str | None


@dataclass(frozen=True)
class Row:
    """A row: ``tasks`` are the suite ids (Tables III, IV) or the primitive id (Table II) whose trials
    are pooled into its cells; ``paper`` is its key in ``paper_tables.json``."""

    key: str
    label: str
    tasks: tuple[str, ...]
    paper: str


@dataclass(frozen=True)
class Block:
    """Rows measured under one setting (the paper's "same as demonstration", "novel objects", ...).

    Attributes:
        methods: column key → the method that fills it in this block.
        pending: column key → why it is not run yet (a "not run" cell).
        fixed: method → trials per row task whatever ``--episodes`` says (a deterministic method: every
            trial it has, once).
        notes: column key → how it is measured, printed under the block.
        novel_primitive: each episode leaves one primitive of its task out of the LLM's examples (its
            records carry ``left_out``; see
            :func:`taskcond.application.condition_sources.novel_primitive_source`).
    """

    key: str
    label: str
    rows: tuple[Row, ...]
    methods: Mapping[str, str]
    pending: Mapping[str, str] = field(default_factory=dict)
    fixed: Mapping[str, int] = field(default_factory=dict)
    notes: Mapping[str, str] = field(default_factory=dict)
    novel_primitive: bool = False

    def trials(self, method: str, episodes: int) -> int:
        return self.fixed.get(method, episodes)


@dataclass(frozen=True)
class TableSpec:
    """One of the paper's tables. ``kind`` is ``conditions`` (Table II) or ``execution``;
    ``default_episodes`` the trials per row task and method of ``taskcond reproduce`` without
    ``--episodes``."""

    name: str
    title: str
    kind: str
    columns: tuple[Column, ...]
    blocks: tuple[Block, ...]
    default_episodes: int
    seed: int = 1000

    def column(self, key: str) -> Column:
        return next(c for c in self.columns if c.key == key)


CONDITION_COLUMNS = (
    Column("generation-llm", "Generation, LLM", "generation-llm"),
    Column("generation-env", "Generation, FromEnv", "generation-env"),
    Column("generalization-llm", "Generalization, LLM", "generalization-llm"),
    Column("generalization-env", "Generalization, FromEnv", "generalization-env"),
    Column("generalization-grounded", "Generalization, LLM + demo", None),
)
"""Table II's columns."""
EXECUTION_COLUMNS = (
    Column("image-il", "Image-based IL baseline", "baseline"),
    Column("none", "w/o cond (DMP only)", "without-cond"),
    Column("env", "w/ cond FromEnv", "with-cond"),
    Column("llm", "w/ cond from LLM", "with-cond"),
)
"""The columns of Tables III and IV (the paper's column keys of Table III)."""
TABLE4_PAPER_COLUMNS = {"env": "cond-env", "llm": "cond-llm"}
"""Where Table IV's paper columns are keyed otherwise than Table III's."""
GROUNDED_COLUMN = Column("llm+demo", "w/ cond from LLM + demo", None)
"""Table IV's column beyond the paper: LLM conditions grounded in the demonstrations (``--method
llm+demo``), measured where a primitive is generalized."""

ONLY_NOVEL = (
    "beyond the paper, measured where a primitive's condition is generalized (the novel-primitive block); "
    "a generated condition is already the reference"
)
IL_NOTE = (
    "behaviour cloning of the oracles from a 64×64 RGB-D camera and proprioception, one policy for every "
    "primitive task name (taskcond.il; `taskcond learn --method image-il`)"
)


def _primitive_rows() -> tuple[Row, ...]:
    from taskcond.tasks.registry import get_task, primitive_task_ids

    ids = primitive_task_ids()
    return tuple(
        Row(pid, p.title, tuple(t for t in ids if get_task(t).info.primitive == pid), pid)
        for pid, p in PRIMITIVES.items()
    )


def _lht_rows(ids: Iterable[str]) -> tuple[Row, ...]:
    return tuple(Row(t, t, (t,), t) for t in ids)


@cache
def table_specs() -> dict[str, TableSpec]:
    """The paper's Tables II–IV as run by ``taskcond reproduce``."""
    table2 = TableSpec(
        name="table2",
        title="Table II: task condition generation and generalization",
        kind="conditions",
        columns=CONDITION_COLUMNS,
        blocks=(
            Block(
                "conditions",
                "All primitives",
                tuple(Row(pid, p.title, (pid,), pid) for pid, p in PRIMITIVES.items()),
                methods={
                    "generation-llm": "generation",
                    "generation-env": "env",
                    "generalization-llm": "generalization",
                    "generalization-grounded": "generalization-grounded",
                },
                fixed={"env": max(len(r.tasks) for r in _primitive_rows())},
                notes={
                    "generation-llm": "correct = every field equals the reference condition (the "
                    "primitive's example for the task's objects); 5 object sets per primitive, trial k uses "
                    "set k mod 5 and shuffles the examples with seed k",
                    "generalization-llm": "the same, with the primitive's own examples left out "
                    "(the default prompt version: the code form for a left-out primitive)",
                    "generalization-grounded": "beyond the paper: the same generalization answer, grounded "
                    "in the suite's demonstration of the primitive (taskcond.grounding; `--method llm+demo`)",
                    "generation-env": "the condition read from the environment in each demonstration of "
                    "the suite's tasks of the primitive (one per task/object pair), correct = it holds "
                    "every pre-, post-condition and collision of the reference; it also holds the "
                    "incidental relations and contacts of its demonstration (each record of "
                    "table2.jsonl also says whether it matched exactly)",
                },
            ),
        ),
        default_episodes=2,
        seed=0,
    )
    table3 = TableSpec(
        name="table3",
        title="Table III: primitive task execution success rate",
        kind="execution",
        columns=EXECUTION_COLUMNS,
        blocks=(
            Block(
                "primitives",
                "Every primitive task of the suite, pooled per primitive",
                _primitive_rows(),
                methods={"image-il": "image-il", "none": "none", "env": "env", "llm": "llm"},
                notes={"image-il": IL_NOTE},
            ),
        ),
        default_episodes=2,
    )
    table4 = TableSpec(
        name="table4",
        title="Table IV: long-horizon tasks",
        kind="execution",
        columns=(
            *(replace(c, paper=TABLE4_PAPER_COLUMNS.get(c.key, c.paper)) for c in EXECUTION_COLUMNS),
            GROUNDED_COLUMN,
        ),
        blocks=(
            Block(
                "same",
                "Same as demonstration",
                _lht_rows(("LHT1", "LHT2", "LHT3", "LHT4")),
                methods={"image-il": "image-il", "none": "none", "env": "env", "llm": "llm"},
                pending={"llm+demo": ONLY_NOVEL},
                notes={"image-il": IL_NOTE + "; a long-horizon task runs its steps' names in turn"},
            ),
            Block(
                "novel-objects",
                "Generalize to novel objects",
                _lht_rows(("LHT1*", "LHT2*")),
                {"llm": "llm"},
                pending={"llm+demo": ONLY_NOVEL},
            ),
            Block(
                "novel-primitive",
                "Generalize to novel primitive tasks",
                _lht_rows(("LHT1", "LHT2", "LHT3", "LHT4")),
                methods={"llm": "llm", "llm+demo": "llm+demo"},
                notes={
                    "llm": "each episode leaves one primitive of the task, drawn from its seed, out of the "
                    "LLM's examples: that primitive's condition is generalized (the default prompt version's "
                    "code form, examples shuffled by the episode's seed), the others generated without its "
                    "example",
                    "llm+demo": "beyond the paper: the same episodes with every condition grounded in the "
                    "demonstration of its skill (taskcond.grounding)",
                },
                novel_primitive=True,
            ),
        ),
        default_episodes=5,
    )
    return {t.name: t for t in (table2, table3, table4)}


ROBOSUITE_TABLE = "robosuite"
"""The name of robosuite's table (``taskcond reproduce robosuite``): not one of the paper's, not in
:func:`table_specs` (``all``), since it needs the ``[robosuite]`` extra."""
ROBOMIMIC_COLUMN = Column(
    "robomimic", "robomimic BC-RNN, 200 human demos (published, not run)", "bc-rnn-ph-low-dim"
)
"""The published success rate of robomimic's BC-RNN trained on 200 proficient-human demonstrations per
task (low-dim agents), beside our one demonstration per primitive step; source in ``paper_tables.json``."""


def robosuite_table() -> TableSpec:
    """robosuite's supported tasks (:data:`taskcond.worlds.robosuite.tasks.TASKS`) by execution method,
    each episode judged by robosuite's own ``_check_success`` from robosuite's default initial-state
    randomization (seeds 1000+), with robomimic's published figures where robomimic has the task."""
    from taskcond.worlds.robosuite.tasks import TASKS

    methods = {"none": "none", "env": "env", "llm": "llm", "llm+demo": "llm+demo"}
    return TableSpec(
        name=ROBOSUITE_TABLE,
        title="robosuite's tasks by method (success: robosuite's _check_success)",
        kind="execution",
        columns=(*(c for c in EXECUTION_COLUMNS if c.key in methods), GROUNDED_COLUMN, ROBOMIMIC_COLUMN),
        blocks=(
            Block(
                "robosuite",
                "robosuite 1.5, Panda + OSC, its placement initializer; one demonstration per primitive step",
                tuple(Row(t.id, t.id, (t.id,), t.id) for t in TASKS.values()),
                methods=methods,
                notes={
                    "llm+demo": "the LLM's conditions grounded in the demonstration of each skill",
                    "robomimic": "~100% Lift, ~100% Can (PickPlaceCan), ~84% Square (NutAssemblySquare): "
                    "the robomimic v0.1 model zoo's BC-RNN low-dim agents (Mandlekar et al., CoRL 2021; "
                    "robosuite's offline_study branch, not 1.5), "
                    "https://robomimic.github.io/docs/model_zoo/robomimic_v0.1.html",
                },
            ),
        ),
        default_episodes=5,
    )


@cache
def paper_values() -> dict[str, Any]:
    """The paper's Tables II–IV (percent; None for its '-'), from ``taskcond/data/paper_tables.json``."""
    text = resources.files("taskcond").joinpath("data/paper_tables.json").read_text(encoding="utf-8")
    return json.loads(text)


def wilson_interval(successes: int, trials: int) -> tuple[float, float]:
    """Wilson score 95% confidence interval of a success rate (fractions), by
    ``scipy.stats.binomtest(...).proportion_ci(method="wilson")``."""
    from scipy.stats import binomtest

    ci = binomtest(successes, trials).proportion_ci(confidence_level=0.95, method="wilson")
    return float(ci.low), float(ci.high)


def only_rows(spec: TableSpec, keys: Iterable[str]) -> TableSpec:
    """``spec`` with only the rows whose key is in ``keys`` (blocks left without rows dropped).

    Raises:
        ValueError: no row of ``spec`` has one of the keys.
    """
    wanted = set(keys)
    blocks = tuple(
        replace(b, rows=rows) for b in spec.blocks if (rows := tuple(r for r in b.rows if r.key in wanted))
    )
    if not blocks:
        valid = sorted({r.key for b in spec.blocks for r in b.rows})
        raise ValueError(f"{spec.name} has no row {', '.join(sorted(wanted))}; valid: {', '.join(valid)}")
    return replace(spec, blocks=blocks)


def only_columns(spec: TableSpec, keys: Iterable[str]) -> TableSpec:
    """``spec`` running only the columns whose key is in ``keys``; the others become "not run" cells.

    Raises:
        ValueError: a key names no column of ``spec``.
    """
    wanted = set(keys)
    valid = [c.key for c in spec.columns]
    unknown = sorted(wanted - set(valid))
    if unknown:
        raise ValueError(f"{spec.name} has no column {', '.join(unknown)}; valid: {', '.join(valid)}")
    skipped = "not selected (--column)"
    blocks = tuple(
        replace(
            b,
            methods={k: m for k, m in b.methods.items() if k in wanted},
            pending={**b.pending, **{k: skipped for k in b.methods if k not in wanted}},
        )
        for b in spec.blocks
    )
    return replace(spec, blocks=blocks)


# -------------------------------------------------------------------------------------------- trials
def trials_for(spec: TableSpec, episodes: int, novel_primitive: bool = False) -> list[Job]:
    """Every trial of ``spec``'s blocks with (``novel_primitive``) or without novel-primitive episodes,
    ``episodes`` per row task and method (each once, though a task may appear in several rows)."""
    out: dict[tuple[str, str, int], Job] = {}
    for block in spec.blocks:
        if block.novel_primitive != novel_primitive:
            continue
        for row in block.rows:
            for method in block.methods.values():
                for task in row.tasks:
                    for k in range(block.trials(method, episodes)):
                        trial = Job(task, method, spec.seed + k)
                        out.setdefault(trial.key, trial)
    return list(out.values())


# ------------------------------------------------------------------------------------------ the table
@dataclass
class Cell:
    """One cell: our measurement (``trials`` 0 when not run) beside the paper's value (percent)."""

    status: str  # measured | not run | infeasible
    paper: float | None
    successes: int = 0
    trials: int = 0
    failures: dict[str, int] = field(default_factory=dict)
    note: str = ""

    @property
    def rate(self) -> float | None:
        return self.successes / self.trials if self.trials else None

    @property
    def ci95(self) -> tuple[float, float] | None:
        return wilson_interval(self.successes, self.trials) if self.trials else None

    def to_dict(self) -> dict[str, Any]:
        return {
            "status": self.status,
            "successes": self.successes,
            "trials": self.trials,
            "rate": self.rate,
            "ci95": list(self.ci95) if self.ci95 else None,
            "paper": self.paper,
            "failures": self.failures,
            "note": self.note,
        }

    def markdown(self) -> str:
        paper = "–" if self.paper is None else f"{self.paper:g}%"
        if self.status == "infeasible":
            return f"– · paper {paper}"
        if self.status == "not run" or not self.trials:
            return f"not run · paper {paper}"
        low, high = self.ci95  # type: ignore[misc]
        return (
            f"**{self.rate:.0%}** ({self.successes}/{self.trials}, CI {low:.0%}–{high:.0%}) · paper {paper}"
        )


def success_of(record: dict[str, Any]) -> bool:
    return bool(record.get("success", record.get("correct")))


def failure_of(record: dict[str, Any]) -> str:
    return record.get("failure") or ("no valid answer" if record.get("error") else "wrong condition")


def _failure_label(record: dict[str, Any]) -> str:
    left_out = record.get("left_out")
    return failure_of(record) + (f", left out: {left_out}" if left_out else "")


def build_cells(spec: TableSpec, records: Iterable[dict[str, Any]], episodes: int) -> dict[tuple, Cell]:
    """``(block, row, column) → Cell`` from the table's records (only seeds below ``spec.seed + episodes``
    count, so a file of a longer run can serve a shorter one; a novel-primitive block counts the records
    with a ``left_out`` primitive, the others those without). A failed novel-primitive episode is counted
    under its reason and the primitive left out (``failure, left out: primitive``)."""
    novel_of = {True: {}, False: {}}  # type: dict[bool, dict[tuple[str, str, int], dict[str, Any]]]
    for r in records:
        if not r.get("skipped"):
            novel_of[r.get("left_out") is not None][(r["task"], r["method"], r["seed"])] = r
    paper = paper_values()[spec.name]
    cells: dict[tuple, Cell] = {}
    for block in spec.blocks:
        for row in block.rows:
            for col in spec.columns:
                value = paper.get(block.key, {}).get(row.paper, {}).get(col.paper) if col.paper else None
                if col.key in block.pending:
                    cell = Cell("not run", value, note=block.pending[col.key])
                elif col.key not in block.methods:
                    cell = Cell("infeasible", value)
                else:
                    method = block.methods[col.key]
                    by_key = novel_of[block.novel_primitive]
                    recs = [
                        by_key[(t, method, spec.seed + k)]
                        for t in row.tasks
                        for k in range(block.trials(method, episodes))
                        if (t, method, spec.seed + k) in by_key
                    ]
                    cell = Cell(
                        "measured",
                        value,
                        successes=sum(success_of(r) for r in recs),
                        trials=len(recs),
                        failures=dict(Counter(_failure_label(r) for r in recs if not success_of(r))),
                    )
                cells[(block.key, row.key, col.key)] = cell
    return cells


def table_markdown(spec: TableSpec, cells: dict[tuple, Cell], footer: str) -> str:
    """The table as markdown: a section per block, ours beside the paper's value in every cell."""
    lines = [f"## {spec.title}", ""]
    for block in spec.blocks:
        lines += [f"**{block.label}**", ""]
        lines.append("| " + " | ".join(["", *(c.label for c in spec.columns)]) + " |")
        lines.append("|" + "---|" * (len(spec.columns) + 1))
        for row in block.rows:
            entries = [cells[(block.key, row.key, c.key)].markdown() for c in spec.columns]
            lines.append("| " + " | ".join([row.label, *entries]) + " |")
        notes = [f"{spec.column(k).label}: {how}" for k, how in block.notes.items()]
        notes += sorted({f"{spec.column(k).label}: not run, {why}" for k, why in block.pending.items()})
        if block.novel_primitive:  # which primitive was left out in each failure
            for row in block.rows:
                for col in spec.columns:
                    failures = cells[(block.key, row.key, col.key)].failures
                    if failures:
                        listed = "; ".join(f"{n} × {why}" for why, n in sorted(failures.items()))
                        notes.append(f"{row.label}, {col.label}, failures: {listed}")
        lines += ["", *(f"* {n}" for n in notes), ""] if notes else [""]
    lines.append(footer)
    return "\n".join(lines) + "\n"


def table_json(spec: TableSpec, cells: dict[tuple, Cell], extra: dict[str, Any]) -> dict[str, Any]:
    return {
        "table": spec.name,
        "title": spec.title,
        **extra,
        "columns": [{"key": c.key, "label": c.label, "paper_column": c.paper} for c in spec.columns],
        "blocks": [
            {
                "key": b.key,
                "label": b.label,
                "rows": [
                    {
                        "key": r.key,
                        "label": r.label,
                        "tasks": list(r.tasks),
                        "cells": {c.key: cells[(b.key, r.key, c.key)].to_dict() for c in spec.columns},
                    }
                    for r in b.rows
                ],
            }
            for b in spec.blocks
        ],
    }


def table_plot(spec: TableSpec, cells: dict[tuple, Cell], path: Path) -> None:
    """A bar chart per block: our success rate per row and column with its Wilson 95% interval as a
    whisker, the paper's value as a black diamond at the bar's right (hollow where our cell is not run,
    which is marked "not run")."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    widths = [len(b.rows) for b in spec.blocks]
    fig, axes = plt.subplots(
        1,
        len(spec.blocks),
        figsize=(max(8.0, 2.0 + 1.3 * sum(widths)), 4.6),
        sharey=True,
        squeeze=False,
        gridspec_kw={"width_ratios": widths},
    )
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    n = len(spec.columns)
    width = 0.8 / n
    for ax, block in zip(axes[0], spec.blocks, strict=True):
        x = np.arange(len(block.rows))
        for j, col in enumerate(spec.columns):
            pos = x - 0.4 + width * (j + 0.5)
            group = [cells[(block.key, r.key, col.key)] for r in block.rows]
            for xi, cell in zip(pos, group, strict=True):
                if cell.trials:
                    low, high = cell.ci95  # type: ignore[misc]
                    rate = 100 * cell.rate  # type: ignore[operator]
                    ax.bar(xi, rate, width, color=colors[j % len(colors)])
                    ax.errorbar(
                        xi, rate, yerr=[[rate - 100 * low], [100 * high - rate]], color="k", capsize=2
                    )
                elif cell.status == "not run":
                    ax.text(xi, 2, "not run", rotation=90, ha="center", va="bottom", fontsize=7, color="0.5")
                if cell.paper is not None:  # beside the whisker, not on it
                    face = "k" if cell.trials else "none"
                    ax.plot(xi + width / 3, cell.paper, "D", ms=5, mec="k", mfc=face)
        ax.set_xticks(x, [r.label for r in block.rows], rotation=30 if len(block.rows) > 4 else 0)
        ax.set_title(textwrap.fill(block.label, 28), fontsize=9)
        ax.set_ylim(0, 105)
        ax.set_xlim(-0.5, len(block.rows) - 0.5)
    axes[0][0].set_ylabel("success rate, % (whiskers: Wilson 95% CI)")
    handles = [plt.Rectangle((0, 0), 1, 1, color=colors[j % len(colors)]) for j in range(n)]
    handles.append(plt.Line2D([], [], marker="D", color="k", ls="none"))
    labels = [*(c.label for c in spec.columns), "paper"]
    fig.legend(handles, labels, loc="lower center", ncol=min(n + 1, 3), fontsize=8)
    fig.suptitle(spec.title, fontsize=10)
    fig.tight_layout(rect=(0, 0.12, 1, 1))
    fig.savefig(path, dpi=120)
    plt.close(fig)


def write_table(
    spec: TableSpec,
    records: list[dict[str, Any]],
    episodes: int,
    out: Path,
    extra: dict[str, Any],
    footer: str,
) -> dict[tuple, Cell]:
    """Write ``out/<name>.md``, ``.json`` and ``.png`` from the table's records."""
    cells = build_cells(spec, records, episodes)
    (out / f"{spec.name}.md").write_text(table_markdown(spec, cells, footer), encoding="utf-8")
    (out / f"{spec.name}.json").write_text(
        json.dumps(table_json(spec, cells, extra), indent=1), encoding="utf-8"
    )
    table_plot(spec, cells, out / f"{spec.name}.png")
    return cells


# --------------------------------------------------------------------------------- Table II trials
def condition_trial_runner(
    generator_factory: Callable[[], Any], library_factory: Callable[[], Any]
) -> Callable[[Job], dict[str, Any]]:
    """A function scoring one Table II trial as a results record: ``generation``/``generalization``
    with the LLM (:func:`~taskcond.evaluation.score_trial`); ``generalization-grounded``: the same
    generalization answer (the same prompt and seed, so a cached one) grounded in the library's
    demonstration of the primitive, correct when the grounded condition matches the reference; or
    ``env``: the FromEnv condition the skill library learned from the ``seed``-th demonstrated suite task
    of the primitive, which is correct when it :func:`covers` the reference condition the LLM is scored
    with (the generator and library are built on first use)."""
    from taskcond.evaluation import score_trial
    from taskcond.examples import reference_condition
    from taskcond.execution.sources import demonstration_evidence
    from taskcond.primitives import parse_task

    generator, library = cache(generator_factory), cache(library_factory)  # built on first use

    def run(trial: Job) -> dict[str, Any]:
        index = trial.seed - table_specs()["table2"].seed
        if trial.method == "env":
            skills = fromenv_skills(library(), trial.task)
            if index >= len(skills):
                return {**trial.to_dict(), "skipped": True}
            skill = skills[index]
            task = parse_task(skill.task_name)
            ref, cond = reference_condition(task), skill.condition
            return {
                **trial.to_dict(),
                "name": task.name,
                "correct": cond is not None and covers(cond, ref),
                "exact": cond is not None and cond.matches(ref),
            }
        if trial.method != "generalization-grounded":
            outcome = score_trial(generator(), trial.task, trial.method, index)
            return {**_scored(trial, outcome), "correct": outcome.correct, "answer": outcome.answer}
        outcome = score_trial(
            generator(),
            trial.task,
            "generalization",
            index,
            evidence=lambda task: demonstration_evidence(library(), task.name),
        )
        return {
            **_scored(trial, outcome),
            "correct": bool(outcome.grounded),
            "answer": outcome.grounded_answer,
            "repairs": outcome.repairs,
            "extra_relations": outcome.extra_relations,
        }

    return run


def _scored(trial: Job, outcome: Any) -> dict[str, Any]:
    """The fields every LLM trial's record has."""
    return {
        **trial.to_dict(),
        "name": outcome.task,
        "seconds": round(outcome.seconds, 3),
        "error": outcome.error,
    }


def covers(condition: Any, reference: Any) -> bool:
    """Every pre-, post-condition and allowed collision of ``reference`` is in ``condition``."""
    return (
        set(reference.pre_conditions) <= set(condition.pre_conditions)
        and set(reference.post_conditions) <= set(condition.post_conditions)
        and set(reference.collisions) <= set(condition.collisions)
    )


def fromenv_skills(library: Any, primitive: str) -> list[Any]:
    """The skills learned from the suite's own primitive tasks of ``primitive`` (not the long-horizon
    steps), in suite order."""
    from taskcond.tasks.registry import primitive_task_ids

    ids = primitive_task_ids()
    skills = [s for s in library.skills.values() if s.primitive == primitive and s.task_id in ids]
    return sorted(skills, key=lambda s: ids.index(s.task_id))


__all__ = [
    "ROBOSUITE_TABLE",
    "Block",
    "Cell",
    "Column",
    "Row",
    "TableSpec",
    "build_cells",
    "condition_trial_runner",
    "only_columns",
    "only_rows",
    "paper_values",
    "robosuite_table",
    "table_specs",
    "trials_for",
    "wilson_interval",
    "write_table",
]
