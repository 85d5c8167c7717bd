"""Concurrent actions on one robot part, on the projected robot (executive._resources).

Before resources, ``par(pick-up cup with left, pick-up bowl with left)`` interleaved both
in the arm module's queue: the cup was dragged to the bowl and left in the hand, and the
failure was a misleading GripperClosedCompletely about the bowl. Now the second action
fails with ResourceConflict before anything moves."""

from __future__ import annotations

from typing import Any

import pytest

import cpl
from executive import Pose, ResourceConflict, a, an, perform

projection = pytest.importorskip("projection")

CUP = Pose((0.5, 0.3, 1.0))  # the seed's cup: the left arm's top grasp reaches it
BOWL_LEFT = Pose((0.55, 0.55, 1.0))  # also on the left
BOWL_RIGHT = Pose((0.55, -0.3, 1.0))  # the right arm's top grasp reaches it


def kitchen(bowl: Pose) -> Any:
    world = projection.World(seed=1)
    world.spawn_object("cup-1", "cup", CUP)
    world.spawn_object("bowl-1", "bowl", bowl)
    return world


def state(world: Any) -> dict[str, Any]:
    """What a motion would change: the objects, what the hands hold, the arms, the
    grippers, the base."""
    return {
        "cup": world.object_pose("cup-1").position,
        "bowl": world.object_pose("bowl-1").position,
        "held": dict(world.attachments),
        "arms": {arm: tuple(world.arm_joints(arm)) for arm in ("left", "right")},
        "grippers": {arm: world.gripper_opening(arm) for arm in ("left", "right")},
        "base": world.robot_pose().position,
    }


def close(before: dict[str, Any], after: dict[str, Any]) -> bool:
    def flat(d: Any) -> list[Any]:
        if isinstance(d, dict):
            return [x for k in sorted(d) for x in [k, *flat(d[k])]]
        if isinstance(d, (tuple, list)):
            return [x for v in d for x in flat(v)]
        return [d]

    a_, b_ = flat(before), flat(after)
    return len(a_) == len(b_) and all(
        x == pytest.approx(y, abs=1e-6) if isinstance(x, float) else x == y for x, y in zip(a_, b_)
    )


def run(mrun: Any, world: Any, body: Any) -> Any:
    async def main() -> Any:
        async with projection.with_projected_robot(world):
            # look between the cup and the bowl: both in view
            ys = [world.object_pose(name).position[1] for name in ("cup-1", "bowl-1")]
            y = sum(ys) / 2
            look = Pose((0.7, y, 0.8), frame="base_footprint")
            await perform(an.action(type="looking", target=a.location(pose=look)))
            cup = await perform(an.action(type="detecting", object=an.object(type="cup")))
            bowl = await perform(an.action(type="detecting", object=an.object(type="bowl")))
            return await body(cup, bowl)

    return mrun(main)


def pick(obj: Any, arm: str) -> Any:
    return perform(an.action(type="picking-up", object=obj, arm=arm, grasp="top"))


def test_two_pick_ups_with_one_arm_fail_before_either_moves(mrun: Any) -> None:
    world = kitchen(BOWL_LEFT)
    seen: dict[str, Any] = {}

    async def body(cup: Any, bowl: Any) -> Any:
        seen["before"] = state(world)
        try:
            await cpl.par(pick(cup, "left"), pick(bowl, "left"))
        finally:
            seen["after"] = state(world)

    with pytest.raises(ResourceConflict, match=r"needs the (arm|gripper) 'left'") as caught:
        run(mrun, world, body)
    assert "right is free" in str(caught.value)
    # the cup was not dragged to the bowl, nothing is in the hand, nothing moved
    assert seen["after"]["held"] == {}
    assert close(seen["before"], seen["after"]), (seen["before"], seen["after"])


def test_pick_up_and_releasing_on_one_arm_conflict(mrun: Any) -> None:
    world = kitchen(BOWL_LEFT)
    seen: dict[str, Any] = {}

    async def body(cup: Any, bowl: Any) -> Any:
        seen["before"] = state(world)
        try:
            await cpl.par(pick(cup, "left"), perform(an.action(type="releasing", gripper="left")))
        finally:
            seen["after"] = state(world)

    with pytest.raises(ResourceConflict, match="needs the gripper 'left'"):
        run(mrun, world, body)
    assert close(seen["before"], seen["after"]), (seen["before"], seen["after"])


def test_pick_ups_with_two_arms_both_succeed(mrun: Any) -> None:
    world = kitchen(BOWL_RIGHT)

    async def body(cup: Any, bowl: Any) -> Any:
        return await cpl.par(pick(cup, "left"), pick(bowl, "right"))

    run(mrun, world, body)
    assert world.attachments == {"cup-1": "l_wrist_roll_link", "bowl-1": "r_wrist_roll_link"}
    assert world.object_pose("cup-1").position[2] > CUP.position[2] + 0.05  # lifted
    assert world.object_pose("bowl-1").position[2] > BOWL_RIGHT.position[2] + 0.05


def test_two_goings_conflict_on_the_base(mrun: Any) -> None:
    world = kitchen(BOWL_RIGHT)
    second = Pose((-0.5, 0.0, 0.0))

    async def body(cup: Any, bowl: Any) -> Any:
        await cpl.par(
            perform(an.action(type="going", target=a.location(pose=Pose((-0.3, 0.0, 0.0))))),
            perform(an.action(type="going", target=a.location(pose=second))),
        )

    with pytest.raises(ResourceConflict, match="needs the base"):
        run(mrun, world, body)
    assert world.robot_pose().distance_to(second) > 0.1  # the loser never drove


def test_looking_and_detecting_conflict_two_detectings_do_not(mrun: Any) -> None:
    # decided: perception shares the head (it reads the camera where the head points):
    # it coexists with other perception, not with a looking outside its subtree
    world = kitchen(BOWL_RIGHT)

    async def both_detect(cup: Any, bowl: Any) -> Any:
        return await cpl.par(
            perform(an.action(type="detecting", object=an.object(type="cup"))),
            perform(an.action(type="detecting", object=an.object(type="bowl"))),
        )

    found = run(mrun, world, both_detect)
    assert [d.get("name") for d in found] == ["cup-1", "bowl-1"]

    async def look_and_detect(cup: Any, bowl: Any) -> Any:
        return await cpl.par(
            perform(an.action(type="looking", direction="forward")),
            perform(an.action(type="detecting", object=an.object(type="cup"))),
        )

    with pytest.raises(ResourceConflict, match="needs the head"):
        run(mrun, world, look_and_detect)
