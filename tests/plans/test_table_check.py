"""Looking at the table before leaving it (issue 26): a delivered object displaced after
its placing is perceived, fixed and delivered again; one that is gone is no longer claimed.
On the simulated real robot, measured in the true world; and with the fake robot
(an InMemoryWorld), where the displacement is injected between placing and looking."""

from __future__ import annotations

from typing import Any

import pytest
from conftest import PR2, cup_world_for, make_robot

import plans
from executive import Pose, an, perform
from executive.testing import InMemoryWorld
from plans.demo import ObjectOutcome, place_location, recheck_table
from plans.island_check import NEAR_PLACED, PlacedState, check_placed, tilt_deg
from projection import FaultProfile, make_world_pair, settle, with_real_robot

TOPPLED = (0.0, 0.7071068, 0.0, 0.7071068)  # the cup on its side


def _on_island(true: Any, name: str) -> bool:
    ((lx, ly, _), (hx, hy, hz)) = true.link_aabb("kitchen_island_surface")
    x, y, z = true.object_pose(name).position
    return bool(lx <= x <= hx and ly <= y <= hy and z > hz)


def _deliver_cup_then(mrun: Any, disturb: Any) -> tuple[ObjectOutcome, Pose, Pose, bool]:
    """Deliver cup-1 on the simulated real robot, ``disturb(true, placed)`` the true world,
    then :func:`recheck_table`; returns the outcome, the placing pose, the cup's true
    pose after settling and whether it is on the island."""
    true, belief = make_world_pair(0, belief_objects="exact")
    try:
        outcome = ObjectOutcome("cup", "cup-1")
        box: dict[str, Any] = {}

        async def main() -> None:
            async with with_real_robot(true, belief, FaultProfile.none()):
                delivered = await perform(
                    an.action(
                        type="transporting",
                        object=an.object(type="cup", name="cup-1"),
                        location=plans.demo.fetch_location("cup"),
                        target=place_location("cup", bowl_placed=False),
                        projection_reasoning=False,
                    )
                )
                assert delivered is not None
                outcome.success = True
                placed = belief.object_pose("cup-1")
                box["placed"] = placed
                disturb(true, placed)
                await recheck_table({"cup": outcome}, {"cup-1": placed})

        mrun(main)
        settle(true, 240)
        return (
            outcome,
            box["placed"],
            true.object_pose("cup-1"),
            _on_island(true, "cup-1"),
        )
    finally:
        true.close()
        belief.close()


def test_a_displaced_delivered_cup_is_fixed_and_delivered_in_the_true_world(mrun: Any) -> None:
    def push(true: Any, placed: Pose) -> None:
        x, y, z = true.object_pose("cup-1").position
        true.set_object_pose("cup-1", Pose((x, y + 0.25, z)))  # along the island
        settle(true, 120)

    outcome, placed, end, on_island = _deliver_cup_then(mrun, push)
    assert outcome.success and outcome.failure is None
    assert outcome.retries.get("table-fixed") == 1
    (x, y, _), (px, py, _) = end.position, placed.position
    assert ((x - px) ** 2 + (y - py) ** 2) ** 0.5 <= NEAR_PLACED
    assert tilt_deg(end) < 15.0 and on_island


def test_a_delivered_cup_that_is_gone_is_not_claimed(mrun: Any) -> None:
    def take_away(true: Any, _placed: Pose) -> None:  # onto the floor, far from the island
        true.set_object_pose("cup-1", Pose((0.3, -1.4, 0.05)))
        settle(true, 120)

    outcome, _placed, _end, on_island = _deliver_cup_then(mrun, take_away)
    assert not outcome.success and outcome.failure is not None
    assert outcome.retries.get("table-unseen") == 1
    assert not on_island


def test_a_toppled_delivered_cup_is_fixed_or_not_claimed(mrun: Any) -> None:
    def topple(true: Any, _placed: Pose) -> None:
        x, y, z = true.object_pose("cup-1").position
        true.set_object_pose("cup-1", Pose((x, y, z), TOPPLED))
        settle(true, 240)
        assert tilt_deg(true.object_pose("cup-1")) > 45.0

    outcome, placed, end, on_island = _deliver_cup_then(mrun, topple)
    (x, y, _), (px, py, _) = end.position, placed.position
    delivered = (
        on_island and tilt_deg(end) < 15.0 and ((x - px) ** 2 + (y - py) ** 2) ** 0.5 <= NEAR_PLACED
    )
    assert outcome.success == delivered  # never a phantom
    assert set(outcome.retries) & {"table-fixed", "table-unfixed"}  # it was seen toppled


# ------------------------------------------------------------------- the fake robot
def _placed_cup_world(at: Pose) -> InMemoryWorld:
    world = cup_world_for(PR2)
    world.set_object_pose("cup-1", at)
    return world


PLACED = Pose((1.3, 0.6, 0.9))


@pytest.mark.parametrize(
    ("now", "state"),
    [
        (Pose((1.33, 0.62, 0.9)), PlacedState.IN_PLACE),
        (Pose((1.3, 0.9, 0.9)), PlacedState.DISPLACED),
        (Pose((1.3, 0.6, 0.9), TOPPLED), PlacedState.TOPPLED),
    ],
)
def test_one_look_tells_in_place_displaced_and_toppled(now: Pose, state: PlacedState) -> None:
    world = _placed_cup_world(now)
    robot = make_robot(world)
    verdicts = robot.run(check_placed, {"cup-1": ("cup", PLACED)})
    assert verdicts["cup-1"].state is state
    assert len(robot.calls("navigation")) == 1  # one look, not one per object


def test_an_object_not_perceived_is_unseen_and_not_claimed() -> None:
    world = _placed_cup_world(PLACED)
    del world.objects["cup-1"]  # gone before the look
    robot = make_robot(world)
    outcome = ObjectOutcome("cup", "cup-1", success=True)
    robot.run(recheck_table, {"cup": outcome}, {"cup-1": PLACED})
    assert not outcome.success
    assert len(robot.calls("perception")) >= 2  # looked, then turned to its own spot


def test_check_placed_rejects_bad_input_before_moving() -> None:
    robot = make_robot(_placed_cup_world(PLACED))
    with pytest.raises(TypeError, match="name: \\(type, placing Pose\\)"):
        robot.run(check_placed, {"cup-1": PLACED})
    assert robot.calls("navigation") == []
