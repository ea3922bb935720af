"""Kinova Gen3 model numbers: DH-vs-PyBullet agreement, IK success and accuracy, timing.

Targets are the tool-centre poses of random joint configurations within the limits, so every one is
reachable; IK starts from the home pose (gripper down) like a tabletop controller would.

    .venv/bin/python benchmarks/bench_kinova.py [--targets 200] [--seed 0]
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np
import pybullet as p
from scipy.spatial.transform import Rotation

from taskcond.sim.kinova import GEN3_HOME, GEN3_JOINTS, KinovaArm


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--targets", type=int, default=200, help="random configurations for FK and IK")
    parser.add_argument("--seed", type=int, default=0, help="seed of the random configurations")
    args = parser.parse_args()

    client = p.connect(p.DIRECT)
    p.setGravity(0, 0, -9.81, physicsClientId=client)
    arm = KinovaArm(client)
    rng = np.random.default_rng(args.seed)
    lower = np.array([-math.pi if s.lower is None else s.lower for s in GEN3_JOINTS])
    upper = np.array([math.pi if s.upper is None else s.upper for s in GEN3_JOINTS])
    configurations = rng.uniform(lower, upper, size=(args.targets, 7))

    fk_position, fk_angle = [], []
    for q in configurations:
        for index, value in zip(arm.arm_joints, q, strict=True):
            p.resetJointState(arm.body_id, index, value, physicsClientId=client)
        expected = arm.forward_kinematics(q)
        position, orientation = arm.ee_pose()
        fk_position.append(np.linalg.norm(position - expected[:3, 3]))
        fk_angle.append(
            (Rotation.from_quat(orientation).inv() * Rotation.from_matrix(expected[:3, :3])).magnitude()
        )
    print(
        f"DH FK vs PyBullet, {args.targets} configurations: max {max(fk_position) * 1e3:.2e} mm, "
        f"max {max(fk_angle):.2e} rad"
    )

    arm.reset_home()
    errors, seconds, successes = [], [], 0
    for q in configurations:
        pose = arm.forward_kinematics(q)
        start = time.perf_counter()
        result = arm.solve_ik(pose[:3, 3], Rotation.from_matrix(pose[:3, :3]).as_quat(), seed=GEN3_HOME)
        seconds.append(time.perf_counter() - start)
        successes += result.success
        if result.success:
            errors.append(result.position_error)
    print(
        f"IK from home, full pose: {successes}/{args.targets} solved; solved error median "
        f"{np.median(errors) * 1e3:.3f} mm, max {max(errors) * 1e3:.3f} mm; "
        f"time median {np.median(seconds) * 1e3:.2f} ms, max {max(seconds) * 1e3:.2f} ms"
    )

    start = time.perf_counter()
    arm.step(2400)
    print(f"stepSimulation with the arm alone: {(time.perf_counter() - start) / 2400 * 1e6:.0f} us/step")
    p.disconnect(client)


if __name__ == "__main__":
    main()
