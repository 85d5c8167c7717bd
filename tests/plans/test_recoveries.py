"""The recoveries that stop the robot losing objects (issue 13), each with its failure
injected: a grasp verified after gripping and after lifting, a lost object announced to the
world model and fetched again, objects not found retried after the others have moved."""

from __future__ import annotations

import pytest
from conftest import make_robot
from test_plans_fake import perceived_cup

from executive import (
    GripperClosedCompletely,
    ManipulationPoseUnreachable,
    an,
    perform,
)
from executive.events import ObjectAttached, ObjectDetached
from plans import retry_ledger


def _pick(world):
    return an.action(type="picking-up", object=perceived_cup(world), arm="left")


# arms calls of a pick: 1-2 reaching, 3 grasping, 4-5 lifting
def test_object_falling_out_while_lifting_is_detached_and_raised(cup_world):
    robot = make_robot(cup_world, arms={4: GripperClosedCompletely})
    with pytest.raises(GripperClosedCompletely, match="lost from the left gripper while lifting"):
        robot.run(perform, _pick(cup_world))
    kinds = [type(e) for e in cup_world.events if isinstance(e, (ObjectAttached, ObjectDetached))]
    assert kinds == [ObjectAttached, ObjectDetached]
    assert cup_world.object_in_hand("left") is None


def test_other_lifting_failures_are_still_ignored(cup_world):
    robot = make_robot(cup_world, arms={4: ManipulationPoseUnreachable})
    robot.run(perform, _pick(cup_world))
    assert cup_world.object_in_hand("left") == "cup-1"


def test_gripper_closed_on_nothing_after_gripping_attaches_nothing(cup_world):
    cup_world.gripper_opening = lambda arm: 0.0  # the fingers met: nothing between them
    robot = make_robot(cup_world)
    with pytest.raises(GripperClosedCompletely, match="after gripping"):
        robot.run(perform, _pick(cup_world))
    assert not [e for e in cup_world.events if isinstance(e, ObjectAttached)]
    assert cup_world.attached() == []


def test_gripper_closed_after_lifting_is_a_lost_object(cup_world):
    openings = iter([0.05, 0.0])  # held after gripping, empty after lifting
    cup_world.gripper_opening = lambda arm: next(openings)
    robot = make_robot(cup_world)
    with pytest.raises(GripperClosedCompletely, match="while lifting"):
        robot.run(perform, _pick(cup_world))
    assert cup_world.object_in_hand("left") is None
    assert any(isinstance(e, ObjectDetached) for e in cup_world.events)


def test_fetching_picks_a_dropped_object_up_again(cup_world):
    # arms calls of a fetch: 1 park (navigating), 2-3 reaching, 4 grasping, 5-6 lifting
    robot = make_robot(cup_world, arms={5: GripperClosedCompletely})

    async def go():
        with retry_ledger() as ledger:
            await perform(an.action(type="fetching", object=perceived_cup(cup_world)))
            return dict(ledger)

    ledger = robot.run(go)
    assert ledger["regrasps"] == 1
    assert cup_world.object_in_hand("right") == "cup-1"
    detached = [e for e in cup_world.events if isinstance(e, ObjectDetached)]
    assert len(detached) == 1
    assert len(robot.calls("perception")) == 2  # looked for it again before the regrasp


def test_object_falling_out_while_parking_is_detached_not_kept(cup_world):
    robot = make_robot(cup_world, arms={6: GripperClosedCompletely})
    robot.run(perform, _pick(cup_world))  # arms calls 1-5
    assert cup_world.object_in_hand("left") == "cup-1"
    robot.run(perform, an.action(type="positioning-arm", left_configuration="carry"))  # call 6
    assert cup_world.object_in_hand("left") is None
    assert isinstance(cup_world.events[-1], ObjectDetached)


# ------------------------------------------------------------------- retried later
def test_an_object_not_found_is_transported_again_after_the_others(mrun, monkeypatch):
    """The cup is "hidden" on its first transport (its search fails); the demo goes on
    with the bowl... and comes back for the cup once the others have moved."""
    projection = pytest.importorskip("projection")
    import plans.demo
    from executive import ObjectNowhereToBeFound

    real_perform = plans.demo.perform
    transported = []

    async def perform_hiding_the_cup_once(designator):
        if designator.type == "transporting":
            otype = designator.get("object").get("type")
            transported.append(otype)
            if otype == "cup" and transported.count("cup") == 1:
                raise ObjectNowhereToBeFound(object=designator.get("object"))
        return await real_perform(designator)

    monkeypatch.setattr(plans.demo, "perform", perform_hiding_the_cup_once)
    world = projection.World(seed=1)

    async def main():
        async with projection.with_projected_robot(world):
            return await plans.demo.table_setting(world, ("cup", "bowl"), True, 1)

    outcomes = mrun(main)
    assert transported == ["cup", "bowl", "cup"]
    assert outcomes["bowl"].success
    assert outcomes["cup"].success and outcomes["cup"].failure is None
    assert outcomes["cup"].retries.get("later") == 1
    assert list(outcomes) == ["cup", "bowl"]


def test_an_object_failing_again_later_is_tried_only_once_more(mrun, monkeypatch):
    projection = pytest.importorskip("projection")
    import plans.demo
    from executive import ObjectNowhereToBeFound

    transported = []

    async def never_found(designator):
        if designator.type == "transporting":
            transported.append(designator.get("object").get("type"))
            raise ObjectNowhereToBeFound(object=designator.get("object"))
        return await real_perform(designator)

    real_perform = plans.demo.perform
    monkeypatch.setattr(plans.demo, "perform", never_found)
    world = projection.World(seed=1)

    async def main():
        async with projection.with_projected_robot(world):
            return await plans.demo.table_setting(world, ("bowl",), True, 1)

    outcomes = mrun(main)
    assert transported == ["bowl", "bowl"]
    assert isinstance(outcomes["bowl"].failure, ObjectNowhereToBeFound)
    assert outcomes["bowl"].retries == {"later": 1}
