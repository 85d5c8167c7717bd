"""The plans drive whichever robot the environment carries (issue 25): the same plans on
the in-memory fake world with a one-armed description (the mobile Panda of
:mod:`robots.panda`) name that robot in their location designators, try only its ``left``
arm, grasp with its tool frame's rotation and open its gripper no wider than it opens;
without a description a plan refuses to start, naming the fix."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
from conftest import KITCHEN, PR2, cup_world_for, location_generator, make_robot

import executive
from executive import (
    NoRobotDescription,
    ObjectUnfetchable,
    Pose,
    a,
    an,
    knowledge,
    perform,
)
from executive.events import ObjectAttached
from executive.testing import InMemoryWorld
from robots.panda import DESCRIPTION as PANDA

LEFT = PANDA.arm("left")


def perceived_cup(world: InMemoryWorld) -> executive.ObjectDesignator:
    assert world.robot is not None
    return an.object(
        type="cup",
        name="cup-1",
        transform=world.object_pose("cup-1", world.robot.base_frame).to_transform("cup-1"),
    )


def recording(robot: Any) -> list[tuple[str, Any]]:
    """Record the robot key (``reachable-for`` / ``visible-for``) of every location
    designator the robot's location generator resolves."""
    seen: list[tuple[str, Any]] = []

    def generator(d: executive.Designator) -> Iterator[Pose] | None:
        for key in ("reachable-for", "visible-for"):
            if key in d:
                seen.append((key, d[key]))
        return location_generator(d)

    robot.rules.register_location_generator(generator, 14)  # before the conftest's (15)
    return seen


def test_picking_up_solutions_are_the_one_arms_only() -> None:
    world = cup_world_for(PANDA)
    robot = make_robot(world)

    async def solutions() -> list[Any]:
        action = an.action(type="picking-up", object=perceived_cup(world))
        return [g.arguments for g in action.solutions()]

    grounded = robot.run(solutions)
    assert {g["arm"] for g in grounded} == {"left"}
    # every grasp of the cup, each straight and from above
    assert [g["grasp"] for g in grounded[::2]] == list(knowledge.grasps("cup"))


def test_the_grasp_poses_are_the_panda_tool_frames() -> None:
    world = cup_world_for(PANDA)
    robot = make_robot(world)
    action = an.action(type="picking-up", object=perceived_cup(world))
    robot.run(perform, action)
    args = action.reference().arguments
    assert isinstance(args, dict)
    transform = args["object_designator"]["transform"]
    panda = knowledge.grasp_poses("cup", "back", transform, LEFT.standard_to_tool)
    pr2 = knowledge.grasp_poses("cup", "back", transform, PR2.arm("left").standard_to_tool)
    tcp = [m.reference().arguments for m in robot.calls("arms", "moving-tcp")]
    assert all(t["right"] is None for t in tcp)
    assert tcp[2]["left"].isclose(panda[2], 1e-9, 1e-9)  # the grasp
    assert not tcp[2]["left"].isclose(pr2[2], 1e-3, 1e-3)
    # the standard gripper's approach (its z) is the Panda hand's z: the tool's z axis
    # points along the back grasp's approach (+x of the cup, in the base frame here)
    approach = panda[2].matrix()[:3, 2]
    assert np.allclose(approach, transform.matrix()[:3, 0], atol=1e-9)
    # the cup's opening (0.10 m) is wider than the Panda's gripper opens (0.08 m)
    assert args["opening"] == LEFT.gripper.max_opening == 0.08
    attached = next(e for e in world.events if isinstance(e, ObjectAttached))
    assert (attached.arm, attached.link) == ("left", LEFT.hand_link)


def test_fetching_says_reachable_for_the_panda_and_relocates_with_its_one_arm() -> None:
    """On the PR2-like robot "the other arm" is the next solution; a one-armed robot has
    none, so after its left arm's solutions it relocates."""
    world = cup_world_for(PANDA)
    robot = make_robot(world)
    seen = recording(robot)
    # the left arm's 10 solutions (5 grasps x straight/above) fail at the first base pose
    world.fail_probe["arm"] = {n: True for n in range(1, 11)}
    robot.run(perform, an.action(type="fetching", object=perceived_cup(world)))
    assert seen and set(seen) == {("reachable-for", "panda")}
    assert {arm for arm, _waypoints in world.probe_calls["arm"]} == {"left"}
    assert len(world.probe_calls["arm"]) == 11  # the 11th: at the second base pose
    assert world.object_in_hand("left") == "cup-1"
    grippers = [m.reference().arguments for m in robot.calls("grippers")]
    assert grippers and all(g["gripper"] == "left" for g in grippers)


def test_fetching_with_a_fixed_right_arm_names_the_robots_arms() -> None:
    world = cup_world_for(PANDA)
    robot = make_robot(world)
    with pytest.raises(executive.DesignatorError, match=r"unknown arm 'right'; known arms: left"):
        robot.run(perform, an.action(type="fetching", object=perceived_cup(world), arm="right"))
    assert robot.calls("navigation") == [] and robot.calls("arms") == []


def test_a_search_looks_from_where_the_panda_sees() -> None:
    world = cup_world_for(PANDA)
    robot = make_robot(world)
    seen = recording(robot)
    found = robot.run(
        perform,
        an.action(type="searching", object=an.object(type="cup"), location=a.location(spots=2)),
    )
    assert found.get("name") == "cup-1"
    assert ("visible-for", "panda") in seen and ("visible-for", "pr2") not in seen


def test_a_search_looks_again_from_the_robots_highest_torso() -> None:
    world = cup_world_for(PANDA)
    # the detecting action retries 4x (5 calls); then the search raises the torso once
    failing = {i: executive.PerceptionObjectNotFound for i in range(1, 6)}
    robot = make_robot(world, perception=failing)
    robot.run(
        perform,
        an.action(type="searching", object=an.object(type="cup"), location=a.location(spots=2)),
    )
    (torso,) = robot.calls("torso")
    assert torso.get("joint-angle") == PANDA.torso.upper == 0.40


def test_parking_moves_only_the_arm_the_robot_has() -> None:
    world = cup_world_for(PANDA)
    robot = make_robot(world)
    robot.run(perform, an.action(type="positioning-arm", left_configuration="park"))
    from plans.atomic import park_arms

    robot.run(park_arms, "carry")
    joints = [m.reference().arguments for m in robot.calls("arms", "moving-arm-joints")]
    assert [j["left"] for j in joints] == [LEFT.state("park"), LEFT.state("carry")]
    assert all(j["right"] is None for j in joints)


def test_a_configuration_for_an_arm_the_robot_lacks_is_refused() -> None:
    world = cup_world_for(PANDA)
    robot = make_robot(world)
    with pytest.raises(executive.DesignatorInputError, match=r"no arm 'right'; known arms: left"):
        robot.run(perform, an.action(type="positioning-arm", right_configuration="park"))
    assert robot.calls("arms") == []


def test_the_gripper_opens_no_wider_than_the_robots() -> None:
    world = cup_world_for(PANDA)
    robot = make_robot(world)
    with pytest.raises(executive.DesignatorError, match=r"from 0 to 0\.08; got 0\.09"):
        robot.run(perform, an.action(type="setting-gripper", gripper="left", position=0.09))
    assert robot.calls("grippers") == []
    world_pr2 = cup_world_for(PR2)
    robot_pr2 = make_robot(world_pr2)
    robot_pr2.run(perform, an.action(type="setting-gripper", gripper="left", position=0.09))
    assert len(robot_pr2.calls("grippers")) == 1


def test_fetching_fails_as_unfetchable_when_the_one_arm_never_reaches() -> None:
    world = cup_world_for(PANDA)
    robot = make_robot(world)
    world.fail_probe["arm"] = {n: True for n in range(1, 1000)}
    with pytest.raises(ObjectUnfetchable):
        robot.run(perform, an.action(type="fetching", object=perceived_cup(world)))
    assert {arm for arm, _waypoints in world.probe_calls["arm"]} == {"left"}
    # 11 base poses (the first and 10 relocations) x the left arm's 10 solutions
    assert len(world.probe_calls["arm"]) == 110


def test_the_demos_initialization_opens_the_one_gripper() -> None:
    """It used to open ("left", "right"): on a one-armed robot a designator error, ignored
    by the initialization, so the gripper stayed as it was."""
    from plans.demo import _initialize_or_finalize

    world = cup_world_for(PANDA)
    robot = make_robot(world)
    robot.run(_initialize_or_finalize, "park")
    opened = [m.reference().arguments for m in robot.calls("grippers", "opening-gripper")]
    assert opened and all(g["gripper"] in ("left", ("left",)) for g in opened)
    joints = [m.reference().arguments for m in robot.calls("arms", "moving-arm-joints")]
    assert [j["left"] for j in joints] == [LEFT.state("park")] * 2


# -------------------------------------------------------------------- no description
def test_a_plan_on_a_world_without_a_description_names_the_fix() -> None:
    world = InMemoryWorld(
        objects={"cup-1": Pose((1.3, 0.6, 0.9))}, types={"cup-1": "cup"}, kitchen=KITCHEN
    )
    robot = make_robot(world)
    cup = an.object(type="cup", name="cup-1")
    with pytest.raises(NoRobotDescription, match=r"carries no robot description.*robot=") as e:
        robot.run(perform, an.action(type="fetching", object=cup))
    assert "InMemoryWorld" in str(e.value)
    assert all(pm.calls == [] for pm in robot.pms.values())  # nothing moved


def test_parking_without_a_description_names_the_fix() -> None:
    robot = make_robot(InMemoryWorld())
    from plans.atomic import park_arms

    with pytest.raises(NoRobotDescription, match="robot="):
        robot.run(park_arms, "park")
    assert robot.calls("arms") == []


def test_the_pr2_like_robot_is_unchanged_reachable_for_pr2() -> None:
    world = cup_world_for(PR2)
    robot = make_robot(world)
    seen = recording(robot)
    world.fail_probe["arm"] = {n: True for n in range(1, 11)}  # the right arm's 10
    robot.run(perform, an.action(type="fetching", object=perceived_cup(world)))
    assert set(seen) == {("reachable-for", "pr2")}
    arms = [arm for arm, _waypoints in world.probe_calls["arm"]]
    assert arms == ["right"] * 10 + ["left"]  # the other arm, at the same base pose
    assert world.object_in_hand("left") == "cup-1"
