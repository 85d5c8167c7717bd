"""Fetching an object from the floor (issue 13; no CRAM plan does this): an object that
was dropped or knocked off a counter is looked for on the floor and picked up from there
(the arms out of the camera's view, base poses close enough for an arm to reach down),
or fails with a typed failure that is logged and counted."""

from __future__ import annotations

import logging
import math
from typing import Any

import pytest
from conftest import KITCHEN, PR2, hand_links, make_robot, transport_for_real

import plans  # noqa: F401 - the action rules
from executive import ObjectNowhereToBeFound, Pose, an, perform
from executive.testing import InMemoryWorld
from plans import retry_ledger
from plans.fetch import (
    FLOOR_PICK_MORE_SIDES,
    FLOOR_PICK_SIDE,
    ObjectUnreachableOnFloor,
    floor_base_poses,
    floor_pick_distances,
    search_floor,
)
from projection import make_world_pair, settle

#: On the floor in front of the sink counter: where a cup knocked off it lands.
ON_THE_FLOOR = Pose((1.0, 0.6, 0.06))


def test_a_cup_on_the_floor_is_fetched_from_there_and_delivered(mrun: Any) -> None:
    # the belief last saw the cup on the sink counter; it lies on the floor in front
    true, belief = make_world_pair(0, belief_objects="exact")
    try:
        true.set_object_pose("cup-1", ON_THE_FLOOR)
        settle(true, 240)
        assert true.object_pose("cup-1").position[2] < 0.1

        async def main() -> Any:
            return await transport_for_real(true, belief, "cup", "cup-1")

        delivered = mrun(main)
        assert delivered is not None  # not dropped at the sink
        (lx, ly, _), (hx, hy, hz) = true.link_aabb("kitchen_island_surface")
        x, y, z = true.object_pose("cup-1").position
        assert lx < x < hx and ly < y < hy and hz < z < hz + 0.1  # on the island, upright
        assert "cup-1" not in true.attachments
    finally:
        true.close()
        belief.close()


def _floor_world() -> InMemoryWorld:
    world = InMemoryWorld(
        objects={"cup-1": Pose((1.3, 0.6, 0.05))},
        types={"cup-1": "cup"},
        links=hand_links(PR2),
        robot=PR2,
        kitchen=KITCHEN,
    )
    return world


def test_a_cup_on_the_floor_out_of_reach_is_a_counted_typed_failure(
    caplog: pytest.LogCaptureFixture,
) -> None:
    world = _floor_world()
    robot = make_robot(world)
    world.fail_probe["arm"] = {n: True for n in range(1, 10_000)}  # no grasp reaches it
    cup = world.object_pose("cup-1")
    counts: dict[str, int] = {}

    async def go() -> None:
        with retry_ledger() as ledger:
            try:
                await perform(
                    an.action(
                        type="fetching",
                        object=an.object(
                            type="cup",
                            name="cup-1",
                            pose=cup,
                            transform=world.object_pose("cup-1", "base_footprint").to_transform(
                                "cup-1"
                            ),
                        ),
                    )
                )
            finally:
                counts.update(ledger)

    with caplog.at_level(logging.WARNING, logger="plans.fetch"):
        with pytest.raises(ObjectUnreachableOnFloor):
            robot.run(go)
    assert counts["floor-unreachable"] == 1 and counts["relocations"] == 10
    assert any("lies on the floor out of reach" in r.getMessage() for r in caplog.records)
    # every base pose tried was one from which an arm reaches down to the floor
    goals = [m.reference().arguments["pose"] for m in robot.calls("navigation", "going")]
    assert goals
    reaches = [
        math.hypot(d, side)
        for d in (0.5, 0.45, 0.4)  # the PR2-like arm's floor_pick_distances()
        for side in (FLOOR_PICK_SIDE, *FLOOR_PICK_MORE_SIDES)
    ]
    for goal in goals:
        away = math.dist(goal.position[:2], cup.position[:2])
        assert min(abs(away - r) for r in reaches) < 1e-6


def test_the_floor_search_needs_an_object_it_knows_by_name() -> None:
    world = _floor_world()
    robot = make_robot(world)
    failure = ObjectNowhereToBeFound("not at the sink")

    async def go() -> None:
        await search_floor(an.object(type="cup"), failure)

    with pytest.raises(ObjectNowhereToBeFound, match="not at the sink"):
        robot.run(go)
    assert robot.calls("navigation") == []  # nothing moved


#: A milk carton lying on its broad face (0.06 m high): its x axis vertical.
ON_ITS_SIDE = (0.0, math.sqrt(0.5), 0.0, math.sqrt(0.5))


def test_a_carton_lying_low_on_the_floor_is_reached_from_closer_and_delivered_standing(
    mrun: Any,
) -> None:
    """Issue 26: a carton on its broad face on the floor is grasped 0.02 m above it, out
    of the PR2-like arm's reach from the 0.5 m floor base poses; the base stands closer
    (:func:`plans.fetch.floor_pick_distances`), the carton is picked from above and
    delivered standing on the island. Before: ``ObjectUnreachableOnFloor``."""
    true, belief = make_world_pair(0, belief_objects="exact")
    try:
        true.set_object_pose("milk-1", Pose((0.85, 0.6, 0.03), ON_ITS_SIDE))
        settle(true, 240)
        assert true.object_pose("milk-1").position[2] < 0.05

        async def main() -> Any:
            return await transport_for_real(true, belief, "milk", "milk-1")

        delivered = mrun(main)
        assert delivered is not None  # not dropped at the sink
        settle(true, 240)
        (lx, ly, _), (hx, hy, hz) = true.link_aabb("kitchen_island_surface")
        end = true.object_pose("milk-1")
        x, y, z = end.position
        assert lx < x < hx and ly < y < hy and hz < z < hz + 0.15  # on the island
        assert end.matrix()[2, 2] > math.cos(math.radians(15))  # standing
        assert "milk-1" not in true.attachments
    finally:
        true.close()
        belief.close()


def test_floor_base_poses_stand_closer_after_farther_at_each_spot() -> None:
    world = _floor_world()
    robot = make_robot(world)
    spot = Pose((1.3, 0.6, 0.03))
    out: list[Any] = []

    got: list[tuple[float, ...]] = []

    async def go() -> None:
        out.extend(floor_base_poses(spot))
        got.append(floor_pick_distances())

    robot.run(go)
    (distances,) = got
    assert distances == pytest.approx((0.5, 0.45, 0.4))
    first = out[: len(distances)]  # one spot: the same yaw, farther first
    assert len({round(p.yaw, 9) for p in first}) == 1
    ahead = [math.dist(p.position[:2], spot.position[:2]) for p in first]  # hypot(distance, side)
    assert ahead == pytest.approx([math.hypot(d, FLOOR_PICK_SIDE) for d in distances])
