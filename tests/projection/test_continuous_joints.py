"""Continuous joints (the PR2's forearm and wrist roll, endless as on the real robot) are
turned the short way: IK wraps them into [-pi, pi], and the controller's straight tool
lines and the planner reach the turn of a goal nearest where the joint is (issue 26: seed
4 without projection rolled the forearm 5.8 rad holding a box and knocked the milk)."""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterator

import numpy as np
import pytest

from projection import World
from projection._arm_planner import cartesian_path, nearest_turn
from projection._motion_planner import ArmMotionPlanner
from robots.pr2 import ARM_JOINTS

RIGHT = [f"r_{j}" for j in ARM_JOINTS]
TOOL = "r_gripper_tool_frame"
WRIST = 6  # r_wrist_roll_joint, continuous


@pytest.fixture()
def world() -> Iterator[World]:
    with World(seed=0) as w:
        w.park_arms("carry")
        yield w


def _wrist_past_the_wrap(world: World) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """A start with the wrist roll at 2.9 rad and the same arm with it at 3.5 rad, as IK
    reports it: wrapped to 3.5 - 2 pi."""
    q = world.arm_joints("right")
    return (*q[:WRIST], 2.9), (*q[:WRIST], 3.5 - 2.0 * math.pi)


def test_the_pr2_roll_joints_are_continuous(world: World) -> None:
    limits = dict((j, (lo, hi)) for j, lo, hi in world.arm_joint_limits("right"))
    for joint in ("r_forearm_roll_joint", "r_wrist_roll_joint"):
        assert limits[joint] == (-math.inf, math.inf)
    assert math.isfinite(limits["r_elbow_flex_joint"][0])
    start, wrapped = _wrist_past_the_wrap(world)
    assert nearest_turn(world, "right", wrapped, start)[WRIST] == pytest.approx(3.5)
    assert nearest_turn(world, "right", wrapped, start)[:WRIST] == wrapped[:WRIST]


def test_a_straight_tool_line_never_turns_a_wrapped_joint_the_long_way(world: World) -> None:
    """The tool rolls 0.6 rad about its axis across the wrap: every step of the line (IK
    at small steps, each wrapped into [-pi, pi]) and the goal as IK gave it are unwrapped
    to the previous step's turn, so no joint moves more than a few tenths of a radian
    between two configurations of the path."""
    start, wrapped = _wrist_past_the_wrap(world)
    world.move_joints(right=wrapped)
    goal = world.link_pose(TOOL)
    world.move_joints(right=start)
    torso = world.torso_height
    path = cartesian_path(
        world, ["right"], {"right": goal}, (torso, {"right": start}), (torso, {"right": wrapped})
    )
    assert len(path) > 3  # IK along the line, not the straight joint-space fallback
    steps = [
        max(abs(a - b) for a, b in zip(u[1]["right"], v[1]["right"]))
        for u, v in itertools.pairwise(path)
    ]
    assert max(steps) < 0.5, steps
    end = path[-1][1]["right"]
    assert end[WRIST] == pytest.approx(3.5)  # the goal's pose, one turn up
    world.move_joints(right=end)
    assert world.link_pose(TOOL).distance_to(goal) < 1e-6


def test_the_planner_reaches_the_nearest_turn_of_a_continuous_goal(world: World) -> None:
    start, wrapped = _wrist_past_the_wrap(world)
    touch = [n for n in world.link_names if n.startswith("r_gripper")]
    planner = ArmMotionPlanner.for_world(world, RIGHT, TOOL, touch)
    try:
        t = planner.plan(start, wrapped, seed=1)
        assert t.positions[-1][WRIST] == pytest.approx(3.5)
        travel = np.abs(np.diff(t.positions[:, WRIST])).sum()
        assert travel == pytest.approx(0.6, abs=1e-6)  # not 2 pi - 0.6
    finally:
        planner.close()


def test_a_continuous_joint_takes_any_value_and_reads_back_wrapped(world: World) -> None:
    q = world.arm_joints("right")
    world.move_joints(right=(*q[:WRIST], 3.5))
    assert world.arm_joints("right")[WRIST] == pytest.approx(3.5 - 2.0 * math.pi)
    with pytest.raises(ValueError, match="r_elbow_flex_joint"):
        world.move_joints(right=(*q[:3], 1.0, *q[4:]))
