"""Table IV's novel primitive tasks: each episode leaves one primitive of its long-horizon task out of the
LLM's examples, drawn from the episode's seed; that primitive's condition is generalized with the examples
in an order the episode's seed draws, and each draw is cached. Real suite tasks and the real embedded LLM."""

from __future__ import annotations

import pytest
from typer.testing import CliRunner

pytest.importorskip("pybullet")

from taskcond.application.condition_sources import left_out_primitive, novel_primitive_source
from taskcond.cli import app
from taskcond.execution.skills import SkillLibrary
from taskcond.execution.sources import EnvConditions, LLMConditions
from taskcond.generator import ConditionGenerator
from taskcond.llm.cache import CachedBackend
from taskcond.primitives import parse_task
from taskcond.tasks.registry import get_task

pytestmark = pytest.mark.sim


def test_the_left_out_primitive_is_drawn_from_the_task_by_the_episode_seed() -> None:
    for task in ("LHT1", "LHT2", "LHT3", "LHT4"):
        primitives = {parse_task(s).primitive.id for s in get_task(task).info.primitive}
        drawn = [left_out_primitive(task, seed) for seed in range(1000, 1040)]
        assert set(drawn) == primitives  # every primitive of the task comes up in 40 episodes
        assert drawn == [left_out_primitive(task, seed) for seed in range(1000, 1040)]  # seeded
    with pytest.raises(ValueError, match="grasp-bottle is a primitive task"):
        left_out_primitive("grasp-bottle", 1000)
    with pytest.raises(ValueError, match="need LLM conditions"):
        novel_primitive_source(EnvConditions(SkillLibrary({})), "LHT1", 1000)


def test_novel_primitive_needs_llm_conditions_and_a_long_horizon_evaluation() -> None:
    runner = CliRunner()
    args = ["eval", "long-horizon", "--novel-primitive", "--task", "LHT1"]
    env = runner.invoke(app, [*args, "--method", "env"])
    assert env.exit_code == 2 and "--method 'env' with --novel-primitive" in env.output
    assert "use one of llm, llm+demo" in env.output
    prim = runner.invoke(app, ["eval", "primitives", "--novel-primitive", "--task", "grasp-bottle"])
    assert prim.exit_code == 2 and "applies to `taskcond eval long-horizon` only" in prim.output


@pytest.mark.llm
def test_each_episode_draws_its_own_generalization_and_a_rerun_is_cached(embedded_backend, tmp_path) -> None:
    generator = ConditionGenerator(CachedBackend(embedded_backend, tmp_path))
    base = LLMConditions(generator)
    first = base.leaving_out("close", 1000)
    novel = first.generate("close box")
    assert novel.mode == "generalization" and novel.excluded == ("close",) and not novel.cached
    task = parse_task("close box")
    asked = novel.transcripts[0].messages
    assert asked == generator.layout("code", task, ("close",), 1000)[0]  # the episode's example order
    assert asked != generator.layout("code", task, ("close",), 1001)[0]  # another episode asks another
    assert first.generate("close box").cached  # the same draw again: from the cache
    seen = first.generate("grasp bottle")
    assert seen.mode == "generation" and seen.excluded == ("close",)
    shown = "\n".join(m.content for m in seen.transcripts[0].messages)
    assert "close A" not in shown and "grasp A" in shown  # the left-out primitive's example is not shown
    assert base.leaving_out("close", 1001).generate("grasp bottle").cached  # seen primitives: one answer
