"""Pushing (issue 26): the objects the robot lost because no grasp reaches them where they
lie are pushed, by the hand, to where one does, then fetched as usual. Set up in the TRUE
world; the outcome measured there (PyBullet contact and friction move the object: no
teleport)."""

from __future__ import annotations

import itertools
import math
from typing import Any

import pytest
from conftest import transport_for_real

import plans  # noqa: F401 - the action rules
from executive import Pose
from plans import retry_ledger
from projection import make_world_pair, settle

#: Lying on its side: the object's x axis vertical.
ON_ITS_SIDE = (0.0, math.sqrt(0.5), 0.0, math.sqrt(0.5))


def _on_the_island(true: Any, name: str) -> bool:
    (lx, ly, _), (hx, hy, hz) = true.link_aabb("kitchen_island_surface")
    x, y, z = true.object_pose(name).position
    return lx < x < hx and ly < y < hy and hz < z < hz + 0.15 and name not in true.attachments


def _gap_to_the_counter(true: Any, name: str) -> float:
    """How far (m) the object's footprint is from the sink counter's (its x side)."""
    (_lx, _ly, _lz), (hx, _hy, _hz) = true.object_aabb(name)
    (cx, _cy, _cz), _hi = true.link_aabb("sink_area_surface")
    return float(cx - hx)


@pytest.mark.parametrize("where", [(0.95, 0.6), (0.96, 0.3)])
def test_a_carton_lying_at_the_foot_of_the_counter_is_pushed_away_by_the_hand(
    mrun: Any, where: tuple[float, float]
) -> None:
    """A milk carton lying on the floor, its end 0.05 m from the sink counter's front:
    before, no base pose, arm and grasp picked it (``ObjectUnreachableOnFloor``, the
    carton never moved). Now the hand pushes it away from the counter first: measured on
    the true world, the carton moved at least 0.12 m farther from the counter (by the
    PyBullet contact of the hand: the plans never set an object's pose), still lying
    flat, and the belief re-perceived it where it is. The outcome is delivered, or the
    typed, counted ``ObjectUnreachableOnFloor`` (see the report: the fetch after the
    push still runs out of relocations here)."""
    from plans.fetch import ObjectUnreachableOnFloor

    true, belief = make_world_pair(0, belief_objects="exact")
    name = "milk-1"
    try:
        true.set_object_pose(name, Pose((*where, 0.06), ON_ITS_SIDE))
        settle(true, 480)
        start = true.object_pose(name)
        assert start.position[2] < 0.1 and abs(start.matrix()[2, 2]) < 0.5  # lying, floor
        gap = _gap_to_the_counter(true, name)
        assert gap < 0.07
        counts: dict[str, int] = {}

        async def main() -> Any:
            with retry_ledger() as ledger:
                try:
                    return await transport_for_real(true, belief, "milk", name)
                finally:
                    counts.update(ledger)

        try:
            mrun(main)
        except ObjectUnreachableOnFloor:
            assert counts.get("floor-unreachable") == 1
            settle(true, 240)
            assert _gap_to_the_counter(true, name) > gap + 0.12, true.object_pose(name)
            assert abs(true.object_pose(name).matrix()[2, 2]) < 0.5  # pushed, not tipped
            seen = belief.object_pose(name).position
            assert math.dist(seen[:2], true.object_pose(name).position[:2]) < 0.03
        else:
            settle(true, 240)
            assert _on_the_island(true, name), true.object_pose(name)
        assert counts.get("pushes") == 1, counts
    finally:
        true.close()
        belief.close()


# ------------------------------------------------------------- in the belief, before moving
def _world_at_the_counter(cup: Pose) -> Any:
    from conftest import KITCHEN, PR2, hand_links

    from executive.testing import InMemoryWorld

    x, y, _z = cup.position
    world = InMemoryWorld(
        objects={"cup-1": cup},
        types={"cup-1": "cup"},
        links=hand_links(PR2),
        robot=PR2,
        kitchen=KITCHEN,
    )
    world.aabbs.update(
        {
            "cup-1": ((x - 0.04, y - 0.04, 0.0), (x + 0.04, y + 0.04, 0.1)),
            # the sink counter's and the island's tops, as the projection world has them
            "sink_area_surface": ((1.12, -0.65, 0.82), (1.9, 1.25, 0.85)),
            "kitchen_island_surface": ((-1.2, 0.4, 0.82), (-0.55, 2.4, 0.85)),
        }
    )
    return world


def _fetch(world: Any, robot: Any, counts: dict[str, int]) -> Any:
    from executive import an, perform

    cup = world.object_pose("cup-1")

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

    return go


def test_a_floor_object_at_the_counter_is_pushed_away_from_it_first() -> None:
    """The direction comes from the kitchen geometry the belief has (the sink counter's
    footprint starts at x = 1.12): the hand comes down between the counter and the cup
    and moves away from the counter (-x), in short steps, before the fetch drives to a
    pick-up pose; the push is counted."""
    from conftest import make_robot

    world = _world_at_the_counter(Pose((0.96, 0.6, 0.05)))
    robot = make_robot(world)
    counts: dict[str, int] = {}
    robot.run(_fetch(world, robot, counts))
    assert counts.get("pushes") == 1 and "push-infeasible" not in counts
    tcps = [m.reference().arguments for m in robot.calls("arms", "moving-tcp")]
    contact = [a.get("collision_mode") == "allow-all" for a in tcps]
    first = contact.index(True)
    line = tcps[first : first + contact[first:].index(False)]  # the push (then the grasp)
    assert len(line) >= 10  # 1 cm at a time
    hands = [a["left"] or a["right"] for a in line]
    xs = [h.position[0] for h in hands]
    assert xs[0] > 1.0 and xs[-1] < xs[0] - 0.15  # from behind the cup, away from the counter
    assert all(b <= a + 1e-9 for a, b in itertools.pairwise(xs))
    assert all(abs(h.position[2] - 0.04) < 1e-6 for h in hands)  # low: it slides, not tips


def test_a_push_that_no_arm_reaches_is_a_counted_typed_refusal_before_moving(
    caplog: pytest.LogCaptureFixture,
) -> None:
    """No arm reaches the push in the belief: nothing is pushed (no contact motion),
    the refusal says why and is counted (``push-infeasible``), and the fetch then tries
    from where the cup lies (here: out of reach, ``ObjectUnreachableOnFloor``)."""
    import logging

    from conftest import make_robot

    from plans.fetch import ObjectUnreachableOnFloor
    from plans.pushing import ObjectUnpushable, plan_push

    world = _world_at_the_counter(Pose((0.96, 0.6, 0.05)))
    robot = make_robot(world)
    world.fail_probe["arm"] = {n: True for n in range(1, 10_000)}
    counts: dict[str, int] = {}
    with caplog.at_level(logging.WARNING, logger="plans.pushing"):
        with pytest.raises(ObjectUnreachableOnFloor):
            robot.run(_fetch(world, robot, counts))
    assert counts.get("push-infeasible") == 1 and "pushes" not in counts
    assert counts.get("floor-unreachable") == 1
    assert not [
        m
        for m in robot.calls("arms", "moving-tcp")
        if m.reference().arguments.get("collision_mode") == "allow-all"
    ]
    assert any("cannot be pushed away" in r.getMessage() for r in caplog.records)

    async def ask() -> None:
        plan_push("cup-1", (-1.0, 0.0), 0.2)

    with pytest.raises(ObjectUnpushable, match="no base pose and arm push it"):
        robot.run(ask)


def _refused_before_moving(fix: str, **keys: object) -> None:
    """A ``pushing-object`` of the cup at the counter with the designator ``keys`` raises
    :class:`DesignatorInputError` matching ``fix``, and neither the base nor an arm moved."""
    from conftest import make_robot

    from executive import DesignatorInputError, an, perform

    world = _world_at_the_counter(Pose((0.96, 0.6, 0.05)))
    robot = make_robot(world)

    async def go() -> None:
        await perform(
            an.action(
                type="pushing-object",
                object=an.object(type="cup", name="cup-1", pose=world.object_pose("cup-1")),
                **keys,
            )
        )

    with pytest.raises(DesignatorInputError, match=fix):
        robot.run(go)
    assert robot.calls("navigation") == [] and robot.calls("arms") == []


@pytest.mark.parametrize(
    ("direction", "distance", "fix"),
    [((0.0, 0.0), 0.2, "non-zero x/y vector"), ((1.0, 0.0), -0.1, "distance must be > 0")],
)
def test_a_bad_push_is_a_typed_error_naming_what_to_fix_before_moving(
    direction: tuple[float, float], distance: float, fix: str
) -> None:
    _refused_before_moving(fix, direction=direction, distance=distance)


@pytest.mark.parametrize(
    ("angles", "fix"),
    [((), "angles is a non-empty tuple of radians"), ((1.5,), "within 80 degrees")],
)
def test_bad_push_angles_are_a_typed_error_naming_what_to_fix_before_moving(
    angles: tuple[float, ...], fix: str
) -> None:
    """``angles`` (the directions a push may take, from the one asked for; the overhang
    push asks for exactly one): empty, or as far as sideways, is refused before anything
    moves."""
    _refused_before_moving(fix, direction=(1.0, 0.0), distance=0.2, angles=angles)
