"""Results that say how they were made (run configurations, results files) and the tables of
``taskcond reproduce`` (specs against the paper's values, Wilson intervals, markdown)."""

from __future__ import annotations

import json
import subprocess

import pytest

from taskcond.generator import PROMPT_VERSION
from taskcond.reproduce import Cell, build_cells, paper_values, table_specs, trials_for, wilson_interval
from taskcond.results import (
    ConfigMismatchError,
    ResultsFile,
    RunConfig,
    checkout_version,
    code_version,
    llm_fields,
)


def config(**changes) -> RunConfig:
    base = {"kind": "execution", **llm_fields("embedded"), "noise": 0.005, "skills": "lib@abc", "code": "x"}
    return RunConfig(**(base | changes))


def test_equal_configurations_have_equal_digests_and_differences_are_named() -> None:
    assert config().digest == config().digest
    assert config(noise=0.08).digest != config().digest
    changed = config(execution={"budget": 30.0})
    assert config(execution={"budget": 60.0}).differences(changed.to_dict()) == [
        "execution.budget: 30.0 (file) vs 60.0 (now)"
    ]
    assert config().to_dict()["llm_model_hash"] == "1d9614638d18024d,cc324af070c2ecbf"  # 0.5B, 1.5B
    assert code_version()  # a git describe here, a package version elsewhere


def test_the_code_version_changes_with_the_package_and_not_with_other_files(tmp_path) -> None:
    """A commit of documentation alone keeps the version (a results file resumes across it); a change of
    the package's files, committed or not, makes another."""

    def git(*args: str) -> None:
        subprocess.run(["git", "-C", str(tmp_path), *args], check=True, capture_output=True)

    package = tmp_path / "pkg"
    package.mkdir()
    (package / "__init__.py").write_text("A = 1\n", encoding="utf-8")
    git("init", "-q")
    git("-c", "user.name=t", "-c", "user.email=t@t", "add", ".")
    git("-c", "user.name=t", "-c", "user.email=t@t", "commit", "-qm", "package")
    first = checkout_version(package)
    assert first and "dirty" not in first
    (tmp_path / "BENCHMARKS.md").write_text("figures\n", encoding="utf-8")
    git("-c", "user.name=t", "-c", "user.email=t@t", "add", ".")
    git("-c", "user.name=t", "-c", "user.email=t@t", "commit", "-qm", "docs")
    assert checkout_version(package) == first
    (package / "__init__.py").write_text("A = 2\n", encoding="utf-8")
    dirty = checkout_version(package)
    assert dirty is not None and dirty.startswith(f"{first}-dirty+")
    git("-c", "user.name=t", "-c", "user.email=t@t", "commit", "-qam", "change")
    assert checkout_version(package) not in (first, dirty)
    assert checkout_version(tmp_path / "elsewhere") is None


def test_a_results_file_holds_one_configuration(tmp_path) -> None:
    path = tmp_path / "r.jsonl"
    results = ResultsFile(path, config())
    results.append({"task": "t", "method": "none", "seed": 1, "success": True})
    results.append({"task": "t", "method": "none", "seed": 2, "crashed": True, "error": "boom"})
    again = ResultsFile(path, config())
    assert [r["seed"] for r in again.results()] == [1]  # the crash is no result
    assert [r["seed"] for r in again.crashes()] == [2]
    with pytest.raises(ConfigMismatchError, match=r"noise: 0.005 \(file\) vs 0.08 \(now\)"):
        ResultsFile(path, config(noise=0.08))
    with pytest.raises(
        ConfigMismatchError, match=rf"prompt_version: '{PROMPT_VERSION}' \(file\) vs 'v4' \(now\)"
    ):
        ResultsFile(path, config(prompt_version="v4"))
    old = tmp_path / "old.jsonl"
    old.write_text(json.dumps({"task": "t", "method": "none", "seed": 1, "success": True}) + "\n")
    with pytest.raises(ConfigMismatchError, match="without a recorded configuration"):
        ResultsFile(old, config())


def test_a_configuration_with_tuples_resumes_from_its_json_header(tmp_path) -> None:
    """A tuple in the configuration (an executor constant) is a list once written: the file reopens."""
    path = tmp_path / "r.jsonl"
    ResultsFile(path, config(execution={"hand": (0.105, 0.035)})).append(
        {"task": "t", "seed": 1, "success": True}
    )
    assert [r["seed"] for r in ResultsFile(path, config(execution={"hand": (0.105, 0.035)})).results()] == [1]
    with pytest.raises(
        ConfigMismatchError, match=r"execution.hand: \[0.105, 0.035\] \(file\) vs \[0.1, 0.035\]"
    ):
        ResultsFile(path, config(execution={"hand": (0.1, 0.035)}))


def test_a_torn_last_line_is_skipped_and_ended(tmp_path) -> None:
    path = tmp_path / "r.jsonl"
    ResultsFile(path, config()).append({"task": "t", "method": "none", "seed": 1, "success": True})
    with path.open("a") as fh:
        fh.write('{"task": "t", "meth')  # an interrupted write
    results = ResultsFile(path, config())
    results.append({"task": "t", "method": "none", "seed": 2, "success": False})
    assert [r["seed"] for r in results.results()] == [1, 2]


def test_wilson_interval() -> None:
    low, high = wilson_interval(19, 20)
    assert low == pytest.approx(0.7639, abs=1e-4) and high == pytest.approx(0.9911, abs=1e-4)
    assert wilson_interval(0, 5)[0] == 0.0


def test_every_cell_of_the_papers_tables_has_a_counterpart() -> None:
    """Every value of paper_tables.json sits in a cell of a table spec (block, row, column), so no cell of
    Tables II-IV is left out; each cell is measured, not run (with its reason), or the paper's '-'."""
    specs = table_specs()
    for name in ("table2", "table3", "table4"):
        spec = specs[name]
        cells = build_cells(spec, [], 1)
        seen = {(b, r, spec.column(c).paper) for (b, r, c) in cells}
        for block, rows in paper_values()[name].items():
            for row, values in rows.items():
                for column in values:
                    assert (block, row, column) in seen, (name, block, row, column)
        pending = [c for c in cells.values() if c.status == "not run"]
        assert all(c.note for c in pending)
    assert len(trials_for(specs["table4"], 2)) == 4 * 4 * 2 + 2 * 2  # LHT1-4 x 4 methods, LHT1*/2* x llm


def test_a_cell_shows_ours_beside_the_papers_value() -> None:
    assert Cell("measured", 60.75, successes=19, trials=20).markdown() == (
        "**95%** (19/20, CI 76%–99%) · paper 60.75%"
    )
    assert Cell("not run", 8.3, note="why").markdown() == "not run · paper 8.3%"
    assert Cell("infeasible", None).markdown() == "– · paper –"


def test_the_generators_own_settings_are_recorded() -> None:
    from taskcond.generator import ConditionGenerator

    made = llm_fields("embedded", ConditionGenerator(backend=None, samples=3, prompt_version="v4"))  # type: ignore[arg-type]
    assert made["prompt_version"] == "v4" and made["generator"]["samples"] == 3
    assert llm_fields("embedded")["generator"]["samples"] == 1


def test_the_novel_primitive_block_counts_its_own_episodes_and_names_what_was_left_out() -> None:
    spec = table_specs()["table4"]
    novel = trials_for(spec, 2, novel_primitive=True)
    methods = ("llm", "llm+demo")  # the LLM's conditions, and the same grounded in the demonstrations
    assert sorted({(t.task, t.method) for t in novel}) == [
        (f"LHT{k}", m) for k in range(1, 5) for m in methods
    ]
    assert len(novel) == 16 and len(trials_for(spec, 2)) == 4 * 4 * 2 + 2 * 2  # the others: another file
    records = [
        {"task": "LHT1", "method": "llm", "seed": 1000, "success": True},  # the "same" block's episode
        {"task": "LHT1", "method": "llm", "seed": 1000, "success": False, "failure": "condition"}
        | {"left_out": "close"},
        {"task": "LHT1", "method": "llm", "seed": 1001, "success": True, "left_out": "grasp"},
    ]
    cells = build_cells(spec, records, 2)
    same, other = cells[("same", "LHT1", "llm")], cells[("novel-primitive", "LHT1", "llm")]
    assert (same.successes, same.trials) == (1, 1)
    assert (other.successes, other.trials, other.paper) == (1, 2, 19.5)
    assert other.failures == {"condition, left out: close": 1}
    from taskcond.reproduce import table_markdown

    md = table_markdown(spec, cells, "")
    assert "LHT1, w/ cond from LLM, failures: 1 × condition, left out: close" in md
    grounded = cells[("same", "LHT1", "llm+demo")]  # beyond the paper: only where a primitive is generalized
    assert grounded.status == "not run" and "novel-primitive block" in grounded.note
