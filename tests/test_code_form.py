"""The code form of prompt version v6 (conditions as Python functions) and the state probe.

Validation paths that need a particular bad answer use a scripted replay backend standing in for a model
that misbehaves; the ``llm`` tests ask the real embedded model.
"""

from __future__ import annotations

import pytest

from doubles import Replay, Spoiled
from taskcond import code_form
from taskcond.conditions import ConditionError
from taskcond.examples import example_conditions, letter_example, reference_condition
from taskcond.generator import (
    PROMPT_VERSION,
    ConditionGenerator,
    code_grammar,
    code_only,
    load_prompt,
    order_seeds,
    parse_answer,
    uses_code_form,
)
from taskcond.llm.base import LLMError
from taskcond.llm.cache import CachedBackend
from taskcond.primitives import PRIMITIVES, parse_task
from taskcond.probe import ProbeResult, probe

TASK = parse_task("move bottle into lunch box")
GOOD = """    # before
    assert gripper.holding(a)
    assert b.is_open()
    robot.move_into(a, b)
    # after
    assert a.inside(b)
    assert gripper.inside(b)
    assert gripper.holding(a)
    assert b.is_open()
    return [(gripper, a)]  # allowed contacts"""


@pytest.mark.parametrize("pid", list(PRIMITIVES))
def test_every_example_reads_back_from_its_function(pid):
    task = parse_task(example_conditions()[pid].task_name)
    body = code_form.body(letter_example(pid), task)
    assert parse_answer(body, "code", task).matches(example_conditions()[pid])
    assert code_form.signature(task).startswith(f"def {pid}(gripper")


def test_a_code_answer_is_read_in_the_condition_types_and_mapped_to_the_objects():
    wrapped = f"```python\n{code_form.signature(TASK)}\n{GOOD}\n```"
    cond = parse_answer(wrapped, "code", TASK)
    assert cond.matches(reference_condition(TASK))
    assert cond.relevant_objects == ("bottle", "lunch box", "gripper")


@pytest.mark.parametrize(
    ("answer", "message"),
    [
        ("", "the answer has no statements"),
        ("    assert gripper.holding(a)\n    assert a.inside(b)", "the body has no robot call"),
        ("    pass", "'pass' is not a line of the body; valid lines: 'assert gripper.holding"),
        ("    assert a.holding(b)\n    robot.move_into(a, b)", "only the gripper holds"),
        ("    assert a.is_tilted()\n    robot.move_into(a, b)", r"calls is_tilted\(\); use only holding"),
        ("    robot.move_into(a, b)\n    assert c.inside(b)", "it names objects not in the task: c"),
        (
            "    robot.move_into(a, b)\n    assert b.is_open()\n    assert b.is_closed()",
            r"'assert b.is_open\(\)' and 'assert b.is_closed\(\)' contradict each other",
        ),
        ("    return []\n    robot.move_into(a, b)", "before the robot call 'robot.move_into"),
        ("    robot.move_into(a, b)\n    return gripper", "return a list of pairs"),
    ],
)
def test_malformed_code_answers_are_refused_in_one_line(answer, message):
    with pytest.raises(ConditionError, match=message) as info:
        parse_answer(answer, "code", TASK)
    assert "\n" not in str(info.value)


def test_v6_asks_a_left_out_primitive_in_one_code_chat_and_generation_as_v5():
    assert uses_code_form("v6") and not uses_code_form("v5")
    v6, v5 = ConditionGenerator(Replay([]), prompt_version="v6"), ConditionGenerator(Replay([]))
    v5.prompt_version = "v5"
    messages = v6.messages("code", TASK, exclude=["move_into"], order_seed=1)
    assert messages[0].role == "system" and "gripper.holding(x)" in messages[0].content
    assert messages[-1].content == 'def move_into(gripper, a, b):\n    """move A into B"""'
    shown = [m.content for m in messages[1:-1:2]]
    assert len(shown) == len(PRIMITIVES) - 1 and not any("def move_into" in s for s in shown)
    assert not any("bottle" in m.content or "lunch" in m.content for m in messages)
    assert messages != v6.messages("code", TASK, exclude=["move_into"], order_seed=2)
    for chat in ("spatial", "state"):  # generation: the same requests as v5's
        assert v6.messages(chat, TASK, order_seed=3) == v5.messages(chat, TASK, order_seed=3)
        assert load_prompt("retry", "v6").template == load_prompt("retry", "v5").template


def test_v7_differs_from_v6_in_the_code_chats_system_message_only():
    v7, v6 = (ConditionGenerator(Replay([]), prompt_version=v) for v in ("v7", "v6"))
    assert uses_code_form("v7")
    seven = v7.messages("code", TASK, exclude=["move_into"], order_seed=1)
    six = v6.messages("code", TASK, exclude=["move_into"], order_seed=1)
    assert seven[1:] == six[1:] and seven[0] != six[0]
    assert "only when the task opens x, closes x or puts something inside x" in seven[0].content
    for chat in ("spatial", "state"):  # generation: the same requests as v6's (v5's)
        assert v7.messages(chat, TASK, order_seed=3) == v6.messages(chat, TASK, order_seed=3)
    assert load_prompt("code_retry", "v7").template == load_prompt("code_retry", "v6").template


def test_v8_the_default_asks_a_generated_condition_in_one_code_chat_with_its_own_example_repeated_last():
    v8, v7 = ConditionGenerator(Replay([GOOD])), ConditionGenerator(Replay([]), prompt_version="v7")
    assert PROMPT_VERSION == "v8" and code_only("v8") and not code_only("v7")
    result = v8.generate(TASK)
    assert result.mode == "generation" and [t.chat for t in result.transcripts] == ["code"]
    assert result.condition.matches(reference_condition(TASK))
    (request,) = v8.backend.requests
    own = code_form.signature(parse_task(example_conditions()["move_into"].task_name))
    shown = [m.content for m in request.messages[1:-1:2]]
    assert len(shown) == len(PRIMITIVES) + 1 and shown.count(own) == 2 and shown[-1] == own
    assert request.shared_messages == len(request.messages) - 3  # all before the repeat
    assert request.messages[-1].content == code_form.signature(TASK)
    # a left-out primitive: the same chat as v7's, so leave-one-out answers stay the same
    assert v8.layout("code", TASK, exclude=["move_into"], order_seed=4) == v7.layout(
        "code", TASK, exclude=["move_into"], order_seed=4
    )


def test_v6_code_answer_goes_through_the_validator_retry_and_grammar():
    backend = Replay(["    assert gripper.holding(a)\n    assert a.inside(b)", GOOD])
    result = ConditionGenerator(backend).generate(TASK, exclude=["move_into"])
    assert result.mode == "generalization" and result.condition.matches(reference_condition(TASK))
    assert [t.chat for t in result.transcripts] == ["code"] and result.attempts == 2
    first, retry = backend.requests
    assert first.grammar is None and retry.grammar == code_grammar(TASK)
    assert retry.messages[-1].role == "user"
    assert "not valid: the body has no robot call" in retry.messages[-1].content
    assert "Write the body of move_into(gripper, a, b) again" in retry.messages[-1].content


def test_v6_without_a_valid_code_answer_ends_in_a_one_line_error():
    backend = Replay(["I think the robot moves it."] * 3)
    message = r"gave no valid code answer for 'move bottle into lunch box' in 3 attempts"
    with pytest.raises(LLMError, match=message) as e:
        ConditionGenerator(backend).generate(TASK, exclude=["move_into"])
    assert "\n" not in str(e.value)


def test_samples_vote_over_example_orders_greedily():
    noisy = GOOD.replace("    assert b.is_open()\n    robot", "    robot")
    backend = Replay([noisy, GOOD, GOOD])
    result = ConditionGenerator(backend, samples=3).generate(TASK, exclude=["move_into"], order_seed=4)
    assert result.condition.matches(reference_condition(TASK))  # 2 of 3 orders state b open before
    assert all(r.sampling.temperature == 0 for r in backend.requests)
    assert len({r.messages for r in backend.requests}) == 3  # three example orders
    single = Replay([GOOD])
    ConditionGenerator(single).generate(TASK, exclude=["move_into"], order_seed=4)
    assert single.requests[0].messages == backend.requests[0].messages  # the first is the trial's own
    assert order_seeds(4, 3)[0] == 4 and len(set(order_seeds(4, 3))) == 3
    lone = Replay([GOOD, "nonsense", "nonsense", "nonsense", "nonsense", "nonsense", "nonsense"])
    cond = ConditionGenerator(lone, samples=3).generate(TASK, exclude=["move_into"]).condition
    assert cond.pre_conditions == ()  # one order of three is no majority


def test_cached_answers_never_cross_prompt_versions(tmp_path):
    backend = Replay([GOOD])
    cached = CachedBackend(backend, tmp_path)
    ConditionGenerator(cached).generate(TASK, exclude=["move_into"])
    again = ConditionGenerator(cached).generate(TASK, exclude=["move_into"])
    assert again.cached and len(backend.requests) == 1
    backend.answers = ["nonsense"] * 6
    with pytest.raises(LLMError, match="no valid spatial answer"):  # v5 asks anew, it is not served v6's
        ConditionGenerator(cached, prompt_version="v5").generate(TASK, exclude=["move_into"])


def test_probe_scores_yes_no_answers_against_the_example_conditions():
    n = sum(2 + 2 * p.n_objects for p in PRIMITIVES.values())
    result = probe(Replay(["yes"] * n))
    assert isinstance(result, ProbeResult) and result.total == n == 46
    assert result.right == result.expected_yes and result.said_yes == n
    assert result.summary() == f"state probe: {result.right}/46 (chance ≈ 23)"
    assert probe(Replay(["maybe"] * n)).right == 0  # neither yes nor no is wrong


@pytest.mark.llm
def test_embedded_code_answer_of_a_left_out_primitive_parses_and_validates(embedded_backend):
    """The default prompts (v8) ask a left-out primitive in the code form, and the answer is right: every
    field equals the reference condition (Table II's criterion), not only well-formed."""
    gen = ConditionGenerator(embedded_backend, max_retries=1)
    result = gen.generate("release cup", exclude=["release"])
    assert gen.prompt_version == "v8"
    assert result.mode == "generalization" and [t.chat for t in result.transcripts] == ["code"]
    reference = reference_condition(parse_task("release cup"))
    assert result.condition.matches(reference), result.condition.to_text()


@pytest.mark.llm
def test_embedded_model_mends_a_malformed_code_answer_on_the_constrained_retry(embedded_backend):
    backend = Spoiled(embedded_backend, "    assert cup.is_tilted()\n    robot.tilt(a)")
    result = ConditionGenerator(backend, max_retries=1).generate("tilt cup", exclude=["tilt"])
    assert result.attempts == 2 and "calls is_tilted()" in result.transcripts[0].errors[0]
    assert backend.requests[1].grammar is not None
    assert result.condition.mentioned_objects() <= {"cup", "gripper"}
    with pytest.raises(LLMError, match="gave no valid code answer for 'tilt cup' in 1 attempts"):
        ConditionGenerator(Spoiled(embedded_backend, "pass"), max_retries=0).generate(
            "tilt cup", exclude=["tilt"]
        )
