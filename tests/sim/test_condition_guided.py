"""Condition-guided execution in the suite (paper §III-E, Alg. 1 and Alg. 2) with real PyBullet, real
demonstrations and, for the LLM method, the real embedded model."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

pytest.importorskip("pybullet")

from taskcond.application.demonstrations import learn_library
from taskcond.application.episode import run_episode
from taskcond.application.plans import RunPlan, llm_decomposer, plan_run
from taskcond.cli import app
from taskcond.conditions import (
    Collision,
    ContainerState,
    GripperState,
    Relation,
    SpatialRelation,
    TaskCondition,
)
from taskcond.envs.kitchen import KitchenEnv
from taskcond.execution.approach import Aim
from taskcond.execution.executor import Executor
from taskcond.execution.skills import Demonstration, SkillLibrary, learn_skill
from taskcond.execution.sources import EnvConditions, GroundedConditions, LLMConditions
from taskcond.execution.world import Touch
from taskcond.generator import ConditionGenerator
from taskcond.tasks.free import FreeTask
from taskcond.tasks.registry import make
from taskcond.worlds.kitchen import KitchenWorld

pytestmark = pytest.mark.sim

DEMOS = ["grasp-bottle", "open-box", "LHT1"]


@pytest.fixture(scope="module")
def library_dir(tmp_path_factory):
    directory = tmp_path_factory.mktemp("skills")
    learn_library(directory, DEMOS, workers=2)
    return directory


@pytest.fixture(scope="module")
def library(library_dir):
    from taskcond.execution.skills import SkillLibrary

    return SkillLibrary.load(library_dir)


class Fixed:
    """A condition source with hand-written conditions (to provoke cycles and collisions)."""

    name = "fixed"

    def __init__(self, conditions: dict[str, TaskCondition]) -> None:
        self.conditions = conditions

    def condition(self, task_name: str) -> TaskCondition:
        return self.conditions[task_name]


def test_two_workers_learn_the_files_one_learns(library_dir, tmp_path) -> None:
    """The module's library was learned by two processes; one process learns its primitives' skill files
    byte for byte (each oracle run has its own simulation and seed)."""
    serial = tmp_path / "serial"
    learn_library(serial, DEMOS[:2])
    files = sorted(p.name for p in serial.iterdir() if p.name != "library.json")
    assert len(files) >= 6 and {f.split("-")[0] for f in files} == {"grasp", "open"}
    assert all((serial / f).read_bytes() == (library_dir / f).read_bytes() for f in files)


def test_learned_library_has_the_primitives_and_the_long_horizon_steps(library) -> None:
    assert {"grasp-bottle", "open-box"} <= set(library.skills)
    steps = sorted(k for k in library.skills if k.startswith("LHT1."))
    assert steps == [
        "LHT1.1-grasp-bottle",
        "LHT1.2-move_into-bottle-box",
        "LHT1.3-release-bottle",
        "LHT1.4-close-box",
    ]
    cond = library.skills["open-box"].condition
    assert ContainerState("box", False) in cond.pre_conditions
    assert ContainerState("box", True) in cond.post_conditions


@pytest.mark.parametrize("method", ["none", "env"])
def test_lht1_succeeds_with_dmp_skills(library, method) -> None:
    source = EnvConditions(library) if method == "env" else None
    for seed in (1000, 1001):
        result = run_episode(plan_run("LHT1"), method, seed, library, source)
        assert result.success, (result.reason, [e["message"] for e in result.events][-5:])
        assert result.failure is None and result.sim_seconds > 5


def test_alg1_raises_the_primitives_an_unmet_precondition_needs(library) -> None:
    """The box starts closed and the bottle on the table: moving it into the box raises 'open box' and
    'grasp bottle' (in the order of the pre-conditions), then succeeds."""
    env = KitchenEnv(FreeTask("move bottle into box"))
    try:
        env.reset(seed=3)
        world = KitchenWorld(env, noise_sigma=0.005, seed=3)
        executor = Executor(world, library, "env", EnvConditions(library))
        result = executor.run(["move bottle into box"])
        raised = [e.task for e in result.events if e.kind == "raise"]
        assert raised[:2] == ["open box", "grasp bottle"]
        assert result.completed, result.failure
        assert env.truth.holds(SpatialRelation("bottle", Relation.INSIDE, "box"))
    finally:
        env.close()


def test_alg1_stops_on_a_cycle_with_a_reason(library) -> None:
    conditions = {
        "grasp bottle": TaskCondition("grasp bottle", pre_conditions=(ContainerState("box", True),)),
        "open box": TaskCondition("open box", pre_conditions=(GripperState("bottle"),)),
    }
    env = make("LHT1")
    try:
        env.reset(seed=0)
        env.scene.set_joint("box", 0.0)
        result = Executor(KitchenWorld(env), library, "llm", Fixed(conditions)).run(["grasp bottle"])
    finally:
        env.close()
    assert not result.completed and result.failure_kind == "cycle"
    assert "grasp bottle -> open box -> grasp bottle" in result.failure


def test_alg2_backs_up_and_moves_the_goal_on_an_unallowed_collision(library) -> None:
    """A grasp whose condition allows no collision with the bottle: touching it is reported, the arm backs
    up and the goal is moved horizontally away from the contact by at most 5 cm (here both fingers touch,
    so the contact's centre is the bottle's and the move is nil; ``tests/test_fake_world.py`` checks a
    one-sided contact's move and that the movement goes on towards the moved goal), a bounded number of
    times; then the grasp goes on and holds the bottle (its post-condition checked, the task's success)."""
    strict = {"grasp bottle": TaskCondition("grasp bottle", post_conditions=(GripperState("bottle"),))}
    env = make("grasp-bottle")
    try:
        env.reset(seed=0)
        result = Executor(KitchenWorld(env), library, "llm", Fixed(strict)).run(["grasp bottle"])
        assert result.completed and result.failure is None and env.task.success(env)
    finally:
        env.close()
    assert [e.kind for e in result.events].count("post") == 1
    hits = [e for e in result.events if e.kind == "collision"]
    assert hits and result.adjustments == len(hits)
    assert {Collision(*hits[0].data["collision"])} == {Collision("gripper", "bottle")}
    for hit in hits:
        assert np.linalg.norm(hit.data["shift"]) <= 0.05 + 1e-3  # trace rounds to 0.1 mm
        assert hit.data["shift"][2] == 0.0  # horizontal only


def test_alg2_moves_the_goal_up_for_the_hand_touching_the_table_below_it() -> None:
    """Alg. 2 lines 11-12 for a contact below the hand (issue 32): the gripper touching the table under a
    fingertip, lower than the end effector, moves the grasp's goal up, to 1 cm above the hand's height at
    the contact; the same contact with the bottle, or the table touched above the end effector, keeps the
    horizontal ``goalPos - collPos``; a move onto the table (the table its target) keeps it too."""
    env = make("grasp-bottle")
    try:
        env.reset(seed=0)
        world = KitchenWorld(env)
        here, _ = world.ee_pose()
        bottle = world.observe().centers["bottle"]
        way = np.linspace(here, bottle + np.array([0.0, 0.0, 0.1]), 30)  # one piece: to the bottle
        demo = Demonstration(
            "grasp bottle",
            "grasp-bottle",
            np.arange(30) / 30,
            way,
            np.tile(world.ee_pose()[1], (30, 1)),
            np.zeros(30),
            "bottle",
            bottle,
        )
        library = SkillLibrary()
        library.add(learn_skill(demo))
        executor = Executor(world, library, "llm", Fixed({}))
        aim = Aim("grasp bottle", next(iter(library.skills.values())), "bottle", bottle)
        goal = here - [0.0, 0.0, 0.004]  # the hand 4 mm above its goal when the fingertip meets the table
        fingertip = here + np.array([0.04, 0.0, -0.01])
        up = executor._goal_shift(Touch("gripper", "table", fingertip), goal, aim, set())
        side = executor._goal_shift(Touch("gripper", "bottle", fingertip), goal, aim, set())
        over = here + np.array([0.04, 0.0, 0.01])  # the table's edge above the end effector
        above = executor._goal_shift(Touch("table", "gripper", over), goal, aim, set())
        onto = Aim("move bottle on top of table", aim.skill, "table", here)
        onto_table = executor._goal_shift(Touch("gripper", "table", fingertip), goal, onto, set())
    finally:
        env.close()
    assert up.below == "table" and np.allclose(up.vector, [0.0, 0.0, 0.014])
    for shift in (side, above, onto_table):
        assert shift.below is None and shift.vector[2] == 0.0 and np.linalg.norm(shift.vector) > 0.0


def test_container_states_an_object_cannot_have_are_ignored_with_a_note(library) -> None:
    """A generated condition with ``bottle closed`` (a bottle has no lid here) neither raises an impossible
    'open'/'close' nor blocks the post-condition check; an open-top mug's ``mug open`` holds and stays."""
    slip = TaskCondition(
        "grasp bottle",
        ("bottle", "gripper"),
        (GripperState(None), ContainerState("bottle", False), ContainerState("mug", True)),
        (GripperState("bottle"), ContainerState("bottle", True)),
        (Collision("gripper", "bottle"),),
    )
    env = make("grasp-bottle")
    try:
        env.reset(seed=0)
        result = Executor(KitchenWorld(env), library, "llm", Fixed({"grasp bottle": slip})).run(
            ["grasp bottle"]
        )
        assert env.task.success(env)
    finally:
        env.close()
    ignored = [e for e in result.events if e.kind == "ignored"]
    assert len(ignored) == 1 and ignored[0].data["ignored"] == ["bottle closed", "bottle open"]
    used = result.conditions["grasp bottle"]
    assert ContainerState("mug", True) in used.pre_conditions
    assert result.raised == 0 and [e.kind for e in result.events].count("post") == 1


def test_bad_input_fails_with_a_reason(library) -> None:
    env = make("move-bottle")
    try:
        env.reset(seed=0)
        world = KitchenWorld(env)
        result = Executor(world, library, "none").run(["grasp banana"])
        assert result.failure_kind == "bad_task" and "'banana' not in the scene" in result.failure
        result = Executor(world, library, "none").run(["open table"])
        assert result.failure_kind == "bad_task" and "has no lid, door or drawer" in result.failure
        env.scene.place("bottle", (0.95, 0.0), 0.0)  # on the table, beyond the arm's reach
        result = Executor(world, library, "none").run(["grasp bottle"])
        assert result.failure_kind == "unreachable" and "is out of reach" in result.failure
        assert "from the gripper's shoulder, it reaches" in result.failure
        result = Executor(world, library, "none").run(["move bottle to position"])
        assert result.failure_kind == "no_skill" and "move" in result.failure  # no move demonstrated
    finally:
        env.close()


def test_run_and_eval_commands(library_dir, tmp_path) -> None:
    runner = CliRunner()
    trace = tmp_path / "trace.json"
    args = [
        "run",
        "LHT1",
        "--method",
        "none",
        "--no-video",
        "--skills",
        str(library_dir),
        "--trace",
        str(trace),
    ]
    res = runner.invoke(app, args)
    assert res.exit_code == 0, res.output
    assert "1. grasp bottle" in res.output and "LHT1: succeeded" in res.output
    data = json.loads(trace.read_text())
    assert data["success"] is True and data["plan"]["steps"][-1] == "close box"
    assert data["goal_missing"] == [] and {"box closed", "bottle inside box"} <= set(data["final_predicates"])
    bad = runner.invoke(app, ["run", "LHT1", "--method", "magic"])
    assert bad.exit_code == 2 and "use one of llm, llm+demo, env, none" in bad.output

    out = tmp_path / "eval.jsonl"
    args = ["eval", "long-horizon", "--task", "LHT1", "--method", "none", "--episodes", "2", "--workers", "1"]
    args += ["--out", str(out), "--skills", str(library_dir), "--json"]
    res = runner.invoke(app, args)
    assert res.exit_code == 0, res.output
    rows = json.loads(res.output[res.output.index("{") :])["results"]
    assert rows[0]["task"] == "LHT1" and rows[0]["episodes"] == 2
    lines = out.read_text().splitlines()
    assert len(lines) == 3  # the configuration, then the episodes
    again = runner.invoke(app, args)  # resumes: nothing left to run, nothing appended
    assert again.exit_code == 0 and len(out.read_text().splitlines()) == 3


@pytest.mark.llm
def test_lht1_with_embedded_llm_conditions(library, cached_llm) -> None:
    source = LLMConditions(ConditionGenerator(cached_llm))
    result = run_episode(RunPlan("LHT1", "LHT1", tuple(plan_run("LHT1").steps)), "llm", 1000, library, source)
    assert result.success, (result.reason, [e["message"] for e in result.events][-6:])
    assert set(result.conditions) >= {"grasp bottle", "close box"}


@pytest.mark.llm
def test_lht1_with_llm_conditions_grounded_in_the_demonstrations(library, cached_llm) -> None:
    """``llm+demo`` on a suite long-horizon task: each step's LLM condition grounded in its primitive's
    demonstration (the repairs in the trace), and the task succeeds."""
    source = GroundedConditions(ConditionGenerator(cached_llm), library)
    result = run_episode(plan_run("LHT1"), "llm+demo", 1001, library, source)
    assert result.success, (result.reason, [e["message"] for e in result.events][-6:])
    assert result.method == "llm+demo" and set(result.conditions) == set(plan_run("LHT1").steps)
    repairs = {e["task"]: e["repairs"] for e in result.events if e["kind"] == "repair"}
    assert repairs == {t: [r.to_dict() for r in rs] for t, rs in source.repairs.items() if rs}


@pytest.mark.llm
def test_a_multi_step_free_instruction_from_a_random_start(library, cached_llm) -> None:
    """A user's instruction in their own words: the real model decomposes it, the LLM writes each step's
    condition, the planner and Alg. 1 fill in what the random start needs, and the goal (derived from the
    plan) holds at the end by the ground truth."""
    instruction = "Place the bottle inside the box, then shut the box."
    plan = plan_run(instruction, llm_decomposer(backend=cached_llm))
    assert plan.decomposed and plan.steps[0] == "grasp bottle" and plan.steps[-1] == "close box"
    source = LLMConditions(ConditionGenerator(cached_llm))
    result = run_episode(plan, "llm", 1002, library, source, start_state="random")
    assert result.start == "random"
    assert result.success and result.goal_missing == [], (result.reason, result.events[-4:])
    assert {"bottle inside box", "box closed"} <= set(result.goal) <= set(result.final_predicates)


def test_fold_runs_both_arms_from_one_two_arm_skill(tmp_path) -> None:
    """The dual-arm fold demonstration becomes one skill of 6-dimensional DMPs (both arms' positions);
    executed from the cloth's perceived centre it folds the cloth with both arms. In the single-arm scene
    the fold is refused with its reason."""
    library = learn_library(tmp_path, ["fold-cloth"])
    skill = library.skills["fold-cloth"]
    assert skill.arms == 2 and skill.segments[0].dmp.n_dims == 6
    result = run_episode(plan_run("fold-cloth"), "none", 1000, library, None, noise=0.0)
    assert result.success, (result.reason, [e["message"] for e in result.events][-4:])
    assert "skill fold-cloth" in result.events[1]["message"]
    env = make("grasp-bottle")
    try:
        env.reset(seed=0)
        refused = Executor(KitchenWorld(env), library, "none").run(["fold cloth"])
    finally:
        env.close()
    assert refused.failure_kind == "bad_task" and "'cloth' not in the scene" in refused.failure


def test_a_free_instruction_whose_goal_does_not_hold_fails_and_its_trace_has_the_final_predicates(
    library,
) -> None:
    """DMP only, the move into the closed box without a grasp: the bottle stays where it stood, so the
    goal (``bottle inside box``) does not hold; the final predicates are the ground truth's."""
    plan = RunPlan("put the bottle into the box", None, ("move bottle into box",), decomposed=True)
    result = run_episode(plan, "none", 1000, library, None, noise=0.0)
    assert result.goal == ["bottle inside box"]
    assert result.success is False and result.failure == "not_succeeded"
    assert result.goal_missing == ["bottle inside box"] and "bottle inside box" in result.reason
    final = result.final_predicates
    assert final == sorted(final) and "box closed" in final and "bottle inside box" not in final
    assert "bottle above table" in final and "gripper not grasping" in final


def test_the_planner_inserts_open_box_before_the_grasp_with_fixed_conditions(library) -> None:
    """LHT1 from a closed box (the free scene): the planner opens the box before the grasp, so Alg. 1
    never throws the bottle away to open it; the plan then reaches its goal. The conditions are the
    reference ones, shortened to what the planner needs (each allows the gripper to touch what it handles:
    a grasp that may not touch the bottle cannot hold it)."""
    conditions = {
        "grasp bottle": TaskCondition(
            "grasp bottle",
            (),
            (GripperState(None),),
            (GripperState("bottle"),),
            (Collision("gripper", "bottle"),),
        ),
        "open box": TaskCondition(
            "open box",
            (),
            (GripperState(None), ContainerState("box", False)),
            (ContainerState("box", True),),
            (Collision("gripper", "box"),),
        ),
        "move bottle into box": TaskCondition(
            "move bottle into box",
            (),
            (GripperState("bottle"), ContainerState("box", True)),
            (SpatialRelation("bottle", Relation.INSIDE, "box"),),
            (Collision("gripper", "bottle"),),
        ),
    }
    plan = RunPlan("put the bottle into the box", None, ("grasp bottle", "move bottle into box"), True)
    seen = []
    result = run_episode(
        plan, "env", 1000, library, Fixed(conditions), noise=0.0, on_plan=lambda r, g: seen.append((r, g))
    )
    ((repair, goal),) = seen
    assert repair.steps == ("open box", "grasp bottle", "move bottle into box")
    assert [str(q) for q in goal] == ["bottle inside box"]
    assert result.steps == list(repair.steps) and result.repair["changes"][0]["task"] == "open box"
    assert result.events[0]["message"] == "step: open box"
    assert result.success and result.goal_missing == [], (result.reason, result.events[-3:])
    assert "bottle inside box" in result.final_predicates and "box open" in result.final_predicates


def test_random_start_is_seeded_and_collision_free() -> None:
    env = KitchenEnv(FreeTask("anything", start="random"))
    try:

        def state(seed: int):
            env.reset(seed=seed)
            poses = {n: env.scene.pose(n)[0].round(4).tolist() for n in env.scene.free_objects}
            fractions = [round(f, 2) for f in env.scene.open_fractions()]
            return poses, fractions

        first, again, other = state(5), state(5), state(6)
        assert first == again and first != other
        assert any(f > 0.5 for _, fs in (first, other) for f in fs)  # some container starts open
        truth = env.truth
        for name in env.scene.free_objects:  # upright on the table, touching nothing but the table
            assert truth.holds(SpatialRelation(name, Relation.ABOVE, "table")), name
    finally:
        env.close()


@pytest.mark.parametrize(
    ("instruction", "error"),
    [
        ("Put the box into the bottle.", "error: cannot 'move box into bottle': 'box' cannot be moved"),
        (  # a clause of a longer instruction; told that it was refused, the LLM answered the mug on the table
            "Open the door, then put the mug in the microwave and close it.",
            "error: cannot 'move mug into microwave': the microwave opens at its side",
        ),
        ("Pick up the can and put it in the microwave.", "error: cannot 'move can into microwave'"),
        (
            "Push the bottle shut.",
            "error: cannot 'close bottle': 'bottle' has no lid",
        ),  # read as said to the LLM
    ],
)
def test_an_instruction_whose_roles_are_impossible_is_one_line_and_nothing_runs(
    tmp_path, monkeypatch, instruction, error
) -> None:
    """Refused in one line before the LLM is asked (no answer cached), and nothing runs."""
    monkeypatch.setenv("TASKCOND_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.chdir(tmp_path)
    res = CliRunner().invoke(app, ["run", instruction])
    assert res.exit_code == 2, res.output
    assert res.stderr.startswith(error)
    assert res.stderr.count("\n") == 1 and not (tmp_path / "runs").exists()
    assert not (tmp_path / "cache").exists() or not any((tmp_path / "cache").rglob("*.json"))


def test_a_flat_cloth_is_located_at_its_resting_height_whatever_the_noise() -> None:
    """The cloth lying flat: its perceived centre's height is noise (σ = 1 cm here), so the world locates
    it at its resting height, the x and y still perceived; a cloth perceived taller than
    :data:`~taskcond.worlds.kitchen.FLAT` keeps its perceived centre."""
    from dataclasses import replace

    from taskcond.worlds.kitchen import FLAT

    env = make("fold-cloth")
    try:
        env.reset(seed=0)
        world = KitchenWorld(env, noise_sigma=0.01, seed=4)
        rest = env.scene.config.cloth.collision_margin
        heights, xs = set(), set()
        for _ in range(5):
            position, orientation = world.ee_pose(2)
            world.step(position, orientation, 1.0)
            obs = world.observe()
            centre = world.locate("cloth", obs)
            lower, upper = obs.boxes["cloth"]
            if upper[2] - lower[2] < FLAT:
                heights.add(round(float(centre[2]), 9))
                xs.add(round(float(centre[0]), 9))
        assert heights == {round(rest, 9)} and len(xs) > 1
        tall = replace(obs, boxes={**obs.boxes, "cloth": (lower, lower + np.array([0.2, 0.2, 0.05]))})
        assert world.locate("cloth", tall)[2] == obs.centers["cloth"][2]
    finally:
        env.close()
