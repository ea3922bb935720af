"""Task conditions written as Python functions: the code form of prompt versions v6 and v7 (beyond the paper).

The coder model states a left-out primitive's condition (paper §III-C, generalization) more often right
when the examples are code than when they are the Listing 1 text (BENCHMARKS.md, "Conditions written as
Python functions"). A condition becomes one function, named after its primitive, whose parameters are the
gripper and the task's objects as lower-case letters::

    def move_into(gripper, a, b):
        \"\"\"move A into B\"\"\"
        # before
        assert gripper.holding(a)
        assert b.is_open()
        robot.move_into(a, b)
        # after
        assert a.inside(b)
        assert gripper.inside(b)
        assert gripper.holding(a)
        assert b.is_open()
        return [(gripper, a)]  # allowed contacts

The asserts before the robot call are the pre-conditions, those after it the post-conditions, the returned
pairs the allowed collisions, and the parameters the relevant objects. The translation knows the
vocabulary only (:func:`assert_line` and :func:`parse_body` are inverse to each other), never a primitive.
"""

from __future__ import annotations

import re

from taskcond.conditions import (
    GRIPPER,
    RELATIONS,
    Collision,
    ConditionError,
    ContainerState,
    GripperState,
    Predicate,
    TaskCondition,
    parse_predicate,
)
from taskcond.primitives import ParsedTask

METHODS = ("holding", "is_open", "is_closed", *(r.replace(" ", "_") for r in RELATIONS))
"""The methods an assert may call: the vocabulary of §III-A.1 as Python (``x.in_front_of(y)``)."""
ASSERT = re.compile(r"assert (\w+)\.(\w+)\((\w*)\)")
CONTACT = re.compile(r"\(\s*(\w+)\s*,\s*(\w+)\s*\)")
CONTACTS_COMMENT = "  # allowed contacts"
VALID_LINES = (
    "'assert gripper.holding(x)', 'assert gripper.holding(None)', 'assert x.is_open()', "
    "'assert x.is_closed()', 'assert x.inside(y)' (likewise above, below, in_front_of), the robot call, "
    "'return [(x, y), ...]'"
)


def parameters(task: ParsedTask) -> list[str]:
    """The function's object parameters: the task's letters, lower case (``a``, ``b``)."""
    return [letter.lower() for letter in task.letters().values()]


def signature(task: ParsedTask) -> str:
    """The function's opening: ``def <primitive>(gripper, a, ...):`` and its letter task name as the
    docstring (what the model is shown of a task it must condition)."""
    params = "".join(f", {x}" for x in parameters(task))
    return f'def {task.primitive.id}({GRIPPER}{params}):\n    """{task.letter_name}"""'


def robot_call(task: ParsedTask) -> str:
    """The line between the pre- and the post-condition asserts: ``robot.<primitive>(a, ...)``."""
    return f"robot.{task.primitive.id}({', '.join(parameters(task))})"


def assert_line(pred: Predicate) -> str:
    """One condition as an assert on lower-case variables (inverse of :func:`parse_body`'s reading)."""
    if isinstance(pred, GripperState):
        return f"assert {pred.gripper}.holding({pred.obj.lower() if pred.obj else 'None'})"
    if isinstance(pred, ContainerState):
        return f"assert {pred.container.lower()}.is_{'open' if pred.is_open else 'closed'}()"
    return f"assert {pred.subject.lower()}.{pred.relation.value.replace(' ', '_')}({pred.reference.lower()})"


def body(cond: TaskCondition, task: ParsedTask) -> str:
    """The function body stating ``cond`` (written with ``task``'s letters), indented by four spaces."""
    lines = ["# before", *(assert_line(p) for p in cond.pre_conditions), robot_call(task), "# after"]
    lines += [assert_line(p) for p in cond.post_conditions]
    contacts = ", ".join(f"({c.a.lower()}, {c.b.lower()})" for c in cond.collisions)
    lines.append(f"return [{contacts}]{CONTACTS_COMMENT}")
    return "\n".join(f"    {line}" for line in lines)


def _predicate(subject: str, method: str, arg: str, line: str) -> Predicate:
    if method not in METHODS:
        raise ConditionError(f"{line!r} calls {method}(); use only {', '.join(METHODS)}")
    if method == "holding":
        if subject != GRIPPER:
            raise ConditionError(
                f"{line!r}: only the gripper holds; write 'assert gripper.holding({arg or subject})'"
            )
        if not arg:
            raise ConditionError(f"{line!r}: holding() needs an object or None")
        return parse_predicate(f"{subject} not grasping" if arg == "None" else f"{subject} grasping {arg}")
    if method in ("is_open", "is_closed"):
        if arg:
            raise ConditionError(f"{line!r}: {method}() takes no argument")
        return parse_predicate(f"{subject} {method.removeprefix('is_')}")
    if not arg or arg == "None":
        raise ConditionError(f"{line!r}: {method}() needs an object")
    return parse_predicate(f"{subject} {method.replace('_', ' ')} {arg}")


def _code_lines(text: str) -> list[str]:
    """The statements of an answer: fences, the ``def`` line, the docstring, comments and blank lines
    dropped."""
    out = []
    for raw in text.splitlines():
        line = raw.split("#", 1)[0].strip()
        if not line or line.startswith(("```", "def ", '"""', "'''")):
            continue
        out.append(line)
    return out


def parse_body(text: str, task: ParsedTask) -> TaskCondition:
    """The condition a function body states, with the task's letters lower case as object names (as
    :meth:`TaskCondition.from_text` reads an answer) and the task's letter name.

    Checks the code's form only: every statement an assert of the vocabulary, one robot call, at most one
    ``return`` of pairs. The vocabulary's own checks (objects of the task, no contradiction) are the
    generator's validator's. Raises :class:`ConditionError` saying what is wrong and what is valid.
    """
    lines = _code_lines(text)
    if not lines:
        raise ConditionError("the answer has no statements; write the function's body")
    pre: list[Predicate] = []
    post: list[Predicate] = []
    contacts: list[Collision] = []
    current: list[Predicate] | None = pre
    for line in lines:
        if line.startswith("robot."):
            if current is not pre:
                raise ConditionError(f"{line!r}: call the robot once, between the two groups of asserts")
            current = post
        elif m := ASSERT.fullmatch(line):
            if current is None:
                raise ConditionError(f"{line!r} after the return: the return ends the body")
            current.append(_predicate(*m.groups(), line))
        elif line.startswith("return"):
            if current is not post:
                raise ConditionError(f"{line!r} before the robot call {robot_call(task)!r}")
            listed = line.removeprefix("return").strip()
            pairs = CONTACT.findall(listed)
            if not (listed.startswith("[") and listed.endswith("]")) or (pairs == [] and listed != "[]"):
                raise ConditionError(f"{line!r}: return a list of pairs, e.g. 'return [(gripper, a)]'")
            contacts = [Collision(a, b) for a, b in pairs]
            current = None
        else:
            raise ConditionError(f"{line!r} is not a line of the body; valid lines: {VALID_LINES}")
    if current is pre:
        raise ConditionError(f"the body has no robot call: write {robot_call(task)!r} between the asserts")
    objects = (*parameters(task), GRIPPER)
    return TaskCondition(task.letter_name, objects, tuple(pre), tuple(post), tuple(contacts))


__all__ = ["assert_line", "body", "parameters", "parse_body", "robot_call", "signature"]
