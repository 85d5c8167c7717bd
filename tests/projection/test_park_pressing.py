"""A configuration move (a park) that would *end* pressing a free object it did not touch
where it started is rejected by the probe (seed 8 without projection, faults 0: the
park's left upper arm ended against the bowl on the island; the probe let an object
touched at the end pass, and the real park toppled the bowl)."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from executive import ManipulationGoalInCollision, Pose
from projection import ProjectedWorldModel, World, make_world_pair
from robots.pr2 import DESCRIPTION as PR2

SINK_NAV = Pose.from_xyz_yaw(0.75, 0.70, 0.0, 0.0)
CARRY = {a: PR2.arm(a).state("carry") for a in ("left", "right")}
#: the link of the left arm that moves farthest from the start (park) to carry
WRIST = "l_wrist_flex_link"


@pytest.fixture
def belief() -> Iterator[World]:
    true, belief = make_world_pair(0, objects={})
    true.close()
    try:
        yield belief
    finally:
        belief.close()


def test_a_park_that_ends_pressing_an_object_is_rejected(belief: World) -> None:
    belief.drive(SINK_NAV)
    start = {a: belief.arm_joints(a) for a in ("left", "right")}
    belief.move_joints(left=CARRY["left"])
    wrist = belief.link_pose(WRIST).position
    belief.move_joints(left=start["left"])
    # a cup where the carried wrist ends, not touched by the arm where it starts
    belief.spawn_object("cup-1", "cup", Pose(wrist), allow_overlap=True)
    model = ProjectedWorldModel(belief)
    result = model.probe_arm_configuration(left=CARRY["left"])
    assert not result.ok
    assert isinstance(result.failure, ManipulationGoalInCollision)
    assert "cup-1" in result.failure.details["swept"]
    assert "end pressing" in str(result.failure)
    assert model.probe_arm_configuration(left=CARRY["left"], allowed_contacts=["cup-1"]).ok
    assert belief.arm_joints("left") == start["left"]  # the world restored
