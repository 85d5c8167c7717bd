"""CRAM's low-level projection functions on a real PyBullet world: success and failure."""

from __future__ import annotations

import math
from collections.abc import Iterator

import numpy as np
import pybullet as pb
import pytest

from executive import knowledge
from executive._pose import Pose
from executive.failures import (
    EnvironmentManipulationGoalNotReached,
    GripperClosedCompletely,
    GripperGoalNotReached,
    ManipulationPoseUnreachable,
    NavigationPoseUnreachable,
    PerceptionObjectNotFound,
    PtuGoalNotReached,
    TorsoGoalNotReached,
)
from projection import World
from robots.pr2 import DESCRIPTION as PR2
from robots.pr2 import STANDARD_TO_TOOL as PR2_TOOL

SINK_NAV = Pose.from_xyz_yaw(0.75, 0.70, 0.0, 0.0)
DRAWER = "sink_area_left_upper_drawer_main"


@pytest.fixture()
def world() -> Iterator[World]:
    with World(seed=0) as w:
        yield w


@pytest.fixture()
def sink(world: World) -> World:
    world.drive(SINK_NAV)
    return world


class Desig:
    """Duck-typed object designator (``get(key, default)``)."""

    def __init__(self, **props: str) -> None:
        self.props = props

    def get(self, key: str, default: object = None) -> object:
        return self.props.get(key, default)


# ------------------------------------------------------------------ drive
def test_drive_into_the_counter_fails_and_restores(sink: World) -> None:
    sink.spawn_object("cup", "cup", Pose((0.9, 0.7, 1.2)))
    sink.attach("cup", "r_gripper_tool_frame")
    before = sink.snapshot()
    goal = Pose.from_xyz_yaw(1.0, 0.7, 0.0, 0.0)
    with pytest.raises(NavigationPoseUnreachable) as info:
        sink.drive(goal)
    assert info.value.location is goal
    assert sink.snapshot() == before


def test_drive_with_carried_object_colliding_fails(sink: World) -> None:
    sink.spawn_object("cereal", "breakfast-cereal", Pose((1.0, 0.7, 1.0)))
    sink.attach("cereal", "r_gripper_tool_frame")
    assert not sink.robot_in_collision()
    with pytest.raises(NavigationPoseUnreachable):
        sink.drive(Pose((0.3, 0.0, 0.0), frame="base_footprint"))  # box into the counter
    assert sink.robot_pose().position == pytest.approx((0.75, 0.7, 0.0))


def test_attached_object_follows_the_robot(sink: World) -> None:
    sink.spawn_object("cup", "cup", Pose((1.0, 0.6, 1.1)))
    sink.attach("cup", "r_gripper_tool_frame")
    rel0 = sink.object_pose("cup", "base_footprint")
    sink.drive(Pose.from_xyz_yaw(0.2, -0.3, 0.0, 1.2))
    rel1 = sink.object_pose("cup", "base_footprint")
    assert rel1.isclose(rel0, 1e-5, 1e-5)
    assert sink.object_pose("cup").distance_to(Pose((1.0, 0.6, 1.1))) > 0.3
    sink.move_torso(0.3)
    assert sink.object_pose("cup", "base_footprint").position[2] == pytest.approx(
        rel0.position[2] + 0.15, abs=1e-5
    )


# ------------------------------------------------------------------ torso
def test_torso_limits(world: World) -> None:
    world.move_torso(0.33)
    assert world.torso_height == pytest.approx(0.33)
    world.move_torso(0.33 + 5e-5)  # clamped by less than 1e-4: fine
    with pytest.raises(TorsoGoalNotReached) as info:
        world.move_torso(0.5)
    assert info.value.torso == 0.5
    with pytest.raises(TorsoGoalNotReached):
        world.move_torso(-0.1)
    assert world.torso_height == pytest.approx(0.33)


# ------------------------------------------------------------------ head
def _camera_error(world: World, point: tuple[float, float, float]) -> float:
    cam = world.link_pose("head_mount_kinect_rgb_optical_frame")
    z = cam.as_rotation().apply([0.0, 0.0, 1.0])
    d = np.subtract(point, cam.position)
    return float(math.acos(min(1.0, np.dot(z, d) / np.linalg.norm(d))))


@pytest.mark.parametrize("point", [(1.3, 0.6, 0.9), (0.9, 1.4, 1.6), (1.6, -0.2, 0.2)])
def test_look_at_points_the_optical_axis_at_the_target(
    sink: World, point: tuple[float, float, float]
) -> None:
    sink.look_at(Pose(point))
    assert _camera_error(sink, point) < 2e-3


def test_look_at_frames_base_poses_and_forward(sink: World) -> None:
    sink.look_at(Pose((0.5, 0.0, 1.0), frame="base_footprint"))  # CRAM's look goal
    assert _camera_error(sink, (1.25, 0.7, 1.0)) < 2e-3
    sink.look_at("sink_area_left_upper_drawer_handle")
    handle = sink.link_pose("sink_area_left_upper_drawer_handle").position
    assert _camera_error(sink, handle) < 2e-3
    sink.look_at("forward")
    assert sink.joint_position("head_pan_joint") == 0.0
    with pytest.raises(LookupError):
        sink.look_at("no_such_link")


@pytest.mark.parametrize(
    "target",
    [
        Pose((-1.0, 0.0, 1.2), frame="base_footprint"),  # behind: pan beyond ±2.857
        Pose((0.05, 0.0, 3.0), frame="base_footprint"),  # straight up: tilt below -0.471
        Pose((0.2, 0.0, 0.0), frame="base_footprint"),  # at the feet: tilt beyond 1.396
    ],
)
def test_look_at_beyond_the_limits_fails_and_keeps_the_head(sink: World, target: Pose) -> None:
    sink.look_at(Pose((1.3, 0.6, 0.9)))
    pan, tilt = sink.joint_position("head_pan_joint"), sink.joint_position("head_tilt_joint")
    with pytest.raises(PtuGoalNotReached) as info:
        sink.look_at(target)
    assert info.value.target is target
    assert (sink.joint_position("head_pan_joint"), sink.joint_position("head_tilt_joint")) == (
        pan,
        tilt,
    )


# ------------------------------------------------------------------ perception
def test_detect_a_visible_cup(sink: World) -> None:
    sink.spawn_object("cup-1", "cup", Pose((1.3, 0.6, 0.9)))
    sink.look_at(Pose((1.3, 0.6, 0.9)))
    (cup,) = sink.detect({"type": "cup"})
    assert cup.name == "cup-1" and cup.type == "cup"
    assert cup.map_pose.position == pytest.approx((1.3, 0.6, 0.9), abs=1e-4)
    assert cup.pose.frame == "base_footprint"
    assert cup.pose.position == pytest.approx((0.55, -0.1, 0.9), abs=1e-4)
    assert cup.transform.child_frame == "cup-1"
    assert sink.detect(Desig(type="cup", name="cup-1"))[0].name == "cup-1"
    with pytest.raises(PerceptionObjectNotFound):
        sink.detect(Desig(type="cup", name="cup-2"))


def test_detect_wrong_type_fails(sink: World) -> None:
    sink.spawn_object("cup", "cup", Pose((1.3, 0.6, 0.9)))
    sink.look_at(Pose((1.3, 0.6, 0.9)))
    desig = {"type": "bowl"}
    with pytest.raises(PerceptionObjectNotFound) as info:
        sink.detect(desig)
    assert info.value.object is desig


def test_detect_a_cup_hidden_behind_a_cereal_box_fails(sink: World) -> None:
    sink.move_torso(0.0)
    sink.spawn_object("cup", "cup", Pose((1.45, 0.7, 0.9)))
    sink.look_at(Pose((1.45, 0.7, 0.9)))
    assert sink.detect({"type": "cup"})
    sink.spawn_object(
        "cereal", "breakfast-cereal", Pose.from_xyz_yaw(1.3, 0.7, 0.85 + 0.145, math.pi / 2)
    )
    assert sink.visibility("cup") < 0.2
    with pytest.raises(PerceptionObjectNotFound):
        sink.detect({"type": "cup"})
    assert sink.detect({"type": "breakfast-cereal"})[0].name == "cereal"


def test_detect_outside_the_field_of_view_fails(sink: World) -> None:
    sink.spawn_object("cup", "cup", Pose((1.3, 0.6, 0.9)))
    sink.look_at(Pose((1.3, 2.5, 1.3)))  # looking far to the left
    with pytest.raises(PerceptionObjectNotFound):
        sink.detect({"type": "cup"})


# ------------------------------------------------------------------ arms
def _tool_error(world: World, arm: str, goal: Pose) -> tuple[float, float]:
    tool = world.link_pose(f"{arm[0]}_gripper_tool_frame")
    goal_map = (
        goal if goal.frame == "map" else (world.robot_pose().to_transform("base_footprint") * goal)
    )
    return tool.distance_to(goal_map), tool.angle_to(goal_map)


def test_move_tcp_to_a_reachable_pose(sink: World) -> None:
    goal = Pose((0.6, -0.2, 0.95), frame="base_footprint")
    sink.move_tcp(right=goal)
    dist, angle = _tool_error(sink, "right", goal)
    assert dist < 0.01 and angle < 0.1
    goal_map = Pose((1.3, 0.9, 1.0), (0, 0.7071068, 0, 0.7071068))  # pointing down
    sink.move_tcp(left=goal_map)
    dist, angle = _tool_error(sink, "left", goal_map)
    assert dist < 0.01 and angle < 0.1


def test_move_tcp_both_arms(sink: World) -> None:
    left = Pose((0.55, 0.2, 1.0), frame="base_footprint")
    right = Pose((0.55, -0.2, 1.0), frame="base_footprint")
    sink.move_tcp(left=left, right=right)
    assert _tool_error(sink, "left", left)[0] < 0.01
    assert _tool_error(sink, "right", right)[0] < 0.01


def test_move_tcp_unreachable_fails_and_leaves_the_robot(sink: World) -> None:
    before = sink.snapshot()
    with pytest.raises(ManipulationPoseUnreachable):
        sink.move_tcp(right=Pose((1.8, 0.0, 1.0), frame="base_footprint"))
    with pytest.raises(ManipulationPoseUnreachable):  # left fine, right not: both refused
        sink.move_tcp(
            left=Pose((0.55, 0.2, 1.0), frame="base_footprint"),
            right=Pose((0.2, -1.5, 0.3), frame="base_footprint"),
        )
    assert sink.snapshot() == before


def test_move_tcp_resamples_the_torso(sink: World) -> None:
    sink.move_torso(0.0)
    high = Pose((0.6, -0.2, 1.05), frame="base_footprint")
    sink.move_tcp(right=high)
    assert sink.torso_height > 0.1  # unreachable at the current height 0
    assert _tool_error(sink, "right", high)[0] < 0.01


def test_move_joints_and_named_configurations(world: World) -> None:
    q = (0.1, 0.2, 0.3, -0.4, 0.5, -0.6, 0.7)
    world.move_joints(left=q)
    assert world.arm_joints("left") == pytest.approx(q)
    with pytest.raises(ValueError, match="outside"):
        world.move_joints(right=(0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0))  # elbow > 0
    assert world.arm_joints("left") == pytest.approx(q)
    world.park_arms("carry")
    assert world.arm_joints("right") == pytest.approx(PR2.arm("right").state("carry"))
    with pytest.raises(LookupError, match="known: park, carry"):
        world.park_arms("wave")


# ------------------------------------------------------------------ grippers
def test_grip_on_nothing_fails(sink: World) -> None:
    sink.gripper("open", "right")
    with pytest.raises(GripperClosedCompletely):
        sink.gripper("grip", "right")
    assert sink.gripper_opening("right") == pytest.approx(0.0)


def test_grip_around_a_cup_succeeds(sink: World) -> None:
    sink.spawn_object("cup", "cup", Pose((1.3, 0.6, 0.9)))
    obj = sink.object_pose("cup", "base_footprint").to_transform("cup")
    grasp = knowledge.grasp_poses("cup", "back", obj, PR2_TOOL)[2]
    sink.gripper("open", ("left", "right"))
    sink.move_tcp(right=grasp)
    sink.gripper("grip", "right")
    assert 0.06 < sink.gripper_opening("right") < 0.085  # stopped at the cup wall (0.08)
    sink.attach("cup", "r_gripper_tool_frame")
    lift = knowledge.grasp_poses("cup", "back", obj, PR2_TOOL)[3]
    sink.move_tcp(right=lift)
    assert sink.object_pose("cup").position[2] == pytest.approx(1.05, abs=0.01)


def test_gripper_openings(world: World) -> None:
    world.gripper(0.04, "left")
    assert world.gripper_opening("left") == pytest.approx(0.04)
    world.gripper("close", ["left", "right"])
    assert world.gripper_opening("right") == 0.0
    with pytest.raises(GripperGoalNotReached):
        world.gripper(0.2, "left")
    assert world.gripper_opening("left") == 0.0
    with pytest.raises(ValueError, match="unknown gripper action"):
        world.gripper("squeeze", "left")


def test_detach_settles_on_the_counter_and_keeps_others(sink: World) -> None:
    sink.spawn_object("milk", "milk", Pose((1.4, 0.2, 0.95)))
    sink.spawn_object("cup", "cup", Pose((1.3, 0.6, 0.92)))  # 2 cm above the counter
    milk0 = sink.object_pose("milk")
    sink.attach("cup", "r_gripper_tool_frame")
    sink.detach("cup", settle_steps=60)
    assert sink.object_pose("cup").position[2] == pytest.approx(0.9, abs=0.004)
    assert sink.object_pose("milk") == milk0
    assert "cup" not in sink.attachments
    with pytest.raises(ValueError, match="not attached"):
        sink.detach("cup")


def test_placing_pose_stability(world: World) -> None:
    assert world.placing_pose_stable("cup", Pose((-0.8, 1.3, 0.905)))
    assert not world.placing_pose_stable("cup", Pose((-0.5, 1.3, 0.905)))  # over the edge
    assert not world.placing_pose_stable("cup", Pose((0.0, 1.3, 0.905)))  # in the air
    assert dict(world.objects) == {}


# ------------------------------------------------------------------ containers
def test_drawer_open_and_close_move_an_attached_spoon(world: World) -> None:
    world.spawn_object("spoon", "spoon", Pose.from_xyz_yaw(1.4, 1.0, 0.7413, math.pi))
    world.attach("spoon", DRAWER)
    handle0 = world.link_pose("sink_area_left_upper_drawer_handle").position
    world.open_container(DRAWER, 0.3)
    assert world.object_pose("spoon").position == pytest.approx((1.1, 1.0, 0.7413), abs=1e-5)
    assert world.link_pose("sink_area_left_upper_drawer_handle").position[0] == pytest.approx(
        handle0[0] - 0.3
    )
    with pytest.raises(EnvironmentManipulationGoalNotReached):
        world.open_container(DRAWER, 0.3)  # 0.6 > 0.48
    world.close_container(f"{DRAWER}_joint", 0.3)
    assert world.object_pose("spoon").position == pytest.approx((1.4, 1.0, 0.7413), abs=1e-5)
    with pytest.raises(LookupError, match="known"):
        world.open_container("fridge", 0.1)


def test_open_drawer_blocks_the_robot(sink: World) -> None:
    sink.drive(Pose.from_xyz_yaw(0.6, 0.9, 0.0, 0.0))
    sink.open_container(DRAWER, 0.45)
    assert sink.robot_in_collision()
    assert any(c.body_b == "kitchen" for c in sink.robot_collisions())


def test_contacts_helper(world: World) -> None:
    world.spawn_object("cup", "cup", Pose((1.3, 0.6, 0.89)))  # 1 cm into the counter
    contacts = world.contacts("cup")
    assert contacts and contacts[0].body_b == "kitchen"
    assert contacts[0].link_b == "sink_area_surface"
    assert pb.getNumBodies(physicsClientId=world.client) == 4  # floor, kitchen, robot, cup
