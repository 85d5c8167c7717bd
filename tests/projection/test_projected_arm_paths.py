"""Projection's arm motions follow the simulated controller's path (issue 26): a projected
``moving-tcp`` or ``moving-arm-joints`` whose path would sweep a free object it does not own
is a predicted failure (the world unchanged); with ``World.arm_motion_planning`` the path
is planned around the object; the projected duration is the path's."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest

import cpl
from executive import ManipulationGoalInCollision, Pose, a, knowledge, perform
from kitchens import iai as kitchen
from projection import World, with_projected_robot
from projection._durations import motion_seconds, robot_state
from projection._objects import object_type
from robots.pr2 import STANDARD_TO_TOOL as PR2_TOOL

SINK_NAV = Pose.from_xyz_yaw(0.75, 0.70, 0.0, 0.0)
#: Between the robot at SINK_NAV and the cup: the right arm's straight path from
#: ``carry`` to the cup's back pregrasp sweeps through a cereal box standing here.
IN_THE_SWEEP = Pose((1.25, 0.7, 0.995))


@pytest.fixture()
def sink() -> Iterator[World]:
    with World(seed=0) as world:
        world.park_arms("carry")
        world.drive(SINK_NAV)
        top = world.link_aabb(kitchen.SINK_SURFACE)[1][2]
        world.spawn_object("cup-1", "cup", Pose((1.3, 0.6, top + object_type("cup").size[2] / 2)))
        yield world


def _pregrasp(world: World) -> Pose:
    cup = world.object_pose("cup-1", "base_footprint").to_transform("cup-1")
    return knowledge.grasp_poses("cup", "back", cup, PR2_TOOL)[0]


def _state(world: World) -> tuple[object, ...]:
    def r(values: Any) -> tuple[float, ...]:
        return tuple(round(float(v), 6) for v in values)

    poses = [world.robot_pose()] + [world.object_pose(n) for n in world.objects]
    return (
        r([world.torso_height, *world.arm_joints("left"), *world.arm_joints("right")]),
        tuple(r([*p.position, *p.orientation]) for p in poses),
        tuple(sorted(world.attachments.items())),
    )


def _run(mrun: Any, world: World, motion: Any) -> float:
    """Perform ``motion`` in projection; the projected seconds it took."""

    async def main() -> float:
        async with with_projected_robot(world):
            start = cpl.current_time()
            await perform(motion)
            return cpl.current_time() - start

    return float(mrun(main))


def _pregrasp_joints(world: World) -> tuple[float, ...]:
    start = world.arm_joints("right")
    world.move_tcp(right=_pregrasp(world))
    goal = world.arm_joints("right")
    world.move_joints(right=start)
    return goal


def test_a_reach_whose_path_sweeps_a_neighbour_fails_and_moves_nothing(
    mrun: Any, sink: World
) -> None:
    # the controller without a planner (with one, the reach now goes around the box:
    # test_with_motion_planning_the_reach_goes_around_and_takes_its_path_time)
    sink.arm_motion_planning = False
    motion = a.motion(type="moving-tcp", right_pose=_pregrasp(sink))
    # the path is clear without the box: the reach is projected and moves the arm
    clear = _state(sink)
    _run(mrun, sink, motion)
    assert _state(sink) != clear
    sink.park_arms("carry")
    sink.spawn_object("cereal-9", "breakfast-cereal", IN_THE_SWEEP)
    before = _state(sink)
    with pytest.raises(ManipulationGoalInCollision) as e:
        _run(mrun, sink, a.motion(type="moving-tcp", right_pose=_pregrasp(sink)))
    assert e.value.details["swept"] == ("cereal-9",)
    assert _state(sink) == before


def test_a_configuration_move_through_a_neighbour_fails_and_moves_nothing(
    mrun: Any, sink: World
) -> None:
    goal = _pregrasp_joints(sink)
    sink.spawn_object("cereal-9", "breakfast-cereal", IN_THE_SWEEP)
    # the routes the controller tries without a planner: each one is blocked here
    sink.spawn_object("cereal-8", "breakfast-cereal", Pose((1.05, 0.45, 0.995)))
    before = _state(sink)
    with pytest.raises(ManipulationGoalInCollision) as e:
        _run(mrun, sink, a.motion(type="moving-arm-joints", right_joint_states=goal))
    assert "cereal-9" in e.value.details["swept"]
    assert _state(sink) == before


def test_with_motion_planning_the_reach_goes_around_and_takes_its_path_time(
    mrun: Any, sink: World
) -> None:
    from projection._swept_motions import arm_motion_sweep

    # the torso at the height the reach's IK picks (the controller reroutes only a
    # reach that keeps its torso), the arm at carry
    carry = sink.arm_joints("right")
    sink.move_tcp(right=_pregrasp(sink))
    sink.move_joints(right=carry)
    sink.spawn_object("cereal-9", "breakfast-cereal", IN_THE_SWEEP)
    sink.arm_motion_planning = True
    torso, start = sink.torso_height, {a_: sink.arm_joints(a_) for a_ in sink.arms}
    before = robot_state(sink)
    seconds = _run(mrun, sink, a.motion(type="moving-tcp", right_pose=_pregrasp(sink)))
    assert sink.motion_planning_fallbacks == 0
    assert sink.object_pose("cereal-9").position == pytest.approx(IN_THE_SWEEP.position)
    straight = motion_seconds(before, robot_state(sink))
    # the planned detour, timed as the real arm module times it: longer than straight
    hits_before = sink.sweep_memo.hits
    reach = {"right": _pregrasp(sink), "collision_mode": None}  # as the motion's
    sweep = arm_motion_sweep(sink, "move-tcp", ["right"], reach, torso, start)
    assert sink.sweep_memo.hits == hits_before + 1  # the executed motion's answer
    assert sweep.swept == () and sweep.waypoints > 2
    assert seconds == pytest.approx(sweep.seconds)
    assert seconds > straight
