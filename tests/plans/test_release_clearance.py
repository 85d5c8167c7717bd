"""A placing lets go of the object without pushing its neighbour (seed 2 without
projection: the spoon put down 6 cm beside the cup was released with the fingers opened
fully, 0.10 m, and a finger pushed the cup 2 cm). Injected on the simulated real robot
and measured on the true world."""

from __future__ import annotations

import math
from typing import Any

import plans  # noqa: F401 - the action rules
from executive import Pose, a, an, perform
from plans.pick_place import release_opening
from projection import FaultProfile, make_world_pair, settle, with_real_robot

#: Where seed 2's robot stood to put the spoon on the island, and the spoon's target.
STAND = Pose.from_xyz_yaw(-0.08, 0.80, 0.0, math.pi - 0.058)
SPOON_AT = Pose.from_xyz_yaw(-0.75, 0.854, 0.86, -3.07)
#: The cup as seed 2 had placed it: 6.2 cm beside the spoon, across the fingers.
CUP_AT = Pose.from_xyz_yaw(-0.757, 0.916, 0.90, 1.88)


def _put_spoon_back(mrun: Any) -> tuple[float, float, str | None, float]:
    """Pick the spoon up and put it back where it lay, the cup beside it; returns how
    far the cup moved during the placing, how far the spoon lies from its target, what
    the left hand holds after, and the release opening the placing chose."""
    true, belief = make_world_pair(
        0,
        objects={"spoon-1": ("spoon", SPOON_AT), "cup-1": ("cup", CUP_AT)},
        belief_objects="exact",
    )
    out: dict[str, Any] = {}
    try:
        settle(true, 100)

        async def main() -> None:
            async with with_real_robot(true, belief, FaultProfile.none()):
                await perform(a.motion(type="going", pose=STAND))
                spoon = an.object(type="spoon", name="spoon-1", pose=belief.object_pose("spoon-1"))
                await perform(an.action(type="picking-up", object=spoon, arm="left"))
                assert true.attachments.get("spoon-1", "").startswith("l_")
                out["cup"] = true.object_pose("cup-1")
                out["opening"] = release_opening("spoon", "left")
                await perform(an.action(type="placing", object=spoon, arm="left", target=SPOON_AT))

        mrun(main)
        cup_moved = math.dist(true.object_pose("cup-1").position, out["cup"].position)
        spoon_off = math.dist(true.object_pose("spoon-1").position[:2], SPOON_AT.position[:2])
        return cup_moved, spoon_off, true.attachments.get("spoon-1"), out["opening"]
    finally:
        true.close()
        belief.close()


def test_placing_releases_as_wide_as_the_pick_opened_and_the_neighbour_stays(mrun: Any) -> None:
    cup_moved, spoon_off, held, opening = _put_spoon_back(mrun)
    assert opening < 0.06  # the spoon's opening (0.04 m), not the gripper's 0.10 m
    assert held is None  # let go of
    assert spoon_off < 0.02  # delivered where it was meant to go
    assert cup_moved < 0.005  # the neighbour did not move (the old release pushed 2.5 cm)
