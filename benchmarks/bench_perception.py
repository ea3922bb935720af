"""Benchmark of the environment-information layer (paper §III-A.2): time per observation, relation accuracy.

Run: ``.venv/bin/python benchmarks/bench_perception.py [--scenes 20] [--repeats 15] [--noise-seeds 50]``

1. **Time per observation** (cameras + environment information) at 320×240 on a kitchen-like table scene with
   a Franka Panda, a cabinet with a drawer, a tray and eight objects; median over repetitions.
2. **Relation accuracy** on randomized hand-placed scenes whose spatial relations are known by construction:
   four groups side by side on a table — an object stacked on another, an object inside an open tray, an
   object in front of another, two objects apart — plus every object above the table. Boxes from ground
   truth (noise-free must be 100 %), ground truth plus Gaussian noise of 5/10/20 mm, and point clouds.
   Accuracy counts every (ordered pair, relation) decision; precision and recall count the true relations;
   "exact" is the share of observations whose whole set of spatial relations is right.

Prints markdown tables.
"""

from __future__ import annotations

import argparse
import statistics
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pybullet as p
import pybullet_data

from taskcond.conditions import Relation, SpatialRelation
from taskcond.sim.camera import CameraSpec
from taskcond.sim.description import BodyKind, ContainerJoint, GripperSpec, NamedBody, SceneDescription
from taskcond.sim.perception import DEFAULT_CAMERAS, Perception, PerceptionConfig
from taskcond.sim.shapes import add_box, add_cylinder, add_tray

TABLE_TOP = 0.0
SLOTS_Y = (-0.54, -0.18, 0.18, 0.54)
"""Lateral centres of the four groups; 36 cm apart, so objects of different groups never relate."""
PANDA_HOME = (0.0, -0.3, 0.0, -2.3, 0.0, 2.0, 0.785)


# ------------------------------------------------------------------------------------------ scene building
def add_table(client: int) -> int:
    """1.0 × 1.6 m slab, top at z = 0, centred at x = 0.55."""
    return add_box(client, (0.5, 0.8, 0.01), (0.55, 0.0, TABLE_TOP - 0.01), rgba=(0.8, 0.8, 0.75, 1.0))


def add_item(
    client: int, rng: np.random.Generator, xy: Sequence[float], bottom: float, half_xy: float
) -> int:
    """A box or an upright cylinder of footprint half-width ``half_xy`` standing at height ``bottom``."""
    height = rng.uniform(0.03, 0.12)
    pos = (xy[0], xy[1], bottom + height / 2)
    if rng.random() < 0.5:
        return add_cylinder(client, half_xy, height, pos)
    return add_box(client, (half_xy, half_xy * rng.uniform(0.7, 1.0), height / 2), pos)


@dataclass
class LabelledScene:
    scene: SceneDescription
    truth: frozenset[SpatialRelation]


def random_scene(client: int, rng: np.random.Generator) -> LabelledScene:
    """Four groups (stack, inside, front, apart) in shuffled lateral slots; relations known by design."""
    p.resetSimulation(physicsClientId=client)
    bodies = [NamedBody("table", add_table(client), kind="furniture")]
    truth: set[SpatialRelation] = set()
    count = 0

    def named(body: int, kind: BodyKind = "object") -> str:
        nonlocal count
        count += 1
        name = f"object {count}" if kind == "object" else f"tray {count}"
        bodies.append(NamedBody(name, body, kind=kind))
        truth.update(
            {SpatialRelation(name, Relation.ABOVE, "table"), SpatialRelation("table", Relation.BELOW, name)}
        )
        return name

    for kind, y in zip(rng.permutation(["stack", "inside", "front", "apart"]), SLOTS_Y, strict=True):
        x = rng.uniform(0.45, 0.65)
        if kind == "stack":
            half_b = rng.uniform(0.03, 0.06)
            height_b = rng.uniform(0.03, 0.08)
            lower = named(add_box(client, (half_b, half_b, height_b / 2), (x, y, TABLE_TOP + height_b / 2)))
            jitter = rng.uniform(-0.3, 0.3, 2) * half_b
            upper = named(
                add_item(client, rng, (x + jitter[0], y + jitter[1]), height_b, rng.uniform(0.015, half_b))
            )
            truth.update(
                {SpatialRelation(upper, Relation.ABOVE, lower), SpatialRelation(lower, Relation.BELOW, upper)}
            )
        elif kind == "inside":
            half, wall = rng.uniform(0.07, 0.1), rng.uniform(0.06, 0.09)
            tray = named(add_tray(client, half, wall, (x, y, TABLE_TOP)), kind="container")
            half_item = rng.uniform(0.015, 0.03)
            room = half - 0.01 - half_item
            xy = (x + rng.uniform(-room, room), y + rng.uniform(-room, room))
            height = rng.uniform(0.03, wall)
            item = named(
                add_box(client, (half_item, half_item, height / 2), (xy[0], xy[1], 0.01 + height / 2))
            )
            truth.add(SpatialRelation(item, Relation.INSIDE, tray))
        elif kind == "front":
            half_b, half_a = rng.uniform(0.025, 0.05), rng.uniform(0.02, 0.045)
            back = named(add_item(client, rng, (x, y), TABLE_TOP, half_b))
            gap = rng.uniform(0.02, 0.15)
            lateral = rng.uniform(-0.3, 0.3) * min(half_a, half_b)
            front = named(add_item(client, rng, (x - half_b - half_a - gap, y + lateral), TABLE_TOP, half_a))
            truth.add(SpatialRelation(front, Relation.IN_FRONT_OF, back))
        else:
            for side in (-1, 1):
                named(
                    add_item(client, rng, (x + rng.uniform(-0.05, 0.05), y + side * 0.09), TABLE_TOP, 0.035)
                )
    return LabelledScene(SceneDescription(client, bodies), frozenset(truth))


def timing_scene(client: int) -> SceneDescription:
    """Table, Panda, cabinet with a drawer, a tray and eight objects: the size of the paper's kitchen."""
    scene = random_scene(client, np.random.default_rng(0)).scene
    panda = p.loadURDF("franka_panda/panda.urdf", useFixedBase=True, physicsClientId=client)
    for joint, q in enumerate(PANDA_HOME):
        p.resetJointState(panda, joint, q, physicsClientId=client)
    col = p.createCollisionShape(p.GEOM_BOX, halfExtents=(0.15, 0.2, 0.15), physicsClientId=client)
    vis = p.createVisualShape(p.GEOM_BOX, halfExtents=(0.15, 0.2, 0.15), physicsClientId=client)
    drawer_col = p.createCollisionShape(p.GEOM_BOX, halfExtents=(0.15, 0.18, 0.05), physicsClientId=client)
    drawer_vis = p.createVisualShape(p.GEOM_BOX, halfExtents=(0.15, 0.18, 0.05), physicsClientId=client)
    cabinet = p.createMultiBody(
        0.0,
        col,
        vis,
        basePosition=(0.55, -1.0, 0.15),
        linkMasses=[0.5],
        linkCollisionShapeIndices=[drawer_col],
        linkVisualShapeIndices=[drawer_vis],
        linkPositions=[(-0.01, 0.0, 0.05)],
        linkOrientations=[(0, 0, 0, 1)],
        linkInertialFramePositions=[(0, 0, 0)],
        linkInertialFrameOrientations=[(0, 0, 0, 1)],
        linkParentIndices=[0],
        linkJointTypes=[p.JOINT_PRISMATIC],
        linkJointAxis=[(-1.0, 0.0, 0.0)],
        physicsClientId=client,
    )
    scene.bodies += [
        NamedBody("cabinet", cabinet, -1, "furniture"),
        NamedBody("drawer", cabinet, 0, "container"),
    ]
    scene.containers.append(ContainerJoint("drawer", cabinet, 0, 0.0, 0.25))
    scene.grippers.append(GripperSpec(panda, (9, 10), 11))
    return scene


# -------------------------------------------------------------------------------------------- measuring
@dataclass
class Score:
    tp: int = 0
    fp: int = 0
    fn: int = 0
    decisions: int = 0
    exact: int = 0
    observations: int = 0

    def add(self, predicted: frozenset[SpatialRelation], truth: frozenset[SpatialRelation], n: int) -> None:
        self.tp += len(predicted & truth)
        self.fp += len(predicted - truth)
        self.fn += len(truth - predicted)
        self.decisions += n * (n - 1) * len(Relation)
        self.exact += predicted == truth
        self.observations += 1

    def row(self, label: str) -> str:
        accuracy = 1 - (self.fp + self.fn) / self.decisions
        precision = self.tp / max(self.tp + self.fp, 1)
        recall = self.tp / max(self.tp + self.fn, 1)
        exact = self.exact / self.observations
        return (
            f"| {label} | {self.observations} | {100 * accuracy:.2f} % | {100 * precision:.1f} % | "
            f"{100 * recall:.1f} % | {100 * exact:.1f} % |"
        )


def spatial(predicates: frozenset) -> frozenset[SpatialRelation]:
    return frozenset(pred for pred in predicates if isinstance(pred, SpatialRelation))


def bench_timing(client: int, repeats: int) -> None:
    scene = timing_scene(client)
    one_camera = DEFAULT_CAMERAS[:1]
    configs = [
        ("ground truth, no rendering", PerceptionConfig(check_visibility=False)),
        ("ground truth + visibility, 1 camera", PerceptionConfig(cameras=one_camera)),
        ("ground truth + visibility, 2 cameras", PerceptionConfig()),
        ("ground truth + noise 1 cm, 1 camera", PerceptionConfig(cameras=one_camera, noise_sigma=0.01)),
        ("point cloud, 1 camera", PerceptionConfig(mode="point_cloud", cameras=one_camera)),
        ("point cloud, 2 cameras", PerceptionConfig(mode="point_cloud")),
    ]
    print(
        f"\n### Time per observation at 320×240: {len(scene.bodies)} named bodies + Panda, "
        f"median of {repeats}\n"
    )
    print("| configuration | total ms | rendering ms | boxes ms | predicates ms | boxes (incl. gripper) |")
    print("|---|---:|---:|---:|---:|---:|")
    for label, config in configs:
        perception = Perception(scene, config)
        infos = [perception.observe(i) for i in range(repeats)]
        med = {
            key: 1000 * statistics.median(getattr(info.timing, key) for info in infos)
            for key in ("total_s", "render_s", "boxes_s", "predicates_s")
        }
        print(
            f"| {label} | {med['total_s']:.1f} | {med['render_s']:.1f} | {med['boxes_s']:.1f} | "
            f"{med['predicates_s']:.1f} | {len(infos[-1].boxes)} |"
        )


def bench_accuracy(client: int, n_scenes: int, noise_seeds: int) -> None:
    rng = np.random.default_rng(2024)
    sigmas = (0.005, 0.01, 0.02)
    exact, noisy = Score(), {s: Score() for s in sigmas}
    clouds = {"point cloud, 2 cameras": Score(), "point cloud, 3 cameras": Score()}
    third = CameraSpec(eye=(1.4, 0.0, 1.1), target=(0.55, 0.0, 0.0))
    cloud_cameras = {
        "point cloud, 2 cameras": DEFAULT_CAMERAS,
        "point cloud, 3 cameras": (*DEFAULT_CAMERAS, third),
    }
    box_errors: list[np.ndarray] = []
    for _ in range(n_scenes):
        labelled = random_scene(client, rng)
        scene, truth = labelled.scene, labelled.truth
        n = len(scene.bodies)
        info = Perception(scene, PerceptionConfig()).observe(0)
        assert len(info.boxes) == n, f"not all objects visible: {sorted(info.boxes)}"
        exact.add(spatial(info.predicates), truth, n)
        for sigma in sigmas:
            perception = Perception(scene, PerceptionConfig(noise_sigma=sigma, check_visibility=False))
            for seed in range(noise_seeds):
                noisy[sigma].add(spatial(perception.observe(seed).predicates), truth, n)
        for label, cameras in cloud_cameras.items():
            perception = Perception(scene, PerceptionConfig(mode="point_cloud", cameras=cameras))
            measured = perception.observe(0)
            clouds[label].add(spatial(measured.predicates), truth, len(measured.boxes))
            if label.endswith("2 cameras"):
                for name, box in measured.boxes.items():
                    gt = perception.ground_truth_box(name)
                    if name != "table":
                        box_errors.append(
                            np.abs(np.concatenate([box.lower - gt.lower, box.upper - gt.upper]))
                        )
    print(f"\n### Spatial-relation accuracy, {n_scenes} randomized scenes ({noise_seeds} noise seeds each)\n")
    print("| boxes | observations | accuracy (pair×relation) | precision | recall | exact scenes |")
    print("|---|---:|---:|---:|---:|---:|")
    print(exact.row("ground truth, visible in 2 cameras"))
    for sigma, score in noisy.items():
        print(score.row(f"ground truth + noise σ = {1000 * sigma:.0f} mm"))
    for label, score in clouds.items():
        print(score.row(label))
    errors = np.concatenate(box_errors)
    print(
        f"\nPoint-cloud box corner error (2 cameras, objects except the table): median "
        f"{1000 * np.median(errors):.1f} mm, 90th percentile {1000 * np.percentile(errors, 90):.1f} mm, "
        f"max {1000 * errors.max():.1f} mm over {len(box_errors)} boxes."
    )
    if exact.fp or exact.fn:
        raise SystemExit("ground-truth relations are not 100 % correct")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", type=int, default=20, help="randomized hand-placed scenes")
    parser.add_argument("--repeats", type=int, default=15, help="timed observations per configuration")
    parser.add_argument("--noise-seeds", type=int, default=50, help="noise draws per scene and sigma")
    args = parser.parse_args()
    client = p.connect(p.DIRECT)
    p.setAdditionalSearchPath(pybullet_data.getDataPath(), physicsClientId=client)
    try:
        bench_timing(client, args.repeats)
        bench_accuracy(client, args.scenes, args.noise_seeds)
    finally:
        p.disconnect(client)


if __name__ == "__main__":
    main()
