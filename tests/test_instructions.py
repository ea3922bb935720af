"""The instruction benchmark's file format (taskcond.instructions): the shipped file and malformed ones."""

from __future__ import annotations

from collections import Counter

import pytest

from taskcond.conditions import ContainerState, GripperState, Relation, SpatialRelation
from taskcond.instructions import TAGS, InstructionError, check_objects, load_instructions
from taskcond.primitives import PRIMITIVES


def test_the_shipped_benchmark_covers_what_the_issue_asks() -> None:
    shipped = load_instructions()
    assert len(shipped) >= 30 and len({i.id for i in shipped}) == len(shipped)
    tags = Counter(t for i in shipped for t in i.tags)
    assert set(PRIMITIVES) - {p.id for p in PRIMITIVES.values() if p.declared} <= set(tags)
    for kind in ("closed-container", "in-the-way", "paraphrase", "multi-word", "misspelling", "dual-arm"):
        assert tags[kind] >= 1, kind
    put = next(i for i in shipped if i.id == "bottle-into-box-close")
    assert put.goal == (
        SpatialRelation("bottle", Relation.INSIDE, "box"),
        ContainerState("box", False),
        GripperState(None),
    )
    assert check_objects(put, ("bottle", "box"), ("gripper",)) is None
    assert "not in its scene" in check_objects(put, ("bowl", "box"), ("gripper",))


ENTRY = '[[instruction]]\nid = "a"\ntext = "Open the box."\ngoal = ["box open"]\n'
GOOD = "version = 1\n" + ENTRY


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("version = 1\n[[instruction]]\nid = 'a'\ntext = 'x'\ngoal = ['box opened']\n", "not a condition"),
        (GOOD + ENTRY, "duplicate id 'a'"),
        (GOOD.replace("version = 1", "version = 2"), "'version = 1' expected"),
        (GOOD + "colour = 'red'\n", "unknown key 'colour'"),
        (GOOD.replace('["box open"]', '["box open", "box closed"]'), "contradict"),
        (GOOD.replace('["box open"]', "[]"), "non-empty list"),
        (GOOD.replace('"Open the box."', '"  "'), "non-empty string"),
        (GOOD + 'tags = ["folding"]\n', "unknown tag 'folding'"),
        ("version = 1\n[[instruction]\n", "not TOML"),
        ("version = 1\n", "no [[instruction]] entries"),
    ],
)
def test_a_malformed_file_is_one_line_naming_what_is_wrong(tmp_path, text, message) -> None:
    path = tmp_path / "bad.toml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(InstructionError) as info:
        load_instructions(path)
    assert message in str(info.value) and "\n" not in str(info.value)
    assert str(info.value).startswith(str(path))


def test_tags_name_every_primitive() -> None:
    assert {p.id for p in PRIMITIVES.values() if not p.declared} <= set(TAGS)


def test_wordings_are_said_in_turn_by_the_episodes_seed(tmp_path) -> None:
    path = tmp_path / "w.toml"
    path.write_text(GOOD + 'wordings = ["Lift the box\'s lid.", "Open the lid."]\n', encoding="utf-8")
    (ins,) = load_instructions(path)
    assert ins.texts == ("Open the box.", "Lift the box's lid.", "Open the lid.")
    assert [ins.text_for(s) for s in range(1000, 1003)] == [
        "Lift the box's lid.",
        "Open the lid.",
        "Open the box.",
    ]
    path.write_text(GOOD + "wordings = ['']\n", encoding="utf-8")
    with pytest.raises(InstructionError, match="'wordings' must be a list of non-empty strings"):
        load_instructions(path)
