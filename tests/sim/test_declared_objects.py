"""Objects a user brings (issue 31): declarations and their errors, declared objects placed by a random
start and perceived in a real PyBullet kitchen, the skill of the most similar demonstrated object, and one
real episode grasping a declared object through the command line."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pybullet")

from taskcond.application.demonstrations import learn_library
from taskcond.cli import main
from taskcond.conditions import Relation, SpatialRelation
from taskcond.envs.kitchen import KitchenEnv
from taskcond.execution.approach import perceived_shapes
from taskcond.execution.skills import ObjectShape, dissimilarity, offset_scale
from taskcond.sim.assets import MeshSpec, SolidSpec, VesselSpec
from taskcond.sim.objects import ObjectError, forget_objects, load_objects, objects_files
from taskcond.sim.scene import SceneConfig, scene_aliases, suite_config
from taskcond.tasks.free import FreeTask
from taskcond.worlds.kitchen import KitchenWorld

pytestmark = pytest.mark.sim

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "objects.toml"


@pytest.fixture(autouse=True)
def _forget():
    forget_objects()
    yield
    forget_objects()


def test_the_examples_declare_a_solid_a_pybullet_mesh_and_a_vessel() -> None:
    objects = {o.name: o for o in load_objects(EXAMPLES)}
    assert isinstance(objects["soup can"].spec, SolidSpec)
    duck = objects["rubber duck"].spec
    assert isinstance(duck, MeshSpec) and duck.path.endswith("pybullet_data/duck_vhacd.urdf")
    assert isinstance(objects["jar"].spec, VesselSpec) and "container" in objects["jar"].roles
    config = SceneConfig()  # the same structure as the suite's objects: free objects and roles
    assert {"soup can", "rubber duck", "jar"} <= set(config.free_objects) and config.roles["jar"] >= {
        "graspable",
        "container",
    }
    assert scene_aliases()["duck"] == "rubber duck" and scene_aliases()["cup"] == "mug"
    assert "jar" not in suite_config().free_objects  # the skill library's demonstrations do without them
    [recorded] = objects_files()
    assert recorded.startswith(f"{EXAMPLES}@")


BAD = {
    "missing file": ('file = "meshes/nowhere.obj"', "file 'meshes/nowhere.obj' not found"),
    "negative size": ('shape = "cylinder"\nsize = [0.03, -0.1]', "must be positive"),
    "scene name": ('name = "bottle"\nshape = "sphere"\nsize = [0.03]', "'bottle' is already an object"),
    "alias clash": ('aliases = ["cup"]\nshape = "sphere"\nsize = [0.03]', "'cup' is already an alias of"),
    "unknown key": ('shape = "sphere"\nsize = [0.03]\nweight = 2', "unknown key(s) ['weight']"),
    "unknown role": ('shape = "sphere"\nsize = [0.03]\nroles = ["edible"]', "roles ['edible']"),
    "container": ('shape = "box"\nsize = [0.1, 0.1, 0.1]\nroles = ["container"]', "needs shape 'vessel'"),
    "size count": ('shape = "box"\nsize = [0.1, 0.1]', "list of 3 numbers"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_a_bad_declaration_is_one_line_naming_the_file_and_the_entry(tmp_path, case) -> None:
    body, expected = BAD[case]
    name = "" if body.startswith("name") else 'name = "thing"\n'
    path = tmp_path / "objects.toml"
    first = '[[object]]\nname = "fine"\nshape = "sphere"\nsize = [0.02]\n\n'
    path.write_text(f"{first}[[object]]\n{name}{body}\n")
    with pytest.raises(ObjectError) as err:
        load_objects(path)
    message = str(err.value)
    assert "\n" not in message and message.startswith(f"{path}: object 2 (") and expected in message
    assert "fine" not in SceneConfig().free_objects  # nothing of a bad file is declared


def test_the_command_line_refuses_a_bad_declaration_with_exit_2(tmp_path, capsys) -> None:
    path = tmp_path / "bad.toml"
    path.write_text('[[object]]\nname = "ball"\nshape = "sphere"\nsize = [-0.03]\n')
    with pytest.raises(SystemExit) as exit_:
        main(["run", "grasp ball", "--objects", str(path), "--method", "env", "--no-video"])
    err = capsys.readouterr().err.strip()
    assert exit_.value.code == 2 and len(err.splitlines()) == 1
    assert err.startswith(f"error: {path}: object 1 ('ball'): size [-0.03] must be positive")


def test_declared_objects_are_placed_by_a_random_start_perceived_and_related() -> None:
    """Each stands upright on the table at a random spot, has a box, relations and a shape class; a cube
    put into the jar is perceived inside it, the jar being a container like the bowl."""
    load_objects(EXAMPLES)
    env = KitchenEnv(FreeTask("anything", start="random"))
    try:
        spots = []
        for seed in (3, 4):
            env.reset(seed=seed)
            world = KitchenWorld(env)
            obs = world.observe()
            declared = ("soup can", "rubber duck", "jar")
            assert set(declared) <= set(world.objects)
            assert not obs.lying, obs.lying
            for name in declared:
                assert SpatialRelation(name, Relation.ABOVE, "table") in obs.predicates, name
            assert obs.shapes["soup can"] == "cylinder" and obs.shapes["rubber duck"] == "mesh"
            assert {"soup can", "jar"} <= obs.round and "rubber duck" not in obs.round
            spots.append(np.concatenate([obs.centers[n][:2] for n in declared]))
            duck = obs.boxes["rubber duck"][1] - obs.boxes["rubber duck"][0]
            assert 0.05 < duck[2] < 0.075  # upright: 0.7 x the duck's 8.6 cm
        assert np.abs(spots[0] - spots[1]).max() > 0.05  # random spots, not the nominal ones
        jar = env.scene.pose("jar")[0]
        env.scene.place("cube", jar[:2], 0.0, z=0.01)
        for _ in range(30):
            env.step(np.concatenate([env.robot.ee_pose().position, env.robot.ee_pose().orientation, [0.0]]))
        obs = KitchenWorld(env).observe()
        assert SpatialRelation("cube", Relation.INSIDE, "jar") in obs.predicates
    finally:
        env.close()


@pytest.fixture(scope="module")
def library():
    return learn_library(None, ["grasp-bottle", "grasp-toothpaste", "grasp-bowl", "grasp-spatula"])


def test_an_undemonstrated_object_gets_the_most_similar_demonstrated_objects_skill(library) -> None:
    """The can and the soup can get the bottle's grasp (cylinders of about its size), the jar the bowl's
    (a vessel), the duck a solid's (not the bowl's wall grasp, nor the spatula's); the grasp's offset is
    scaled by the perceived box."""
    load_objects(EXAMPLES)
    env = KitchenEnv(FreeTask("anything"))
    try:
        env.reset(seed=0)
        obs = KitchenWorld(env).observe()
    finally:
        env.close()
    chosen = {}
    for name in ("can", "soup can", "jar", "rubber duck", "cube"):
        choice = library.choose(f"grasp {name}", perceived_shapes(obs, (name,)))
        chosen[name] = choice.skills[0].task_name
        assert name in choice.reason and chosen[name].removeprefix("grasp ") in choice.reason
    assert chosen["can"] == chosen["soup can"] == "grasp bottle"
    assert chosen["jar"] == "grasp bowl"
    assert chosen["rubber duck"] in ("grasp bottle", "grasp toothpaste")
    assert chosen["cube"] == "grasp toothpaste"  # a box
    assert library.choose("grasp bowl", perceived_shapes(obs, ("bowl",))).reason == ""
    bottle = library.skills["grasp-bottle"].shapes["bottle"]
    can = perceived_shapes(obs, ("can",))["can"]
    scale = offset_scale(can, bottle)
    assert scale[2] == pytest.approx(can.height / bottle.height) and scale[2] < 0.9
    cloth = ObjectShape("fixed", (0.3, 0.3, 0.01))
    assert dissimilarity(can, bottle) < dissimilarity(can, cloth)


def test_taskcond_run_grasps_a_declared_object_from_a_random_start(library, tmp_path, capsys) -> None:
    """One real episode through the command line, conditions from the demonstrations (method env, no
    LLM): the soup can is grasped with the bottle's skill, scaled, and the trace says so."""
    trace = tmp_path / "trace.json"
    args = ["run", "pick up the soup can", "--objects", str(EXAMPLES), "--method", "env"]
    library.save(tmp_path / "skills")
    args += ["--start", "random", "--seed", "2", "--no-video", "--trace", str(trace)]
    args += ["--skills", str(tmp_path / "skills")]
    with pytest.raises(SystemExit) as exit_:
        main(args)
    out = capsys.readouterr().out
    assert exit_.value.code == 0, out
    data = json.loads(trace.read_text())
    assert data["success"] and any(str(EXAMPLES) in f for f in data["config"]["objects"])
    [event] = [e for e in data["events"] if e["kind"] == "primitive"][:1]
    assert event["demonstration"] == "grasp bottle" and "bottle stands in for soup can" in event["similar"]
    assert event["offset_scale"][2] < 1.0


def test_an_obj_mesh_from_pybullet_data_stands_on_the_table_at_its_scale(tmp_path) -> None:
    """A Wavefront file is wrapped in a URDF; the scene stands it by its bounding box, wherever its own
    origin lies (the bunny's is inside it)."""
    path = tmp_path / "mesh.toml"
    path.write_text(
        '[[object]]\nname = "bunny"\nfile = "pybullet_data:bunny.obj"\nscale = 0.04\n'
        "upright = [1.5708, 0.0, 0.0]\nmass = 0.05\ncolor = [0.9, 0.8, 0.7]\nplace = [0.45, 0.05]\n"
    )
    load_objects(path)
    env = KitchenEnv(FreeTask("anything"))
    try:
        env.reset(seed=0)
        obs = KitchenWorld(env).observe()
        lo, hi = obs.boxes["bunny"]
        assert hi[2] - lo[2] == pytest.approx(0.04 * (0.777 + 0.667), abs=0.012)  # its y, stood up
        assert abs(lo[2]) < 0.012 and np.hypot(*(obs.centers["bunny"][:2] - (0.45, 0.05))) < 0.04
        assert obs.shapes["bunny"] == "mesh" and "bunny" not in obs.lying
    finally:
        env.close()


@pytest.mark.parametrize("command", [["learn"], ["conditions", "grasp ball"], ["eval", "primitives"]])
def test_every_command_with_objects_refuses_a_bad_declaration(tmp_path, capsys, command) -> None:
    """``--objects`` on learn, conditions and eval (run: above) is read before anything else runs."""
    path = tmp_path / "bad.toml"
    path.write_text('[[object]]\nname = "ball"\nshape = "sphere"\nsize = [0.03]\ncolour = [1, 0, 0]\n')
    with pytest.raises(SystemExit) as exit_:
        main([*command, "--objects", str(path)])
    err = capsys.readouterr().err.strip()
    assert exit_.value.code == 2 and len(err.splitlines()) == 1
    assert err.startswith(f"error: {path}: object 1 ('ball'): unknown key(s) ['colour']")


def test_the_same_object_may_be_declared_again_but_not_differently(tmp_path, monkeypatch) -> None:
    first, second = tmp_path / "a.toml", tmp_path / "b.toml"
    first.write_text('[[object]]\nname = "ball"\nshape = "sphere"\nsize = [0.03]\nplace = [0.4, 0.1]\n')
    second.write_text('[[object]]\nname = "ball"\nshape = "sphere"\nsize = [0.04]\nplace = [0.4, 0.1]\n')
    load_objects(first)
    load_objects(first)  # the same declaration again (a worker loading the files of its parent)
    monkeypatch.chdir(EXAMPLES.parent)  # a mesh named relative to the file, by a relative then resolved path
    load_objects(EXAMPLES.name)
    load_objects(EXAMPLES.resolve())
    with pytest.raises(ObjectError, match=rf"^{second}: object 1 \('ball'\): 'ball' is declared differently"):
        load_objects(second)
    assert SceneConfig().free_objects["ball"][0] == SolidSpec("sphere", (0.03,))


def test_declared_objects_enter_the_combination_benchmark_with_their_roles() -> None:
    """The generator reads the roles of the scene config, the declared objects' among them: the duck is
    grasped and carried (its size from the mesh as the scene loads it), the jar (a vessel) takes what fits
    and is tilted, and a pairing that cannot fit is refused with a reason."""
    from taskcond.combinations import generate
    from taskcond.sim.roles import scene_roles

    load_objects(EXAMPLES)
    objects = scene_roles()
    duck, jar = objects["rubber duck"], objects["jar"]
    assert duck.free and duck.roles.graspable and not duck.roles.container
    assert min(duck.size) > 0.03 and max(duck.size) < 0.2  # the mesh's box at the declared scale
    assert jar.roles.container and jar.roles.vessel and jar.interior is not None
    generated = generate(objects)
    names = {s.name for c in generated.combinations for s in c.steps}
    assert {"grasp rubber duck", "tilt jar", "move rubber duck into box"} <= names
    assert any(r.task == "move bowl into jar" for r in generated.refused)


def test_the_scene_objects_an_instruction_may_name_follow_later_declarations() -> None:
    """What the decomposition reads of the scene, built once per process, is built again when objects
    are declared after it was first asked (a "soup can" is not the suite's "can")."""
    from taskcond.worlds.kitchen import scene_objects

    before, _ = scene_objects()
    load_objects(EXAMPLES)
    after, _ = scene_objects()
    assert "soup can" not in before and {"soup can", "rubber duck", "jar"} <= set(after)
