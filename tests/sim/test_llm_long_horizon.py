"""Long-horizon tasks of the paper's Table I through the executor with conditions the real embedded model
writes (§III-B), each from the demonstration of the task itself (as ``taskcond learn`` does): LHT3 (a mug
placed, toothpaste put into it) and LHT4 (the spatula onto the cloth, then the two-arm fold)."""

from __future__ import annotations

import pytest

pytest.importorskip("pybullet")

from taskcond.application.demonstrations import learn_library
from taskcond.application.episode import run_episode
from taskcond.application.plans import plan_run
from taskcond.execution.sources import LLMConditions
from taskcond.generator import ConditionGenerator

pytestmark = [pytest.mark.sim, pytest.mark.llm]


@pytest.mark.parametrize("task", ["LHT3", "LHT4"])
def test_a_long_horizon_task_with_embedded_llm_conditions(task, tmp_path, cached_llm) -> None:
    library = learn_library(tmp_path, [task])
    source = LLMConditions(ConditionGenerator(cached_llm))
    plan = plan_run(task)
    result = run_episode(plan, "llm", 1000, library, source)
    assert result.success, (result.reason, [e["message"] for e in result.events][-6:])
    assert set(result.conditions) == set(plan.steps) and result.goal_missing == []
    assert all(c["collisions"] for c in result.conditions.values())  # each names what it may touch
