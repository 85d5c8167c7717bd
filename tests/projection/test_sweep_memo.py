"""What an arm motion sweeps (``projection._swept_motions.arm_motion_sweep``), remembered
per world (``World.sweep_memo``): a hit gives the same answer, a change of what the path
depends on misses; and the straight tool line of a reach is checked once (the reroute's
own pass over it is skipped where the answer is known from the line alone)."""

from __future__ import annotations

import itertools
from collections.abc import Iterator
from typing import Any

import pytest

from executive import Pose, knowledge
from kitchens import iai as kitchen
from projection import World
from projection import _arm_planner as arm_planner
from projection import _swept_motions as swept_motions
from projection._motion_memo import Sweep, SweepMemo
from projection._objects import object_type
from robots.pr2 import STANDARD_TO_TOOL as PR2_TOOL

SINK_NAV = Pose.from_xyz_yaw(0.75, 0.70, 0.0, 0.0)
#: On the right arm's straight tool line from ``carry`` to the cup's back pregrasp.
IN_THE_SWEEP = Pose((1.25, 0.7, 0.995))


@pytest.fixture()
def sink() -> Iterator[World]:
    """The robot at the sink, the right arm at carry with the torso at the height the
    reach to the cup's pregrasp keeps (the controller reroutes only such a reach), the
    planner off (the router's path: the answer needs no OMPL)."""
    with World(seed=0) as world:
        world.arm_motion_planning = False
        world.park_arms("carry")
        world.drive(SINK_NAV)
        top = world.link_aabb(kitchen.SINK_SURFACE)[1][2]
        world.spawn_object("cup-1", "cup", Pose((1.3, 0.6, top + object_type("cup").size[2] / 2)))
        carry = world.arm_joints("right")
        world.move_tcp(right=_pregrasp(world))
        world.move_joints(right=carry)
        yield world


def _pregrasp(world: World) -> Pose:
    cup = world.object_pose("cup-1", "base_footprint").to_transform("cup-1")
    return knowledge.grasp_poses("cup", "back", cup, PR2_TOOL)[0]


def _lifted(world: World, dz: float = 0.1) -> Pose:
    """The cup's pregrasp ``dz`` higher (base_footprint)."""
    pre = _pregrasp(world)
    return Pose((*pre.position[:2], pre.position[2] + dz), pre.orientation, pre.frame)


def _reach(world: World, goal: Pose | None = None) -> tuple[Sweep, list[Any], set[str]]:
    """The sweep of the right arm's ``move-tcp`` to ``goal`` (default: the cup's
    pregrasp) from where the arm is, and the reference answer: the controller's path
    (computed in full) and what it sweeps. The arm is left at its start."""
    torso = world.torso_height
    start = {a: world.arm_joints(a) for a in world.arms}
    goal = _pregrasp(world) if goal is None else goal
    world.move_tcp(right=goal)
    sweep = swept_motions.arm_motion_sweep(
        world, "move-tcp", ["right"], {"right": goal}, torso, start
    )
    path = arm_planner.controller_path(world, "move-tcp", ["right"], {"right": goal}, torso, start)
    free = {n for n in world.objects if n not in world.attachments}
    world.move_torso(path[0][0])
    world.move_joints(**path[0][1])
    others = free - arm_planner.touched_objects(world, free)
    world.move_torso(path[-1][0])
    world.move_joints(**path[-1][1])
    others -= arm_planner.touched_objects(world, others)
    hits = arm_planner.swept_objects(world, path, others)
    world.move_torso(torso)
    world.move_joints(right=start["right"])
    return sweep, path, hits


def test_a_hit_is_the_same_answer_and_a_moved_object_misses(sink: World) -> None:
    sink.spawn_object("cereal-9", "breakfast-cereal", IN_THE_SWEEP)
    memo = sink.sweep_memo
    first, _path, hits = _reach(sink)
    assert first.swept == ("cereal-9",) == tuple(sorted(hits))
    assert (memo.hits, memo.misses) == (0, 1)
    again, _path, _hits = _reach(sink)
    assert again is first
    assert (memo.hits, memo.misses) == (1, 1)
    # the box moved out of the way: another world, computed afresh, and clear
    sink.set_object_pose("cereal-9", Pose((1.25, 1.4, 0.995)))
    moved, _path, _hits = _reach(sink)
    assert (memo.hits, memo.misses) == (1, 2)
    assert moved.swept == ()
    # a change below the memo's rounding (0.1 mm) is the same world
    sink.set_object_pose("cereal-9", Pose((1.25, 1.40004, 0.995)))
    assert _reach(sink)[0] is moved
    # the planner switched on: another answer's key
    sink.arm_motion_planning = True
    _reach(sink)
    assert memo.misses == 3


def test_a_clear_tool_line_is_checked_once_with_the_controllers_answer(
    sink: World, monkeypatch: pytest.MonkeyPatch
) -> None:
    # a box within the arm's reach, beside the lift from the cup's pregrasp
    sink.spawn_object("cereal-9", "breakfast-cereal", Pose((1.3, 0.95, 0.995)))
    sink.move_tcp(right=_pregrasp(sink))
    reroutes: list[int] = []
    real = arm_planner.reroute_cartesian

    def counting(*args: Any, **kwargs: Any) -> Any:
        reroutes.append(1)
        return real(*args, **kwargs)

    # the sweep's module resolves controller_path's reroute through _arm_planner
    monkeypatch.setattr(arm_planner, "reroute_cartesian", counting)
    sweep, path, hits = _reach(sink, _lifted(sink))
    assert len(reroutes) == 1  # the reference path only: the sweep skipped its reroute
    assert sweep.swept == () and not hits
    assert sweep.waypoints == len(path) > 2  # the tool line, as the controller follows it
    assert sweep.seconds is not None  # computed: something was within reach
    seconds = sum(arm_planner.leg_seconds(u, v) for u, v in itertools.pairwise(path))
    assert sweep.seconds == pytest.approx(seconds)


def test_a_tool_line_that_sweeps_something_takes_the_controllers_whole_path(
    sink: World, monkeypatch: pytest.MonkeyPatch
) -> None:
    sink.spawn_object("cereal-9", "breakfast-cereal", IN_THE_SWEEP)
    reroutes: list[int] = []
    real = arm_planner.reroute_cartesian

    def counting(*args: Any, **kwargs: Any) -> Any:
        reroutes.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(arm_planner, "reroute_cartesian", counting)
    sweep, path, hits = _reach(sink)
    assert len(reroutes) == 2  # the sweep's controller path and the reference
    assert sweep.swept == tuple(sorted(hits)) == ("cereal-9",)
    assert sweep.waypoints == len(path)


def test_the_memo_is_bounded_least_recently_used_first() -> None:
    memo = SweepMemo(size=2)
    a, b, c = Sweep((), 1.0, 2), Sweep(("x",), 2.0, 3), Sweep((), None, 2)
    memo.put(("a",), a)
    memo.put(("b",), b)
    assert memo.get(("a",)) is a  # now the most recently used
    memo.put(("c",), c)
    assert len(memo) == 2
    assert memo.get(("b",)) is None
    assert memo.get(("a",)) is a and memo.get(("c",)) is c
    assert (memo.hits, memo.misses) == (3, 1)
    for bad in (0, -1, True, 1.5):
        with pytest.raises(ValueError, match="at least 1 entry"):
            SweepMemo(size=bad)  # type: ignore[arg-type]
