"""``World._set_joints`` resets a block of joints with one ``resetJointStatesMultiDof``:
the joints end where they were set, at rest; collision checks see the new link poses; and
the physics that follows is a pure function of the calls (runs are reproducible)."""

from __future__ import annotations

import math
from collections.abc import Iterator
from typing import Any

import pybullet as pb
import pytest

from executive import Pose
from projection import World
from projection._real_body import _Body
from projection._real_faults import FaultProfile


@pytest.fixture
def world() -> Iterator[World]:
    w = World(seed=0)
    yield w
    w.close()


def _counting(monkeypatch: pytest.MonkeyPatch, name: str) -> list[tuple[Any, ...]]:
    calls: list[tuple[Any, ...]] = []
    real = getattr(pb, name)

    def reset(*args: Any, **kw: Any) -> None:
        calls.append(args)
        real(*args, **kw)

    monkeypatch.setattr(pb, name, reset)
    return calls


def test_the_joints_end_where_they_were_set_and_at_rest(world: World) -> None:
    dofs = list(world._dofs)
    c, robot = world.client, world.robot_body
    # a joint at the right place but moving must still be reset (its velocity changes)
    pb.resetJointState(robot, dofs[3], 0.2, 0.7, physicsClientId=c)
    # -0.0 and 0.0 compare equal but are not the same state
    pb.resetJointState(robot, dofs[4], -0.0, 0.0, physicsClientId=c)
    values = [s[0] for s in pb.getJointStates(robot, dofs, physicsClientId=c)]
    values[3], values[4] = 0.2, 0.0
    world._set_joints(dofs, values)
    states = pb.getJointStates(robot, dofs, physicsClientId=c)
    assert [s[0] for s in states] == values
    assert all(s[1] == 0.0 for s in states)
    assert math.copysign(1.0, states[4][0]) == 1.0


def test_a_block_is_one_command_and_a_single_joint_one_reset(
    world: World, monkeypatch: pytest.MonkeyPatch
) -> None:
    dofs = list(world._dofs)
    now = list(world._get_joints(dofs))
    many = _counting(monkeypatch, "resetJointStatesMultiDof")
    one = _counting(monkeypatch, "resetJointState")
    moved = list(now)
    moved[5] += 0.1
    world._set_joints(dofs, moved)
    assert len(many) == 1 and one == []
    world._set_joints([dofs[5]], [now[5]])
    assert len(many) == 1 and len(one) == 1
    world._set_joints([], [])
    assert len(many) == 1 and len(one) == 1
    assert list(world._get_joints(dofs)) == now


def test_repeated_indices_the_last_value_wins(world: World) -> None:
    j = world._dofs[2]
    world._set_joints([j, j], [0.1, 0.2])
    assert world._get_joints([j]) == (0.2,)


def test_collision_checks_see_the_new_link_poses(world: World) -> None:
    """An object put where the left gripper goes only after the block reset touches it."""
    world._reset_base(0.75, 0.7, 0.0)
    arm = list(world._arm_joints["left"])
    start = list(world._get_joints(arm))
    goal = [v + 0.4 * (1 if j % 2 else -1) for j, v in enumerate(start)]
    world._set_joints(arm, goal)
    tool = world.link_pose("l_gripper_tool_frame").position
    world._set_joints(arm, start)
    world.spawn_object("cup", "cup", Pose(tool), allow_overlap=True)
    c, cup = world.client, world.body_of("cup")
    pb.performCollisionDetection(physicsClientId=c)
    assert not pb.getContactPoints(world.robot_body, cup, physicsClientId=c)
    world._set_joints(arm, goal)
    pb.performCollisionDetection(physicsClientId=c)
    assert pb.getContactPoints(world.robot_body, cup, physicsClientId=c)


def _scenario(world: World) -> list[Any]:
    """Objects resting on the island and one falling onto it while the robot's arm moves
    through them, with snapshots, restores and mostly no-op joint resets in between (what
    the real robot's control steps do), then physics. Returns every object's pose and
    velocity and the contacts after each round."""
    world._reset_base(0.75, 0.7, 0.0)
    body = _Body(world, world, FaultProfile.none())
    arm = list(world._arm_joints["left"])
    start = list(world._get_joints(arm))

    def arm_at(k: int) -> list[float]:
        return [v + 0.08 * k * (1 if j % 2 else -1) for j, v in enumerate(start)]

    world._set_joints(arm, arm_at(6))  # the objects stand where the gripper will pass
    tool = world.link_pose("l_gripper_tool_frame").position
    world._set_joints(arm, start)
    world.spawn_object("cup", "cup", Pose((tool[0], tool[1], tool[2] - 0.05)), allow_overlap=True)
    world.spawn_object("bowl", "bowl", Pose((1.4, 0.9, 0.95)), allow_overlap=True)
    world.spawn_object("milk", "milk", Pose((tool[0] + 0.1, tool[1], 1.2)), allow_overlap=True)
    out: list[Any] = []
    for k in range(12):
        q = arm_at(k)
        world._set_joints(arm, q)
        world._set_joints(world._dofs, world._get_joints(world._dofs))  # no-ops
        snap = world.snapshot()
        world.restore(snap)
        body._simulate(24)
        c = world.client
        for name in ("cup", "bowl", "milk"):
            b = world.body_of(name)
            out.append(pb.getBasePositionAndOrientation(b, physicsClientId=c))
            out.append(pb.getBaseVelocity(b, physicsClientId=c))
        out.append(
            [(p[1], p[2], p[3], p[4], p[8], p[9]) for p in pb.getContactPoints(physicsClientId=c)]
        )
    return out


def test_the_physics_after_block_resets_is_reproducible() -> None:
    with World(seed=0) as first:
        once = _scenario(first)
    with World(seed=0) as second:
        again = _scenario(second)
    assert once == again  # exact equality: floats compared bit for bit (no tolerance)
    assert any(v != (0.0, 0.0, 0.0) for pair in once[1::7] for v in pair)  # things moved
