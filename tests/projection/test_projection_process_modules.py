"""The six projection process modules and ``with_projected_robot`` on a real PyBullet world."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

import pytest

import cpl
import executive
from executive import (
    DesignatorError,
    GripperClosedCompletely,
    ManipulationGoalNotReached,
    ManipulationPoseUnreachable,
    NavigationPoseUnreachable,
    NoProcessModule,
    PerceptionObjectNotFound,
    PMStatus,
    Pose,
    PtuGoalNotReached,
    TorsoGoalNotReached,
    a,
    an,
    current_environment,
    knowledge,
    perform,
    pm_execute,
)
from executive.events import ObjectPerceived, subscribe
from projection import ProjectedWorldModel, World, with_projected_robot
from projection._process_modules import projection_process_modules
from robots.pr2 import DESCRIPTION as PR2
from robots.pr2 import STANDARD_TO_TOOL as PR2_TOOL

SINK_NAV = Pose.from_xyz_yaw(0.75, 0.70, 0.0, 0.0)
CUP_ON_COUNTER = Pose((1.3, 0.6, 0.9))
PM_NAMES = ["navigation", "torso", "ptu", "perception", "grippers", "arms"]


@pytest.fixture()
def world() -> Iterator[World]:
    with World(seed=0) as w:
        yield w


@pytest.fixture()
def sink(world: World) -> World:
    world.drive(SINK_NAV)
    world.spawn_object("cup-1", "cup", CUP_ON_COUNTER)
    return world


def run_projected(mrun: Any, world: World, body: Callable[[], Any], **kw: Any) -> Any:
    """Run ``body`` inside ``with_projected_robot(world)`` in a cpl run."""

    async def main() -> Any:
        async with with_projected_robot(world, **kw):
            return await body()

    return mrun(main, name="projected")


def tool_error(world: World, arm: str, goal: Pose) -> float:
    tool = world.link_pose(f"{arm[0]}_gripper_tool_frame", goal.frame)
    return tool.distance_to(goal)


# ------------------------------------------------------------------ dispatch
def test_the_repl_step_going(mrun: Any, world: World) -> None:
    pose = Pose.from_xyz_yaw(0.5, -0.2, 0.0, 0.4)

    async def main() -> None:
        async with with_projected_robot(world):
            await perform(a.motion(type="going", pose=pose))

    mrun(main, name="repl")
    assert world.robot_pose().isclose(pose, 1e-9, 1e-9)
    tree = cpl.task_tree("repl")
    assert tree is not None
    goal = tree.find("navigation")
    assert goal is not None and goal.kind == "task" and goal.succeeded
    assert goal.annotations["motion"].startswith("<a motion (type going)")


def test_going_to_a_location_designator_and_pm_execute(mrun: Any, world: World) -> None:
    async def body() -> None:
        await perform(a.motion(type="going", target=a.location(pose=Pose((0.4, 0.1, 0.0)))))
        assert world.robot_pose().position == pytest.approx((0.4, 0.1, 0.0))
        await pm_execute("navigation", a.motion(type="going", pose=Pose((0.2, 0.0, 0.0))))
        assert world.robot_pose().position == pytest.approx((0.2, 0.0, 0.0))

    run_projected(mrun, world, body)


def test_moving_torso(mrun: Any, world: World) -> None:
    async def body() -> None:
        await perform(a.motion(type="moving-torso", joint_angle=0.3))

    run_projected(mrun, world, body)
    assert world.torso_height == pytest.approx(0.3)


def test_looking_at_a_pose_a_frame_forward_and_joint_states(mrun: Any, sink: World) -> None:
    def head() -> tuple[float, float]:
        return sink.joint_position("head_pan_joint"), sink.joint_position("head_tilt_joint")

    async def body() -> None:
        await perform(a.motion(type="looking", pose=CUP_ON_COUNTER))
        pan, tilt = head()
        assert pan < -0.1 and tilt > 0.3  # the cup is right of and below the camera
        await perform(a.motion(type="looking", direction="forward"))
        assert head() == (0.0, 0.0)
        await perform(a.motion(type="looking", frame="sink_area_left_upper_drawer_handle"))
        assert head()[1] > 0.3
        await perform(a.motion(type="looking", joint_states=(0.3, 0.2)))
        assert head() == pytest.approx((0.3, 0.2))
        await perform(a.motion(type="looking", target=a.location(pose=Pose((2.0, 0.7, 1.42)))))
        assert abs(head()[0]) < 1e-6

    run_projected(mrun, sink, body)


def test_detecting_returns_a_new_designator_equated_to_the_input(mrun: Any, sink: World) -> None:
    perceived_events: list[Any] = []
    cup = an.object(type="cup", color="red")

    async def body() -> Any:
        subscribe(ObjectPerceived, perceived_events.append)
        await perform(a.motion(type="looking", pose=CUP_ON_COUNTER))
        return await perform(a.motion(type="detecting", object=cup))

    perceived = run_projected(mrun, sink, body)
    assert perceived is not cup and cup.current() is perceived
    assert [e.designator for e in perceived_events] == [perceived]
    text = repr(perceived)
    assert text.startswith("<an object (type cup) (name cup-1) (pose <Pose map (1.300 0.600 ")
    assert perceived["color"] == "red"
    data = perceived.reference()
    assert data.name == "cup-1" and data.type == "cup"
    assert data.pose == sink.object_pose("cup-1")
    assert data.transform.frame == "base_footprint" and data.transform.child_frame == "cup-1"
    assert data.transform.translation == pytest.approx((0.55, -0.1, 0.9), abs=1e-6)


@pytest.mark.parametrize(
    ("motion", "opening"),
    [
        (a.motion(type="closing-gripper", gripper="left"), 0.0),
        (a.motion(type="closing", gripper=("left", "right")), 0.0),
        (a.motion(type="moving-gripper-joint", gripper="left", joint_angle=0.04), 0.04),
    ],
)
def test_gripper_motions(mrun: Any, world: World, motion: Any, opening: float) -> None:
    async def body() -> None:
        await perform(motion)

    run_projected(mrun, world, body)
    assert world.gripper_opening("left") == pytest.approx(opening)


def test_opening_gripper_and_gripping_a_cup(mrun: Any, sink: World) -> None:
    obj = sink.object_pose("cup-1", "base_footprint").to_transform("cup-1")
    grasp = knowledge.grasp_poses("cup", "back", obj, PR2_TOOL)[2]

    async def body() -> None:
        await perform(a.motion(type="closing-gripper", gripper="right"))
        await perform(a.motion(type="opening", gripper="right"))
        assert sink.gripper_opening("right") == pytest.approx(0.1)
        # straight at the cup, its fingers around it: a grasping motion (contacts allowed)
        await perform(a.motion(type="moving-tcp", right_pose=grasp, collision_mode="allow-all"))
        await perform(a.motion(type="gripping", gripper="right", effort=50))

    run_projected(mrun, sink, body)
    assert 0.06 < sink.gripper_opening("right") < 0.085


def test_moving_tcp_and_arm_joints(mrun: Any, sink: World) -> None:
    left = Pose((0.55, 0.2, 1.0), frame="base_footprint")
    carry = PR2.arm("right").state("carry")

    async def body() -> None:
        await perform(a.motion(type="moving-tcp", left_pose=left))
        await perform(a.motion(type="moving-arm-joints", right_joint_states=carry))

    run_projected(mrun, sink, body)
    assert tool_error(sink, "left", left) < 0.01
    assert sink.arm_joints("right") == pytest.approx(carry)


def test_opening_without_a_gripper_is_not_for_the_grippers(mrun: Any, world: World) -> None:
    async def body() -> None:
        await perform(a.motion(type="opening"))

    # nothing accepts it, and it cannot resolve: the resolution error says what is missing
    with pytest.raises(DesignatorError, match="needs a gripper property"):
        run_projected(mrun, world, body)


# ------------------------------------------------------------------ failures
@pytest.mark.parametrize(
    ("motion", "failure", "module"),
    [
        (
            a.motion(type="going", pose=Pose((1.0, 0.7, 0.0))),
            NavigationPoseUnreachable,
            "navigation",
        ),
        (a.motion(type="moving-torso", joint_angle=0.5), TorsoGoalNotReached, "torso"),
        (
            a.motion(type="looking", pose=Pose((-1.0, 0.0, 1.2), frame="base_footprint")),
            PtuGoalNotReached,
            "ptu",
        ),
        (a.motion(type="looking", joint_states=(0.0, 2.0)), PtuGoalNotReached, "ptu"),
        (
            a.motion(type="detecting", object=an.object(type="bowl")),
            PerceptionObjectNotFound,
            "perception",
        ),
        (a.motion(type="gripping", gripper="left"), GripperClosedCompletely, "grippers"),
        (
            a.motion(type="moving-tcp", right_pose=Pose((1.8, 0.0, 1.0), frame="base_footprint")),
            ManipulationPoseUnreachable,
            "arms",
        ),
        (
            a.motion(type="moving-arm-joints", right_joint_states=(0.0,) * 3 + (1.0,) + (0.0,) * 3),
            ManipulationGoalNotReached,
            "arms",
        ),
    ],
    ids=lambda v: v.__name__ if isinstance(v, type) else None,
)
def test_failures_propagate_typed_and_leave_the_world(
    mrun: Any, sink: World, motion: Any, failure: type[Exception], module: str
) -> None:
    if motion.type == "gripping":
        sink.gripper("open", "left")  # grip on nothing closes the gripper: compare after
    before = sink.snapshot()
    statuses: dict[str, PMStatus] = {}

    async def main() -> None:
        async with with_projected_robot(sink) as env:
            try:
                await perform(motion)
            finally:
                pm = env.find_process_module(module)
                assert pm is not None
                statuses[module] = pm.status.value

    with pytest.raises(failure):
        mrun(main, name="failing")
    assert statuses == {module: PMStatus.FAILED}
    if motion.type == "gripping":
        sink.gripper("open", "left")
    assert sink.snapshot() == before


def test_driving_into_the_counter_keeps_the_robot(mrun: Any, sink: World) -> None:
    goal = Pose.from_xyz_yaw(1.0, 0.7, 0.0, 0.0)

    async def body() -> None:
        await perform(a.motion(type="going", pose=goal))

    before = sink.snapshot()
    with pytest.raises(NavigationPoseUnreachable) as info:
        run_projected(mrun, sink, body)
    assert info.value.location is goal
    assert sink.snapshot() == before
    assert sink.robot_pose() == Pose.from_xyz_yaw(0.75, 0.70, 0.0, 0.0)


# ------------------------------------------------------------------ lifecycle
def test_no_process_module_outside_and_after_the_block(mrun: Any, world: World) -> None:
    going = a.motion(type="going", pose=Pose((0.3, 0.0, 0.0)))
    seen: dict[str, Any] = {}

    async def main() -> None:
        with pytest.raises(NoProcessModule):
            await perform(going)
        async with with_projected_robot(world) as env:
            assert current_environment() is env
            assert [pm.name for pm in env.process_modules] == PM_NAMES
            assert all(pm.status.value is PMStatus.IDLE for pm in env.process_modules)
            assert isinstance(env.world, ProjectedWorldModel) and env.world.world is world
            seen["env"] = env
        assert current_environment() is not env
        assert not current_environment().process_modules
        assert not current_environment().has_world
        with pytest.raises(NoProcessModule):
            await perform(going)
        with pytest.raises(NoProcessModule):
            await pm_execute("navigation", going)

    mrun(main, name="lifecycle")
    env = seen["env"]
    assert all(pm.status.value is PMStatus.OFFLINE for pm in env.process_modules)
    assert not any(pm.running or pm.pending for pm in env.process_modules)
    assert world.robot_pose().position == (0.0, 0.0, 0.0)


def test_leaving_the_block_on_a_failure_stops_the_modules(mrun: Any, world: World) -> None:
    seen: list[executive.Environment] = []

    async def main() -> None:
        async with with_projected_robot(world) as env:
            seen.append(env)
            raise ValueError("boom")

    with pytest.raises(ValueError, match="boom"):
        mrun(main, name="boom")
    assert all(pm.status.value is PMStatus.OFFLINE for pm in seen[0].process_modules)


def test_nested_blocks_inner_wins(mrun: Any, world: World) -> None:
    async def main() -> None:
        async with with_projected_robot(world) as outer:
            async with with_projected_robot(world, rules=None) as inner:
                assert current_environment() is inner
                assert inner.rules is executive.static_rules
                await perform(a.motion(type="moving-torso", joint_angle=0.2))
                nav_in = inner.find_process_module("navigation")
                nav_out = outer.find_process_module("navigation")
                assert nav_in is not None and nav_out is not None
                assert nav_in is not nav_out and nav_in.running and nav_out.running
            assert current_environment() is outer
            assert all(pm.status.value is PMStatus.OFFLINE for pm in inner.process_modules)
            await perform(a.motion(type="going", pose=Pose((0.2, 0.0, 0.0))))

    mrun(main, name="nested")
    assert world.torso_height == pytest.approx(0.2)
    assert world.robot_pose().position == pytest.approx((0.2, 0.0, 0.0))


def test_bad_arguments(world: World) -> None:
    with pytest.raises(TypeError, match=r"projection\.World"):
        projection_process_modules("world")  # type: ignore[arg-type]

    async def enter(arg: Any) -> None:
        async with with_projected_robot(arg):
            pass

    with pytest.raises(TypeError, match=r"projection\.World"):
        cpl.run(enter, ProjectedWorldModel(world))
    other = World(seed=0)
    other.close()
    with pytest.raises(RuntimeError, match="closed"):
        cpl.run(enter, other)
