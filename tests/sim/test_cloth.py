"""The cloth, the Kinova in the scene, the fold measure and oracle, grasp cloth, and their bad inputs."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from numpy.testing import assert_allclose

pytest.importorskip("pybullet")

from taskcond.conditions import KINOVA_GRIPPER, GripperState, Relation, SpatialRelation
from taskcond.sim.cloth import ClothSpec, FingerFrame, covered_layers, fold_measure, nodes_between_fingers
from taskcond.sim.franka import top_down
from taskcond.sim.perception import Perception, PerceptionConfig
from taskcond.tasks.fold import fold_trajectory
from taskcond.tasks.oracle import run_episode
from taskcond.tasks.registry import make

pytestmark = pytest.mark.sim


def _flat(spec: ClothSpec) -> np.ndarray:
    return np.column_stack([spec.rest_nodes(), np.zeros(spec.resolution**2)])


def _folded(spec: ClothSpec, gap: float) -> np.ndarray:
    """The flat cloth with its -x half mirrored onto the +x half, ``gap`` m higher."""
    nodes = _flat(spec)
    moved = nodes[:, 0] < 0
    nodes[moved, 0] *= -1
    nodes[moved, 2] = gap
    return nodes


def test_fold_measure_of_a_flat_and_an_ideal_fold():
    spec = ClothSpec(size=0.2, resolution=11)
    flat = fold_measure(_flat(spec), spec, "-x", "+x", cell=0.002)
    assert_allclose(flat.double_fraction, 0.0)
    assert_allclose(flat.edge_distance, 0.2)
    ideal = fold_measure(_folded(spec, 0.004), spec, "-x", "+x", cell=0.002)
    assert_allclose(ideal.double_fraction, 1.0, atol=0.05)
    assert_allclose(ideal.edge_distance, 0.004)
    assert_allclose(ideal.edge_offset, 0.0, atol=1e-12)  # the layers differ in height only
    assert_allclose(ideal.max_height, 0.004)


def test_covered_layers_counts_each_layer_once():
    spec = ClothSpec(size=0.1, resolution=5)
    counts, area = covered_layers(_flat(spec), spec.triangles(), 0.01)
    assert counts.shape == (10, 10)
    assert_allclose(area, 1e-4)
    assert np.all(counts == 1)  # cell centres never lie on a shared triangle edge here


def test_nodes_between_fingers_grows_the_box_per_axis():
    frame = FingerFrame(
        center=np.zeros(3),
        closing=np.array([1.0, 0.0, 0.0]),
        approach=np.array([0.0, 0.0, -1.0]),
        half_opening=0.01,
        pad_half_width=0.01,
        pad_half_length=0.02,
        pad_thickness=0.005,
    )
    # between the pads; beside a pad (closing axis); past the pad's side (across); past the fingertips
    nodes = np.array([[0.0, 0.0, 0.0], [0.013, 0.0, 0.0], [0.0, 0.015, 0.0], [0.0, 0.0, -0.025]])
    assert nodes_between_fingers(nodes, frame, 0.0).tolist() == [0]
    assert nodes_between_fingers(nodes, frame, 0.006).tolist() == [0, 2, 3]
    assert nodes_between_fingers(nodes, frame, 0.006, across_margin=0.0).tolist() == [0, 3]
    assert nodes_between_fingers(nodes, frame, 0.0, closing_margin=0.005).tolist() == [0, 1]


def test_cloth_spec_rejects_bad_values():
    with pytest.raises(ValueError, match="at least 3 nodes per edge"):
        ClothSpec(resolution=2)
    with pytest.raises(ValueError, match="substeps must be at least 1"):
        ClothSpec(substeps=0)
    with pytest.raises(ValueError, match="unknown cloth edge 'x'"):
        ClothSpec().edge("x")


def test_single_arm_tasks_have_no_kinova_or_cloth():
    env = make("grasp-bottle", seed=0)
    try:
        assert env.kinova is None and env.scene.cloth is None and env.scene.grips is None
        assert [g.name for g in env.scene.description().grippers] == ["gripper"]
        assert env.action_space.shape == (8,)
        env.reset()
        with pytest.raises(ValueError, match=r"action must have shape \(8,\) or \(7,\)"):
            env.step(np.zeros(16))
        # fold without a cloth: a one-line error, not a hang
        with pytest.raises(ValueError, match="fold needs a cloth in the scene"):
            fold_trajectory(env)
        with pytest.raises(ValueError, match="the scene has no cloth"):
            env.scene.cloth_nodes()
    finally:
        env.close()


@pytest.fixture(scope="module")
def fold_env():
    env = make("fold-cloth", seed=0, render_mode="rgb_array")
    yield env
    env.close()


def test_dual_arm_scene_names_both_grippers_and_reads_the_cloth(fold_env):
    env = fold_env
    env.reset(seed=0)
    description = env.scene.description()
    assert [g.name for g in description.grippers] == ["gripper", KINOVA_GRIPPER]
    assert description.soft_bodies == [env.scene.cloth]
    assert env.action_space.shape == (16,)
    obs, _ = env.reset(seed=1)
    spec = env.scene.config.cloth
    assert obs["cloth_nodes"].shape == (spec.resolution**2, 3)
    # flat on the table, centred near its nominal place
    assert_allclose(obs["cloth_nodes"][:, 2], spec.collision_margin, atol=0.002)
    assert_allclose(obs["cloth_nodes"][:, :2].mean(axis=0), env.scene.config.cloth_center, atol=0.03)
    assert_allclose(
        obs["kinova_ee_position"],
        env.kinova.forward_kinematics(env.kinova.joint_positions())[:3, 3],
        atol=1e-4,
    )
    # the Kinova stands on the Franka's left, clear of the single-arm work area
    assert env.kinova.base_position[1] > 0.5
    # the spatula put on the cloth: the relation in perception; both grippers free
    top = float(obs["cloth_nodes"][:, 2].max())
    env.scene.place("spatula", env.scene.config.cloth_center, 0.0, z=top + 0.003)
    env.settle(0.2)
    info = Perception(description, PerceptionConfig(check_visibility=False)).observe(0)
    assert SpatialRelation("spatula", Relation.ABOVE, "cloth") in info.predicates
    assert {GripperState(None), GripperState(None, KINOVA_GRIPPER)} <= info.predicates
    lo, hi = info.boxes["cloth"].lower, info.boxes["cloth"].upper
    assert_allclose(hi[:2] - lo[:2], [spec.size, spec.size], atol=0.02)


def test_spatula_put_on_the_cloth_rests_on_it(fold_env):
    """The spatula collides with the cloth: dropped 3 mm onto it, it comes to rest on the nodes beneath
    it (bottom above them by less than the cloth's collision margin and its own), not on the table through
    the cloth, and the cloth stays flat (2 sub-steps per 240 Hz step; at 1 it blew up within a second)."""
    env = fold_env
    obs, _ = env.reset(seed=2)
    flat = obs["cloth_nodes"]
    centre = flat[:, :2].mean(axis=0)
    env.scene.place("spatula", centre, 0.4, z=float(flat[:, 2].max()) + 0.003)
    env.settle(1.5)
    lo, hi = env.scene.aabb("spatula")
    nodes = env.scene.cloth_nodes()
    beneath = nodes[np.all((nodes[:, :2] >= lo[:2]) & (nodes[:, :2] <= hi[:2]), axis=1)]
    assert len(beneath) >= 20
    gap = lo[2] - beneath[:, 2].max()
    assert 0.0 < gap < 0.006  # on the cloth's nodes, within the contact margins
    assert lo[2] > env.scene.config.cloth.collision_margin + 0.001  # not on the table
    assert np.abs(nodes - flat).max() < 0.003  # no blow-up: every node within 3 mm of where it lay
    assert_allclose(env.scene.pose("spatula")[0][:2], centre, atol=0.005)  # and it stayed put


def _sweep_open_fingers(env) -> float:
    """Sweep the open Franka fingers 8 cm along +x into the cloth's near edge, fingertips about 4 mm above
    the table, closing axis along x; return the mean x displacement (m) of the cloth's nodes."""
    flat = env.scene.cloth_nodes()
    orientation = np.array(top_down(np.pi / 2))
    start = np.array([flat[:, 0].min() - 0.04, flat[:, 1].mean() - 0.06, 0.015])
    for k in range(45):
        z = 0.1 if k < 10 else 0.0
        ahead = max(0, k - 20) / 25 * 0.08
        env.step(np.concatenate([start + np.array([ahead, 0.0, z]), orientation, [0.0]]))
    return float((env.scene.cloth_nodes() - flat)[:, 0].mean())


def test_open_fingers_push_the_cloth_and_pass_through_only_with_pad_contact_off(fold_env):
    env = fold_env
    grips = env.scene.grips
    env.reset(seed=0)
    pushed = _sweep_open_fingers(env)
    assert grips.passing == set() and grips.anchors == {}
    assert pushed > 0.005
    grips.spec = replace(grips.spec, pad_contact=False)
    try:
        env.reset(seed=0)
        assert grips.passing == {"gripper", KINOVA_GRIPPER}
        assert abs(_sweep_open_fingers(env)) < 1e-4  # the fingers pass through
    finally:
        grips.spec = env.scene.config.cloth
        grips.reset_contacts()


def test_kinova_target_out_of_reach_fails_the_episode_with_its_reason(fold_env):
    env = fold_env
    env.reset(seed=0)
    franka = np.concatenate([env.robot.ee_pose().position, env.robot.ee_pose().orientation, [0.0]])
    kinova = np.array([2.0, 2.0, 0.5, 1.0, 0.0, 0.0, 0.0, 0.0])
    _, _, terminated, _, info = env.step(np.concatenate([franka, kinova]))
    assert terminated
    assert info["failure"] == "kinova_unreachable"
    assert "beyond its reach" in info["failure_detail"]


def test_fold_oracle_folds_the_cloth_with_both_arms(fold_env):
    env = fold_env
    ok, reason, trajectory, _steps = run_episode(env, 3)
    assert (ok, reason) == (True, None)
    assert trajectory.action(0).shape == (16,)
    assert env.scene.grips.anchors == {}  # both let go
    assert env.scene.grips.passing == set()  # and the finger links collide with the cloth again
    frame = env.render()
    assert frame.shape == (240, 320, 3)


def test_grasp_cloth_anchors_only_a_closed_gripper():
    env = make("grasp-cloth", seed=0)
    try:
        env.reset()
        pose = env.robot.ee_pose()
        open_action = np.concatenate([pose.position, pose.orientation, [0.0]])
        closed_action = open_action.copy()
        closed_action[7] = 1.0
        for _ in range(180):  # closed in the air, far from the cloth: no anchor
            env.step(closed_action)
        assert env.scene.grips.anchors == {}
        assert not env.truth.grasping("cloth")
        ok, reason, _, _ = run_episode(env, 0)
        assert (ok, reason) == (True, None)
        assert env.truth.holds(GripperState("cloth"))
        info = Perception(env.scene.description(), PerceptionConfig(check_visibility=False)).observe(0)
        assert GripperState("cloth") in info.predicates
        env.step(open_action)  # opening lets go
        assert env.scene.grips.anchors == {}
    finally:
        env.close()


_DROPS = """
import numpy as np
import pybullet as p
import pybullet_data
from taskcond.sim.cloth import ClothSpec, cloth_nodes, load_cloth

def drop(spec):
    client = p.connect(p.DIRECT)
    p.resetSimulation(p.RESET_USE_DEFORMABLE_WORLD, physicsClientId=client)
    p.setGravity(0, 0, -9.8, physicsClientId=client)
    p.setAdditionalSearchPath(pybullet_data.getDataPath(), physicsClientId=client)
    p.loadURDF("plane.urdf", physicsClientId=client)
    p.loadURDF("cube_small.urdf", [0.02, 0.01, 0.03], globalScaling=2, physicsClientId=client)
    body = load_cloth(client, spec, (0.0, 0.0, 0.12))
    for _ in range(180):
        p.stepSimulation(physicsClientId=client)
    nodes = cloth_nodes(client, body)
    p.disconnect(client)
    return nodes

spec = ClothSpec(self_collision={self_collision})
np.save({path!r}, np.stack([drop(spec), drop(spec)]))
"""


def _drops(path, self_collision: bool) -> np.ndarray:
    """The cloth's nodes (2, N, 3) m after two identical drops over a cube in one fresh process."""
    import subprocess
    import sys

    script = _DROPS.format(path=str(path), self_collision=self_collision)
    subprocess.run([sys.executable, "-c", script], check=True, capture_output=True)
    return np.load(path)


def test_a_cloth_simulates_alike_only_as_the_first_in_its_process(tmp_path):
    """Why the cloth's episodes each get a fresh process (``SceneConfig.repeatable_in_process``): the same
    cloth draped over a cube twice in one process lies differently the second time (Bullet's soft-body
    self-collision draws from a random state per process); the first drop is the same in every fresh
    process, and without self-collision both are the same."""
    first, again = _drops(tmp_path / "a.npy", True), _drops(tmp_path / "b.npy", True)
    assert_allclose(first[0], again[0], atol=0)
    assert np.abs(first[1] - first[0]).max() > 1e-3
    plain = _drops(tmp_path / "c.npy", False)
    assert_allclose(plain[1], plain[0], atol=0)
    assert not make("fold-cloth").scene.config.repeatable_in_process
    assert make("LHT1").scene.config.repeatable_in_process


def test_the_cloth_episodes_of_an_evaluation_get_a_process_each(tmp_path):
    from taskcond.application.workers import WorkerArgs, needs_own_process
    from taskcond.results import Job

    path = tmp_path / "instructions.toml"
    path.write_text(
        'version = 1\n[[instruction]]\nid = "fold"\ntext = "Fold the cloth."\n'
        'goal = ["gripper not grasping"]\n'
        '[[instruction]]\nid = "box"\ntext = "Open the box."\ngoal = ["box open"]\n'
    )
    jobs = [
        Job(t, "env", 1) for t in ("LHT4", "fold-cloth", "grasp-cloth", "LHT1", "open-box", "fold", "box")
    ]
    flags = needs_own_process(jobs, WorkerArgs("skills", None, 0.0, instructions=str(path)))
    assert flags == [True, True, True, False, False, True, False]


def test_a_cloth_episode_of_an_evaluation_replays_and_warns_in_a_used_process(tmp_path):
    """The evaluation runs the cloth's episode in a process of its own (workers 1 included); its replay in
    a process that has simulated a cloth before reproduces this insensitive episode but says that such a
    replay is not to be trusted."""
    from taskcond.application.demonstrations import learn_library
    from taskcond.application.evaluate import evaluate, execution_config
    from taskcond.application.replay import find_episode, replay
    from taskcond.results import Job, ResultsFile

    library_dir, out = tmp_path / "skills", tmp_path / "eval.jsonl"
    learn_library(library_dir, ["grasp-cloth"])
    results = ResultsFile(out, execution_config(library_dir, 0.005))
    (record,) = evaluate([Job("grasp-cloth", "env", 1000)], results, library_dir, noise=0.005)
    assert record["success"], record
    done = replay(find_episode(out, "grasp-cloth:env:1000"), library_dir)
    assert done.reproduced, done.differences
    assert any("fresh process" in w for w in done.warnings)
