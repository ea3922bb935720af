"""The command line: output formats, exit codes and one-line errors."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest
from typer.testing import CliRunner

from taskcond.cli import app, main
from taskcond.conditions import TaskCondition
from taskcond.generator import ConditionGenerator
from taskcond.llm.config import LLMConfig
from taskcond.primitives import PRIMITIVES

runner = CliRunner()


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["conditions", ""], "error: empty task name; valid patterns: grasp A"),
        (["conditions", "jump over box"], "error: unknown verb 'jump'"),
        (["conditions", "move bottle"], "error: 'move bottle' does not match a task pattern"),
        (
            ["conditions", "open box", "--exclude", "opening"],
            "error: unknown primitive 'opening'; valid: grasp",
        ),
        (["conditions", "open box", "--llm", "gpt5"], "error: [config] unknown backend 'gpt5'"),
        (["conditions", "open box", "--grammar", "maybe"], "error: --grammar 'maybe'"),
        (["eval", "conditions", "--primitive", "jump"], "error: unknown primitive 'jump'"),
        (
            ["oracle", "grasp-unicorn"],
            "error: unknown object(s) 'unicorn' for primitive 'grasp'; valid: bottle",
        ),
        (["oracle", "grasp-bottle", "--video", "x.avi"], "error: --video x.avi: use a .mp4 or .gif"),
        (
            ["conditions", "open box", "--prompt-version", "v9"],
            "error: --prompt-version 'v9': use one of v1, v2, v3, v4",
        ),
        (
            ["run", "LHT1", "--method", "magic"],
            "error: --method 'magic': use one of llm, llm+demo, env, none",
        ),
        (["run", "LHT1", "--planner", "magic"], "error: --planner 'magic': use one of conditions, none"),
        (["run", ""], "error: empty instruction; give a suite task id"),
        (["run", " \t "], "error: empty instruction; give a suite task id"),
        (["learn", "--task", "grasp-unicorn"], "error: unknown object(s) 'unicorn' for primitive 'grasp'"),
        (["eval", "long-horizon", "--task", "LHT9"], "error: 'LHT9' is not a long-horizon task"),
        (
            ["eval", "primitives", "--method", "magic"],
            "error: --method 'magic': use one of llm, llm+demo, env, none, image-il",
        ),
        (["learn", "--method", "magic"], "error: --method 'magic': use dmp or image-il"),
        (
            ["learn", "--method", "image-il", "--task", "LHT1"],
            "error: --method image-il learns from the suite",
        ),
    ],
)
def test_bad_input_is_a_one_line_error_with_exit_code_2(args, message, monkeypatch, tmp_path):
    monkeypatch.setenv("TASKCOND_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.chdir(tmp_path)
    result = runner.invoke(app, args)
    assert result.exit_code == 2, result.output
    assert result.stderr.startswith(message)
    assert result.stderr.count("\n") == 1 and "Traceback" not in result.output
    assert not (tmp_path / "runs").exists() and not (tmp_path / "cache").exists()  # nothing ran


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["run", "LHT1", "--noise", "-1"], "error: Invalid value for '--noise'"),
        (["oracle", "grasp-bottle", "--episodes", "0"], "error: Invalid value for '--episodes'"),
        (["run"], "error: Missing argument 'spec'; see 'taskcond run --help'"),
        (["conditions", "open box", "--bogus"], "error: No such option: --bogus"),
        (["fly"], "error: No such command 'fly'; see 'taskcond --help'"),
    ],
)
def test_usage_errors_of_the_console_entry_point_are_one_line(args, message, capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(args)
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith(message)
    assert err.count("\n") == 1


def test_console_entry_point_passes_exit_codes_through(capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["conditions", "jump over box"])
    assert exit_info.value.code == 2
    assert capsys.readouterr().err.startswith("error: unknown verb 'jump'")
    with pytest.raises(SystemExit) as exit_info:
        main(["tasks", "--json"])
    assert exit_info.value.code == 0
    assert json.loads(capsys.readouterr().out)


def test_a_closed_pipe_ends_quietly():
    """``taskcond tasks | head -1``: the reader is gone before the listing is written (the read end is
    closed first, so the write fails for certain); the command exits without a traceback."""
    read, write = os.pipe()
    os.close(read)
    try:
        proc = subprocess.run(
            [sys.executable, "-m", "taskcond.cli", "tasks"], stdout=write, stderr=subprocess.PIPE, timeout=120
        )
    finally:
        os.close(write)
    assert "Traceback" not in proc.stderr.decode()
    assert proc.returncode == 1


def test_openai_without_key_names_the_variable(monkeypatch, tmp_path):
    monkeypatch.delenv("OPENAI_API_KEY", raising=False)
    monkeypatch.delenv("OPENAI_BASE_URL", raising=False)
    monkeypatch.setenv("TASKCOND_CONFIG", str(tmp_path / "none.toml"))
    result = runner.invoke(app, ["conditions", "open box", "--llm", "openai"])
    assert result.exit_code == 2
    assert (
        result.stderr.strip()
        == "error: [openai] no API key: set OPENAI_API_KEY, or OPENAI_BASE_URL for a local server"
    )


def test_tasks_lists_the_suite_as_json():
    result = runner.invoke(app, ["tasks", "--json"])
    assert result.exit_code == 0
    data = json.loads(result.stdout)
    assert {t["kind"] for t in data} == {"primitive", "long-horizon"}
    for task in data:
        assert {"id", "kind", "primitive", "objects"} <= set(task)
        if task["kind"] == "primitive":
            assert task["primitive"] in PRIMITIVES
        else:
            assert all(p in PRIMITIVES for p in task["primitive"])
            assert len(task["steps"]) == len(task["primitive"])
    lht1 = next(t for t in data if t["id"] == "LHT1")
    assert lht1["primitive"][:2] == ["grasp", "move_into"]
    assert {"LHT1", "LHT2", "LHT3", "LHT1*", "LHT2*"} <= {t["id"] for t in data}


def test_tasks_text_shows_the_patterns():
    result = runner.invoke(app, ["tasks"])
    assert result.exit_code == 0
    for prim in PRIMITIVES.values():
        assert prim.pattern in result.stdout


@pytest.mark.llm
def test_conditions_from_the_cache_need_no_model():
    """A repeated run is answered from the on-disk cache (the session's, where the model's answer was put):
    identical, and the model is never loaded."""
    expected = ConditionGenerator.from_config(LLMConfig.load(None)).generate("close box")
    assert expected.model == "embedded:qwen2.5-coder-0.5b"
    result = runner.invoke(app, ["conditions", "close box", "--json"])
    assert result.exit_code == 0, result.output
    assert TaskCondition.from_json(result.stdout) == expected.condition
    assert "from cache" not in result.stdout
    text = runner.invoke(app, ["conditions", "close box"])
    assert text.stdout.strip() == expected.condition.to_text()
    assert "from cache" in text.stderr
