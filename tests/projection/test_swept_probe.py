"""The arm probe checks the path the real controller sweeps between waypoints, not the
waypoints alone (issue 13: reaches from ``carry`` to a pregrasp swept through the
neighbours and toppled or pushed them)."""

from __future__ import annotations

import math
from collections.abc import Iterator

import pytest

import cpl
from cpl.testing import MockClock
from executive import ManipulationGoalInCollision, Pose, a, knowledge, perform
from projection import FaultProfile, ProjectedWorldModel, World, make_world_pair, with_real_robot
from robots.pr2 import DESCRIPTION as PR2
from robots.pr2 import STANDARD_TO_TOOL as PR2_TOOL

SINK_NAV = Pose.from_xyz_yaw(0.75, 0.70, 0.0, 0.0)
CUP = "cup-1"
NEIGHBOUR = "cereal-9"
#: On the sink counter between the robot and the cup: the right arm's straight path from
#: ``carry`` to the cup's back pregrasp sweeps through a cereal box standing here, while
#: neither the pregrasp nor any later waypoint of that grasp touches it.
IN_THE_SWEEP = Pose((1.25, 0.7, 0.995))


@pytest.fixture()
def pair() -> Iterator[tuple[World, World]]:
    true, belief = make_world_pair(0, belief_objects="exact")
    try:
        for world in (true, belief):
            world.park_arms("carry")
        yield true, belief
    finally:
        true.close()
        belief.close()


def _add_neighbour(*worlds: World) -> None:
    for world in worlds:
        world.spawn_object(NEIGHBOUR, "breakfast-cereal", IN_THE_SWEEP)


def _back_grasp(world: World) -> list[Pose]:
    cup = world.object_pose(CUP, "base_footprint").to_transform(CUP)
    return knowledge.grasp_poses("cup", "back", cup, PR2_TOOL)


def _state(world: World) -> tuple[object, ...]:
    def r(values: object) -> tuple[float, ...]:
        return tuple(round(float(v), 6) for v in values)  # type: ignore[attr-defined]

    poses = [world.robot_pose()] + [world.object_pose(n) for n in world.objects]
    return (
        r([world.torso_height, *world.arm_joints("left"), *world.arm_joints("right")]),
        tuple(r([*p.position, *p.orientation]) for p in poses),
    )


def test_a_reach_sweeping_through_a_neighbour_is_rejected(pair: tuple[World, World]) -> None:
    _true, belief = pair
    belief.drive(SINK_NAV)
    _add_neighbour(belief)
    poses = _back_grasp(belief)
    before = _state(belief)
    at_waypoints = ProjectedWorldModel(belief, swept=False)
    assert at_waypoints.probe_arm_trajectory("right", poses, allowed_contacts=[CUP]).ok
    result = ProjectedWorldModel(belief).probe_arm_trajectory(
        "right", poses, allowed_contacts=[CUP]
    )
    assert not result.ok
    assert isinstance(result.failure, ManipulationGoalInCollision)
    assert result.index == 0  # on its way from carry to the pregrasp
    assert result.failure.details["swept"] == (NEIGHBOUR,)
    assert "sweeps through cereal-9" in str(result.failure)
    assert _state(belief) == before  # the world is restored
    # an allowed contact is not a sweep failure
    assert (
        ProjectedWorldModel(belief)
        .probe_arm_trajectory("right", poses, allowed_contacts=[CUP, NEIGHBOUR])
        .ok
    )


def test_without_the_neighbour_the_same_reach_passes(pair: tuple[World, World]) -> None:
    _true, belief = pair
    belief.drive(SINK_NAV)
    assert (
        ProjectedWorldModel(belief)
        .probe_arm_trajectory("right", _back_grasp(belief), allowed_contacts=[CUP])
        .ok
    )


@pytest.mark.parametrize("planning", [False, True], ids=["router", "planned"])
def test_the_rejected_reach_really_pushes_the_neighbour(
    pair: tuple[World, World], planning: bool
) -> None:
    """The truth behind the check: the real arm of the old controller (motion planning
    off), sent along that reach anyway, moves the box (its rerouting finds no clear way
    around it); with OMPL planning the reach (a free motion, the default) it goes around
    the box, which stays put."""
    true, belief = pair
    true.arm_motion_planning = planning
    _add_neighbour(true, belief)
    start = true.object_pose(NEIGHBOUR)

    async def main() -> None:
        async with with_real_robot(true, belief, FaultProfile.none(), rules=None):
            await perform(a.motion(type="going", pose=SINK_NAV))
            for pose in _back_grasp(belief)[:2]:
                await perform(a.motion(type="moving-tcp", right_pose=pose))

    cpl.run(main, clock=MockClock())
    moved = math.dist(true.object_pose(NEIGHBOUR).position, start.position)
    assert (moved < 0.005) if planning else (moved > 0.01)


def test_swept_must_be_a_bool(pair: tuple[World, World]) -> None:
    with pytest.raises(TypeError, match="swept must be True or False"):
        ProjectedWorldModel(pair[1], swept="yes")  # type: ignore[arg-type]


# ------------------------------------------------------------------ configuration moves
CARRY = {a: PR2.arm(a).state("carry") for a in ("left", "right")}


def _hand_around_the_cup(world: World) -> None:
    """The right hand at the cup's back grasp pose, the gripper open (a failed grip that
    did not back out): a park from here sweeps the hand through the cup."""
    world.drive(SINK_NAV)
    world.gripper(0.09, "right")
    for pose in _back_grasp(world)[:3]:
        world.move_tcp(right=pose)


def test_a_park_sweeping_through_an_object_is_rejected(pair: tuple[World, World]) -> None:
    _true, belief = pair
    _hand_around_the_cup(belief)
    model = ProjectedWorldModel(belief)
    before = _state(belief)
    result = model.probe_arm_configuration(left=CARRY["left"], right=CARRY["right"])
    assert not result.ok
    assert isinstance(result.failure, ManipulationGoalInCollision)
    assert result.failure.details["swept"] == (CUP,)
    assert _state(belief) == before
    assert model.probe_arm_configuration(left=CARRY["left"]).ok  # the left arm is clear
    assert model.probe_arm_configuration(**CARRY, allowed_contacts=[CUP]).ok
    assert model.probe_arm_configuration().ok  # nothing moves
    with pytest.raises(ValueError, match="7 joint values"):
        model.probe_arm_configuration(left=(0.0,))
    with pytest.raises(TypeError, match="not one string"):
        model.probe_arm_configuration(**CARRY, allowed_contacts=CUP)


def test_the_rejected_park_really_pushes_the_object(pair: tuple[World, World]) -> None:
    true, belief = pair
    start = true.object_pose(CUP)

    async def main() -> None:
        async with with_real_robot(true, belief, FaultProfile.none(), rules=None):
            await perform(a.motion(type="going", pose=SINK_NAV))
            await perform(a.motion(type="moving-gripper-joint", gripper="right", joint_angle=0.09))
            for pose in _back_grasp(belief)[:3]:
                await perform(a.motion(type="moving-tcp", right_pose=pose))
            assert math.dist(true.object_pose(CUP).position, start.position) < 0.01
            await perform(
                a.motion(
                    type="moving-arm-joints",
                    left_joint_states=CARRY["left"],
                    right_joint_states=CARRY["right"],
                )
            )

    cpl.run(main, clock=MockClock())
    assert math.dist(true.object_pose(CUP).position, start.position) > 0.01


# ------------------------------------------------ putting down against a neighbour (issue 26)
def _holding_the_cup(belief: World) -> None:
    """The right hand holds the cup by its back grasp, lifted, from ``SINK_NAV``."""
    belief.drive(SINK_NAV)
    poses = _back_grasp(belief)
    for pose in poses[:3]:
        belief.move_tcp(right=pose)
    belief.attach(CUP, PR2.arm("right").hand_link)
    belief.move_tcp(right=poses[3])


def _put_down_at(y: float) -> list[Pose]:
    """Above, then down at a spot of the sink counter ``y`` to the robot's left (the
    tool's pose: the cup stands 2 cm in front of it)."""
    return [
        Pose((0.67, y, 1.081), frame="base_footprint"),
        Pose((0.67, y, 0.931), frame="base_footprint"),
    ]


def test_putting_down_pressed_into_a_neighbour_is_rejected(pair: tuple[World, World]) -> None:
    """The put waypoint is not checked for collisions (the object touches its support
    there), but the cup it presses into the bowl (seed 1's cereal against the bowl,
    knocked three times) is a collision all the same: the probe names the bowl."""
    _true, belief = pair
    _holding_the_cup(belief)
    before = _state(belief)
    world = ProjectedWorldModel(belief)
    # 9 cm beside the bowl's centre: the cup's side presses into the bowl's rim
    result = world.probe_arm_trajectory(
        "right", _put_down_at(0.19), allowed_contacts=[CUP], check_collisions=[True, False]
    )
    assert not result.ok and result.index == 1
    assert isinstance(result.failure, ManipulationGoalInCollision)
    assert "touches bowl-1" in str(result.failure)
    assert _state(belief) == before
    # 3 cm farther away the same put down is clear
    assert world.probe_arm_trajectory(
        "right", _put_down_at(0.22), allowed_contacts=[CUP], check_collisions=[True, False]
    ).ok
