"""The real perception reports every object it sees, not only the one asked for: the
belief learns the neighbours its collision checks must avoid (issue 13)."""

from __future__ import annotations

import math

import cpl
from cpl.testing import MockClock
from executive import Pose, a, an, perform
from projection import FaultProfile, make_world_pair, with_real_robot

SINK_NAV = Pose.from_xyz_yaw(0.75, 0.70, 0.0, 0.0)
CUP_LOOK = Pose((1.3, 0.6, 0.9))


def _detect_cup(
    faults: FaultProfile,
) -> tuple[dict[str, str], dict[str, Pose], dict[str, Pose], set]:
    true, belief = make_world_pair(0)
    try:

        async def main() -> None:
            async with with_real_robot(true, belief, faults, rules=None):
                await perform(a.motion(type="going", pose=SINK_NAV))
                await perform(a.motion(type="looking", pose=CUP_LOOK))
                await perform(a.motion(type="detecting", object=an.object(type="cup")))

        cpl.run(main, clock=MockClock())
        visible = {n for n in true.objects if true.visibility(n) >= 0.5}
        return (
            dict(belief.objects),
            {n: belief.object_pose(n) for n in belief.objects},
            {n: true.object_pose(n) for n in true.objects},
            visible,
        )
    finally:
        true.close()
        belief.close()


def test_detecting_one_object_teaches_the_belief_its_visible_neighbours():
    known, believed, truth, visible = _detect_cup(FaultProfile.none())
    assert "cup-1" in known
    neighbours = visible - {"cup-1"}
    assert neighbours, "the set-up must show the cup's neighbours"
    assert set(known) == visible  # every visible object, nothing else (the spoon is hidden)
    assert "spoon-1" not in known
    for name in known:
        assert believed[name].isclose(truth[name], 1e-6, 1e-6)


def test_neighbours_are_reported_with_noise():
    known, believed, truth, _visible = _detect_cup(
        FaultProfile(detection_noise=(0.02, 0.05), seed=3)
    )
    errors = [math.dist(believed[n].position[:2], truth[n].position[:2]) for n in known]
    assert all(e > 1e-6 for e in errors) and all(e < 0.15 for e in errors)
