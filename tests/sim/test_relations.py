"""One meaning per relation: the suite's judge and the perceiver (ground-truth boxes, no noise) agree on every
spatial relation between every pair of objects of seeded kitchen scenes, before and after oracle episodes."""

from __future__ import annotations

import itertools

import pytest

pytest.importorskip("pybullet")

from taskcond.conditions import Relation, SpatialRelation
from taskcond.envs.kitchen import KitchenEnv
from taskcond.sim.perception import Perception, PerceptionConfig
from taskcond.tasks.oracle import run_episode
from taskcond.tasks.registry import make

pytestmark = pytest.mark.sim

TASKS = (
    "move_into-bowl-top_drawer",
    "move_on_top-bottle-box",
    "move_in_front-mug-box",
    "move_into-bottle-box",
)
"""Oracle episodes after which an ``inside``, an ``above`` and an ``in front of`` hold (besides the objects'
``above table``)."""


def judged_and_perceived(env: KitchenEnv) -> tuple[set[SpatialRelation], set[SpatialRelation]]:
    """The relations the judge finds between every ordered pair of the perceiver's objects (grippers apart),
    and those the perceiver reports between them."""
    scene = env.scene
    perception = Perception(scene.description(), PerceptionConfig(check_visibility=False))
    info = perception.observe(0)
    grippers = {g.name for g in scene.grippers}
    objects = sorted(set(info.boxes) - grippers)
    judged = {
        pred
        for a, b in itertools.permutations(objects, 2)
        for relation in Relation
        if env.truth.holds(pred := SpatialRelation(a, relation, b))
    }
    perceived = {
        pred
        for pred in info.predicates
        if isinstance(pred, SpatialRelation) and pred.subject in objects and pred.reference in objects
    }
    return judged, perceived


def test_judge_and_perceiver_agree_at_reset_and_after_the_oracle() -> None:
    found: set[Relation] = set()
    for seed, task in enumerate(TASKS):
        env = make(task)
        try:
            env.reset(seed=seed)
            judged, perceived = judged_and_perceived(env)
            assert judged == perceived, (task, seed, "reset")
            ok, reason, _, _ = run_episode(env, seed)
            assert ok, (task, seed, reason)
            judged, perceived = judged_and_perceived(env)
            assert judged == perceived, (task, seed, "after the oracle")
            assert set(env.task.post_conditions()) <= judged
            found |= {pred.relation for pred in judged}
        finally:
            env.close()
    assert found == set(Relation)
