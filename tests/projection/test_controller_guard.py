"""The simulated real controller never pushes an arm through an object it sees (issue 26,
knocks at 0 % faults): ``projection._arm_planner.guard_path``.

Two situations staged from the campaign's runs on ``451dc8a`` at 0 % faults with
projection, where the belief had a neighbour about a centimetre off and the arm knocked it:

- seed 18: the left arm's straight retract after placing the cup passed 11.6 mm through
  the bowl (the bowl moved 1.7 cm). It now stops before the bowl and reports the goal
  not reached (the placing ignores that, logged and counted).
- seed 44: a reach whose plan failed (its goal grazes the real milk) fell back to the
  straight tool line, which pushed the forearm 13 mm through the milk. It is now refused
  before anything moves, with the failure an unreachable pose gives.

Each test also shows the old path would have touched the neighbour, so it can fail."""

from __future__ import annotations

import asyncio
from collections.abc import Iterator, Mapping

import pytest

import cpl
from cpl.testing import MockClock
from executive import Pose, a, perform
from executive.failures import ManipulationGoalNotReached, ManipulationPoseUnreachable
from projection import FaultProfile, World, with_real_robot
from projection._arm_planner import cartesian_path, swept_objects
from tests.staged_worlds import staged_pair

PARK_LEFT = (0.22, 1.294, 1.566, -2.321, -2.37, -0.284, 0.282)
PARK_RIGHT = (-0.16, 1.018, -1.309, -2.22, 1.187, -0.059, -0.594)


def _pose(xyz: tuple[float, float, float], quat: tuple[float, float, float, float]) -> Pose:
    return Pose(xyz, quat)


# ------------------------------------------------------------------ seed 18: the retract
RETRACT_BASE = Pose((-0.12, 0.96, 0.0), (0.0, 0.0, 0.99618863, 0.08722511))
RETRACT_ARMS = {
    # where the put ended: the left fingers open around the cup just released
    "left": (0.34108, 0.25469, 1.74771, -0.99538, -0.26997, -0.64980, -1.08967),
    "right": PARK_RIGHT,
}
RETRACT = Pose((0.65421, 0.12484, 0.92996), (0.0, 0.0, -0.60022, 0.79984), "base_footprint")
#: (type, true pose, believed pose), as the run had them
RETRACT_OBJECTS: dict[str, tuple[str, Pose, Pose]] = {
    "bowl-1": (
        "bowl",
        _pose((-0.71592, 0.75104, 0.87848), (0.0, 0.0, -0.77044, 0.63751)),
        _pose((-0.72007, 0.76006, 0.87800), (0.0, 0.0, -0.76698, 0.64167)),
    ),
    "cup-1": (
        "cup",
        _pose((-0.79378, 1.09270, 0.90048), (0.0, 0.0, -0.67875, 0.73437)),
        _pose((-0.79993, 1.08000, 0.90054), (0.0, 0.0, -0.66768, 0.74445)),
    ),
}

# ----------------------------------------------------------------- seed 44: the reach
REACH_BASE = Pose((0.64, 0.32, 0.0), (0.0, 0.0, 0.35499768, 0.93486718))
REACH_ARMS = {
    "left": PARK_LEFT,
    "right": (-0.76097, 0.04571, -1.64627, -1.74016, 2.40691, -0.10629, -0.89129),
}
REACH = Pose((0.60138, -0.12504, 0.93097), (0.0, 0.0, 0.43500, 0.90043), "base_footprint")
REACH_OBJECTS: dict[str, tuple[str, Pose, Pose]] = {
    "cup-1": (
        "cup",
        _pose((1.16005, 0.75999, 0.90099), (0.0, 0.0, -0.68879, 0.72496)),
        _pose((1.16563, 0.75545, 0.90099), (0.0, 0.0, -0.68736, 0.72632)),
    ),
    "milk-1": (
        "milk",
        _pose((1.28000, 0.32000, 0.94999), (0.0, 0.0, 0.99532, 0.09665)),
        _pose((1.28751, 0.32321, 0.94999), (0.0, 0.0, 0.99777, 0.06668)),
    ),
    "breakfast-cereal-1": (
        "breakfast-cereal",
        _pose((1.43999, 0.52000, 0.99499), (0.0, 0.0, 0.87279, -0.48809)),
        _pose((1.44271, 0.51871, 0.99499), (0.0, 0.0, 0.88227, -0.47074)),
    ),
}


@pytest.fixture()
def released() -> Iterator[tuple[World, World]]:
    with staged_pair(
        RETRACT_BASE, 0.33, RETRACT_ARMS, RETRACT_OBJECTS, open_grippers=("left", "right")
    ) as worlds:
        yield worlds


@pytest.fixture()
def reaching() -> Iterator[tuple[World, World]]:
    with staged_pair(
        REACH_BASE, 0.33, REACH_ARMS, REACH_OBJECTS, open_grippers=("left", "right")
    ) as worlds:
        yield worlds


def _poses(world: World) -> dict[str, Pose]:
    return {n: world.object_pose(n) for n in world.objects}


def _unmoved(world: World, before: Mapping[str, Pose]) -> None:
    for name, pose in before.items():
        assert world.object_pose(name).isclose(pose, 2e-3, 2e-2), name


def _line_sweeps(world: World, arm: str, goal: Pose, name: str) -> bool:
    """Whether the straight tool line from here to ``goal`` touches ``name`` (the path
    the controller took before the guard); the robot is put back."""
    snap = world.snapshot()
    try:
        start = {arm: world.arm_joints(arm)}
        torso = world.torso_height
        world.move_tcp(**{arm: goal})
        last = (world.torso_height, {arm: world.arm_joints(arm)})
        world.move_torso(torso)
        world.move_joints(**start)
        line = cartesian_path(world, [arm], {arm: goal}, (torso, start), last)
        return name in swept_objects(world, line, {name})
    finally:
        world.restore(snap)


def _perform(true: World, belief: World, **pose: Pose) -> None:
    async def main() -> None:
        async with asyncio.timeout(600):  # simulated seconds: a motion takes a few
            async with with_real_robot(true, belief, FaultProfile.none(), rules=None):
                await perform(a.motion(type="moving-tcp", **pose))

    cpl.run(main, clock=MockClock())


def test_the_retract_stops_before_the_neighbour_it_would_push(
    released: tuple[World, World],
) -> None:
    true, belief = released
    assert _line_sweeps(true, "left", RETRACT, "bowl-1")  # the old path touched the bowl
    before = _poses(true)
    start = true.arm_joints("left")
    with pytest.raises(ManipulationGoalNotReached, match="stopped before its goal"):
        _perform(true, belief, left_pose=RETRACT)
    _unmoved(true, before)
    assert true.motions_truncated == 1
    assert true.motions_refused == 0
    # the arm moved away from the cup, but stopped short of the retract pose
    assert max(abs(p - q) for p, q in zip(true.arm_joints("left"), start)) > 0.01
    tool = true.link_pose(true.robot.arm("left").tool_frame)
    goal = true.robot_pose().to_transform("base_footprint") * RETRACT
    assert tool.distance_to(goal) > 0.01


def test_the_retract_that_sweeps_nothing_reaches_its_goal(
    released: tuple[World, World],
) -> None:
    """Without the bowl in its way, the same retract goes all the way (nothing counted)."""
    true, belief = released
    for world in (true, belief):
        world.remove_object("bowl-1")
    _perform(true, belief, left_pose=RETRACT)
    tool = true.link_pose(true.robot.arm("left").tool_frame)
    goal = true.robot_pose().to_transform("base_footprint") * RETRACT
    assert tool.distance_to(goal) < 0.01
    assert true.motions_truncated == 0


def test_a_reach_that_would_sweep_a_seen_object_is_refused_before_moving(
    reaching: tuple[World, World],
) -> None:
    true, belief = reaching
    assert _line_sweeps(true, "right", REACH, "milk-1")  # the fallback touched the milk
    before = _poses(true)
    arms = {arm: true.arm_joints(arm) for arm in true.arms}
    torso = true.torso_height
    with pytest.raises(ManipulationPoseUnreachable, match="sweeps through milk-1") as info:
        _perform(true, belief, right_pose=REACH)
    assert info.value.details["swept"] == ("milk-1",)
    assert true.motions_refused == 1
    assert true.motion_planning_fallbacks >= 1  # the plan failed first
    # nothing moved: neither an object nor the robot
    _unmoved(true, before)
    assert true.torso_height == pytest.approx(torso, abs=1e-9)
    for arm, q in arms.items():
        assert true.arm_joints(arm) == pytest.approx(q, abs=1e-6), arm


def test_the_old_controller_still_pushes_what_it_meets(
    reaching: tuple[World, World],
) -> None:
    """With arm motion planning off (the old controller, no collision checks), the same
    reach is not refused: the guard belongs to the collision-aware controller."""
    true, belief = reaching
    true.arm_motion_planning = False
    _perform(true, belief, right_pose=REACH)
    assert true.motions_refused == 0


def test_a_graze_shallower_than_the_guard_depth_passes(
    reaching: tuple[World, World], monkeypatch: pytest.MonkeyPatch
) -> None:
    """The reach above presses 13 mm into the milk: with a guard depth deeper than that,
    the controller lets it go (and the milk is pushed), so the depth is what decides."""
    true, belief = reaching
    monkeypatch.setattr("projection._arm_planner.GUARD_DEPTH", 0.05)
    _perform(true, belief, right_pose=REACH)
    assert true.motions_refused == 0
