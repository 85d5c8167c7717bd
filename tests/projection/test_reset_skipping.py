"""``World._set_joints`` skips the joint resets that change nothing, and only those: the
joints end where they were set, at rest, and the physics that follows is the same bit for
bit as when every reset runs (Bullet's broadphase remembers the history of AABB updates;
see the docstring of ``_set_joints`` for why these skips leave it unchanged)."""

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


def _counting(monkeypatch: pytest.MonkeyPatch) -> list[tuple[Any, ...]]:
    calls: list[tuple[Any, ...]] = []
    real = pb.resetJointState

    def reset(*args: Any, **kw: Any) -> None:
        calls.append(args)
        real(*args, **kw)

    monkeypatch.setattr(pb, "resetJointState", reset)
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


def test_only_the_resets_that_change_nothing_are_skipped(
    world: World, monkeypatch: pytest.MonkeyPatch
) -> None:
    dofs = list(world._dofs)
    now = list(world._get_joints(dofs))
    calls = _counting(monkeypatch)
    world._set_joints(dofs, now)
    assert len(calls) == 1  # the block's first reset always runs
    calls.clear()
    world._set_joints(dofs, now, refreshed=True)
    assert calls == []  # after a reset of the same body, none needs to
    moved = list(now)
    moved[5] += 0.1
    moved[9] -= 0.1
    world._set_joints(dofs, moved)
    assert [a[1] for a in calls] == [dofs[0], dofs[5], dofs[9]]
    calls.clear()
    world._set_joints([dofs[2], dofs[2]], [now[2], now[2]])  # repeated: nothing skipped
    assert len(calls) == 2
    calls.clear()
    nan = list(moved)
    nan[1] = math.nan
    world._set_joints(dofs[:3], nan[:3], refreshed=True)
    assert [a[1] for a in calls] == [dofs[1]]  # NaN never equals: reset, as before


def _plain_set_joints(world: World, indices: Any, values: Any, body: Any = None, **_: Any) -> None:
    """Every reset, as before the skipping."""
    b = world.robot_body if body is None else body
    for i, v in zip(indices, values):
        pb.resetJointState(b, i, v, 0.0, physicsClientId=world.client)


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


def _batched_set_joints(
    world: World, indices: Any, values: Any, body: Any = None, **_: Any
) -> None:
    """One command for the block: the same joint states, a different AABB history."""
    b = world.robot_body if body is None else body
    pb.resetJointStatesMultiDof(
        b, list(indices), [[v] for v in values], physicsClientId=world.client
    )


def test_skipping_leaves_the_physics_bit_for_bit_the_same(monkeypatch: pytest.MonkeyPatch) -> None:
    with World(seed=0) as fast:
        skipped = _scenario(fast)
    with monkeypatch.context() as m:
        m.setattr(World, "_set_joints", _plain_set_joints)
        with World(seed=0) as plain:
            every = _scenario(plain)
    assert skipped == every  # exact equality: floats compared bit for bit (no tolerance)
    # the scenario does see the broadphase's history: one batched reset per block (the
    # same joint states after every block) changes where the objects end up
    with monkeypatch.context() as m:
        m.setattr(World, "_set_joints", _batched_set_joints)
        with World(seed=0) as batched:
            assert _scenario(batched) != every
