"""The belief's probe of a drawer opening: the opened drawer would be pushed into the
robot's other forearm (the true robot then stood wedged against it and no base motion
was collision-free), and the arm-configuration probe of a park that would end inside an
open drawer (issue 13)."""

from __future__ import annotations

import math
from collections.abc import Iterator

import pytest

from executive import ContainerOpeningProbe, ManipulationGoalInCollision, Pose
from projection import ProjectedWorldModel, World
from robots.pr2 import DESCRIPTION as PR2

DRAWER = "sink_area_left_upper_drawer_main"
#: Where the seed-1 demo opened the spoon drawer with the left arm, the right in carry.
WEDGED = Pose.from_xyz_yaw(0.60, 0.96, 0.0, 2 * math.asin(0.039))
#: Next to the drawer open by 0.3 m: the parked arms are clear, in carry the right
#: forearm would be inside it; 0.1 m further back both are clear.
PARKED_NEXT_TO_IT = Pose.from_xyz_yaw(0.55, 0.96, 0.0, 0.08)
BACKED_OFF = Pose.from_xyz_yaw(0.45, 0.96, 0.0, 0.08)


@pytest.fixture
def model() -> Iterator[ProjectedWorldModel]:
    world = World(seed=0)
    try:
        world.park_arms("carry")
        yield ProjectedWorldModel(world)
    finally:
        world.close()


def _state(world: World) -> tuple[object, ...]:
    return (world.robot_pose(), world.container_state(DRAWER), world.arm_joints("right"))


def test_a_drawer_opened_into_the_other_forearm_is_rejected(model: ProjectedWorldModel) -> None:
    assert isinstance(model, ContainerOpeningProbe)
    world = model.world
    world.drive(WEDGED)
    before = _state(world)
    result = model.probe_container_opening(DRAWER, 0.3, "left")
    assert not result.ok
    assert isinstance(result.failure, ManipulationGoalInCollision)
    assert f"kitchen/{DRAWER}" in result.failure.details["swept"]
    assert _state(world) == before  # the drawer is closed again, nothing moved
    world.drive(BACKED_OFF)
    assert model.probe_container_opening(DRAWER, 0.3, "left").ok


def test_the_opening_probe_rejects_a_wrong_arm_and_an_unknown_drawer(
    model: ProjectedWorldModel,
) -> None:
    with pytest.raises(ValueError, match="known arms"):
        model.probe_container_opening(DRAWER, 0.3, "middle")
    with pytest.raises(LookupError):
        model.probe_container_opening("no_such_drawer", 0.3, "left")


def test_a_park_that_would_end_inside_an_open_drawer_is_rejected(
    model: ProjectedWorldModel,
) -> None:
    world = model.world
    world.park_arms("park")
    world.open_container(DRAWER, 0.3)
    world.drive(PARKED_NEXT_TO_IT)  # the drawer stands open in front of the right arm
    carry = {arm: PR2.arm(arm).state("carry") for arm in PR2.arm_names}
    touching = {c.link_b for c in world.robot_collisions()}
    assert DRAWER not in touching  # parked, the arms are clear of it
    result = model.probe_arm_configuration(left=carry["left"], right=carry["right"])
    assert not result.ok
    assert f"kitchen/{DRAWER}" in result.failure.details["swept"]  # type: ignore[union-attr]
    world.drive(BACKED_OFF)
    assert model.probe_arm_configuration(left=carry["left"], right=carry["right"]).ok
    world.drive(PARKED_NEXT_TO_IT)
    world.close_container(DRAWER, 0.3)
    assert model.probe_arm_configuration(left=carry["left"], right=carry["right"]).ok
