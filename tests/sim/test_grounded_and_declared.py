"""Grounding in real demonstrations, and a primitive beyond the ten end to end (declared, demonstrated,
learned, conditioned by the real embedded LLM and grounded, executed), with real PyBullet."""

from __future__ import annotations

import json
import runpy
from pathlib import Path

import pytest
from typer.testing import CliRunner

pytest.importorskip("pybullet")

from taskcond.application.demonstrations import learn_library
from taskcond.application.episode import run_episode
from taskcond.application.plans import plan_run
from taskcond.cli import app
from taskcond.conditions import TaskCondition, parse_predicate
from taskcond.execution.skills import SkillLibrary
from taskcond.execution.sources import GroundedConditions, demonstration_evidence
from taskcond.generator import ConditionGenerator
from taskcond.grounding import ground
from taskcond.llm.cache import CachedBackend
from taskcond.primitives import PRIMITIVES, load_primitives, unregister_primitive

pytestmark = pytest.mark.sim
EXAMPLES = Path(__file__).parents[2] / "examples"


def condition(task: str, pre: list[str], post: list[str]) -> TaskCondition:
    objects = (task.split()[-1], "gripper")
    return TaskCondition(task, objects, tuple(map(parse_predicate, pre)), tuple(map(parse_predicate, post)))


@pytest.fixture(scope="module")
def library_dir(tmp_path_factory):
    directory = tmp_path_factory.mktemp("skills")
    learn_library(directory, ["open-box"])
    return directory


def test_a_real_demonstration_grounds_a_wrong_condition(library_dir) -> None:
    """The suite's demonstration of 'open box', renamed by role to another container, corrects an answer
    that has the container open before and closed after."""
    library = SkillLibrary.load(library_dir)
    evidence = demonstration_evidence(library, "open microwave")
    assert parse_predicate("microwave closed") in evidence.start
    assert parse_predicate("microwave open") in evidence.end
    assert "box" not in {o for p in evidence.start | evidence.end for o in p.objects}
    wrong = condition(
        "open microwave", ["gripper grasping microwave", "microwave open"], ["microwave closed"]
    )
    result = ground(wrong, evidence)
    cond = result.condition
    assert set(cond.pre_conditions) == {
        parse_predicate("gripper not grasping"),
        parse_predicate("microwave closed"),
    }
    assert set(cond.post_conditions) == {
        parse_predicate("gripper not grasping"),
        parse_predicate("microwave open"),
    }
    assert {str(r) for r in result.repairs} >= {
        "pre: 'microwave open' -> 'microwave closed' (the demonstration's start shows 'microwave closed')"
    }


@pytest.mark.llm
def test_a_declared_push_end_to_end(library_dir, tmp_path, embedded_backend, monkeypatch) -> None:
    runner = CliRunner()
    toml = str(EXAMPLES / "push.toml")
    try:
        demo = tmp_path / "push.json"
        runpy.run_path(str(EXAMPLES / "push_demo.py"))["push_demonstration"]().save(demo)
        unregister_primitive("push_in_front")  # the script declared it
        # undeclared, the task is refused; declared, its demonstration is learned into the library
        refused = runner.invoke(app, ["learn", "--demo", str(demo), "--out", str(library_dir)])
        assert refused.exit_code == 2 and "unknown verb 'push'" in refused.output
        res = runner.invoke(
            app, ["learn", "--primitives", toml, "--demo", str(demo), "--out", str(library_dir)]
        )
        assert res.exit_code == 0, res.output
        assert "learned push_in_front-cube-bowl" in res.output
        library = SkillLibrary.load(library_dir)
        skill = library.skills["push_in_front-cube-bowl"]
        assert parse_predicate("cube in front of bowl") in skill.evidence.end - skill.evidence.start

        # conditioned by the LLM (generalization: it has no example) and grounded in the demonstration
        load_primitives(toml)
        backend = CachedBackend(embedded_backend, tmp_path / "responses")
        source = GroundedConditions(ConditionGenerator(backend), library)
        grounded = source.grounded("push cube in front of bowl")
        cond = grounded.condition
        assert parse_predicate("gripper not grasping") in cond.pre_conditions
        assert parse_predicate("cube in front of bowl") in cond.post_conditions
        assert not any(
            str(p).startswith("gripper grasping") for p in (*cond.pre_conditions, *cond.post_conditions)
        )

        # the command line prints the same repairs (its answers from the cache just written)
        monkeypatch.setenv("TASKCOND_CACHE_DIR", str(tmp_path))
        monkeypatch.delenv("TASKCOND_LLM", raising=False)
        monkeypatch.setenv("TASKCOND_CONFIG", str(tmp_path / "none.toml"))
        args = ["conditions", "--primitives", toml, "--explain", "--skills", str(library_dir)]
        res = runner.invoke(app, [*args, "push cube in front of bowl"])
        assert res.exit_code == 0, res.output
        assert res.stdout.rstrip().endswith(cond.to_text())
        assert f"grounded in the demonstration: {len(grounded.repairs)} repair(s)" in res.stdout
        assert all(f"#   {r}" in res.stdout for r in grounded.repairs)

        # executed on another seed: the cube ends in front of the bowl, the trace holds the repairs
        result = run_episode(plan_run("push cube in front of bowl"), "llm+demo", 1001, library, source)
        assert result.success, (result.reason, [e["message"] for e in result.events][-5:])
        repairs = [e for e in result.events if e["kind"] == "repair"]
        assert [r["repairs"] for r in repairs] == (
            [[r.to_dict() for r in grounded.repairs]] if grounded.repairs else []
        )
        json.dumps(result.events)
    finally:
        if "push_in_front" in PRIMITIVES:
            unregister_primitive("push_in_front")
