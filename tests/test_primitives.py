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
    there and consistent (Primitive.problems: its pattern names its objects; its target and carried objects
    are among them; a carrying approach moves its first object; its effect names its objects; an idempotent
    primitive's effect is a hand's or a container's state), and the catalogue's is the paper's."""
    from taskcond.primitives import PRIMITIVES, HandApproach

    assert {p.id: p.problems() for p in PRIMITIVES.values()} == {p: [] for p in PRIMITIVES}
    carried = {p.id for p in PRIMITIVES.values() if p.approach is HandApproach.CARRY}
    assert carried == {"move", "move_on_top", "move_into", "move_in_front"}
    assert {p.id for p in PRIMITIVES.values() if p.idempotent} == {"grasp", "release", "open", "close"}
    assert [p.id for p in PRIMITIVES.values() if p.grasps] == ["grasp"]
    assert [p.id for p in PRIMITIVES.values() if p.lets_go] == ["release"]
    assert [p.id for p in PRIMITIVES.values() if p.sets_container] == ["open", "close"]
    assert [p.id for p in PRIMITIVES.values() if p.achieves is None] == ["tilt", "fold", "move"]
    assert [p.id for p in PRIMITIVES.values() if p.to_position] == ["move"]
    # an incomplete declaration says what is wrong
    from dataclasses import replace

    grasp = PRIMITIVES["grasp"]
    assert replace(grasp, target=None).problems() == [
        "an empty hand's approach aims at its first object (target A)"
    ]
    assert "must name A once each" in replace(grasp, achieves="gripper grasping box").problems()[0]
    assert "is idempotent" in replace(PRIMITIVES["tilt"], idempotent=True).problems()[0]


@pytest.mark.parametrize(
    "pid", ["grasp", "release", "open", "close", "move_into", "move_on_top", "move_in_front"]
)
def test_cond2task_and_the_named_effects_are_one_table(pid):
    """Cond2Task (achiever) is read from the same declaration as the planner's named effects: the effect of
    a task is achieved by that very task."""
    from taskcond.execution.planner import named_effects
    from taskcond.primitives import achiever

    prim = PRIMITIVES[pid]
    objects = ("bottle", "box")[: prim.n_objects]
    task = prim.task_name(*objects)
    (effect,) = named_effects(task)
    assert effect == prim.effect(*objects)
    assert achiever(effect, grasped="bottle") == parse_task(task)
