"""Careless input to the world: typed errors that say what to fix, the world unchanged."""

from __future__ import annotations

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
