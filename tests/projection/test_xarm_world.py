"""A projection world with a 6-joint arm whose gripper closes at a *larger* joint value:
pybullet_data's xArm6 on the mobile base, described as in docs/robots.md (issue 25). The
world reads the chain length, the gripper's direction and its six coupled joints from the
description."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from pathlib import Path

import pybullet_data
import pytest

from executive import (
    ArmDescription,
    CameraDescription,
    GripperDescription,
    GripperGoalNotReached,
    NeckDescription,
    Pose,
    Reach,
    RobotDescription,
    TorsoDescription,
)
from projection import World
from robots import mobile_base

CUP = (1.3, 0.6, 0.9)
SINK_NAV = Pose.from_xyz_yaw(0.75, 0.6, 0.0, 0.0)
_S = math.sqrt(0.5)
BACK = (0.0, _S, 0.0, _S)  # the hand's z along map x, the fingers along map y
JOINTS = ("joint1", "joint2", "joint3", "joint4", "joint5", "joint6")
GRIPPER = (
    "drive_joint",
    "left_finger_joint",
    "left_inner_knuckle_joint",
    "right_outer_knuckle_joint",
    "right_finger_joint",
    "right_inner_knuckle_joint",
)


def xarm_description(directory: Path) -> RobotDescription:
    """docs/robots.md's xArm6 (a TCP 0.16 m ahead of the gripper base), URDF written into
    ``directory``."""
    shipped = Path(pybullet_data.getDataPath()) / "xarm" / "xarm6_with_gripper.urdf"
    tcp = ET.Element("link", name="xarm_tcp")
    tcp_joint = ET.Element("joint", name="xarm_tcp_joint", type="fixed")
    ET.SubElement(tcp_joint, "origin", xyz="0 0 0.16", rpy="0 0 0")
    ET.SubElement(tcp_joint, "parent", link="xarm_gripper_base_link")
    ET.SubElement(tcp_joint, "child", link="xarm_tcp")
    urdf = directory / "xarm6.urdf"
    urdf.write_text(mobile_base.mount_arm("xarm6", shipped, "world", (tcp, tcp_joint)))
    return RobotDescription(
        name="xarm6",
        urdf=lambda: urdf,
        base_frame="base_footprint",
        base_link="base_link",
        arms=(
            ArmDescription(
                name="left",
                joints=JOINTS,
                tool_frame="xarm_tcp",
                hand_link="xarm_gripper_base_link",
                standard_to_tool=((0.0, 1.0, 0.0), (-1.0, 0.0, 0.0), (0.0, 0.0, 1.0)),
                gripper=GripperDescription(
                    joints=GRIPPER,
                    max_opening=0.085,
                    open_position=0.0,
                    closed_position=0.85,
                    effort=50.0,
                ),
                reach=Reach(in_reach_distance=0.75, minimal_distance=0.2),
                states={
                    "park": (0.0, -0.5, -0.8, 0.0, 1.3, 0.0),
                    "carry": (0.0, -0.3, -1.0, 0.0, 1.3, 0.0),
                },
            ),
        ),
        torso=TorsoDescription(joint="torso_lift_joint", lower=0.0, upper=0.4, default=0.2),
        neck=NeckDescription(
            pan_joint="head_pan_joint",
            tilt_joint="head_tilt_joint",
            camera=CameraDescription(
                frame="camera_optical_frame",
                vertical_fov=math.radians(45.0),
                horizontal_fov=math.radians(60.0),
            ),
            states={"forward": (0.0, 0.0)},
        ),
    )


@pytest.fixture()
def world(tmp_path: Path) -> Iterator[World]:
    with World(seed=0, robot=xarm_description(tmp_path)) as w:
        yield w


def test_a_six_joint_arm_parks_and_moves_by_its_own_chain(world: World) -> None:
    assert world.arms == ("left",)
    assert world.arm_joints("left") == pytest.approx((0.0, -0.5, -0.8, 0.0, 1.3, 0.0))
    assert [j for j, _lo, _hi in world.arm_joint_limits("left")] == list(JOINTS)
    assert world.robot_collisions() == []
    with pytest.raises(ValueError, match=r"needs 6 joint values \(joint1, "):
        world.move_joints(left=(0.0,) * 7)
    world.set_arm_configuration("carry")
    assert world.arm_joints("left") == pytest.approx((0.0, -0.3, -1.0, 0.0, 1.3, 0.0))


def test_a_gripper_that_closes_at_the_larger_joint_value(world: World) -> None:
    assert world.gripper_opening("left") == pytest.approx(0.085)  # open: all six at 0
    assert {world.joint_position(j) for j in GRIPPER} == {0.0}
    world.gripper("close", "left")
    assert world.gripper_opening("left") == 0.0
    assert {world.joint_position(j) for j in GRIPPER} == {0.85}
    world.gripper(0.0425, "left")
    assert world.joint_position("right_finger_joint") == pytest.approx(0.425)
    assert world.gripper_opening("left") == pytest.approx(0.0425)
    with pytest.raises(GripperGoalNotReached, match=r"outside \[0, 0.085\]"):
        world.gripper(0.09, "left")


def test_the_xarm_reaches_grips_and_sees_the_cup(world: World) -> None:
    world.drive(SINK_NAV)
    world.spawn_object("cup-1", "cup", Pose(CUP))
    world.spawn_object("cup-2", "cup", Pose((1.3, 0.3, 0.9)))
    world.look_at(Pose(CUP))
    assert sorted(o.name for o in world.detect({"type": "cup"})) == ["cup-1", "cup-2"]
    for x in (1.2, CUP[0]):
        goal = Pose((x, 0.6, 0.9), BACK)
        world.move_tcp(left=goal)
        assert world.link_pose("xarm_tcp").distance_to(goal) < 0.01
    world.gripper("grip", "left")  # closing (the joints rising) until a finger touches
    assert 0.0 < world.gripper_opening("left") < 0.085
    assert world._gripper_touches("left")
    world.attach("cup-1", "xarm_gripper_base_link")
    world.move_tcp(left=Pose((1.3, 0.6, 1.05), BACK))
    assert world.object_pose("cup-1").position == pytest.approx((1.3, 0.6, 1.05), abs=0.01)
