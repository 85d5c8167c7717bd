"""The cleanup's sealing (issue 23, item 3) on the fake robot: a drawer is closed by
however far the world model has it open, with a free hand, and never for longer than
:data:`plans.environment_access.SEAL_TIMEOUT`."""

from __future__ import annotations

import asyncio
from typing import Any

import pytest
from conftest import DRAWER, make_robot

from executive import (
    ContainerStates,
    EnvironmentManipulationImpossible,
    Pose,
    a,
    an,
    current_environment,
    emit,
)
from executive.events import ContainerClosed, ObjectAttached
from executive.testing import InMemoryWorld
from plans.environment_access import SEAL_TIMEOUT, seal_if_open

DRAWER_LINK = "sink_area_left_upper_drawer_main"
LOCATION = a.location(("side", "front"), in_=DRAWER)


class _DrawerWorld(InMemoryWorld):
    """The fake world, also answering :class:`executive.ContainerStates` from its
    ``joint_states`` (travel 0..0.48 m)."""

    def container_state(self, link_or_joint: str) -> tuple[float, float, float]:
        if link_or_joint != DRAWER_LINK:
            raise LookupError(link_or_joint)
        return self.joint_states.get(link_or_joint, 0.0), 0.0, 0.48


def _world(cup_world: InMemoryWorld, opened: float) -> _DrawerWorld:
    world = _DrawerWorld(
        objects={n: o.pose for n, o in cup_world.objects.items()},
        types={n: o.type for n, o in cup_world.objects.items() if o.type is not None},
        links=cup_world.links,
        robot=cup_world.robot,
    )
    world.joint_states[DRAWER_LINK] = opened
    assert isinstance(world, ContainerStates)
    return world


def _closings(world: InMemoryWorld) -> list[ContainerClosed]:
    return [e for e in world.events if isinstance(e, ContainerClosed)]


def test_a_half_open_drawer_is_closed_by_its_opening(cup_world):
    world = _world(cup_world, 0.12)
    robot = make_robot(world)
    assert robot.run(seal_if_open, LOCATION) is True
    (closed,) = _closings(world)
    assert closed.distance == pytest.approx(0.12)
    assert world.joint_states[DRAWER_LINK] == pytest.approx(0.0)


def test_a_closed_drawer_is_left_alone(cup_world):
    world = _world(cup_world, 0.0)
    robot = make_robot(world)
    assert robot.run(seal_if_open, LOCATION) is False
    assert not _closings(world) and not robot.calls("arms")


def test_a_world_that_cannot_tell_is_sealed_only_when_the_caller_opened_it(cup_world):
    robot = make_robot(cup_world)
    assert not isinstance(cup_world, ContainerStates)
    assert robot.run(seal_if_open, LOCATION) is False
    assert not robot.calls("arms")
    assert robot.run(lambda: seal_if_open(LOCATION, assume_open=True)) is True
    assert _closings(cup_world)[0].distance == pytest.approx(0.3)


def _holding(*arms: str) -> Any:
    async def seal() -> bool:
        for arm in arms:
            emit(ObjectAttached(an.object(name="cup-1"), arm, None))
        assert {current_environment().world.object_in_hand(arm) for arm in arms} == {"cup-1"}
        return await seal_if_open(LOCATION)

    return seal


def test_the_sealing_hand_is_a_free_one(cup_world):
    """Left is the sealing arm; holding the cup there, the right hand closes the drawer."""
    world = _world(cup_world, 0.3)
    robot = make_robot(world)
    assert robot.run(_holding("left")) is True
    assert _closings(world)
    moves = [m.reference().arguments for m in robot.calls("arms", "moving-tcp")]
    assert moves and all(m["right"] is not None and m["left"] is None for m in moves)


def test_both_hands_full_is_impossible_before_anything_moves(cup_world):
    world = _world(cup_world, 0.3)
    world.add_object("cup-2", Pose((1.3, 0.4, 0.9)), type="cup")
    robot = make_robot(world)

    async def seal() -> bool:
        emit(ObjectAttached(an.object(name="cup-1"), "left", None))
        emit(ObjectAttached(an.object(name="cup-2"), "right", None))
        return await seal_if_open(LOCATION)

    with pytest.raises(EnvironmentManipulationImpossible, match="both hands hold objects"):
        robot.run(seal)
    assert not robot.calls("navigation") and not robot.calls("arms")


def test_a_sealing_that_hangs_is_cut_short(cup_world):
    """Arm motions that never end (each would take an hour): the sealing gives up after
    SEAL_TIMEOUT simulated seconds with a typed failure, and its motion is cancelled."""
    world = _world(cup_world, 0.3)
    robot = make_robot(world)
    robot.pms["arms"].delay = 3600.0

    async def timed() -> float:
        loop = asyncio.get_running_loop()
        start = loop.time()
        with pytest.raises(EnvironmentManipulationImpossible, match="did not finish within"):
            await seal_if_open(LOCATION)
        return loop.time() - start

    took = robot.run(timed)
    assert took == pytest.approx(SEAL_TIMEOUT, abs=1.0)
    assert robot.pms["arms"].cancelled
    assert not _closings(world)


def test_a_cleanup_step_that_fails_is_logged_and_counted(caplog):
    # the demo's final cleanup goes on past a failed step, and never silently: the failure
    # is logged and counted (cleanup-step-failed) in the running retry ledger
    import cpl
    from executive import NavigationGoalNotReached
    from plans import retry_ledger
    from plans.demo import _ignoring_logged

    steps: list[str] = []

    async def failing() -> None:
        steps.append("failing")
        raise NavigationGoalNotReached("the base did not get there")

    async def main() -> Any:
        with retry_ledger() as ledger:
            await _ignoring_logged("go to the origin", failing)
            steps.append("went on")
        return dict(ledger)

    with caplog.at_level("WARNING", logger="plans.demo"):
        counted = cpl.run(main)
    assert steps == ["failing", "went on"]
    assert counted == {"cleanup-step-failed": 1}
    assert "could not go to the origin" in caplog.text
