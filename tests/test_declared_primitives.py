"""Primitives beyond the paper's ten, declared by a user (primitives.register_primitive, load_primitives),
and demonstration files (execution.demofile)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from taskcond.conditions import parse_predicate
from taskcond.execution.demofile import DemoFileError, RecordedTrajectory, load_trajectory
from taskcond.execution.planner import named_effects
from taskcond.generator import ConditionGenerator, example_turns
from taskcond.primitives import (
    PRIMITIVES,
    TaskNameError,
    load_primitives,
    parse_task,
    register_primitive,
    task_for_condition,
    unregister_primitive,
)

TOML = """
[[primitive]]
id = "push_in_front"
pattern = "push A in front of B"
aliases = ["slide A in front of B"]
target = "A"
movable = ["A"]

[[primitive]]
id = "move_below"
pattern = "move A below B"
achieves = "a below b"
approach = "carry"
target = "B"
movable = ["A"]
"""


@pytest.fixture
def declared(tmp_path):
    path = tmp_path / "prims.toml"
    path.write_text(TOML)
    prims = load_primitives(path)
    yield prims
    for prim in prims:
        unregister_primitive(prim.id)


def test_declared_primitives_parse_like_the_built_in_ones(declared) -> None:
    assert [p.id for p in declared] == ["push_in_front", "move_below"]
    task = parse_task("Slide the toothpaste in front of the coffee mug")
    assert task.primitive.id == "push_in_front" and task.objects == ("toothpaste", "coffee mug")
    assert task.name == "push toothpaste in front of coffee mug"
    assert (task.primitive.target, task.primitive.movable, task.primitive.declared) == (0, (0,), True)
    below = parse_task("move ball below table")
    assert below.primitive.id == "move_below" and below.primitive.target == 1
    # the built-in "move A to position" still parses, and declaring the same thing again is allowed
    assert parse_task("move bottle to position").primitive.id == "move"
    assert register_primitive(**_MOVE_BELOW) is PRIMITIVES["move_below"]
    assert all(p.problems() == [] for p in declared)


def test_what_a_declared_primitive_achieves_is_read_by_alg_1_and_the_planner(declared) -> None:
    """Its effect is first-class: Cond2Task raises it for its condition (before, ``A below B`` was the
    converse's ``move B on top of A``), and the planner counts it as the task's effect."""
    below = parse_predicate("ball below table")
    assert task_for_condition(below) == "move ball below table"
    assert named_effects("move ball below table") == (below,)
    assert named_effects("push ball in front of table") == ()
    unregister_primitive("move_below")
    assert task_for_condition(below) == "move table on top of ball"
    register_primitive(**_MOVE_BELOW)


_MOVE_BELOW = {
    "id": "move_below",
    "pattern": "move A below B",
    "achieves": "A below B",
    "approach": "carry",
    "target": "B",
    "movable": ["A"],
}


def test_without_a_declaration_the_task_is_refused() -> None:
    with pytest.raises(TaskNameError, match="does not match a task pattern"):
        parse_task("move ball below table")


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"id": "Push", "pattern": "push A"}, "lower case letters"),
        ({"id": "push", "pattern": "push B"}, "A, B, ... once each, in order"),
        ({"id": "push", "pattern": "A pushes B"}, "start with a verb"),
        ({"id": "push", "pattern": "push A", "target": "B"}, "not one of the pattern's letters"),
        ({"id": "grasp", "pattern": "seize A"}, "built-in primitive"),
        ({"id": "take", "pattern": "grasp A"}, "already a pattern of 'grasp'"),
        ({"id": "push", "pattern": "push A into B", "aliases": ["shove A"]}, "alias 'shove A'"),
        ({"id": "push", "pattern": "push A into B", "achieves": "A inside C"}, "must name A, B once each"),
        ({"id": "push", "pattern": "push A", "achieves": "A inside box"}, "must name A once each"),
        ({"id": "push", "pattern": "push A", "achieves": "A wobbly"}, "not a condition"),
        ({"id": "push", "pattern": "push A into B", "achieves": "gripper not grasping"}, "on one object"),
        ({"id": "push", "pattern": "push A", "approach": "fly"}, "approach 'fly' is not one of"),
        ({"id": "push", "pattern": "push A", "approach": "carry"}, "carrying approach needs"),
        ({"id": "push", "pattern": "push A", "idempotent": True}, "is idempotent"),
    ],
)
def test_bad_declarations_are_refused_with_a_reason(kwargs, message) -> None:
    with pytest.raises(TaskNameError, match=message):
        register_primitive(**kwargs)
    assert "push" not in PRIMITIVES


def test_bad_declaration_files_name_the_file(tmp_path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text('[[primitive]]\nid = "push"\npatern = "push A"\n')
    with pytest.raises(TaskNameError, match=r"bad.toml: primitive 1 needs at least 'id' and 'pattern'"):
        load_primitives(bad)
    bad.write_text('[[primitive]]\nid = "push"\npattern = "push A"\ncolour = "red"\n')
    with pytest.raises(TaskNameError, match=r"unknown field\(s\) \['colour'\]"):
        load_primitives(bad)
    with pytest.raises(TaskNameError, match="cannot read primitives"):
        load_primitives(tmp_path / "missing.json")
    js = tmp_path / "p.json"
    js.write_text(json.dumps({"primitive": [{"id": "wipe", "pattern": "wipe A"}]}))
    assert load_primitives(js)[0].pattern == "wipe A"
    unregister_primitive("wipe")


def test_a_declared_primitive_is_always_generalized_without_examples_of_its_own(declared) -> None:
    turns = example_turns("spatial")
    assert len(turns) == 10  # the paper's ten examples, none for the declared primitives
    gen = ConditionGenerator(backend=None, prompt_version="v7")  # type: ignore[arg-type]
    messages, _ = gen.layout("spatial", parse_task("push cube in front of bowl"), ("push_in_front",))
    text = "\n".join(m.content for m in messages)
    assert "push A in front of B" in text and "move A in front of B" in text


def _trajectory() -> RecordedTrajectory:
    t = np.arange(5) * 0.1
    positions = np.stack([0.3 + t, np.zeros(5), 0.2 + 0 * t], axis=1)
    orientations = np.tile([1.0, 0.0, 0.0, 0.0], (5, 1))
    return RecordedTrajectory(
        "grasp bottle", None, 3, t, positions, orientations, np.array([0, 0, 1, 1, 1.0])
    )


def test_demonstration_files_round_trip_and_resample(tmp_path) -> None:
    path = _trajectory().save(tmp_path / "demo.json")
    data = json.loads(path.read_text())
    assert data["format"] == "taskcond-demonstration/1" and data["objects"] == {"A": "bottle"}
    back = load_trajectory(path)
    assert back.task_name == "grasp bottle" and back.seed == 3 and back.scene is None
    actions = back.actions(0.05)
    assert actions.shape == (9, 8)
    np.testing.assert_allclose(actions[1, :3], [0.35, 0.0, 0.2])
    assert list(actions[:, 7]) == [0, 0, 0, 0, 1, 1, 1, 1, 1]  # the gripper command is held, not blended


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"format": "v0"}, "format 'v0'"),
        ({"task_name": "juggle bottle"}, "unknown verb 'juggle'"),
        ({"objects": {"A": "mug"}}, "disagree with the task name"),
        ({"positions": [[0, 0]] * 5}, r"'positions' must be finite numbers of shape \(n, 3\) or \(n, 6\)"),
        ({"gripper": [0, 1]}, "one row per sample"),
        ({"times": [0, 1, 1, 2, 3]}, "increasing"),
    ],
)
def test_bad_demonstration_files_are_refused_with_a_reason(tmp_path, change, message) -> None:
    data = _trajectory().to_dict() | change
    path = tmp_path / "demo.json"
    path.write_text(json.dumps(data))
    with pytest.raises(DemoFileError, match=message):
        load_trajectory(path)
