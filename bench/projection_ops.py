"""Projection world costs beside raw-PyBullet baselines measured in the same run.

``python bench/projection_ops.py [--reps N]``: medians (µs) of ``time.perf_counter_ns``
over many repetitions, and each figure's ratio to its baseline.
"""

from __future__ import annotations

import argparse
import math

import pybullet as pb
from _timing import median_us, row

from executive import knowledge
from executive._pose import Pose
from projection import World
from projection._world import DEFAULT_TORSO
from projection._world_model import ProjectedWorldModel


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--reps", type=int, default=2000)
    reps = parser.parse_args().reps
    with World(seed=0) as w:
        c, robot = w.client, w.robot_body
        for name, t, xyz, yaw in [
            ("cereal", "breakfast-cereal", (1.4, 0.4, 0.996), 0.0),
            ("cup", "cup", (1.3, 0.6, 0.901), 0.0),
            ("bowl", "bowl", (1.4, 0.8, 0.8785), 0.0),
            ("milk", "milk", (1.4, 0.62, 0.951), math.pi),
        ]:
            w.spawn_object(name, t, Pose.from_xyz_yaw(*xyz, yaw))
        a = Pose.from_xyz_yaw(0.75, 0.7, 0.0, 0.0)
        b = Pose.from_xyz_yaw(0.70, 0.65, 0.0, 0.1)
        flip = [a, b]

        def drive() -> None:
            flip.reverse()
            w.drive(flip[0])

        def raw_probe() -> None:
            flip.reverse()
            pos = flip[0].position
            pb.resetBasePositionAndOrientation(
                robot, (pos[0], pos[1], 0.0), flip[0].orientation, physicsClientId=c
            )
            pb.performCollisionDetection(physicsClientId=c)
            pb.getContactPoints(bodyA=robot, physicsClientId=c)

        row(
            "drive + collision check",
            median_us(drive, reps),
            "reset + collision detection + contacts",
            median_us(raw_probe, reps),
            "target ≤ 2x",
        )
        w.drive(a)

        # IK: one verified solve (current torso) vs one raw calculateInverseKinematics,
        # cold (the world's IK memo cleared before every call) and cached
        obj = w.object_pose("cup", "base_footprint").to_transform("cup")
        waypoints = knowledge.grasp_poses("cup", "back", obj, w.robot.arm("right").standard_to_tool)
        goal = waypoints[2]
        goal_map = w.robot_pose().to_transform("base_footprint") * goal
        park = w.robot.arm("right").state("park")

        def ik_cold() -> None:
            w.move_joints(right=park)
            w.clear_ik_cache()
            w.move_tcp(right=goal)

        def ik_cached() -> None:
            w.move_joints(right=park)
            w.move_tcp(right=goal)

        def raw_ik() -> None:
            w.move_joints(right=park)
            pb.calculateInverseKinematics(
                robot,
                w._tool["right"],
                goal_map.position,
                goal_map.orientation,
                maxNumIterations=100,
                residualThreshold=1e-4,
                physicsClientId=c,
            )

        n = max(50, reps // 10)
        raw_us = median_us(raw_ik, n)
        row(
            "move_tcp (verified IK, cold)",
            median_us(ik_cold, n),
            "calculateInverseKinematics 100 it",
            raw_us,
            "target ≤ 3x",
        )
        row(
            "move_tcp (verified IK, cached)",
            median_us(ik_cached, n),
            "calculateInverseKinematics 100 it",
            raw_us,
            "target ≤ 3x",
        )
        w.park_arms()

        # probe_arm_trajectory: the cup's back grasp with the right arm (5 waypoints, from
        # the park pose at the default torso: waypoint 0 needs torso resampling) vs five
        # raw IK calls (what the probe would cost if every waypoint took one raw solve)
        model = ProjectedWorldModel(w)
        w.move_torso(DEFAULT_TORSO)

        def probe_cold() -> None:
            w.clear_ik_cache()
            model.probe_arm_trajectory("right", waypoints, allowed_contacts=("cup",))

        def probe_warm() -> None:
            model.probe_arm_trajectory("right", waypoints, allowed_contacts=("cup",))

        wp_map = [w.robot_pose().to_transform("base_footprint") * p for p in waypoints]

        def raw_five() -> None:
            for p in wp_map:
                pb.calculateInverseKinematics(
                    robot,
                    w._tool["right"],
                    p.position,
                    p.orientation,
                    maxNumIterations=100,
                    residualThreshold=1e-4,
                    physicsClientId=c,
                )

        five_us = median_us(raw_five, max(20, reps // 40))
        m = max(20, reps // 40)
        row(
            "probe_arm_trajectory 5 wp (cold)",
            median_us(probe_cold, m),
            "5 x calculateInverseKinematics 100 it",
            five_us,
            "was ~30 ms",
        )
        row(
            "probe_arm_trajectory 5 wp (warm)",
            median_us(probe_warm, reps // 4),
            "5 x calculateInverseKinematics 100 it",
            five_us,
            "target ≤ 3x",
        )
        print(f"{'':<34} IK memo: {w.ik_cache_stats}, {len(w._ik_cache)} entries")

        # detect vs one ray batch and vs one 320x200 segmentation render
        w.look_at(Pose((1.3, 0.6, 0.9)))
        desig = {"type": "cup"}
        cam = w.link_pose("head_mount_kinect_rgb_optical_frame")
        z = cam.as_rotation().apply([0.0, 0.0, 1.0])
        y = cam.as_rotation().apply([0.0, -1.0, 0.0])
        target = [cam.position[i] + z[i] for i in range(3)]
        view = pb.computeViewMatrix(cam.position, target, y)
        proj = pb.computeProjectionMatrixFOV(50.0, 320 / 200, 0.1, 10.0)
        lo, hi = w.object_aabb("cup")
        starts = [cam.position] * 27
        ends = [
            (
                lo[0] + (hi[0] - lo[0]) * i / 2,
                lo[1] + (hi[1] - lo[1]) * j / 2,
                lo[2] + (hi[2] - lo[2]) * k / 2,
            )
            for i in range(3)
            for j in range(3)
            for k in range(3)
        ]
        det = median_us(lambda: w.detect(desig), reps // 4)
        rays = median_us(lambda: pb.rayTestBatch(starts, ends, physicsClientId=c), reps // 4)
        cam_us = median_us(
            lambda: pb.getCameraImage(
                320,
                200,
                view,
                proj,
                flags=pb.ER_SEGMENTATION_MASK_OBJECT_AND_LINKINDEX,
                renderer=pb.ER_TINY_RENDERER,
                physicsClientId=c,
            ),
            20,
        )
        row("detect (27 rays)", det, "rayTestBatch 27 rays", rays, "absolute < 20 ms")
        row(
            "detect (27 rays)",
            det,
            "getCameraImage 320x200 segmentation",
            cam_us,
            "CRAM renders twice",
        )

        # snapshot / restore vs saveState / restoreState
        snap = w.snapshot()
        state = pb.saveState(physicsClientId=c)
        row(
            "snapshot()",
            median_us(w.snapshot, reps),
            "saveState",
            median_us(
                lambda: pb.removeState(pb.saveState(physicsClientId=c), physicsClientId=c),
                max(20, reps // 20),
            ),
            "manual vs PyBullet",
        )
        row(
            "restore(snap)",
            median_us(lambda: w.restore(snap), reps),
            "restoreState",
            median_us(lambda: pb.restoreState(state, physicsClientId=c), reps),
            "manual vs PyBullet",
        )
        row(
            "placing_pose_stable (side world)",
            median_us(lambda: w.placing_pose_stable("cup", Pose((-0.8, 1.3, 0.905))), 20),
            "600 x stepSimulation (main world)",
            median_us(lambda: [pb.stepSimulation(physicsClientId=c) for _ in range(1)], 200) * 600,
            "early stop at rest",
        )


if __name__ == "__main__":
    main()
