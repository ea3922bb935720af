"""Condition generation: prompts, grammar, validation, retries, self-consistency and the response cache.

The backends here are real: the embedded llama.cpp model (loaded once per session) and, for validation
paths that need a specific bad answer, a scripted replay backend standing in for an LLM that misbehaves.
"""

from __future__ import annotations

import pytest

from doubles import Replay, Spoiled
from taskcond.conditions import ConditionError, TaskCondition
from taskcond.examples import reference_condition
from taskcond.generator import ConditionGenerator, answer_grammar, examples_block, parse_answer
from taskcond.llm.base import ChatMessage, ChatRequest, LLMError, Sampling
from taskcond.llm.cache import CachedBackend
from taskcond.llm.config import LLMConfig, backend_label
from taskcond.llm.embedded import PREFIX_CACHE_BYTES, EmbeddedBackend
from taskcond.llm.models import DEFAULT_EMBEDDED_MODEL, EMBEDDED_MODELS, MODE_MODELS
from taskcond.primitives import PRIMITIVES, parse_task

TWO_CHATS = "v7"
"""A prompt version whose generation asks the paper's two chats (the default, v8, asks one code chat)."""

GOOD_SPATIAL = """Relevant objects: A, B, gripper
Pre-conditions:
  none
Post-conditions:
  A inside B
  gripper inside B
Collisions: gripper and A
"""
GOOD_STATE = """Relevant objects: A, B, gripper
Pre-conditions:
  gripper grasping A
  B open
Post-conditions:
  gripper grasping A
  B open
"""


def test_prompt_has_the_four_parts_and_letters_only():
    gen = ConditionGenerator(Replay([]), prompt_version="v1")
    task = parse_task("move coffee mug into top drawer")
    prompt = gen.prompt("spatial", task)
    assert prompt.startswith("Imagine you are a spatial relation & collision judgment machine.")
    assert "above, below, inside, in front of" in prompt
    assert "Here are some examples:" in prompt
    assert "Remember to strictly follow the examples' format." in prompt
    assert prompt.rstrip().endswith("Q: Task name: move A into B")
    assert "coffee mug" not in prompt and "drawer" not in prompt
    state = gen.prompt("state", task)
    assert "gripper grasping/not grasping, container open/closed" in state
    assert "Collisions" not in state.split("Here are some examples:")[1]


def test_leaving_a_primitive_out_removes_its_examples_and_uses_chain_of_thought():
    gen = ConditionGenerator(Replay([]), prompt_version="v1")
    task = parse_task("move bottle into box")
    prompt = gen.prompt("spatial", task, exclude=["move_into"])
    assert prompt.count("Task name: move A into B") == 1  # only the question
    assert "First, decide which objects are relevant" in prompt
    assert prompt.count("Task name:") == len(PRIMITIVES) - 1 + 1
    assert examples_block("state").count("Task name:") == len(PRIMITIVES)


def test_example_order_is_shuffled_by_the_trial_seed_and_keeps_every_example():
    orders = {examples_block("spatial", order_seed=s) for s in range(4)}
    assert len(orders) > 1
    for block in orders:
        assert sorted(block.split("\n\n")) == sorted(examples_block("spatial").split("\n\n"))


def test_parse_answer_maps_letters_back_and_checks_form_only():
    task = parse_task("move bottle into box")
    spatial = parse_answer(GOOD_SPATIAL, "spatial", task)
    state = parse_answer(GOOD_STATE, "state", task)
    merged = TaskCondition.merge(spatial, state)
    assert merged.matches(reference_condition(task))
    assert merged.task_name == "move bottle into box"


@pytest.mark.parametrize(
    ("answer", "chat", "message"),
    [
        ("", "spatial", "empty"),
        ("I cannot help with that.", "spatial", "unexpected line"),
        (GOOD_SPATIAL.replace("A inside B", "A near B"), "spatial", "not a condition"),
        (GOOD_SPATIAL.replace("A inside B", "C inside B"), "spatial", "not in the task: c; use only A, B"),
        (GOOD_SPATIAL.replace("A inside B", "gripper grasping A"), "spatial", "only spatial relations"),
        (GOOD_STATE.replace("B open", "A inside B"), "state", "only object states"),
        (GOOD_STATE + "Collisions: gripper and A\n", "state", "no collisions"),
        (GOOD_SPATIAL.replace("Relevant objects: A, B, gripper", "Relevant objects: A, gripper"), "spatial",
         "missing from 'Relevant objects:'"),
        (GOOD_SPATIAL.replace("gripper and A", "A and A"), "spatial", "cannot collide with itself"),
        (GOOD_SPATIAL.replace("A inside B", "A inside A"), "spatial", "relation with itself"),
        (GOOD_SPATIAL.replace("gripper inside B", "B inside A"), "spatial",
         "post-conditions 'A inside B' and 'B inside A' contradict each other"),
        (GOOD_STATE.replace("  B open\nPost", "  B open\n  B closed\nPost"), "state",
         "pre-conditions 'B open' and 'B closed' contradict"),
        (GOOD_STATE.replace("  B open\nPost", "  gripper not grasping\nPost"), "state",
         "'gripper grasping A' and 'gripper not grasping' contradict"),
    ],
)  # fmt: skip
def test_parse_answer_refuses_malformed_answers(answer, chat, message):
    with pytest.raises(ConditionError, match=message):
        parse_answer(answer, chat, parse_task("move bottle into box"))


def test_invalid_answer_is_retried_with_the_error_shown():
    backend = Replay(["Sure! Here you go.", GOOD_SPATIAL, GOOD_STATE])
    result = ConditionGenerator(backend, prompt_version=TWO_CHATS).generate("move bottle into box")
    assert result.condition.matches(reference_condition(parse_task("move bottle into box")))
    assert result.attempts == 3
    first, retry = backend.requests[0].messages, backend.requests[1].messages
    assert retry[: len(first)] == first
    assert [m.role for m in retry[len(first) :]] == ["assistant", "user"]
    assert retry[-2].content == "Sure! Here you go."
    assert "not valid" in retry[-1].content and "unexpected line" in retry[-1].content


def test_a_second_retry_samples_instead_of_repeating_the_greedy_one():
    """Greedy decoding of the same chat mostly repeats a refused answer; the second retry samples."""
    backend = Replay(["nonsense", "nonsense", GOOD_SPATIAL, GOOD_STATE])
    result = ConditionGenerator(backend, temperature=0.7, prompt_version=TWO_CHATS).generate(
        "move bottle into box", seed=5
    )
    assert result.attempts == 4
    assert [r.sampling.temperature for r in backend.requests] == [0.0, 0.0, 0.7, 0.0]
    assert [r.sampling.seed for r in backend.requests] == [5, 6, 7, 5]
    assert [r.grammar is not None for r in backend.requests] == [False, True, True, False]


def test_retries_are_bounded_and_end_in_a_one_line_error():
    backend = Replay(["nonsense"] * 3)
    with pytest.raises(LLMError, match=r"\[replay\] script gave no valid spatial answer .* in 3 attempts"):
        ConditionGenerator(backend, max_retries=2, prompt_version=TWO_CHATS).generate("move bottle into box")
    assert not backend.answers


def test_self_consistency_keeps_the_majority_of_each_condition():
    noisy = GOOD_SPATIAL.replace("  gripper inside B\n", "  gripper inside B\n  B above A\n")
    backend = Replay([GOOD_SPATIAL, noisy, GOOD_SPATIAL, GOOD_STATE, GOOD_STATE, GOOD_STATE])
    result = ConditionGenerator(backend, samples=3, prompt_version=TWO_CHATS).generate("move bottle into box")
    assert result.condition.matches(reference_condition(parse_task("move bottle into box")))
    assert [r.sampling.seed for r in backend.requests] == [0, 1, 2, 0, 1, 2]
    assert all(r.sampling.temperature > 0 for r in backend.requests)


def test_response_cache_answers_repeats_without_the_backend(tmp_path):
    backend = Replay([GOOD_SPATIAL, GOOD_STATE])
    cached = CachedBackend(backend, tmp_path)
    first = ConditionGenerator(cached, prompt_version=TWO_CHATS).generate("move bottle into box")
    second = ConditionGenerator(cached, prompt_version=TWO_CHATS).generate("move bottle into box")
    assert not first.cached and second.cached
    assert second.condition == first.condition
    assert len(backend.requests) == 2
    other = ConditionGenerator(
        CachedBackend(Replay([GOOD_SPATIAL]), tmp_path), grammar="never", prompt_version=TWO_CHATS
    )
    assert other.backend.key(backend.requests[0]) != other.backend.key(
        ChatRequest(backend.requests[0].messages, backend.requests[0].sampling, None)
    )


def test_grammar_names_only_the_tasks_letters():
    grammar = answer_grammar("spatial", parse_task("move bottle into box"))
    assert '"A " rel " B"' in grammar and '"A " rel " A"' not in grammar
    assert '"in front of"' in grammar
    state = answer_grammar("state", parse_task("grasp bottle"))
    assert 'item ::= "A"' in state and '"B"' not in state
    two = answer_grammar("state", parse_task("move bottle into box"))  # one state per thing, in order
    assert 'conds ::= "  none\\n" | gripper state-a? state-b? | state-a state-b? | state-b\n' in two


@pytest.mark.llm
@pytest.mark.parametrize("pid", ["tilt", "move_into"])
def test_embedded_constrained_answers_are_always_valid(embedded_backend, pid):
    """Constrained decoding: the real model's first answer parses even for an unseen primitive (the two
    chain-of-thought chats of v5)."""
    gen = ConditionGenerator(embedded_backend, max_retries=0, grammar="always", prompt_version="v5")
    prim = PRIMITIVES[pid]
    task = parse_task(prim.task_name(*["bowl", "top drawer"][: prim.n_objects]))
    result = gen.generate(task, exclude=[pid])
    assert result.attempts == 2
    assert result.mode == "generalization"
    assert result.condition.mentioned_objects() <= {"bowl", "top drawer", "gripper"}


@pytest.mark.llm
def test_embedded_free_answer_falls_back_to_the_grammar(embedded_backend):
    """With the default fallback, a rejected free answer is retried once with the answer grammar sent
    (constrained decoding), and the constrained answer is valid. The first answer of each chat is spoiled so
    that the fallback runs every time; the retry is the real model's (the two chain-of-thought chats of v5;
    the code form of v6 in test_code_form.py). Two primitives that the constrained test above leaves out,
    changing a container and a placement, keep the test short."""
    for pid in ("open", "move_in_front"):
        spoiled = Spoiled(embedded_backend, "Relevant objects: C, gripper\n", spoil=lambda k: k % 2 == 0)
        gen = ConditionGenerator(spoiled, max_retries=1, prompt_version="v5")
        prim = PRIMITIVES[pid]
        result = gen.generate(prim.task_name(*["cup", "lunch box"][: prim.n_objects]), exclude=[pid])
        constrained = [r.grammar is not None for r in spoiled.requests]
        assert result.attempts == 4 and constrained == [False, True, False, True], pid
        for transcript in result.transcripts:
            assert len(transcript.answers) == 2 and len(transcript.errors) == 1
            assert transcript.answers[0] == "Relevant objects: C, gripper\n"
        assert result.condition.mentioned_objects() <= {"cup", "lunch box", "gripper"}


@pytest.mark.llm
def test_the_default_generates_with_the_small_model_and_generalizes_with_the_large_one(
    embedded_backend, small_backend
):
    """The command line's default generator asks the paper's Listing 1 task of the 0.5B and a left-out
    primitive of the 1.5B, each answer right (Table II's criterion) and cached under its own model."""
    gen = ConditionGenerator.from_config(LLMConfig.load(None))
    assert gen.generation_backend.backend is small_backend and gen.backend.backend is embedded_backend
    seen = gen.generate("move bottle into box")
    left_out = gen.generate("release cup", exclude=["release"])
    assert (seen.mode, seen.model) == ("generation", "embedded:qwen2.5-coder-0.5b")
    assert (left_out.mode, left_out.model) == ("generalization", "embedded:qwen2.5-coder-1.5b")
    for result in (seen, left_out):
        reference = reference_condition(parse_task(result.condition.task_name))
        assert result.condition.matches(reference), result.condition.to_text()
    again = ConditionGenerator.from_config(LLMConfig.load("embedded:qwen2.5-coder-1.5b"))
    assert again.generation_backend is None and again.model == "embedded:qwen2.5-coder-1.5b"
    request = ChatRequest(seen.transcripts[0].messages)
    assert again.backend.key(request) != gen.generation_backend.key(request)  # nothing reused across models


def test_each_mode_has_its_model_and_results_name_both():
    """One place maps a mode to its model (:meth:`LLMConfig.for_mode`): the default's two, a chosen model for
    both; the label of the default names each mode's model and hash, and loads back as the default (a
    replay runs a result again with its recorded backend)."""
    default = LLMConfig.load(None)
    assert default.model is None
    assert {m: default.for_mode(m).model for m in ("generation", "generalization")} == MODE_MODELS
    assert MODE_MODELS == {"generation": "qwen2.5-coder-0.5b", "generalization": DEFAULT_EMBEDDED_MODEL}
    for spec in ("embedded:qwen2.5-coder-0.5b", "openai:m"):
        chosen = LLMConfig.load(spec)
        assert chosen.for_mode("generation") == chosen.for_mode("generalization") == chosen
    label, digest = backend_label(default)
    assert label.startswith("embedded:generation=qwen2.5-coder-0.5b,generalization=qwen2.5-coder-1.5b@")
    assert digest == ",".join(EMBEDDED_MODELS[m].sha256[:16] for m in MODE_MODELS.values())
    assert backend_label(LLMConfig.load("embedded:qwen2.5-coder-0.5b"))[0].startswith(
        "embedded:qwen2.5-coder-0.5b@"
    )
    recorded = label.split("@")[0]  # what `taskcond replay` runs a result again with
    assert LLMConfig.load(recorded) == default


def test_similar_order_puts_the_most_alike_examples_next_to_the_question():
    block = examples_block("spatial", nearest=PRIMITIVES["move_into"], order_seed=3)
    names = [line for line in block.splitlines() if line.startswith("Task name:")]
    assert names[-1] == "Task name: move A into B"  # generation: the task's own example is nearest
    loo = examples_block("state", exclude=["move_into"], nearest=PRIMITIVES["move_into"], order_seed=3)
    names = [line.removeprefix("Task name: ") for line in loo.splitlines() if line.startswith("Task name:")]
    assert sorted(names[-2:]) == ["move A in front of B", "move A on top of B"]
    assert names[-3] == "move A to position"
    assert sorted(loo.split("\n\n")) == sorted(examples_block("state", exclude=["move_into"]).split("\n\n"))


def test_prompt_versions_are_selectable_and_v2_keeps_the_papers_parts():
    task = parse_task("open top drawer")
    v1 = ConditionGenerator(Replay([]), prompt_version="v1").prompt("state", task, exclude=["open"])
    v2 = ConditionGenerator(Replay([]), prompt_version="v2").prompt("state", task, exclude=["open"])
    assert v1 != v2
    for prompt in (v1, v2):
        assert "gripper grasping/not grasping, container open/closed" in prompt
        assert "Remember to strictly follow the examples' format." in prompt
        assert prompt.rstrip().endswith("Q: Task name: open A")
        assert prompt.count("Task name: open A") == 1  # the question only
    with pytest.raises(ValueError, match="no prompt 'state' in prompt version 'v0'"):
        ConditionGenerator(Replay([]), prompt_version="v0").prompt("state", task)


def test_prompt_version_v3_asks_left_out_primitives_like_seen_ones():
    """v3: the plain Listing 2/3 prompt also when the task's primitive is left out (no CoT text)."""
    task = parse_task("move bottle into box")
    gen = ConditionGenerator(Replay([]), prompt_version="v3")
    for chat in ("spatial", "state"):
        loo = gen.prompt(chat, task, exclude=["move_into"])
        assert "First, decide which objects are relevant" not in loo
        assert loo.count("Task name: move A into B") == 1
        assert loo == ConditionGenerator(Replay([]), prompt_version="v1").prompt(chat, task).replace(
            letter_example_text(chat, "move_into") + "\n\n", ""
        )


def letter_example_text(chat, pid):
    from taskcond.examples import letter_example

    spatial = chat == "spatial"
    return letter_example(pid).only(spatial).to_text(include_collisions=spatial)


def test_prompt_version_v4_shows_worked_reasoning_of_the_shown_examples_only():
    """v4: for a left-out primitive every shown example reasons in one line before its answer; the left-out
    example's reasoning is left out with it, so the model reasons about the new primitive itself."""
    from taskcond.generator import load_reasons

    task = parse_task("open top drawer")
    gen = ConditionGenerator(Replay([]), prompt_version="v4")
    for chat in ("spatial", "state"):
        reasons = load_reasons(chat, "v4")
        assert reasons is not None and len(reasons) == len(PRIMITIVES)
        v1 = ConditionGenerator(Replay([]), prompt_version="v1")
        assert gen.prompt(chat, task) == v1.prompt(chat, task)  # generation: v1's
        loo = gen.prompt(chat, task, exclude=["open"])
        assert loo.count("Reasoning: ") == len(PRIMITIVES) - 1
        assert f"Task name: close A\nReasoning: {reasons['close A']}\nRelevant objects: A, gripper" in loo
        assert loo.count("Task name: open A") == 1  # the question only
        assert "First, decide which objects are relevant" in loo  # Listing 4's chain-of-thought prompt
        assert loo.rstrip().endswith("Q: Task name: open A")
    assert load_reasons("state", "v1") is None


def test_prompt_version_v5_shows_generation_examples_as_earlier_turns_of_the_chat():
    """v5: for a seen primitive the examples are the chat's earlier turns (task name asked, condition
    answered), the question its last turn; a left-out primitive gets v4's one-message prompt."""
    task = parse_task("move coffee mug into top drawer")
    gen = ConditionGenerator(Replay([]), prompt_version="v5")
    for chat in ("spatial", "state"):
        messages = gen.messages(chat, task, order_seed=2)
        assert [m.role for m in messages] == [
            "system",
            *["user", "assistant"] * (len(PRIMITIVES) + 1),
            "user",
        ]
        assert "Remember to strictly follow the examples' format." in messages[0].content
        assert "Task name" not in messages[0].content
        assert messages[-1].content == "Task name: move A into B"
        shown = [f"{q.content}\n{a.content}" for q, a in zip(messages[1:-1:2], messages[2:-1:2], strict=True)]
        registry = examples_block(chat, order_seed=2).split("\n\n")
        own = next(b for b in registry if b.startswith("Task name: move A into B\n"))
        assert shown == [*registry, own]  # the default order of the turns layout: all, then its own again
        assert examples_block(chat, order_seed=3) != examples_block(chat, order_seed=2)
        similar = ConditionGenerator(Replay([]), prompt_version="v5", example_order="similar")
        turns = similar.messages(chat, task, order_seed=2)[1:-1]
        nearest = examples_block(chat, order_seed=2, nearest=PRIMITIVES["move_into"]).split("\n\n")
        assert [f"{q.content}\n{a.content}" for q, a in zip(turns[::2], turns[1::2], strict=True)] == nearest
        assert not any("coffee mug" in m.content or "drawer" in m.content for m in messages)
        v4 = ConditionGenerator(Replay([]), prompt_version="v4")
        loo = gen.messages(chat, task, exclude=["move_into"])
        assert loo == v4.messages(chat, task, exclude=["move_into"])
    assert "gripper grasping/not grasping" in gen.messages("state", task)[0].content
    one_message = ConditionGenerator(Replay([]), prompt_version="v1", example_order="recall")
    assert one_message.prompt("state", task).count("Task name: move A into B") == 3  # twice, then asked


def test_v5_turns_reach_the_backend_and_their_answers_are_validated():
    invalid = "Relevant objects: A, B, gripper\nPre-conditions:\n  A tilted"
    backend = Replay([invalid, GOOD_SPATIAL, GOOD_STATE])
    result = ConditionGenerator(backend, prompt_version="v5").generate("move bottle into box")
    assert result.condition.matches(reference_condition(parse_task("move bottle into box")))
    assert backend.requests[0].messages[0].role == "system"
    assert backend.requests[1].messages[-2].content.endswith("A tilted")
    assert "not a condition: 'A tilted'" in backend.requests[1].messages[-1].content
    assert result.transcripts[0].messages == backend.requests[0].messages


def test_reasoning_before_the_answer_is_not_parsed():
    task = parse_task("move bottle into box")
    answer = "Reason: B is a container, so it stays open.\n" + GOOD_STATE
    cond = parse_answer(answer, "state", task, reasoning=True)
    assert cond.matches(reference_condition(task).only(spatial=False))
    with pytest.raises(ConditionError, match="unexpected line 'Reason: B is a container"):
        parse_answer(answer, "state", task)
    with pytest.raises(ConditionError, match="unexpected line"):
        parse_answer("Reasoning: none of it fits.\nI cannot answer.", "state", task, reasoning=True)
    grammar = answer_grammar("state", task, reasoning=True)
    assert grammar.startswith('root ::= "Reasoning: " [^\\n]+ "\\n" "Relevant objects: "')


def test_evaluation_scores_every_field_and_counts_invalid_answers_as_failures():
    """The Table II protocol on a scripted model: right in generation, no valid answer when left out."""
    from taskcond.evaluation import evaluate_conditions

    head = "Relevant objects: A, gripper\nPre-conditions:\n"
    spatial = head + "  none\nPost-conditions:\n  none\nCollisions: gripper and A"
    state = head + "  gripper not grasping\nPost-conditions:\n  gripper grasping A"
    backend = Replay([spatial, state, "nonsense", "nonsense", "nonsense"])
    result = evaluate_conditions(
        ConditionGenerator(backend, prompt_version=TWO_CHATS), trials=1, primitives=["grasp"]
    )
    assert (result.generation["grasp"].correct, result.generalization["grasp"].correct) == (1, 0)
    assert dict(result.generalization["grasp"].failures) == {"no valid answer": 1}
    assert "| Grasp | 100% (1/1) | 0% (0/1) |" in result.table()
    only = evaluate_conditions(
        ConditionGenerator(Replay([spatial, state]), prompt_version=TWO_CHATS),
        1,
        ["grasp"],
        modes=["generation"],
    )
    assert "| **all** | 100% (1/1) | not measured |" in only.table()


def _small_request(question: str) -> ChatRequest:
    """A few-shot chat of two examples and a question; its first three messages are the shared prefix."""
    turns = [
        ChatMessage("system", "Answer with the colour of the named fruit, in one word."),
        ChatMessage("user", "banana"),
        ChatMessage("assistant", "yellow"),
        ChatMessage("user", "cherry"),
        ChatMessage("assistant", "red"),
        ChatMessage("user", question),
    ]
    return ChatRequest(tuple(turns), sampling=Sampling(max_tokens=4), shared_messages=3)


@pytest.fixture
def prefix_backend(embedded_backend, tmp_path):
    """The session's embedded backend keeping its shared prefixes in ``tmp_path``, from an empty memory."""
    kept = embedded_backend.prefix_dir
    embedded_backend.prefix_dir = tmp_path
    embedded_backend.forget()
    yield embedded_backend
    embedded_backend.prefix_dir = kept
    embedded_backend.prefix_bytes = PREFIX_CACHE_BYTES
    embedded_backend.forget()


@pytest.mark.llm
def test_embedded_prefix_state_on_disk_answers_like_evaluating_it(prefix_backend, tmp_path):
    """A later process (here: the backend with its memory dropped) starts from the state kept on disk and
    answers exactly as the first one did; a damaged state is evaluated again instead of loaded."""
    first = prefix_backend.chat(_small_request("lime")).text
    (state,) = tmp_path.glob("*.state")
    hits = prefix_backend.prefix_hits
    prefix_backend.forget()
    assert prefix_backend.chat(_small_request("lime")).text == first
    assert prefix_backend.prefix_hits == hits + 1
    whole = state.read_bytes()
    state.write_bytes(whole[:-100])
    prefix_backend.forget()
    assert prefix_backend.chat(_small_request("lime")).text == first
    assert prefix_backend.prefix_hits == hits + 1
    assert [s.read_bytes() for s in tmp_path.glob("*.state")] == [whole]  # written whole again


@pytest.mark.llm
def test_embedded_answer_does_not_depend_on_the_requests_before_it(embedded_backend):
    """Every prompt is evaluated in the same segments, so a request answered from an empty context, after
    a request sharing part of its prompt, or after an unrelated one, gets the same tokens."""
    embedded_backend.forget()
    alone = embedded_backend.chat(_small_request("plum")).text
    embedded_backend.chat(_small_request("a lemon, or a grape if none"))
    after_shared = embedded_backend.chat(_small_request("plum")).text
    embedded_backend.chat(ChatRequest((ChatMessage("user", "Name a colour."),), Sampling(max_tokens=4)))
    embedded_backend.chat(ChatRequest((ChatMessage("user", "Name a fruit."),), Sampling(max_tokens=4)))
    after_other = embedded_backend.chat(_small_request("plum")).text
    assert alone == after_shared == after_other


@pytest.mark.llm
def test_embedded_prefix_states_beyond_the_bound_are_dropped_oldest_first(prefix_backend, tmp_path):
    prefix_backend.chat(_small_request("lime"))
    (older,) = tmp_path.glob("*.state")
    prefix_backend.prefix_bytes = older.stat().st_size + 1
    other = _small_request("lime")
    other = ChatRequest(
        (ChatMessage("system", "Name the fruit's colour."), *other.messages[1:]),
        other.sampling,
        shared_messages=3,
    )
    prefix_backend.chat(other)
    (kept,) = tmp_path.glob("*.state")
    assert kept != older


def test_the_shared_prefix_ends_before_the_repeated_own_example():
    """v5's generation shares the system message and every example; the repeated own example and the
    question follow it. The one-message layout marks nothing."""
    gen = ConditionGenerator(Replay([]), prompt_version=TWO_CHATS)
    task = parse_task("grasp cup")
    messages, shared = gen.layout("spatial", task)
    assert shared == 1 + 2 * len(PRIMITIVES)
    assert messages[shared].content == "Task name: grasp A"
    assert len(messages) == shared + 3
    other, other_shared = gen.layout("spatial", parse_task("open box"))
    assert (
        other_shared == shared and other[:shared] == messages[:shared] and other[shared] != messages[shared]
    )
    assert gen.layout("spatial", task, exclude=["grasp"])[1] == 0


@pytest.mark.llm
def test_embedded_prefix_directory_that_cannot_be_written_only_costs_time(prefix_backend, tmp_path):
    """The prefix states only save time: a prefix directory that cannot be created leaves the answer as
    it is and raises nothing."""
    answer = prefix_backend.chat(_small_request("lime")).text
    blocked = tmp_path / "not-a-directory"
    blocked.write_text("a file where the directory should be")
    prefix_backend.prefix_dir = blocked / "prefixes"
    prefix_backend.forget()
    assert prefix_backend.chat(_small_request("lime")).text == answer
    assert blocked.read_text() == "a file where the directory should be"


def test_lookup_proposes_the_continuation_of_the_longest_earlier_match():
    """Prompt lookup: the place whose preceding tokens match the most of the sequence's end wins (here the
    second ``7 8 9``, preceded by ``6`` as the end is), and the draft is twice the match long, at least 4."""
    tokens = [1, 7, 8, 9, 10, 11, 6, 7, 8, 9, 20, 21, 22, 23, 24, 25, 26, 27, 28, 6, 7, 8, 9]
    starts: dict[tuple[int, ...], list[int]] = {}
    for i in range(3, len(tokens) + 1):
        starts.setdefault(tuple(tokens[i - 3 : i]), []).append(i)
    assert EmbeddedBackend.lookup(tokens, starts) == [20, 21, 22, 23, 24, 25, 26, 27]
    assert EmbeddedBackend.lookup([*tokens, 99, 98, 97], starts) == []
    assert EmbeddedBackend.lookup([5, 5, 5, 1, 2, 3, 4, 1, 2, 3], {(1, 2, 3): [6, 10]}) == [4, 1, 2, 3]


@pytest.mark.llm
@pytest.mark.native_runtime
def test_embedded_drafts_keep_the_greedy_answer(embedded_backend, monkeypatch):
    """Drafts from the prompt change how many evaluations an answer takes, not the answer: a generation
    prompt (whose answer the repeated own example shows, nearly all of it accepted from drafts) and a
    request cut by ``max_tokens`` get llama-cpp-python's own greedy completion, with and without drafts.
    (A free reasoning line can tip at a near tie between a batch's and a single token's floating-point
    result, so no chain-of-thought answer is compared here.) The native runtime's own decoding; the
    xllamacpp runtime's drafts are tested in test_xllamacpp_backend.py."""
    assert isinstance(embedded_backend, EmbeddedBackend)  # the marker deselects this test otherwise
    gen = ConditionGenerator(embedded_backend)
    requests = [
        ChatRequest(gen.messages("state", parse_task("move bowl into top drawer")), stop=("\n\n",)),
        ChatRequest(gen.messages("spatial", parse_task("tilt cup")), stop=("\n\n",)),
        _small_request("lime"),
    ]
    for request in requests:
        embedded_backend.forget()
        drafted = embedded_backend.accepted
        with_drafts = embedded_backend.chat(request)
        assert with_drafts.completion_tokens <= request.sampling.max_tokens
        if request is not requests[-1]:
            assert embedded_backend.accepted - drafted >= with_drafts.completion_tokens - 2
        monkeypatch.setattr(embedded_backend, "draft", False)
        embedded_backend.forget()
        assert embedded_backend.chat(request).text == with_drafts.text
        monkeypatch.setattr(embedded_backend, "draft", True)
        embedded_backend.forget()
        llm = embedded_backend._contexts[0]  # as the backend answered before it drafted
        messages = [{"role": m.role, "content": m.content} for m in request.messages]
        tokens = embedded_backend._tokens(llm, messages)
        embedded_backend._prepare(0, tokens, embedded_backend.segment_starts(llm, tokens), 0)
        reference = llm.create_chat_completion(
            messages=messages,
            temperature=0.0,
            top_k=1,
            max_tokens=request.sampling.max_tokens,
            stop=list(request.stop) or None,
        )
        embedded_backend.forget()
        assert with_drafts.text == reference["choices"][0]["message"]["content"]


@pytest.mark.llm
def test_a_plan_the_answers_keep_contradicting_is_what_the_words_say(embedded_backend):
    """Every answer says ``move cube into box`` for "stack the cube on the box, then close the top drawer":
    each is shown its contradiction and asked again; after the last, every clause reading as a primitive
    task, the plan is what the clauses say (releases added) and the caller is told. With a clause that
    reads as no task, there is no such plan: the error names the contradiction."""
    from taskcond.decompose import DecompositionError, decompose

    wrong = "grasp cube\nmove cube into box\nrelease cube\nclose top drawer\n"
    spoiled = Spoiled(embedded_backend, wrong, spoil=lambda k: True)
    objects = ["cube", "box", "top drawer"]
    told: list[str] = []
    plan = decompose(
        "Stack the cube on the box, then close the top drawer.", spoiled, objects, tell=told.append
    )
    assert plan == ["move cube on top of box", "release cube", "close top drawer"]
    assert len(spoiled.requests) == 3 and "says 'move cube on top of box'" in told[0]
    assert "says 'move cube on top of box'" in spoiled.requests[1].messages[-1].content
    with pytest.raises(DecompositionError, match="says 'move cube on top of box'"):
        decompose("Stack the cube on the box, then tidy up.", spoiled, objects)
