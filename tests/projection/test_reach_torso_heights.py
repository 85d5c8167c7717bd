"""A free reach whose plan fails at the torso height its IK chose is planned at another
height, not sent along the controller's fallback line (issue 26, knocks at 0 % faults).

The situation is the one seed 14 (with projection) met: the robot stands at the sink
counter, torso at 0.15 m, arms at carry, and reaches for the pregrasp above a bowl (a top
grasp); a cereal box stands between, 1.3 cm nearer in the true world than in the belief.
At 0.15 m the pregrasp lies in a pocket past the box that no plan reaches within its
budget; the fallback (the straight tool line) grazed the true box and pushed it 2.4 cm."""

from __future__ import annotations

import asyncio
from collections.abc import Iterator

import pytest

import cpl
from cpl.testing import MockClock
from executive import Pose, a, perform
from projection import FaultProfile, World, with_real_robot
from projection._arm_planner import _plan_arms
from tests.staged_worlds import staged_pair

BASE = Pose((0.72, 0.72, 0.0), (0.0, 0.0, 0.08965822, 0.99597259))
TORSO = 0.15
ARMS: dict[str, tuple[float, ...]] = {
    "left": (0.22, 1.294, 1.566, -2.321, -2.37, -0.284, 0.282),
    "right": (-0.16, 1.018, -1.309, -2.22, 1.187, -0.059, -0.594),
}
#: (type, true pose, believed pose or None: the belief lacks it)
OBJECTS: dict[str, tuple[str, Pose, Pose | None]] = {
    "bowl-1": (
        "bowl",
        Pose((1.36, 0.84, 0.87847), (0.0, 0.0, 0.86231, 0.50639)),
        Pose((1.35615, 0.84398, 0.87847), (0.0, 0.0, 0.86112, 0.5084)),
    ),
    "breakfast-cereal-1": (
        "breakfast-cereal",
        Pose((1.28, 0.55999, 0.99499), (0.0, 0.0, 0.42952, 0.90306)),
        Pose((1.29125, 0.56577, 0.99499), (0.0, 0.0, 0.43412, 0.90085)),
    ),
    "cup-1": (
        "cup",
        Pose((1.19999, 0.35998, 0.90098), (0.0, 0.0, -0.42305, 0.9061)),
        Pose((1.20463, 0.35321, 0.90098), (0.0, 0.0, -0.42372, 0.90579)),
    ),
    "milk-1": ("milk", Pose((1.43999, 0.44001, 0.94999), (0.0, 0.0, 0.90498, 0.42546)), None),
}
#: the bowl's top pregrasp (base_footprint)
PREGRASP = Pose((0.648, 0.078, 1.088), (0.707, 0.0, -0.707, 0.0), "base_footprint")


@pytest.fixture()
def counter() -> Iterator[tuple[World, World]]:
    with staged_pair(BASE, TORSO, ARMS, OBJECTS, open_grippers=ARMS) as worlds:
        yield worlds


def test_at_the_torso_height_the_ik_chose_no_plan_reaches_the_pregrasp(
    counter: tuple[World, World],
) -> None:
    """The situation is real: planned at 0.15 m (in the belief, the true objects as
    obstacles too) the reach has no path."""
    true, belief = counter
    true.move_tcp(right=PREGRASP)
    assert true.torso_height == pytest.approx(TORSO)
    goal = {"right": true.arm_joints("right")}
    true.move_joints(right=ARMS["right"])
    assert _plan_arms(true, belief, ["right"], dict(ARMS), goal, TORSO, count=False) is None


def test_the_reach_is_planned_at_another_torso_height_and_knocks_nothing(
    counter: tuple[World, World],
) -> None:
    """On the simulated real robot the reach raises the torso and follows a planned
    path: the tool ends at the pregrasp, nothing falls back to the controller's line,
    and no object moves on the true world."""
    true, belief = counter
    before = {n: true.object_pose(n) for n in OBJECTS}

    async def main() -> None:
        async with asyncio.timeout(600):  # simulated seconds: the reach takes a few
            async with with_real_robot(true, belief, FaultProfile.none(), rules=None):
                await perform(a.motion(type="moving-tcp", right_pose=PREGRASP))

    cpl.run(main, clock=MockClock())
    for name, pose in before.items():
        assert true.object_pose(name).isclose(pose, 2e-3, 2e-2), name
    assert true.motion_planning_fallbacks == 0
    assert true.torso_height > TORSO + 0.05
    tool = true.link_pose(true.robot.arm("right").tool_frame)
    goal = true.robot_pose().to_transform("base_footprint") * PREGRASP
    assert tool.distance_to(goal) < 0.01
    assert tool.angle_to(goal) < 0.1
