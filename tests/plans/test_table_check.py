"""Looking at the table before leaving it (issue 26): a delivered object displaced after
its placing is perceived, fixed and delivered again; one that is gone is no longer claimed.
On the simulated real robot, measured in the true world; and with the fake robot
(an InMemoryWorld), where the displacement is injected between placing and looking."""

from __future__ import annotations

from typing import Any

import pytest
from conftest import PR2, cup_world_for, make_robot

import plans
from executive import ObjectUnfetchable, PerceptionObjectNotFound, Pose, an, perform
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


# --------------------------------------------- what the look at the whole table misses
def test_an_object_the_first_look_misses_is_claimed_after_the_aimed_look() -> None:
    # every detect of the look at the whole table fails (two detects, with their own
    # retries); the look aimed at the cup's placing pose then sees it in place
    world = _placed_cup_world(PLACED)
    robot = make_robot(world, perception={i: PerceptionObjectNotFound for i in range(1, 11)})
    outcome = ObjectOutcome("cup", "cup-1", success=True)
    robot.run(recheck_table, {"cup": outcome}, {"cup-1": PLACED})
    assert outcome.success and outcome.failure is None
    assert outcome.retries.get("table-aimed") == 1
    assert "table-unseen" not in outcome.retries and "table-floor" not in outcome.retries
    assert len(robot.calls("navigation")) == 2  # the look at the table, then its own


def test_an_object_no_look_sees_is_looked_for_on_the_floor_then_not_claimed() -> None:
    world = _placed_cup_world(PLACED)
    del world.objects["cup-1"]
    robot = make_robot(world)
    outcome = ObjectOutcome("cup", "cup-1", success=True)
    robot.run(recheck_table, {"cup": outcome}, {"cup-1": PLACED})
    assert not outcome.success
    assert outcome.retries.get("table-aimed") == 1
    assert outcome.retries.get("table-floor") == 1
    assert outcome.retries.get("table-unseen") == 1


def _spoon_spot(true: Any) -> Pose:
    """A spot on the island for the spoon, near its edge towards the room (map)."""
    ((_, ly, _), (hx, hy, hz)) = true.link_aabb("kitchen_island_surface")
    return Pose((hx - 0.25, (ly + hy) / 2, hz + 0.02))


def test_a_spoon_in_place_the_first_look_misses_is_still_claimed(
    mrun: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    """On the simulated real robot: the true camera does not see the spoon until the look
    aimed at its own placing pose (injected: every detect of it fails before that look),
    which sees it in place; it stays claimed and is where it was placed."""
    true, belief = make_world_pair(0, belief_objects="exact")
    try:
        spot = _spoon_spot(true)
        true.set_object_pose("spoon-1", spot)
        settle(true, 120)
        placed = true.object_pose("spoon-1")
        belief.set_object_pose("spoon-1", placed)
        hidden = {"spoon": True}
        real_detect = true.detect
        real_look = getattr(plans.island_check, "look_for_placed", None)

        def detect(designator: Any, *args: Any, **kwargs: Any) -> Any:
            if hidden["spoon"] and designator.get("type") == "spoon":
                raise PerceptionObjectNotFound("injected: the first look misses the spoon")
            return real_detect(designator, *args, **kwargs)

        async def aimed(*args: Any) -> Any:
            assert real_look is not None
            hidden["spoon"] = False
            return await real_look(*args)

        monkeypatch.setattr(true, "detect", detect)
        monkeypatch.setattr(plans.island_check, "look_for_placed", aimed, raising=False)
        outcome = ObjectOutcome("spoon", "spoon-1", success=True)

        async def main() -> None:
            async with with_real_robot(true, belief, FaultProfile.none()):
                await recheck_table({"spoon": outcome}, {"spoon-1": placed})

        mrun(main)
        assert not hidden["spoon"]  # the aimed look ran
        assert outcome.success and outcome.failure is None, outcome.retries
        assert outcome.retries.get("table-aimed") == 1
        assert not set(outcome.retries) & {"table-unseen", "table-fixed", "table-unfixed"}
        (x, y, _), (px, py, _) = true.object_pose("spoon-1").position, placed.position
        assert ((x - px) ** 2 + (y - py) ** 2) ** 0.5 <= NEAR_PLACED
    finally:
        true.close()
        belief.close()


def _knock_off(true: Any, placed: Pose) -> None:
    """The cup off the island onto the floor next to it, on the room's side."""
    (_, (hx, _, _)) = true.link_aabb("kitchen_island_surface")
    true.set_object_pose("cup-1", Pose((hx + 0.2, float(placed.position[1]), 0.05)))
    settle(true, 120)


def test_a_delivered_cup_knocked_to_the_floor_is_found_there_and_fixed(mrun: Any) -> None:
    """Knocked off the island onto the floor next to it: the look at the table and the
    aimed look miss it, the floor look around its placing pose sees it; it is picked up
    from the floor, placed again and, seen in place, claimed: the true world agrees."""
    outcome, placed, end, on_island = _deliver_cup_then(mrun, _knock_off)
    assert outcome.retries.get("table-floor") == 1  # looked on the floor
    assert outcome.retries.get("table-fixed") == 1, outcome.retries
    assert outcome.success and outcome.failure is None
    (x, y, _), (px, py, _) = end.position, placed.position
    assert on_island and tilt_deg(end) < 15.0
    assert ((x - px) ** 2 + (y - py) ** 2) ** 0.5 <= NEAR_PLACED


def test_a_delivered_cup_knocked_to_the_floor_and_not_fixable_is_not_claimed(
    mrun: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The same, but its pick-up from the floor fails for good (injected: ``fetching``
    gives up): it is not claimed, and it is indeed not delivered."""

    async def unfetchable(perceived: Any, _target: Pose) -> bool:
        raise ObjectUnfetchable(object=perceived)

    monkeypatch.setattr(plans.demo, "_pick_and_place_again", unfetchable)
    outcome, _placed, _end, on_island = _deliver_cup_then(mrun, _knock_off)
    assert outcome.retries.get("table-floor") == 1
    assert outcome.retries.get("table-unfixed") == 1
    assert not outcome.success and isinstance(outcome.failure, ObjectUnfetchable)
    assert not on_island


def test_a_fix_is_claimed_only_when_the_look_after_it_sees_it_in_place(
    mrun: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Pushed, fixed, and pushed again right after its placing (injected before the look
    that verifies the fix): that look sees it displaced, so it is not claimed."""
    box: dict[str, Any] = {}
    real_look_again = getattr(plans.island_check, "look_again", None)

    def push(true: Any, _placed: Pose) -> None:
        box["true"] = true
        x, y, z = true.object_pose("cup-1").position
        true.set_object_pose("cup-1", Pose((x, y + 0.25, z)))
        settle(true, 120)

    async def pushed_again(name: str, otype: str, pose: Pose) -> Any:
        push(box["true"], pose)
        assert real_look_again is not None
        return await real_look_again(name, otype, pose)

    monkeypatch.setattr(plans.demo, "look_again", pushed_again, raising=False)
    outcome, placed, end, _on_island = _deliver_cup_then(mrun, push)
    assert outcome.retries.get("table-unfixed") == 1, outcome.retries
    assert not outcome.success and outcome.failure is not None
    (x, y, _), (px, py, _) = end.position, placed.position
    assert ((x - px) ** 2 + (y - py) ** 2) ** 0.5 > NEAR_PLACED  # indeed not delivered
