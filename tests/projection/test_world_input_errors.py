"""Careless input to the world: typed errors that say what to fix, the world unchanged."""

from __future__ import annotations

import math

import pytest

from executive import NavigationPoseUnreachable, Pose

projection = pytest.importorskip("projection")

DRAWER_LINK = "sink_area_left_upper_drawer_main"


@pytest.fixture
def world():
    w = projection.World(seed=3)
    yield w
    w.close()


def _state(world):
    return (
        world.robot_pose(),
        {n: world.object_pose(n) for n in world.objects},
        world.joint_position(f"{DRAWER_LINK}_joint"),
    )


def test_spawning_into_another_object_is_refused(world):
    world.spawn_object("cup-1", "cup", Pose((1.3, 0.6, 0.9)))
    before = _state(world)
    with pytest.raises(projection.SpawnOverlap, match="overlap cup-1") as info:
        world.spawn_object("cup-2", "cup", Pose((1.31, 0.6, 0.9)))
    assert info.value.name == "cup-2" and info.value.overlaps == ("cup-1",)
    assert isinstance(info.value, ValueError)
    assert _state(world) == before and "cup-2" not in world.objects
    world.spawn_object("cup-2", "cup", Pose((1.3, 0.9, 0.9)))  # a free spot is fine
    assert "cup-2" in world.objects


def test_spawning_into_the_robot_is_refused(world):
    before = _state(world)
    with pytest.raises(projection.SpawnOverlap, match="overlap pr2"):
        world.spawn_object("cup-1", "cup", Pose((0.0, 0.0, 0.5)))
    assert _state(world) == before


def test_objects_spawned_apart_stay_put_when_settled(world):
    """Without overlaps, settling moves nothing far (it used to throw objects 0.14-0.33 m
    when spawns overlapped)."""
    from projection import settle

    poses = {"cup-1": Pose((1.3, 0.6, 0.9)), "bowl-1": Pose((1.4, 0.85, 0.88))}
    for name, pose in poses.items():
        world.spawn_object(name, name.split("-")[0], pose)
    settle(world, 240)
    for name, pose in poses.items():
        moved = world.object_pose(name).distance_to(pose)
        assert moved < 0.05, (name, moved)


def test_driving_out_of_the_room_is_refused(world):
    before = _state(world)
    with pytest.raises(NavigationPoseUnreachable, match="outside the room"):
        world.drive(Pose((100.0, 100.0, 0.0)))
    assert _state(world) == before
    x0, y0, x1, y1 = world.room
    assert x0 < 0.5 < x1 and y0 < 0.0 < y1
    world.drive(Pose((0.5, 0.0, 0.0)))  # inside: fine
    assert world.robot_pose().position[0] == pytest.approx(0.5)


def test_set_container_out_of_range_is_an_error_not_a_clamp(world):
    position, lower, upper = world.container_state(DRAWER_LINK)
    assert (position, lower) == (0.0, 0.0) and upper > 0.3
    with pytest.raises(ValueError, match=r"within \[0\.0, 0\.48\]"):
        world.set_container(DRAWER_LINK, 1e9)
    assert world.container_state(DRAWER_LINK)[0] == 0.0
    world.set_container(DRAWER_LINK, 0.2)
    assert world.container_state(DRAWER_LINK)[0] == pytest.approx(0.2)


def _head(world):
    return world.joint_position("head_pan_joint"), world.joint_position("head_tilt_joint")


@pytest.mark.parametrize(
    "target",
    [
        Pose((1e300, 1e300, 1.0), frame="base_footprint"),
        Pose((1e300, 1e300, 1.0)),
        Pose((1e200, 0.0, 1.0)),
    ],
)
def test_looking_at_a_point_too_far_away_is_refused_with_the_head_unchanged(world, target):
    from executive import PtuGoalUnreachable

    world.look_at(Pose((1.4, 0.8, 0.87)))
    before = _head(world)
    with pytest.raises(PtuGoalUnreachable, match="too far away to compute pan and tilt"):
        world.look_at(target)
    assert _head(world) == before
    assert all(math.isfinite(v) for v in before)


def test_looking_through_perform_at_a_huge_pose_fails_as_a_plan_failure(mrun, world):
    import cpl
    from executive import a, perform

    before = (_head(world), world.robot_pose())

    async def main():
        async with projection.with_projected_robot(world):
            huge = Pose((1e300, 1e300, 1.0), frame="base_footprint")
            await perform(a.motion(type="looking", target=a.location(pose=huge)))

    with pytest.raises(cpl.PlanFailure, match="too far away"):
        mrun(main)
    assert (_head(world), world.robot_pose()) == before


@pytest.mark.parametrize(
    "goal",
    [
        Pose((1e200, 0.0, 1.0)),
        Pose((1e300, 1e300, 1.0)),
        Pose((1e300, 0, 1), frame="base_footprint"),
    ],
)
def test_a_huge_arm_goal_is_out_of_reach_not_an_overflow(world, goal):
    from executive import ManipulationPoseUnreachable

    before = world.arm_joints("left"), world.torso_height
    with pytest.raises(ManipulationPoseUnreachable):
        world.move_tcp(left=goal)
    assert (world.arm_joints("left"), world.torso_height) == before


def test_a_huge_arm_goal_through_perform_is_a_plan_failure(mrun, world):
    import cpl
    from executive import a, perform

    async def main():
        async with projection.with_projected_robot(world):
            await perform(a.motion(type="moving-tcp", left_pose=Pose((1e200, 0.0, 1.0))))

    before = world.arm_joints("left")
    with pytest.raises(cpl.PlanFailure):
        mrun(main)
    assert world.arm_joints("left") == before


BAD_POSES = {
    "outside the room": (Pose((9.0, 0.0, 1.0)), "outside the room"),
    "under the floor": (Pose((0.5, 0.5, -0.3)), "between the floor"),
    "huge": (Pose((1e300, 0.0, 1.0)), "outside the room"),
    "huge height": (Pose((0.5, 0.5, 1e300)), "between the floor"),
    "non-finite in map": (Pose((1e300, 1e300, 1.0), frame="base_footprint"), "not finite"),
    "inside furniture": (Pose((1.4, 0.8, 0.5)), "inside the kitchen's sink_area"),
}


@pytest.mark.parametrize("case", sorted(BAD_POSES))
def test_bad_object_poses_are_refused_naming_the_argument(world, case):
    from projection import BadObjectPose

    pose, message = BAD_POSES[case]
    world.spawn_object("cup-1", "cup", Pose((1.3, 0.6, 0.9)))
    before = _state(world)
    with pytest.raises(BadObjectPose, match=message) as info:
        world.spawn_object("cup-2", "cup", pose)
    assert isinstance(info.value, ValueError) and info.value.argument == "pose"
    assert info.value.name == "cup-2" and "cup-2" not in world.objects
    with pytest.raises(BadObjectPose, match=message):
        world.set_object_pose("cup-1", pose)
    assert _state(world) == before


def test_the_demo_poses_are_still_accepted(world):
    from kitchens.iai import DESCRIPTION as kitchen

    for object_type, pose in kitchen.demo_poses.items():
        world.spawn_object(f"{object_type}-1", object_type, pose)
    assert len(world.objects) == len(kitchen.demo_poses)


def test_a_negative_seed_names_the_argument():
    with pytest.raises(
        ValueError, match=r"World\(seed=...\) takes None or an integer >= 0, got -1"
    ):
        projection.World(seed=-1)


def test_spawning_an_unknown_object_type_names_the_known_types(world):
    with pytest.raises(LookupError, match=r"unknown object type 'bwol'; known types: bowl"):
        world.spawn_object("bwol-1", "bwol", Pose((1.3, 0.6, 0.9)))
