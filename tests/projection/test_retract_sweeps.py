"""The retract after placing does not knock a neighbour (issue 26, knocks at 0 % faults).

The situation is the one seed 12 (without projection) met: the robot has just put a
cereal box down on the island next to a cup and opened its right gripper; the retract (a
``moving-tcp`` without a collision mode, the fingers still at the box: the straight tool
line) has an IK step across the wrap of the forearm roll (IK reported the continuous joint
4.6 rad away between two 2 cm steps of the line). No configuration of the line touches
the cup, but the arm turned the long way between those two, through it: the cup was
knocked over. The line now turns the forearm the short way."""

from __future__ import annotations

import asyncio
import itertools
import math
from collections.abc import Iterator

import pytest

import cpl
from cpl.testing import MockClock
from executive import Pose, a, perform
from projection import FaultProfile, World, with_real_robot
from projection._arm_planner import cartesian_path, swept_objects, touched_objects
from tests.staged_worlds import staged_pair

BASE = Pose((-0.12, 0.88, 0.0), (0.0, 0.0, -0.99818179, 0.06027528))
TORSO = 0.33
ARMS = {
    "left": (0.22, 1.294, 1.566, -2.321, -2.37, -0.284, 0.282),
    # where the put ended: the fingers around the box just released
    "right": (-0.57708, -0.13854, -2.04382, -1.50030, -2.67552, -2.07825, -1.04287),
}
#: (type, true pose, believed pose): the belief has each a few millimetres off
OBJECTS: dict[str, tuple[str, Pose, Pose]] = {
    "breakfast-cereal-1": (
        "breakfast-cereal",
        Pose((-0.77994, 1.24422, 0.99494), (0.0, 0.0, 0.82944, 0.55860)),
        Pose((-0.77995, 1.25000, 0.99494), (0.0, 0.0, 0.83205, 0.55470)),
    ),
    "cup-1": (
        "cup",
        Pose((-0.71745, 1.06365, 0.90099), (0.0, 0.0, 0.52872, 0.84879)),
        Pose((-0.71998, 1.07996, 0.90055), (0.0, 0.0, 0.55479, 0.83199)),
    ),
    "bowl-1": (
        "bowl",
        Pose((-0.68578, 0.77501, 0.87849), (0.0, 0.0, 0.08873, 0.99606)),
        Pose((-0.68007, 0.76003, 0.87800), (0.0, 0.0, 0.08485, 0.99639)),
    ),
}
#: the index of the forearm roll (continuous) among the arm's joints
FOREARM = 4
#: the placing's retract pose (base_footprint)
RETRACT = Pose((0.565, -0.272, 1.035), (0.0, 0.0, -0.604, 0.797), "base_footprint")


@pytest.fixture()
def placed() -> Iterator[tuple[World, World]]:
    """The true world and the belief, the robot's right gripper open at the box it has
    just put down, the cup next to it."""
    with staged_pair(BASE, TORSO, ARMS, OBJECTS, open_grippers=("right",)) as worlds:
        yield worlds


def test_the_retract_line_turns_the_forearm_the_short_way_across_its_wrap(
    placed: tuple[World, World],
) -> None:
    """The situation is real: two IK steps of the straight tool line lie on either side of
    the forearm roll's wrap (IK, wrapping the continuous joint into [-pi, pi], reports
    them more than pi apart: seed 12 turned the arm that way, through the cup). The line
    unwraps each step to the previous one's turn: the forearm turns the short way between
    any two of its configurations, and the line sweeps nothing."""
    true, _belief = placed
    start: dict[str, tuple[float, ...]] = {"right": ARMS["right"]}
    true.move_tcp(right=RETRACT)
    goal = (true.torso_height, {"right": true.arm_joints("right")})
    true.move_joints(**start)
    line = cartesian_path(true, ["right"], {"right": RETRACT}, (TORSO, start), goal)
    assert len(line) > 2
    wrapped = [(c["right"][FOREARM] + math.pi) % (2 * math.pi) - math.pi for _t, c in line]
    assert max(abs(b - a) for a, b in itertools.pairwise(wrapped)) > math.pi
    # the forearm turns the short way (the step across the wrap: 1.7 rad, not 4.6; that
    # step lands on another branch of the arm's solutions, the shoulder moves too)
    steps = [
        abs(v[1]["right"][FOREARM] - u[1]["right"][FOREARM]) for u, v in itertools.pairwise(line)
    ]
    assert max(steps) < math.pi, steps
    touching = set()
    for t, config in line[1:-1]:
        true.move_torso(t)
        true.move_joints(**config)
        touching |= touched_objects(true, {"cup-1"})
    assert touching == set()
    assert swept_objects(true, line, {"cup-1"}) == set()


def test_the_retract_after_placing_does_not_knock_the_neighbour(
    placed: tuple[World, World],
) -> None:
    """On the simulated real robot, the retract goes around the cup (the line is
    rerouted because a segment between its steps sweeps it): on the true world neither
    the cup nor the box just placed moves, and the tool ends at the retract pose."""
    true, belief = placed
    before = {n: true.object_pose(n) for n in OBJECTS}

    async def main() -> None:
        async with asyncio.timeout(600):  # simulated seconds: the retract takes ~5
            async with with_real_robot(true, belief, FaultProfile.none(), rules=None):
                await perform(a.motion(type="moving-tcp", right_pose=RETRACT))

    cpl.run(main, clock=MockClock())
    for name, pose in before.items():
        assert true.object_pose(name).isclose(pose, 2e-3, 2e-2), name
    tool = true.link_pose(true.robot.arm("right").tool_frame)
    goal = true.robot_pose().to_transform("base_footprint") * RETRACT
    assert tool.distance_to(goal) < 0.01
    assert tool.angle_to(goal) < 0.1
