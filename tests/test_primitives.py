"""The primitive catalogue: task-name parsing, the registry, Alg. 1's condition-to-task mapping."""

import pytest

from taskcond.conditions import parse_predicate
from taskcond.examples import example_conditions, letter_example, reference_condition
from taskcond.primitives import PRIMITIVES, TaskNameError, parse_task, task_for_condition


def test_registry_has_the_papers_ten_primitives():
    expected = [
        "grasp",
        "release",
        "open",
        "close",
        "tilt",
        "fold",
        "move",
        "move_on_top",
        "move_into",
        "move_in_front",
    ]
    assert list(PRIMITIVES) == expected


@pytest.mark.parametrize(
    ("name", "pid", "objects"),
    [
        ("grasp bottle", "grasp", ("bottle",)),
        ("Pick up the coffee mug", "grasp", ("coffee mug",)),
        ("hold a mug up", "grasp", ("mug",)),
        ("release the bowl", "release", ("bowl",)),
        ("open top drawer", "open", ("top drawer",)),
        ("shut the microwave", "close", ("microwave",)),
        ("tilt mug", "tilt", ("mug",)),
        ("fold the cloth", "fold", ("cloth",)),
        ("move spatula to position", "move", ("spatula",)),
        ("move bowl to the target position", "move", ("bowl",)),
        ("move coffee mug on top of top drawer", "move_on_top", ("coffee mug", "top drawer")),
        ("place the spatula onto the cloth", "move_on_top", ("spatula", "cloth")),
        ("move bottle into box", "move_into", ("bottle", "box")),
        ("put the bowl into the bottom drawer", "move_into", ("bowl", "bottom drawer")),
        ("put the mug in front of the bowl", "move_in_front", ("mug", "bowl")),
        ("move coffee mug in front of top drawer", "move_in_front", ("coffee mug", "top drawer")),
    ],
)
def test_parse_task(name, pid, objects):
    task = parse_task(name)
    assert task.primitive.id == pid
    assert task.objects == objects
    assert parse_task(task.name) == task


@pytest.mark.parametrize(
    ("name", "message"),
    [
        ("", "empty task name; valid patterns: grasp A"),
        ("   ", "empty task name"),
        ("jump over the box", "unknown verb 'jump'.*valid verbs: close"),
        ("move bottle", "does not match a task pattern.*move A into B"),
        ("move bottle into", "does not match a task pattern"),
        ("grasp", "does not match a task pattern.*grasp A"),
        ("grasp gripper", "gripper is not an object"),
        ("move box into box", "must differ"),
        ("grasp bottle, box", "invalid object name"),
    ],
)
def test_bad_task_names_are_refused_with_what_is_valid(name, message):
    with pytest.raises(TaskNameError, match=message):
        parse_task(name)


def test_every_primitive_has_an_example_whose_letter_form_uses_only_letters():
    examples = example_conditions()
    assert list(examples) == list(PRIMITIVES)
    for pid in PRIMITIVES:
        letters = letter_example(pid)
        assert letters.task_name == PRIMITIVES[pid].pattern
        assert letters.mentioned_objects() <= {"A", "B", "gripper"}


def test_reference_condition_renames_objects():
    ref = reference_condition(parse_task("move coffee mug into top drawer"))
    assert ref.task_name == "move coffee mug into top drawer"
    assert parse_predicate("coffee mug inside top drawer") in ref.post_conditions
    assert parse_predicate("top drawer open") in ref.pre_conditions


@pytest.mark.parametrize(
    ("condition", "grasped", "task"),
    [
        ("gripper grasping bottle", None, "grasp bottle"),
        ("gripper not grasping", "bottle", "release bottle"),
        ("gripper not grasping", None, None),
        ("box open", None, "open box"),
        ("top drawer closed", None, "close top drawer"),
        ("bottle inside box", None, "move bottle into box"),
        ("bowl above box", None, "move bowl on top of box"),
        ("box below bowl", None, "move bowl on top of box"),
        ("mug in front of bowl", None, "move mug in front of bowl"),
        ("gripper inside box", None, None),
    ],
)
def test_condition_to_task_mapping_of_alg_1(condition, grasped, task):
    assert task_for_condition(parse_predicate(condition), grasped=grasped) == task
    if task is not None:
        parse_task(task)


def test_every_primitive_is_declared_completely():
    """A primitive is one declaration: what the executor, the planner and the grounding read of it is
    there and consistent (its pattern names its objects; its target and carried objects are among them; a
    carrying approach moves its first object; an idempotent primitive is one whose post-conditions are its
    whole effect, never a move to a place)."""
    from taskcond.primitives import LETTERS, PRIMITIVES, HandApproach

    for p in PRIMITIVES.values():
        letters = [w for w in p.pattern.split() if w in LETTERS]
        assert letters == list(LETTERS[: p.n_objects]), p.id
        assert p.target is None or p.target == -1 or 0 <= p.target < p.n_objects, p.id
        assert all(0 <= m < p.n_objects for m in p.movable), p.id
        assert isinstance(p.approach, HandApproach) and isinstance(p.idempotent, bool), p.id
        if p.approach is HandApproach.CARRY:
            assert 0 in p.movable and p.target is not None and not p.idempotent, p.id
        if p.approach is HandApproach.EMPTY_HAND:
            assert p.target == 0, p.id
    carried = {p.id for p in PRIMITIVES.values() if p.approach is HandApproach.CARRY}
    assert carried == {"move", "move_on_top", "move_into", "move_in_front"}
    assert {p.id for p in PRIMITIVES.values() if p.idempotent} == {"grasp", "release", "open", "close"}
