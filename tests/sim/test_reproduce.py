"""Evaluations that say how they were made, resume only their own configuration and retry crashes;
``taskcond reproduce`` at tiny scale; the Ray backend against local processes. Real PyBullet episodes."""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

pytest.importorskip("pybullet")

from taskcond.application.demonstrations import learn_library
from taskcond.application.evaluate import evaluate, execution_config
from taskcond.cli import app
from taskcond.results import Job, ResultsFile

pytestmark = pytest.mark.sim
runner = CliRunner()


@pytest.fixture(scope="module")
def library_dir(tmp_path_factory):
    directory = tmp_path_factory.mktemp("skills")
    learn_library(directory, ["grasp-bottle", "LHT1"])
    return directory


def lines(path) -> list[dict]:
    return [json.loads(line) for line in path.read_text().splitlines()]


def test_another_noise_in_the_same_file_is_an_error_and_an_identical_rerun_is_free(library_dir, tmp_path):
    out = tmp_path / "F.jsonl"
    args = ["eval", "primitives", "--task", "grasp-bottle", "--episodes", "2", "--method", "none"]
    args += ["--workers", "1", "--out", str(out), "--skills", str(library_dir)]
    first = runner.invoke(app, [*args, "--noise", "0.0"])
    assert first.exit_code == 0, first.output
    header, *records = lines(out)
    assert header["config"]["noise"] == 0.0 and header["config"]["skills"].startswith(library_dir.name)
    assert [r["seed"] for r in records] == [1000, 1001]
    assert all(r["digest"] == header["digest"] for r in records)

    other = runner.invoke(app, [*args, "--noise", "0.08"])
    assert other.exit_code == 2
    assert "holds results of another configuration (noise: 0.0 (file) vs 0.08 (now))" in other.output
    assert len(lines(out)) == 3  # nothing appended

    again = runner.invoke(app, [*args, "--noise", "0.0"])
    assert again.exit_code == 0 and "grasp-bottle" in again.output and "2/2" in again.output
    assert len(lines(out)) == 3  # reused, nothing run


def test_a_crashed_episode_is_retried_and_never_counted(library_dir, tmp_path):
    results = ResultsFile(tmp_path / "r.jsonl", execution_config(library_dir, 0.005))
    # what an earlier run left: seed 1000 crashed (an exception, not a task failure)
    results.append({"task": "grasp-bottle", "method": "none", "seed": 1000, "crashed": True, "error": "X: y"})
    jobs = [Job("grasp-bottle", "none", 1000), Job("no-such-task", "none", 1000)]
    records = evaluate(jobs, results, library_dir, workers=1)
    assert [(r["task"], r["success"]) for r in records] == [("grasp-bottle", True)]  # retried
    crashes = results.crashes()
    assert crashes[-1]["task"] == "no-such-task" and "neither a suite task id" in crashes[-1]["error"]
    evaluate(jobs, results, library_dir, workers=1)  # the crash is tried again, the success reused
    assert [r["task"] for r in results.crashes()].count("no-such-task") == 2
    assert len(results.results()) == 1


def test_the_trace_of_a_run_carries_its_configuration(library_dir, tmp_path):
    trace = tmp_path / "t.json"
    args = ["run", "grasp-bottle", "--method", "none", "--no-video", "--noise", "0.01"]
    res = runner.invoke(app, [*args, "--skills", str(library_dir), "--trace", str(trace)])
    assert res.exit_code == 0, res.output
    data = json.loads(trace.read_text())
    assert data["config"]["noise"] == 0.01 and data["config"]["kind"] == "execution"
    assert data["digest"] == execution_config(library_dir, 0.01).digest


def test_reproduce_writes_the_table_and_resumes(library_dir, tmp_path):
    out = tmp_path / "repro"
    args = ["reproduce", "table4", "--row", "LHT1", "--column", "none", "--episodes", "1", "--workers", "1"]
    args += ["--skills", str(library_dir), "--out", str(out)]
    res = runner.invoke(app, args)
    assert res.exit_code == 0, res.output
    assert {p.name for p in out.iterdir()} == {"table4.md", "table4.json", "table4.png", "table4.jsonl"}
    md = (out / "table4.md").read_text()
    assert "| LHT1 | not run · paper 0.8% | **100%** (1/1, CI 21%–100%) · paper 50% |" in md
    assert "Image-based IL baseline: not run, not selected (--column)" in md  # why the baseline is not run
    table = json.loads((out / "table4.json").read_text())
    cell = table["blocks"][0]["rows"][0]["cells"]["none"]
    assert cell["trials"] == 1 and cell["paper"] == 50 and cell["ci95"][1] == 1.0
    assert table["config"]["digest"] == lines(out / "table4.jsonl")[0]["digest"]
    assert (out / "table4.png").read_bytes()[:4] == b"\x89PNG"
    before = (out / "table4.jsonl").read_text()
    again = runner.invoke(app, args)
    assert again.exit_code == 0 and (out / "table4.jsonl").read_text() == before  # resumed: nothing run
    bad = runner.invoke(app, ["reproduce", "table9", "--out", str(out)])
    assert bad.exit_code == 2 and "use one of table2, table3, table4, all or robosuite" in bad.output
    parallel = runner.invoke(app, ["reproduce", "robosuite", "--workers", "2", "--out", str(tmp_path / "rs")])
    assert parallel.exit_code == 2
    assert "--workers, --backend and --ray-address do not apply" in parallel.output
    assert parallel.output.count("\n") == 1 and not (tmp_path / "rs").exists()


@pytest.fixture
def own_ray():
    """A new local Ray instance of two CPUs for this test alone, never a cluster that happens to be up (the
    backend uses a Ray session its caller started as it is)."""
    ray = pytest.importorskip("ray", reason="Ray is not installed (extra [ray])")
    ray.init(address="local", num_cpus=2, include_dashboard=False, log_to_driver=False, logging_level="ERROR")
    yield ray
    ray.shutdown()


def test_ray_gives_the_same_episodes_as_local_processes(library_dir, tmp_path, own_ray):
    jobs = [Job("grasp-bottle", "none", 1000 + k) for k in range(2)] + [Job("LHT1", "env", 1000)]
    config = execution_config(library_dir, 0.005)
    local = evaluate(jobs, ResultsFile(tmp_path / "local.jsonl", config), library_dir, workers=1)
    remote = evaluate(jobs, ResultsFile(tmp_path / "ray.jsonl", config), library_dir, 2, backend="ray")
    fields = ("success", "failure", "sim_seconds", "adjustments", "raised")

    def by_key(records):
        return {(r["task"], r["method"], r["seed"]): tuple(r[f] for f in fields) for r in records}

    assert len(remote) == 3 and by_key(remote) == by_key(local)


def test_reproduce_table2_scores_the_demonstrations_conditions(library_dir, tmp_path):
    """Table II's FromEnv column: each demonstration's condition against the reference (no LLM)."""
    args = ["reproduce", "table2", "--row", "grasp", "--column", "generation-env"]
    res = runner.invoke(app, [*args, "--skills", str(library_dir), "--out", str(tmp_path)])
    assert res.exit_code == 0, res.output
    cells = json.loads((tmp_path / "table2.json").read_text())["blocks"][0]["rows"][0]["cells"]
    assert cells["generation-env"]["trials"] == 1  # the library holds one grasp demonstration
    assert cells["generation-env"]["successes"] == 1 and cells["generation-env"]["paper"] == 100
    assert cells["generation-llm"]["status"] == "not run"
    assert cells["generalization-env"]["status"] == "infeasible"


def test_reproduce_table2_refuses_the_grounded_column_before_the_llm_without_a_demonstration(
    library_dir, tmp_path
):
    """The library holds no fold demonstration: the grounded column is refused at once, in one line, and
    nothing is asked or written."""
    args = ["reproduce", "table2", "--row", "fold", "--column", "generalization-grounded", "--episodes", "1"]
    res = runner.invoke(app, [*args, "--skills", str(library_dir), "--out", str(tmp_path)])
    assert res.exit_code == 2
    assert "fold" in res.output and "grounded column needs it" in res.output
    assert len(res.output.strip().splitlines()) == 1
    assert not (tmp_path / "table2.jsonl").exists()


@pytest.mark.llm
def test_reproduce_table2_grounds_the_generalization_answer_in_the_demonstration(library_dir, tmp_path):
    """Table II's grounded column: the leave-one-out answer (the embedded LLM), grounded in the grasp
    demonstration, matches the reference; its record lists the repairs and any extra relation."""
    args = ["reproduce", "table2", "--row", "grasp", "--episodes", "1"]
    args += ["--column", "generalization-llm", "--column", "generalization-grounded"]
    res = runner.invoke(app, [*args, "--skills", str(library_dir), "--out", str(tmp_path)])
    assert res.exit_code == 0, res.output
    cells = json.loads((tmp_path / "table2.json").read_text())["blocks"][0]["rows"][0]["cells"]
    assert cells["generalization-llm"]["trials"] == cells["generalization-grounded"]["trials"] == 1
    assert cells["generalization-grounded"]["successes"] == 1
    assert cells["generalization-grounded"]["paper"] is None  # beyond the paper
    (grounded,) = [
        r for r in lines(tmp_path / "table2.jsonl") if r.get("method") == "generalization-grounded"
    ]
    assert grounded["extra_relations"] == [] and isinstance(grounded["repairs"], list)
    assert "Generalization, LLM + demo" in (tmp_path / "table2.md").read_text()
