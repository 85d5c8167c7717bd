"""ProjectedWorldModel: queries, events and the projection probes on a real PyBullet world."""

from __future__ import annotations

import math
from collections.abc import Iterator
from typing import Any

import pytest

import executive
from executive import (
    EnvironmentManipulationGoalNotReached,
    GripperGoalNotReached,
    HighLevelFailure,
    ManipulationGoalInCollision,
    ManipulationPoseUnreachable,
    NavigationPoseUnreachable,
    PerceptionObjectNotInWorld,
    Pose,
    a,
    an,
    knowledge,
    perform,
)
from executive.events import (
    ContainerClosed,
    ContainerOpened,
    ObjectAttached,
    ObjectDetached,
    ObjectPerceived,
    RobotStateChanged,
    emit,
)
from projection import ProjectedWorldModel, World, with_projected_robot
from robots.pr2 import STANDARD_TO_TOOL as PR2_TOOL

SINK_NAV = Pose.from_xyz_yaw(0.75, 0.70, 0.0, 0.0)
CUP = Pose((1.3, 0.6, 0.9))
DRAWER = "sink_area_left_upper_drawer_main"
DRAWER_JOINT = f"{DRAWER}_joint"
DOWN = (0.0, 0.7071068, 0.0, 0.7071068)  # tool x pointing down


@pytest.fixture()
def world() -> Iterator[World]:
    with World(seed=0) as w:
        w.drive(SINK_NAV)
        w.spawn_object("cup-1", "cup", CUP)
        yield w


@pytest.fixture()
def model(world: World) -> ProjectedWorldModel:
    return ProjectedWorldModel(world)


def back_grasp(world: World, obj: str = "cup-1") -> list[Pose]:
    transform = world.object_pose(obj, "base_footprint").to_transform(obj)
    return knowledge.grasp_poses("cup", "back", transform, PR2_TOOL)


# ------------------------------------------------------------------ queries
def test_is_a_projection_world_and_answers_queries(model: ProjectedWorldModel) -> None:
    assert isinstance(model, executive.ProjectionWorld)
    assert model.object_pose("cup-1") == model.world.object_pose("cup-1")
    assert model.object_pose("cup-1", "base_footprint").position == pytest.approx((0.55, -0.1, 0.9))
    assert model.robot_pose() == model.world.robot_pose()
    assert model.object_type("cup-1") == "cup"
    assert model.object_in_hand("left") is None
    assert model.link_pose("r_gripper_tool_frame").frame == "map"
    with pytest.raises(PerceptionObjectNotInWorld, match=r"no object 'bowl-9'.*cup-1"):
        model.object_pose("bowl-9")
    with pytest.raises(PerceptionObjectNotInWorld):
        model.object_type("bowl-9")
    with pytest.raises(LookupError, match="unknown link"):
        model.link_pose("r_gripper_tool_fram")
    with pytest.raises(ValueError, match="known arms"):
        model.object_in_hand("middle")
    with pytest.raises(TypeError, match=r"projection\.World"):
        ProjectedWorldModel(model)  # type: ignore[arg-type]


# ------------------------------------------------------------------ events
def test_attached_object_follows_the_gripper_on_drive(mrun: Any, world: World) -> None:
    cup = an.object(type="cup", name="cup-1")
    for pose in back_grasp(world)[:3]:
        world.move_tcp(right=pose)

    async def main() -> None:
        async with with_projected_robot(world) as env:
            emit(ObjectAttached(cup, "right", "r_wrist_roll_link"))
            assert env.world.object_in_hand("right") == "cup-1"
            assert env.world.object_in_hand("left") is None
            await perform(a.motion(type="going", pose=Pose.from_xyz_yaw(0.3, -0.4, 0.0, 1.0)))

    in_hand = world.object_pose("cup-1", "base_footprint")
    mrun(main, name="carry")
    assert world.attachments == {"cup-1": "r_wrist_roll_link"}
    assert world.object_pose("cup-1", "base_footprint").isclose(in_hand, 1e-5, 1e-5)
    assert world.object_pose("cup-1").distance_to(CUP) > 0.5


def test_attach_defaults_to_the_wrist_and_detach_settles(model: ProjectedWorldModel) -> None:
    world = model.world
    world.spawn_object("milk", "milk", Pose((1.4, 0.2, 0.95)))
    world.set_object_pose("cup-1", Pose((1.3, 0.6, 0.92)))  # 2 cm above the counter
    milk = world.object_pose("milk")
    model.handle_event(ObjectAttached("cup-1", "left"))
    assert world.attachments == {"cup-1": "l_wrist_roll_link"}
    assert model.object_in_hand("left") == "cup-1"
    model.handle_event(ObjectDetached("cup-1", "left"))
    assert world.attachments == {}
    assert model.object_in_hand("left") is None
    assert world.object_pose("cup-1").position[2] < 0.92 - 1e-4  # fell during 10 steps
    assert world.object_pose("milk") == milk
    model.handle_event(ObjectDetached("cup-1", "left"))  # not held: nothing happens


def test_attaching_the_spoon_takes_it_out_of_the_drawer(model: ProjectedWorldModel) -> None:
    world = model.world
    world.spawn_object("spoon", "spoon", Pose.from_xyz_yaw(1.4, 1.0, 0.7413, math.pi))
    world.attach("spoon", DRAWER)
    drawer = an.object(type="drawer", urdf_name=DRAWER, part_of="kitchen")
    model.handle_event(ContainerOpened(drawer, 0.3))
    assert world.joint_position(DRAWER_JOINT) == pytest.approx(0.3)
    assert world.object_pose("spoon").position == pytest.approx((1.1, 1.0, 0.7413), abs=1e-5)
    assert model.object_in_hand("right") is None  # in the drawer, not in a hand
    model.handle_event(ObjectAttached(an.object(name="spoon"), "right"))
    assert world.attachments == {"spoon": "r_wrist_roll_link"}
    model.handle_event(ContainerClosed(DRAWER, 0.3))
    assert world.joint_position(DRAWER_JOINT) == pytest.approx(0.0)
    assert world.object_pose("spoon").position == pytest.approx((1.1, 1.0, 0.7413), abs=1e-5)


def test_container_events_move_the_drawer(mrun: Any, world: World) -> None:
    handle = "sink_area_left_upper_drawer_handle"
    x0 = world.link_pose(handle).position[0]

    async def main() -> None:
        async with with_projected_robot(world):
            emit(ContainerOpened(DRAWER, 0.2))
            assert world.link_pose(handle).position[0] == pytest.approx(x0 - 0.2)
            emit(ContainerClosed(DRAWER_JOINT, 0.2))

    mrun(main, name="drawer")
    assert world.link_pose(handle).position[0] == pytest.approx(x0)


def test_other_events_change_nothing_and_bad_events_fail(model: ProjectedWorldModel) -> None:
    world = model.world
    before = world.snapshot()
    model.handle_event(RobotStateChanged("going"))
    model.handle_event(ObjectPerceived(an.object(type="cup", name="cup-1")))
    assert world.snapshot() == before
    with pytest.raises(PerceptionObjectNotInWorld):
        model.handle_event(ObjectAttached("bowl-9", "left"))
    with pytest.raises(ValueError, match="known arms"):
        model.handle_event(ObjectAttached("cup-1", "middle"))
    with pytest.raises(LookupError, match="no container 'fridge'"):
        model.handle_event(ContainerOpened("fridge", 0.1))
    with pytest.raises(EnvironmentManipulationGoalNotReached):
        model.handle_event(ContainerOpened(DRAWER, 0.6))
    with pytest.raises(TypeError, match="Event"):
        model.handle_event("object-attached")  # type: ignore[arg-type]
    assert world.snapshot() == before


# ------------------------------------------------------------------ probes
def test_probe_base_pose(model: ProjectedWorldModel) -> None:
    world = model.world
    world.drive(Pose((0.0, 0.0, 0.0)))
    before = world.snapshot()
    assert model.probe_base_pose(SINK_NAV) == executive.ProbeResult(True)
    assert world.snapshot() == before
    inside = Pose.from_xyz_yaw(1.5, 0.3, 0.0, 0.0)
    result = model.probe_base_pose(inside)
    assert not result.ok and result.index is None
    assert isinstance(result.failure, NavigationPoseUnreachable)
    assert result.failure.location is inside
    assert world.snapshot() == before
    with pytest.raises(TypeError, match="Pose"):
        model.probe_base_pose((0.75, 0.7, 0.0))  # type: ignore[arg-type]


def test_probe_base_pose_with_a_carried_object(model: ProjectedWorldModel) -> None:
    world = model.world
    world.spawn_object("cereal", "breakfast-cereal", Pose((1.0, 0.7, 1.0)))
    model.handle_event(ObjectAttached("cereal", "right"))
    before = world.snapshot()
    cereal = world.object_pose("cereal")
    # the robot alone fits 0.1 m further, the box it carries goes into the counter
    result = model.probe_base_pose(Pose.from_xyz_yaw(0.85, 0.7, 0.0, 0.0))
    assert not result.ok and isinstance(result.failure, NavigationPoseUnreachable)
    assert model.probe_base_pose(Pose.from_xyz_yaw(0.5, 0.7, 0.0, 0.0)).ok
    assert world.snapshot() == before
    assert world.object_pose("cereal") == cereal


def test_probe_arm_trajectory_back_grasp_is_feasible(model: ProjectedWorldModel) -> None:
    world = model.world
    before = world.snapshot()
    waypoints = back_grasp(world)
    result = model.probe_arm_trajectory(
        "right", waypoints, gripper_opening=0.1, allowed_contacts=["cup-1"]
    )
    assert result == executive.ProbeResult(True)
    assert world.snapshot() == before
    # from another base pose: map-frame waypoints stay at the cup
    robot = world.robot_pose().to_transform("base_footprint")
    map_waypoints = [robot * p for p in waypoints]
    result = model.probe_arm_trajectory(
        "right",
        map_waypoints,
        robot_pose=Pose.from_xyz_yaw(0.75, 0.6, 0.0, 0.0),
        allowed_contacts=("cup-1",),
    )
    assert result.ok
    assert world.snapshot() == before


def test_probe_arm_trajectory_reports_the_unreachable_waypoint(
    model: ProjectedWorldModel,
) -> None:
    world = model.world
    before = world.snapshot()
    waypoints = back_grasp(world)
    waypoints[2] = Pose((1.8, 0.0, 1.0), frame="base_footprint")
    result = model.probe_arm_trajectory("right", waypoints, allowed_contacts=["cup-1"])
    assert not result.ok and result.index == 2
    assert isinstance(result.failure, ManipulationPoseUnreachable)
    assert world.snapshot() == before


def test_probe_arm_trajectory_detects_collisions_unless_allowed(
    model: ProjectedWorldModel,
) -> None:
    world = model.world
    before = world.snapshot()
    above = Pose((1.3, 0.9, 1.0), DOWN)
    into_counter = Pose((1.3, 0.9, 0.84), DOWN)  # the fingers go into the counter top
    result = model.probe_arm_trajectory("left", [above, into_counter, above])
    assert not result.ok and result.index == 1
    assert isinstance(result.failure, ManipulationGoalInCollision)
    assert "sink_area_surface" in str(result.failure)
    assert any(c.link_b == "sink_area_surface" for c in result.failure.details["contacts"])
    for allowed in (
        ["sink_area_surface"],
        ["kitchen"],
        ["l_gripper_l_finger_link", "l_gripper_r_finger_link"],
    ):
        assert model.probe_arm_trajectory(
            "left", [above, into_counter, above], allowed_contacts=allowed
        ).ok, allowed
    assert model.probe_arm_trajectory(
        "left", [above, into_counter, above], check_collisions=[True, False, True]
    ).ok
    assert model.probe_arm_trajectory("left", [above, into_counter], check_collisions=False).ok
    assert world.snapshot() == before


def test_probe_arm_trajectory_start_failures_and_bad_arguments(
    model: ProjectedWorldModel,
) -> None:
    world = model.world
    before = world.snapshot()
    waypoints = back_grasp(world)
    result = model.probe_arm_trajectory(
        "right", waypoints, robot_pose=Pose.from_xyz_yaw(1.5, 0.3, 0.0, 0.0)
    )
    assert not result.ok and result.index is None
    assert isinstance(result.failure, NavigationPoseUnreachable)
    result = model.probe_arm_trajectory("right", waypoints, gripper_opening=0.3)
    assert not result.ok and isinstance(result.failure, GripperGoalNotReached)
    assert model.probe_arm_trajectory("right", []).ok
    with pytest.raises(ValueError, match="known arms"):
        model.probe_arm_trajectory("both", waypoints)
    with pytest.raises(ValueError, match="2 entries for 5 waypoints"):
        model.probe_arm_trajectory("right", waypoints, check_collisions=[True, False])
    with pytest.raises(TypeError, match="waypoint 1"):
        model.probe_arm_trajectory("right", [waypoints[0], (1, 2, 3)])  # type: ignore[list-item]
    with pytest.raises(TypeError, match="sequence of names"):
        model.probe_arm_trajectory("right", waypoints, allowed_contacts="cup-1")
    assert world.snapshot() == before


def test_probe_arm_trajectory_with_an_object_in_hand(model: ProjectedWorldModel) -> None:
    world = model.world
    for pose in back_grasp(world)[:4]:
        world.move_tcp(right=pose)
    model.handle_event(ObjectAttached("cup-1", "right"))
    before = world.snapshot()
    cup = world.object_pose("cup-1")
    # carrying the cup down into the counter collides; the cup itself is not "touching"
    down = Pose(
        (0.55, -0.1, 0.80),
        world.link_pose("r_gripper_tool_frame", "base_footprint").orientation,
        "base_footprint",
    )
    result = model.probe_arm_trajectory("right", [down])
    assert not result.ok and isinstance(result.failure, ManipulationGoalInCollision)
    assert world.snapshot() == before
    assert world.object_pose("cup-1") == cup


@pytest.mark.parametrize(
    ("pose", "ok"),
    [
        (Pose((1.4, 0.2, 0.9)), True),  # on the counter (top 0.85, cup 0.1 high)
        (Pose((-0.8, 1.3, 0.905)), True),  # on the island
        (Pose((1.12, 0.2, 0.9)), False),  # half over the counter's edge
        (Pose((0.3, 0.0, 1.0)), False),  # in mid-air above the floor
    ],
)
def test_probe_placing_stability(model: ProjectedWorldModel, pose: Pose, ok: bool) -> None:
    world = model.world
    before = world.snapshot()
    result = model.probe_placing_stability("cup", pose)
    assert result.ok is ok
    if not ok:
        assert isinstance(result.failure, HighLevelFailure)
        assert "Pose unstable" in str(result.failure)
    assert world.snapshot() == before
    assert dict(world.objects) == {"cup-1": "cup"}


def test_probe_placing_stability_bad_input(model: ProjectedWorldModel) -> None:
    with pytest.raises(LookupError, match="known"):
        model.probe_placing_stability("teapot", Pose((1.4, 0.2, 0.9)))
    with pytest.raises(TypeError, match="Pose"):
        model.probe_placing_stability("cup", (1.4, 0.2, 0.9))  # type: ignore[arg-type]
