"""The simulated real robot does not knock the neighbours of what it picks (issue 13): a
neighbour standing in the arm's sweep is injected, and the plan-side check (the belief,
which knows the neighbour from perception, probed along the controller's path) makes the
fetch choose another arm or grasp instead of pushing it."""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from typing import Any

import pytest

import plans  # noqa: F401 - the action rules
from executive import Pose, a, an, current_environment, perform
from projection import FaultProfile, make_world_pair, settle, with_real_robot
from robots.pr2 import DESCRIPTION as PR2

SINK_NAV = Pose.from_xyz_yaw(0.75, 0.70, 0.0, 0.0)
CUP_LOOK = Pose((1.3, 0.6, 0.9))
NEIGHBOUR = "cereal-9"
#: On the sink counter in front of the cup: the first picking-up solution that passes the
#: waypoint checks sweeps the arm through a box standing here.
IN_THE_SWEEP = Pose((1.2, 0.5, 0.995))


def _fetch_cup(mrun: Any, swept: bool) -> tuple[float, dict[str, str]]:
    """Detect the cup from the sink and fetch it with the real robot, a cereal box in the
    sweep; returns how far the box moved in the true world and what the robot holds."""
    true, belief = make_world_pair(0)
    try:
        true.spawn_object(NEIGHBOUR, "breakfast-cereal", IN_THE_SWEEP)
        settle(true, 100)
        start = true.object_pose(NEIGHBOUR)

        async def main() -> None:
            async with with_real_robot(true, belief, FaultProfile.none()):
                current_environment().world.belief.swept = swept  # type: ignore[attr-defined]
                await perform(a.motion(type="going", pose=SINK_NAV))
                await perform(a.motion(type="looking", pose=CUP_LOOK))
                cup = await perform(a.motion(type="detecting", object=an.object(type="cup")))
                assert NEIGHBOUR in belief.objects  # perception taught the belief
                await perform(an.action(type="fetching", object=cup))

        mrun(main)
        return math.dist(true.object_pose(NEIGHBOUR).position, start.position), dict(
            true.attachments
        )
    finally:
        true.close()
        belief.close()


def test_fetching_chooses_a_reach_that_does_not_sweep_through_a_neighbour(
    mrun: Any, caplog: pytest.LogCaptureFixture
) -> None:
    with caplog.at_level(logging.INFO, logger="plans.checks"):
        moved, held = _fetch_cup(mrun, swept=True)
    assert held.get("cup-1", "").endswith("_wrist_roll_link")
    assert moved < 0.005
    assert any("sweeps through cereal-9" in r.getMessage() for r in caplog.records)


def test_checking_the_waypoints_only_pushes_the_neighbour(mrun: Any) -> None:
    """The injected knock is real: with the probe checking the waypoints only (CRAM's
    check), the same fetch pushes the box."""
    moved, held = _fetch_cup(mrun, swept=False)
    assert "cup-1" in held
    assert moved > 0.01


# ---------------------------------------------------------------- parking (test double)
def _scripted_park_probe(world: Any, ok: bool, failures: int = 1000) -> list[dict[str, Any]]:
    """The park probe: clear (``ok``), or failing its first ``failures`` calls."""
    from executive import ManipulationGoalInCollision, ProbeResult

    calls: list[dict[str, Any]] = []

    def probe(**kw: Any) -> ProbeResult:
        calls.append(kw)
        if ok or len(calls) > failures:
            return ProbeResult(True)
        return ProbeResult(False, ManipulationGoalInCollision("sweeps through bowl-1"))

    world.probe_arm_configuration = probe
    return calls


def test_a_park_that_would_sweep_through_an_object_backs_off_first(cup_world: Any) -> None:
    from conftest import make_robot

    from plans.navigation import park_clear

    robot = make_robot(cup_world)
    calls = _scripted_park_probe(cup_world, ok=False, failures=1)
    robot.run(park_clear)
    carry = {a: PR2.arm(a).state("carry") for a in ("left", "right")}
    assert calls == [carry, carry]  # re-probed after the back-off: clear
    (drive,) = robot.calls("navigation")  # the back-off, then the park
    assert drive.reference().arguments["pose"].isclose(Pose((-0.25, 0.0, 0.0)))
    (park,) = robot.calls("arms")
    assert park.reference().arguments["right"] == PR2.arm("right").state("carry")


def test_a_park_that_stays_blocked_backs_off_at_most_twice_then_parks(cup_world: Any) -> None:
    from conftest import make_robot

    from plans.navigation import PARK_BACK_OFFS, park_clear

    robot = make_robot(cup_world)
    calls = _scripted_park_probe(cup_world, ok=False)
    robot.run(park_clear)
    assert PARK_BACK_OFFS == 2 and len(calls) == PARK_BACK_OFFS
    assert len(robot.calls("navigation")) == PARK_BACK_OFFS
    assert len(robot.calls("arms")) == 1


def test_a_clear_park_parks_where_the_robot_stands(cup_world: Any) -> None:
    from conftest import make_robot

    from plans.navigation import park_clear

    robot = make_robot(cup_world)
    calls = _scripted_park_probe(cup_world, ok=True)
    robot.run(park_clear, "park")
    assert len(calls) == 1
    assert robot.calls("navigation") == []
    assert len(robot.calls("arms")) == 1


def test_a_world_model_without_the_park_probe_just_parks(cup_world: Any) -> None:
    from conftest import make_robot

    from plans.navigation import park_clear

    robot = make_robot(cup_world)
    assert not hasattr(cup_world, "probe_arm_configuration")
    robot.run(park_clear)
    assert robot.calls("navigation") == []
    assert len(robot.calls("arms")) == 1


# ------------------------------------------------------------- placing (test double)
def _held_cup_placing(cup_world: Any) -> tuple[Any, Any]:
    from conftest import make_robot
    from test_plans_fake import perceived_cup  # type: ignore[import-not-found]

    robot = make_robot(cup_world)
    robot.run(perform, an.action(type="picking-up", object=perceived_cup(cup_world), arm="right"))
    cup_world.probe_calls["arm"].clear()
    target = Pose((0.6, 0.1, 0.8), frame="base_footprint")
    return robot, an.action(type="placing", target=a.location(pose=target))


def _swept_failure() -> Any:
    from executive import ManipulationGoalInCollision, ProbeResult

    return ProbeResult(
        False, ManipulationGoalInCollision("sweeps through bowl-1", swept=("bowl-1",)), 0
    )


def test_placing_prefers_a_solution_that_sweeps_through_nothing(cup_world: Any) -> None:
    from plans.checks import check_placing_collisions

    robot, placing = _held_cup_placing(cup_world)
    cup_world.fail_probe["arm"] = {1: _swept_failure()}  # the first yaw sweeps

    async def check() -> Any:
        return check_placing_collisions(placing).reference().arguments

    chosen = robot.run(check)
    calls = cup_world.probe_calls["arm"]
    assert len(calls) == 3  # the first swept; the second passed (and its putting) was taken
    probed = (*chosen["reach_poses"], *chosen["put_poses"], *chosen["retract_poses"])
    assert calls[1] == (chosen["arm"], probed)
    assert calls[2] == (chosen["arm"], (*chosen["reach_poses"], *chosen["put_poses"]))


def test_placing_falls_back_to_clear_waypoints_when_every_solution_sweeps(
    cup_world: Any, caplog: pytest.LogCaptureFixture
) -> None:
    from plans.checks import check_placing_collisions

    robot, placing = _held_cup_placing(cup_world)
    # both solutions of a target pose (it and its yaw + pi) sweep
    cup_world.fail_probe["arm"] = {n: _swept_failure() for n in (1, 2)}

    async def check() -> Any:
        return check_placing_collisions(placing).reference().arguments

    with caplog.at_level(logging.WARNING, logger="plans.checks"):
        chosen = robot.run(check)
    calls = cup_world.probe_calls["arm"]
    assert len(calls) == 4  # 2 swept, then the first one again, its waypoints only (+ putting)
    probed = (*chosen["reach_poses"], *chosen["put_poses"], *chosen["retract_poses"])
    assert calls[2] == calls[0] == (chosen["arm"], probed)
    assert any("every solution sweeps" in r.getMessage() for r in caplog.records)


def test_placing_does_not_fall_back_past_a_real_collision(cup_world: Any) -> None:
    from executive import ObjectUnreachable
    from plans.checks import check_placing_collisions

    robot, placing = _held_cup_placing(cup_world)
    cup_world.fail_probe["arm"] = {n: True for n in (1, 2)}  # unreachable, not swept

    async def check() -> Any:
        return check_placing_collisions(placing)

    with pytest.raises(ObjectUnreachable):
        robot.run(check)
    assert len(cup_world.probe_calls["arm"]) == 2  # no second pass


@dataclass(frozen=True)
class _Contact:
    body_a: str
    link_a: str
    body_b: str
    link_b: str


def _putting_touches(*others: str) -> Any:
    """The putting probe's failure: the hand touches ``others`` at the put waypoint."""
    from executive import ManipulationGoalInCollision, ProbeResult

    contacts = tuple(_Contact("robot", "hand", other, "object") for other in others)
    return ProbeResult(False, ManipulationGoalInCollision("touches", contacts=contacts), 2)


def test_placing_passes_over_a_put_down_that_touches_another_object(cup_world: Any) -> None:
    """A hand wider than the gap to an object placed before (the Panda's, 0.2 m across
    its fingers) would push it over while setting the new one down: the put waypoint's
    contacts with other objects reject the solution; the next one is taken."""
    from plans.checks import check_placing_collisions

    robot, placing = _held_cup_placing(cup_world)
    cup_world.objects["bowl-1"] = cup_world.objects["cup-1"]  # placed before, nearby
    cup_world.object_names = lambda: sorted(cup_world.objects)  # an ObjectInventory
    # call 1: the first solution's waypoints pass; call 2: its put-down touches the bowl
    cup_world.fail_probe["arm"] = {2: _putting_touches("bowl-1")}

    async def check() -> Any:
        return check_placing_collisions(placing).reference().arguments

    chosen = robot.run(check)
    calls = cup_world.probe_calls["arm"]
    assert len(calls) == 4  # solution 1 and its putting, solution 2 and its putting
    assert calls[0] != calls[2]  # the second solution was taken
    probed = (*chosen["reach_poses"], *chosen["put_poses"], *chosen["retract_poses"])
    assert calls[2] == (chosen["arm"], probed)


def test_placing_lets_the_put_down_touch_the_environment(cup_world: Any) -> None:
    """The object (or the hand) touching its support at the put waypoint is no reason to
    refuse: only contacts with other objects are."""
    from plans.checks import check_placing_collisions

    robot, placing = _held_cup_placing(cup_world)
    cup_world.object_names = lambda: sorted(cup_world.objects)  # an ObjectInventory
    cup_world.fail_probe["arm"] = {2: _putting_touches("kitchen")}

    async def check() -> Any:
        return check_placing_collisions(placing).reference().arguments

    chosen = robot.run(check)
    calls = cup_world.probe_calls["arm"]
    assert len(calls) == 2  # the first solution and its putting: taken
    probed = (*chosen["reach_poses"], *chosen["put_poses"], *chosen["retract_poses"])
    assert calls[0] == (chosen["arm"], probed)
