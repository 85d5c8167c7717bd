"""The fast paths of ``World.move_tcp``: the per-world IK memo and the reach pre-check
must never change an answer, only its cost."""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterator

import numpy as np
import pybullet as pb
import pytest

from executive import knowledge
from executive._pose import Pose
from executive.failures import ManipulationPoseUnreachable
from projection import World
from robots.pr2 import STANDARD_TO_TOOL as PR2_TOOL

SINK_NAV = Pose.from_xyz_yaw(0.75, 0.70, 0.0, 0.0)
DOWN = (0.0, 0.7071068, 0.0, 0.7071068)  # tool x pointing down
FORWARD = (0.0, 0.0, 0.0, 1.0)
#: base_footprint targets around and beyond the right arm's workspace
GRID = [
    Pose((x, y, z), q, frame="base_footprint")
    for x, y, z, q in itertools.product(
        (0.3, 0.6, 0.95), (-0.5, -0.15, 0.3), (0.75, 1.05, 1.45), (FORWARD, DOWN)
    )
]


@pytest.fixture()
def sink() -> Iterator[World]:
    with World(seed=0) as w:
        w.drive(SINK_NAV)
        yield w


def _tool_error(world: World, arm: str, goal: Pose) -> tuple[float, float]:
    tool = world.link_pose(f"{arm[0]}_gripper_tool_frame")
    goal_map = world.robot_pose().to_transform("base_footprint") * goal
    return tool.distance_to(goal_map), tool.angle_to(goal_map)


def _verdicts(world: World) -> list[tuple[bool, float, tuple[float, ...]]]:
    out = []
    start = world.snapshot()
    for goal in GRID:
        try:
            world.move_tcp(right=goal)
            out.append((True, world.torso_height, world.arm_joints("right")))
        except ManipulationPoseUnreachable:
            assert world.snapshot() == start
            out.append((False, world.torso_height, world.arm_joints("right")))
        world.restore(start)
    return out


def test_verdicts_are_the_same_with_and_without_the_cache(sink: World) -> None:
    with World(seed=0) as plain:
        plain.drive(SINK_NAV)
        plain.ik_cache_size = 0
        expected = _verdicts(plain)
        assert len(plain._ik_cache) == 0
    cold = _verdicts(sink)
    warm = _verdicts(sink)
    assert sink.ik_cache_stats["hits"] > 0
    assert 0 < sum(ok for ok, *_ in expected) < len(GRID)  # the grid is not one-sided
    for e, c, w in zip(expected, cold, warm):
        assert e[0] == c[0] == w[0]
        assert e[1] == pytest.approx(c[1]) and e[1] == pytest.approx(w[1])
        assert e[2] == pytest.approx(c[2], abs=1e-5) and c[2] == pytest.approx(w[2], abs=1e-5)


def test_a_cached_solution_is_fk_verified_when_applied(sink: World) -> None:
    goal = Pose((0.6, -0.2, 0.95), frame="base_footprint")
    start = sink.snapshot()
    sink.move_tcp(right=goal)
    assert max(_tool_error(sink, "right", goal)) < 0.01
    sink.restore(start)
    # poison every cached answer: a hit must be rejected by FK and solved afresh
    for key, q in list(sink._ik_cache.items()):
        if q is not None:
            sink._ik_cache[key] = tuple(v + 0.3 for v in q)
    misses = sink.ik_cache_stats["misses"]
    sink.move_tcp(right=goal)
    dist, angle = _tool_error(sink, "right", goal)
    assert dist < 0.01 and angle < 0.1
    assert sink.ik_cache_stats["misses"] > misses
    # a target within the key's rounding: the hit is checked against the exact target
    sink.restore(start)
    near = Pose((0.6 + 4e-5, -0.2, 0.95), frame="base_footprint")
    sink.move_tcp(right=near)
    assert _tool_error(sink, "right", near)[0] < 0.01


def test_the_same_goal_at_another_torso_height_shares_the_entry(sink: World) -> None:
    goal = Pose((0.6, -0.2, 0.95), frame="base_footprint")
    start = sink.snapshot()
    sink.move_tcp(right=goal)
    q0, h0 = sink.arm_joints("right"), sink.torso_height
    sink.restore(start)
    sink.move_torso(h0 + 0.05)
    hits = sink.ik_cache_stats["hits"]
    sink.move_tcp(right=Pose((0.6, -0.2, 0.95 + 0.05), frame="base_footprint"))
    assert sink.ik_cache_stats["hits"] == hits + 1
    assert sink.arm_joints("right") == pytest.approx(q0, abs=1e-9)


def test_reach_precheck_never_rejects_a_reachable_target(sink: World) -> None:
    rng = np.random.default_rng(7)
    saved = sink._get_joints(sink._dofs)
    rejected = 0
    for _ in range(160):
        arm = ("left", "right")[int(rng.integers(2))]
        pos_b = tuple(float(v) for v in rng.uniform((-0.2, -1.0, 0.3), (1.1, 1.0, 1.9)))
        yaw, pitch = rng.uniform(-math.pi, math.pi), rng.uniform(-1.5, 1.5)
        orn_b = tuple(pb.getQuaternionFromEuler((0.0, pitch, yaw)))
        h = float(rng.choice([0.0, 0.15, 0.33]))
        local = sink._in_base(*sink._to_map(Pose(pos_b, orn_b, "base_footprint")))
        wrist = _wrist(local)
        if sink._in_reach(arm, wrist, h):
            continue
        rejected += 1
        sink._set_joints([sink._torso], [h])
        pos, orn = sink._to_map(Pose(pos_b, orn_b, "base_footprint"))
        assert sink._solve_arm(arm, pos, orn, saved) is None, (arm, pos_b, orn_b, h)
    sink._set_joints(sink._dofs, saved)
    assert rejected > 20


def _wrist(local: tuple[tuple[float, ...], tuple[float, ...]]) -> tuple[float, float, float]:
    from projection._world_ik import _wrist_point

    return _wrist_point(*local)


def test_precheck_accepts_what_the_solver_reaches(sink: World) -> None:
    obj = Pose((0.55, -0.1, 0.93), frame="base_footprint").to_transform("cup")
    for g in knowledge.grasps("cup"):
        for wp in knowledge.grasp_poses("cup", g, obj, PR2_TOOL):
            start = sink.snapshot()
            try:
                sink.move_tcp(right=wp)
            except ManipulationPoseUnreachable:
                continue
            finally:
                sink.restore(start)
            local = sink._in_base(*sink._to_map(wp))
            assert sink._in_reach("right", _wrist(local), sink.torso_height)


def test_unreachable_leaves_the_robot_unchanged_cold_and_cached(sink: World) -> None:
    sink.move_tcp(right=Pose((0.6, -0.2, 0.95), frame="base_footprint"))
    before = sink.snapshot()
    bad = Pose((0.3, -0.15, 1.45), DOWN, frame="base_footprint")
    for _ in range(2):  # cold, then from the memo
        with pytest.raises(ManipulationPoseUnreachable):
            sink.move_tcp(right=bad)
        assert sink.snapshot() == before
    with pytest.raises(ManipulationPoseUnreachable):  # left fine, right out of reach
        sink.move_tcp(
            left=Pose((0.55, 0.2, 1.0), frame="base_footprint"),
            right=Pose((0.2, -1.5, 0.3), frame="base_footprint"),
        )
    assert sink.snapshot() == before


def test_the_cache_is_bounded_and_per_world(sink: World) -> None:
    sink.ik_cache_size = 3
    start = sink.snapshot()
    for z in (0.9, 0.95, 1.0, 1.05, 1.1):
        sink.move_tcp(right=Pose((0.6, -0.2, z), frame="base_footprint"))
        sink.restore(start)
    assert len(sink._ik_cache) <= 3
    with World(seed=0) as other:
        assert len(other._ik_cache) == 0
    sink.clear_ik_cache()
    assert len(sink._ik_cache) == 0
