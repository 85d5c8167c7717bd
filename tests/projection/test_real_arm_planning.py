"""The simulated real robot plans its free arm motions with OMPL (issue 26): on by
default, planned in the belief world around the objects it knows (the held object riding
in the hand), followed in time along the planned trajectory; contact motions stay on the
straight tool line."""

from __future__ import annotations

import asyncio
import itertools
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest

import cpl
from cpl.testing import MockClock
from executive import Pose, a, knowledge, perform
from executive.failures import ManipulationGoalInCollision
from kitchens import iai as kitchen
from projection import FaultProfile, World, make_world_pair, with_real_robot
from projection._arm_planner import (
    _planner,
    controller_trajectory,
    is_free_motion,
    nearest_turn,
    swept_objects,
)
from projection._objects import object_type
from projection._real_body import CONTROL_PERIOD
from robots.pr2 import STANDARD_TO_TOOL as PR2_TOOL

SINK_NAV = Pose.from_xyz_yaw(0.75, 0.70, 0.0, 0.0)
TOOL = "r_gripper_tool_frame"
#: Between the robot at SINK_NAV and the cup: the right arm's straight joint-space line
#: from ``carry`` to the cup's back pregrasp sweeps through a cereal box here.
IN_THE_SWEEP = Pose((1.25, 0.7, 0.995))

Recorded = list[tuple[float, tuple[float, ...], tuple[float, ...]]]


def _setup(world: World, held: bool) -> None:
    world.park_arms("carry")
    world.drive(SINK_NAV)
    top = world.link_aabb(kitchen.SINK_SURFACE)[1][2]
    world.spawn_object(
        "cup-1", "cup", Pose((1.3, 0.6, top + object_type("cup").size[2] / 2 + 1e-3))
    )
    world.spawn_object("cereal-9", "breakfast-cereal", IN_THE_SWEEP)
    if held:
        world.spawn_object("held", "spoon", world.link_pose(TOOL), allow_overlap=True)
        world.attach("held", TOOL)


@pytest.fixture(params=[False, True], ids=["empty-hand", "holding"])
def scene(request: pytest.FixtureRequest) -> Iterator[tuple[World, World]]:
    """The true world and the belief, both with the robot at the sink counter (arms at
    carry), a cup and the cereal box in the right arm's straight sweep; with a spoon in
    the right hand or not."""
    true, belief = make_world_pair(0, objects={})
    try:
        for w in (true, belief):
            _setup(w, request.param)
        yield true, belief
    finally:
        true.close()
        belief.close()


def _pregrasp(world: World) -> tuple[Pose, tuple[float, ...], Pose]:
    """The cup's back pregrasp and grasp tool poses (base_footprint) and the right arm's
    configuration at the pregrasp (the arm is put back)."""
    start = world.arm_joints("right")
    cup = world.object_pose("cup-1", "base_footprint").to_transform("cup-1")
    poses = knowledge.grasp_poses("cup", "back", cup, PR2_TOOL)
    world.move_tcp(right=poses[0])
    goal = world.arm_joints("right")
    world.move_joints(right=start)
    return poses[0], goal, poses[-1]


def _record(monkeypatch: pytest.MonkeyPatch, world: World) -> Recorded:
    """(loop time, right arm joints, tool position) after every ``move_joints`` of the
    true robot while a loop runs."""
    out: Recorded = []
    move = world.move_joints

    def recording(**kw: Any) -> None:
        move(**kw)
        try:
            t = asyncio.get_running_loop().time()
        except RuntimeError:
            return
        out.append((t, world.arm_joints("right"), world.link_pose(TOOL).position))

    monkeypatch.setattr(world, "move_joints", recording)
    return out


def _run(true: World, belief: World, *motions: Any) -> list[float]:
    """Perform the motions on the real robot; the loop time before each and at the end."""

    async def main() -> list[float]:
        times = []
        async with with_real_robot(true, belief, FaultProfile.none(), rules=None):
            for m in motions:
                times.append(asyncio.get_running_loop().time())
                await perform(m)
            times.append(asyncio.get_running_loop().time())
        return times

    return list(cpl.run(main, clock=MockClock()))


def test_arm_motion_planning_is_on_by_default() -> None:
    with World(seed=0) as world:
        assert world.arm_motion_planning is True
        assert world.motion_planning_fallbacks == 0


def test_which_motions_are_free(scene: tuple[World, World]) -> None:
    """Free (planned): a configuration move, a reach without a collision mode; straight:
    a motion with a collision mode (grasping, lifting, putting), and one whose gripper
    starts at a free object (the retract from an object just released)."""
    true, _belief = scene
    assert is_free_motion(true, "move-joints", ["right"], {"right": (0.0,) * 7})
    assert is_free_motion(true, "move-tcp", ["right"], {"collision_mode": None})
    for mode in ("allow-all", "allow-hand"):
        assert not is_free_motion(true, "move-tcp", ["right"], {"collision_mode": mode})
    _pre, _goal, grasp = _pregrasp(true)
    true.move_tcp(right=grasp)  # the gripper around the cup
    assert not is_free_motion(true, "move-tcp", ["right"], {"collision_mode": None})


def test_a_free_motion_goes_around_what_the_straight_line_sweeps(
    scene: tuple[World, World], monkeypatch: pytest.MonkeyPatch
) -> None:
    """carry -> the cup's pregrasp: the straight joint line sweeps the arm through the
    cereal box; the real robot's path, planned in its belief (with the spoon it holds
    attached to the hand), goes around it and follows the planned trajectory in time:
    the joints it passes through are the trajectory's at those times, and the motion
    takes the trajectory's duration (within a control period). The true cereal box does
    not move."""
    true, belief = scene
    start = true.arm_joints("right")
    torso = true.torso_height
    _pre, goal, _grasp = _pregrasp(true)
    straight = [(torso, {"right": start}), (torso, {"right": goal})]
    assert swept_objects(true, straight, {"cereal-9"}) == {"cereal-9"}
    true.move_joints(right=start)
    held_before = dict(true.attachments)
    cereal = true.object_pose("cereal-9")
    # what the robot will follow: the belief's planner (deterministic, seeded)
    planner = _planner(belief, "right")
    planner.sync(belief)
    expected = planner.plan(start, goal, seed=1, allowed_contacts=frozenset())
    assert expected.planned
    recorded = _record(monkeypatch, true)
    t0, t1 = _run(true, belief, a.motion(type="moving-arm-joints", right_joint_states=goal))
    moving = [(t, q, p) for t, q, p in recorded if t0 < t <= t1]
    assert len(moving) >= expected.duration / CONTROL_PERIOD - 1
    for t, q, _p in moving:
        want = expected.at(t - t0)
        assert nearest_turn(true, "right", q, want) == pytest.approx(want, abs=1e-6)
    assert t1 - t0 == pytest.approx(expected.duration, abs=CONTROL_PERIOD)
    # the same pose (a continuous joint reads back wrapped into [-pi, pi))
    assert nearest_turn(true, "right", true.arm_joints("right"), goal) == pytest.approx(
        goal, abs=1e-9
    )
    assert true.motion_planning_fallbacks == 0
    # went around: nothing along the followed path touches the box, which stayed put
    path = [(torso, {"right": q}) for _t, q, _p in moving]
    assert swept_objects(true, path, {"cereal-9"}) == set()
    assert true.object_pose("cereal-9").isclose(cereal, 1e-3, 1e-2)
    assert dict(true.attachments) == held_before
    assert dict(belief.attachments) == held_before


@pytest.fixture()
def empty_hand() -> Iterator[tuple[World, World]]:
    true, belief = make_world_pair(0, objects={})
    try:
        for w in (true, belief):
            _setup(w, held=False)
        yield true, belief
    finally:
        true.close()
        belief.close()


def test_a_pregrasp_to_grasp_line_stays_straight(
    empty_hand: tuple[World, World], monkeypatch: pytest.MonkeyPatch
) -> None:
    """The reach to the pregrasp (no collision mode) is planned; the grasping motion
    (``allow-all``) from there follows the straight tool line into the cup."""
    true, belief = empty_hand
    pre, _goal, grasp = _pregrasp(true)
    recorded = _record(monkeypatch, true)
    _t0, t1, t2 = _run(
        true,
        belief,
        a.motion(type="moving-tcp", right_pose=pre),
        a.motion(type="moving-tcp", right_pose=grasp, collision_mode="allow-all"),
    )
    robot = true.robot_pose().to_transform("base_footprint")
    p0 = np.array((robot * pre).position)
    p1 = np.array((robot * grasp).position)
    line = (p1 - p0) / np.linalg.norm(p1 - p0)
    tool = [np.array(p) for t, _q, p in recorded if t1 < t <= t2]
    assert len(tool) >= 3
    for p in tool:
        off = (p - p0) - float(np.dot(p - p0, line)) * line
        assert float(np.linalg.norm(off)) < 0.01, p
    assert np.linalg.norm(tool[-1] - p1) < 0.01
    assert true.motion_planning_fallbacks == 0


def test_the_timed_path_of_a_straight_move_is_at_joint_speed(scene: tuple[World, World]) -> None:
    """Without planning (the flag off), the controller's path is timed at the joint
    velocity limit, segment by segment, as before."""
    true, belief = scene
    true.arm_motion_planning = False
    start = {"right": true.arm_joints("right")}
    torso = true.torso_height
    _pre, goal, _grasp = _pregrasp(true)
    true.move_joints(right=goal)
    timed = controller_trajectory(true, "move-joints", ["right"], {}, torso, start, belief)
    assert not timed.planned
    legs = [
        max(abs(q - p) for p, q in zip(u[1]["right"], v[1]["right"]))
        for u, v in itertools.pairwise(timed.configs)
    ]
    assert timed.duration == pytest.approx(sum(legs))
    assert true.arm_joints("right") == pytest.approx(start["right"])


@pytest.mark.parametrize("believed", [False, True], ids=["unrecognised", "misplaced"])
def test_an_object_where_the_belief_does_not_have_it_is_an_obstacle_too(
    empty_hand: tuple[World, World], believed: bool
) -> None:
    """A cup right where the plan in the belief alone would move the hand, that the
    belief lacks (perception never reported it) or places far away: the real robot's
    plan still goes around it (the stand-in for the depth camera's occupancy map), and
    the cup stays where it is. The belief is left as it was."""
    true, belief = empty_hand
    elsewhere = Pose((-1.0, 0.0, 0.05))  # behind the robot, out of the arm's reach
    if believed:
        belief.spawn_object("cup-9", "cup", elsewhere)
    start = true.arm_joints("right")
    torso = true.torso_height
    _pre, goal, _grasp = _pregrasp(true)
    planner = _planner(belief, "right")
    planner.sync(belief)
    alone = [tuple(float(v) for v in q) for q in planner.plan(start, goal, seed=1).positions]
    true.move_joints(right=alone[len(alone) // 2])
    true.spawn_object("cup-9", "cup", Pose(true.link_pose(TOOL).position), allow_overlap=True)
    path = [(torso, {"right": q}) for q in alone]
    assert swept_objects(true, path, {"cup-9"}) == {"cup-9"}
    true.move_joints(right=start)
    cup = true.object_pose("cup-9")
    _run(true, belief, a.motion(type="moving-arm-joints", right_joint_states=goal))
    # the same pose (a continuous joint reads back wrapped into [-pi, pi))
    assert nearest_turn(true, "right", true.arm_joints("right"), goal) == pytest.approx(
        goal, abs=1e-9
    )
    assert true.motion_planning_fallbacks == 0
    assert true.object_pose("cup-9").isclose(cup, 1e-3, 1e-2)
    if believed:
        assert belief.object_pose("cup-9").isclose(elsewhere, 1e-9, 1e-9)
    else:
        assert "cup-9" not in belief.objects
    assert "cup-9~seen" not in belief.objects


def _swept(failure: BaseException | None) -> object:
    assert isinstance(failure, ManipulationGoalInCollision)
    return failure.details.get("swept")


def test_the_probe_checks_the_path_the_robot_plans_for_a_free_reach(
    scene: tuple[World, World],
) -> None:
    """carry -> the cup's pregrasp, whose straight tool line sweeps the arm through the
    cereal box: probed as a free reach (collision mode None, as plans.checks passes it),
    the probe checks the path the real robot plans around the box and accepts it; as a
    contact motion (straight) or with the mode unknown, it refuses it. The real robot
    then goes around: the true box does not move."""
    from projection import ProjectedWorldModel

    true, belief = scene
    pre, _goal, _grasp = _pregrasp(true)
    probe = ProjectedWorldModel(belief)
    unknown = probe.probe_arm_trajectory("right", [pre])
    assert not unknown.ok and _swept(unknown.failure) == ("cereal-9",)
    contact = probe.probe_arm_trajectory("right", [pre], collision_modes=["allow-all"])
    assert not contact.ok and _swept(contact.failure) == ("cereal-9",)
    free = probe.probe_arm_trajectory("right", [pre], collision_modes=[None])
    assert free.ok, free.failure
    with pytest.raises(ValueError, match="one mode"):
        probe.probe_arm_trajectory("right", [pre], collision_modes=[None, None])
    cereal = true.object_pose("cereal-9")
    _run(true, belief, a.motion(type="moving-tcp", right_pose=pre))
    assert true.motion_planning_fallbacks == 0
    assert true.object_pose("cereal-9").isclose(cereal, 1e-3, 1e-2)
