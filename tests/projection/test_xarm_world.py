"""A projection world with a 6-joint arm whose gripper closes at a *larger* joint value:
pybullet_data's xArm6 on the mobile base, described as in docs/robots.md (issue 25). The
world reads the chain length, the gripper's direction and its six coupled joints from the
description."""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path

import pytest

from executive import (
    GripperGoalNotReached,
    Pose,
)
from projection import World
from tests.xarm_robot import GRIPPER, JOINTS, xarm_description

CUP = (1.3, 0.6, 0.9)
SINK_NAV = Pose.from_xyz_yaw(0.75, 0.6, 0.0, 0.0)
_S = math.sqrt(0.5)
BACK = (0.0, _S, 0.0, _S)  # the hand's z along map x, the fingers along map y


@pytest.fixture()
def world(tmp_path: Path) -> Iterator[World]:
    with World(seed=0, robot=xarm_description(tmp_path)) as w:
        yield w


def test_a_six_joint_arm_parks_and_moves_by_its_own_chain(world: World) -> None:
    assert world.arms == ("left",)
    assert world.arm_joints("left") == pytest.approx(world.robot.arm("left").state("park"))
    assert [j for j, _lo, _hi in world.arm_joint_limits("left")] == list(JOINTS)
    assert world.robot_collisions() == []
    with pytest.raises(ValueError, match=r"needs 6 joint values \(joint1, "):
        world.move_joints(left=(0.0,) * 7)
    world.set_arm_configuration("carry")
    assert world.arm_joints("left") == pytest.approx(world.robot.arm("left").state("carry"))
    assert world.robot_collisions() == []


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
