"""The task-condition data model: predicates, text and JSON round-trips (paper Listing 1)."""

import json

import pytest

from taskcond.conditions import (
    Collision,
    ConditionError,
    ContainerState,
    GripperState,
    Relation,
    SpatialRelation,
    TaskCondition,
    about_gripper_place,
    contradictions,
    converse,
    parse_predicate,
)
from taskcond.examples import example_conditions

LISTING_1 = """Task name: move bottle into box
Relevant objects: bottle, box, gripper
Pre-conditions:
  gripper grasping bottle
  box open
Post-conditions:
  bottle inside box
  gripper inside box
  gripper grasping bottle
  box open
Collisions: gripper and bottle"""


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("bottle inside box", SpatialRelation("bottle", Relation.INSIDE, "box")),
        ("coffee mug above top drawer", SpatialRelation("coffee mug", Relation.ABOVE, "top drawer")),
        ("A below B", SpatialRelation("a", Relation.BELOW, "b")),
        ("mug in front of bowl", SpatialRelation("mug", Relation.IN_FRONT_OF, "bowl")),
        ("gripper grasping coffee mug", GripperState("coffee mug")),
        ("gripper not grasping", GripperState(None)),
        ("kinova gripper grasping cloth", GripperState("cloth", "kinova gripper")),
        ("top drawer open", ContainerState("top drawer", True)),
        ("  Box   Closed ", ContainerState("box", False)),
    ],
)
def test_parse_predicate_and_canonical_string(text, expected):
    pred = parse_predicate(text)
    assert pred == expected
    assert parse_predicate(str(pred)) == pred


@pytest.mark.parametrize(
    "text", ["bottle near box", "gripper holding bottle", "", "gripper open", "a and b inside c"]
)
def test_parse_predicate_rejects_words_outside_the_vocabulary(text):
    with pytest.raises(ConditionError, match=r"not a condition|invalid object name|empty"):
        parse_predicate(text)


def test_listing_1_round_trips_exactly_through_text_and_json():
    cond = TaskCondition.from_text(LISTING_1)
    assert cond.to_text() == LISTING_1
    assert TaskCondition.from_json(cond.to_json()) == cond
    data = json.loads(cond.to_json())
    assert data == {
        "task_name": "move bottle into box",
        "relevant_objects": ["bottle", "box", "gripper"],
        "pre_conditions": ["gripper grasping bottle", "box open"],
        "post_conditions": ["bottle inside box", "gripper inside box", "gripper grasping bottle", "box open"],
        "collisions": [["gripper", "bottle"]],
    }


def test_every_example_round_trips():
    for cond in example_conditions().values():
        assert TaskCondition.from_text(cond.to_text()) == cond
        assert TaskCondition.from_json(cond.to_json()) == cond


def test_matches_ignores_order_and_collision_direction():
    a = TaskCondition.from_text(LISTING_1)
    b = TaskCondition(
        "move bottle into box",
        ("gripper", "box", "bottle"),
        tuple(reversed(a.pre_conditions)),
        tuple(reversed(a.post_conditions)),
        (Collision("bottle", "gripper"),),
    )
    assert a.matches(b)
    c = TaskCondition(a.task_name, a.relevant_objects, a.pre_conditions[:1], a.post_conditions, a.collisions)
    assert not a.matches(c)


def test_split_and_merge_give_back_the_condition():
    cond = TaskCondition.from_text(LISTING_1)
    spatial, states = cond.only(spatial=True), cond.only(spatial=False)
    assert all(isinstance(p, SpatialRelation) for p in (*spatial.pre_conditions, *spatial.post_conditions))
    assert not states.collisions
    assert TaskCondition.merge(spatial, states).matches(cond)


def test_empty_sections_are_written_as_none():
    cond = TaskCondition("fold cloth", ("cloth", "gripper"))
    text = cond.to_text()
    assert "Pre-conditions:\n  none\nPost-conditions:\n  none\nCollisions: none" in text
    assert TaskCondition.from_text(text) == cond


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("Relevant objects: a\nPre-conditions:\nPost-conditions:", "missing 'Task name:'"),
        ("Task name: grasp a\nPre-conditions:\nPost-conditions:", "missing 'Relevant objects:'"),
        ("Task name: grasp a\nRelevant objects: a\nPost-conditions:", "missing Pre-conditions"),
        (
            "Task name: grasp a\nRelevant objects: a\nPre-conditions:\n  a near b\nPost-conditions:",
            "not a condition",
        ),
        ("Task name: grasp a\nRelevant objects: a\nfoo bar", "unexpected line"),
        (
            "Task name: x\nRelevant objects: a\nPre-conditions:\nPost-conditions:\nCollisions: a b",
            "'A and B'",
        ),
    ],
)
def test_malformed_text_is_refused_with_the_reason(text, message):
    with pytest.raises(ConditionError, match=message):
        TaskCondition.from_text(text)


def test_malformed_json_is_refused_with_the_reason():
    with pytest.raises(ConditionError, match="missing the field 'pre_conditions'"):
        TaskCondition.from_json('{"task_name": "x", "relevant_objects": []}')
    with pytest.raises(ConditionError, match="not JSON"):
        TaskCondition.from_json("{")
    with pytest.raises(ConditionError, match="pair"):
        TaskCondition.from_json(
            '{"task_name": "x", "relevant_objects": [], "pre_conditions": [], "post_conditions": [],'
            ' "collisions": [["a"]]}'
        )


@pytest.mark.parametrize(
    ("conditions", "clash"),
    [
        (["A inside B", "B inside A"], ("A inside B", "B inside A")),
        (["A above B", "A below B"], ("A above B", "A below B")),
        (["A above B", "B above A"], ("A above B", "B above A")),
        (["A in front of B", "B in front of A"], ("A in front of B", "B in front of A")),
        (["gripper grasping A", "gripper not grasping"], ("gripper grasping A", "gripper not grasping")),
        (["gripper grasping A", "gripper grasping B"], ("gripper grasping A", "gripper grasping B")),
        (["B open", "A inside B", "B closed"], ("B open", "B closed")),
    ],
)
def test_contradictions_by_the_vocabulary_meaning(conditions, clash):
    preds = [parse_predicate(c) for c in conditions]
    assert [(str(a), str(b)) for a, b in contradictions(preds)] == [tuple(c.lower() for c in clash)]


def test_no_contradiction_in_any_example_or_in_equivalent_relations():
    for cond in example_conditions().values():
        assert contradictions(cond.pre_conditions) == contradictions(cond.post_conditions) == []
    same = ("A above B", "B below A", "A inside B", "A above C", "A open", "B open", "gripper grasping A")
    assert contradictions([parse_predicate(c) for c in same]) == []


def test_converse_and_relations_of_the_gripper_itself():
    """``A below B`` is ``B above A`` (Cond2Task reaches a move on top through it); inside, in front of and
    states have no converse; a spatial relation of a gripper is left to the primitive's motion."""
    assert converse(parse_predicate("box below bowl")) == parse_predicate("bowl above box")
    assert converse(parse_predicate("bowl above box")) == parse_predicate("box below bowl")
    for text in ("bottle inside box", "mug in front of bowl", "box open", "gripper grasping mug"):
        assert converse(parse_predicate(text)) is None
    assert about_gripper_place(parse_predicate("gripper in front of box"))
    assert about_gripper_place(parse_predicate("bottle inside kinova gripper"))
    assert not about_gripper_place(parse_predicate("gripper grasping box"))
    assert not about_gripper_place(parse_predicate("bottle inside box"))
