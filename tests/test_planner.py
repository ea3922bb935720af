"""The look-ahead planner and the goal of a plan on hand-built conditions (no simulator, no LLM)."""

from __future__ import annotations

from taskcond.conditions import TaskCondition, parse_predicate
from taskcond.execution.planner import apply, goal_of, repair


def _cond(name: str, pre: list[str], post: list[str]) -> TaskCondition:
    return TaskCondition(name, (), tuple(map(parse_predicate, pre)), tuple(map(parse_predicate, post)), ())


CONDITIONS = {
    c.task_name: c
    for c in (
        _cond("grasp bottle", ["gripper not grasping"], ["gripper grasping bottle"]),
        _cond("grasp bowl", ["gripper not grasping"], ["gripper grasping bowl"]),
        _cond("release bottle", ["gripper grasping bottle"], ["gripper not grasping"]),
        _cond("release bowl", ["gripper grasping bowl"], ["gripper not grasping"]),
        _cond("open box", ["gripper not grasping", "box closed"], ["box open", "gripper not grasping"]),
        _cond("close box", ["gripper not grasping", "box open"], ["box closed", "gripper not grasping"]),
        _cond(
            "move bottle into box",
            ["gripper grasping bottle", "box open"],
            ["gripper grasping bottle", "bottle inside box", "gripper above box"],
        ),
        _cond("grasp mug", ["gripper not grasping"], ["gripper grasping mug"]),
        _cond("tilt bottle", ["gripper grasping bottle"], ["gripper grasping bottle"]),
        _cond(
            "move bottle in front of microwave",
            ["gripper grasping bottle"],
            ["gripper grasping bottle", "bottle in front of microwave"],
        ),
        _cond("release mug", ["gripper grasping mug"], ["gripper not grasping"]),
        _cond(
            "move mug on top of table", ["gripper grasping mug"], ["gripper grasping mug", "mug above table"]
        ),
        _cond(
            "move bowl into box",
            ["gripper grasping bowl", "box open"],
            ["gripper grasping bowl", "bowl inside box"],
        ),
    )
}


def conditions(task: str) -> TaskCondition:
    return CONDITIONS[task]


def _start(*preds: str) -> frozenset:
    return frozenset(map(parse_predicate, preds))


CLOSED = _start("gripper not grasping", "box closed", "bottle above table", "bowl above table")
OPEN = _start("gripper not grasping", "box open", "bottle above table", "bowl above table")


def test_open_box_goes_before_the_grasp_that_would_block_it() -> None:
    plan = ("grasp bottle", "move bottle into box", "release bottle")
    out = repair(plan, CLOSED, conditions)
    assert out.steps == ("open box", "grasp bottle", "move bottle into box", "release bottle")
    assert out.impossible is None and not out.unresolved
    (change,) = out.changes
    assert (change.kind, change.task, change.position) == ("insert", "open box", 1)
    assert "'box open'" in change.reason and "'gripper not grasping'" in change.reason


def test_bowl_into_the_closed_box_and_shut_it_gets_open_and_release() -> None:
    out = repair(("grasp bowl", "move bowl into box", "close box"), CLOSED, conditions)
    assert out.steps == ("open box", "grasp bowl", "move bowl into box", "release bowl", "close box")
    assert [c.kind for c in out.changes] == ["insert", "insert"]


def test_a_step_whose_effect_already_holds_is_dropped() -> None:
    out = repair(("open box", "grasp bottle", "move bottle into box"), OPEN, conditions)
    assert out.steps == ("grasp bottle", "move bottle into box")
    (change,) = out.changes
    assert (change.kind, change.task, change.position) == ("drop", "open box", 1)
    assert "'box open'" in change.reason


def test_a_step_whose_effect_an_earlier_step_achieves_is_kept() -> None:
    plan = ("open box", "grasp bottle", "move bottle into box", "release bottle", "close box")
    assert repair(plan, CLOSED, conditions).steps == plan


def test_an_open_that_a_later_close_undoes_before_any_step_needs_it_is_dropped() -> None:
    """ "Close the box and the drawers" planned by a small model as ``open box``, ``close box``."""
    out = repair(("open box", "grasp bottle", "release bottle", "close box"), OPEN, conditions)
    assert out.steps == ("grasp bottle", "release bottle", "close box")
    (change,) = out.changes
    assert (change.kind, change.task) == ("drop", "open box") and "'close box' undoes" in change.reason


def test_moving_onto_an_open_container_closes_it_first() -> None:
    """On an open box the mug would fall inside; an affording scene makes the box's closing a
    pre-condition of the move whatever its condition says."""

    def affords(primitive: str, objects: tuple[str, ...]) -> str | None:
        return None if objects != ("table",) else "'table' cannot be opened or closed"

    mug_on = {
        "move mug on top of box": _cond(
            "move mug on top of box", ["gripper grasping mug"], ["gripper grasping mug", "mug above box"]
        )
    }
    plan = ("grasp mug", "move mug on top of box", "release mug")
    out = repair(plan, OPEN, lambda t: mug_on.get(t) or CONDITIONS[t], affords)
    assert out.steps == ("close box", *plan)
    table = ("grasp mug", "move mug on top of table", "release mug")
    assert repair(table, OPEN, conditions, affords).steps == table


def test_a_move_whose_relation_already_holds_is_kept() -> None:
    """The mug stands on the table at the start, and still the move sets it down after the grasp (LHT3)."""
    plan = ("grasp mug", "move mug on top of table", "release mug")
    assert repair(plan, _start("gripper not grasping", "mug above table"), conditions).steps == plan


def test_no_repair_is_the_identity() -> None:
    plan = ("grasp bottle", "move bottle into box", "release bottle", "close box")
    out = repair(plan, OPEN, conditions)
    assert out.steps == plan and out.changes == () and out.unresolved == () and out.impossible is None


def test_a_later_step_that_achieves_a_missing_pre_condition_is_moved_before() -> None:
    out = repair(("grasp bottle", "move bottle into box", "release bottle", "open box"), CLOSED, conditions)
    assert out.steps == ("open box", "grasp bottle", "move bottle into box", "release bottle")
    assert [c.kind for c in out.changes] == ["move"]


def test_a_flaw_whose_primitive_the_scene_refuses_makes_the_plan_impossible() -> None:
    def affords(primitive: str, objects: tuple[str, ...]) -> str | None:
        return "'box' has no lid, door or drawer" if primitive == "open" else None

    out = repair(("grasp bottle", "move bottle into box"), CLOSED, conditions, affords)
    assert out.impossible is not None and "'open box'" in out.impossible and "no lid" in out.impossible


def test_frame_rule_keeps_what_no_post_condition_contradicts() -> None:
    after = apply(CLOSED, CONDITIONS["grasp bottle"])
    assert parse_predicate("gripper grasping bottle") in after
    assert parse_predicate("gripper not grasping") not in after
    assert parse_predicate("box closed") in after
    moved = apply(after | {parse_predicate("box open")}, CONDITIONS["move bottle into box"])
    assert parse_predicate("bottle inside box") in moved
    assert parse_predicate("bottle above table") not in moved  # the bottle was placed anew
    assert parse_predicate("bowl above table") in moved


def test_goal_composes_effects_and_keeps_the_gripper_from_a_final_grasp_or_release_or_when_alone() -> None:
    repaired = ("open box", "grasp bowl", "move bowl into box", "release bowl", "close box")
    assert [str(p) for p in goal_of(repaired, conditions)] == ["bowl inside box", "box closed"]
    put = ("grasp bottle", "move bottle into box", "release bottle")
    assert [str(p) for p in goal_of(put, conditions)] == ["bottle inside box", "gripper not grasping"]
    assert [str(p) for p in goal_of(("grasp bottle",))] == ["gripper grasping bottle"]
    # a final tilt states nothing but the hand: the bottle still held is the goal, not nothing
    assert [str(p) for p in goal_of(("grasp bottle", "tilt bottle"), conditions)] == [
        "gripper grasping bottle"
    ]
    moved = ("grasp bottle", "move bottle in front of microwave")
    assert [str(p) for p in goal_of(moved, conditions)] == ["bottle in front of microwave"]
    below = {"move bottle on top of box": _cond("move bottle on top of box", [], ["box below bottle"])}
    assert [str(p) for p in goal_of(["move bottle on top of box"], below.get)] == ["bottle above box"]


def test_closing_what_is_closed_is_dropped_after_another_close() -> None:
    """ "Close the box and the drawers" from a start where the box is open and the top drawer closed: the
    close of the top drawer is dropped, not given an ``open top drawer`` first."""
    drawer = {
        "close top drawer": _cond(
            "close top drawer",
            ["gripper not grasping", "top drawer open"],
            ["gripper not grasping", "top drawer closed"],
        )
    }
    start = _start("gripper not grasping", "box open", "top drawer closed")
    out = repair(("close box", "close top drawer"), start, lambda t: drawer.get(t) or CONDITIONS[t])
    assert out.steps == ("close box",)
    assert [(c.kind, c.task) for c in out.changes] == [("drop", "close top drawer")]
