"""The simulated real robot does not knock the neighbours of what it picks (issue 13): a
neighbour standing in the arm's sweep is injected, and the plan-side check (the belief,
which knows the neighbour from perception, probed along the controller's path) makes the
fetch choose another arm or grasp instead of pushing it."""

from __future__ import annotations

import logging
import math
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
    sweep; returns how far the box moved in the true world and what the robot holds. Arm
    motion planning is off in both worlds: the controller's router reaches straight, as
    the sweep check was built for (with planning on, OMPL's path goes around the box and
    neither check nor robot meets it: tests/projection/test_projected_arm_paths.py)."""
    true, belief = make_world_pair(0)
    true.arm_motion_planning = belief.arm_motion_planning = False
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


def test_a_park_that_stays_blocked_backs_off_at_most_twice_then_parks_arm_by_arm(
    cup_world: Any, caplog: pytest.LogCaptureFixture
) -> None:
    from conftest import make_robot

    from plans.navigation import PARK_BACK_OFFS, park_clear

    robot = make_robot(cup_world)
    calls = _scripted_park_probe(cup_world, ok=False)
    with caplog.at_level(logging.WARNING, logger="plans.navigation"):
        robot.run(park_clear)
    both = [c for c in calls if len(c) == 2]
    assert PARK_BACK_OFFS == 2 and len(both) == PARK_BACK_OFFS + 1  # re-probed after each
    assert len(robot.calls("navigation")) == PARK_BACK_OFFS
    # still blocked: one arm at a time (each probed alone), parked anyway, logged
    parks = [p.reference().arguments for p in robot.calls("arms")]
    assert [sorted(a for a in ("left", "right") if p[a]) for p in parks] == [["right"], ["left"]]
    assert sum("although it sweeps" in r.getMessage() for r in caplog.records) == 2


def _park_clear_for_one_arm_alone(world: Any, robot: Any) -> list[dict[str, Any]]:
    """Both arms together sweep, and so does the left arm alone until the right one is
    parked (an arm moved); the right arm alone is clear."""
    from executive import ManipulationGoalInCollision, ProbeResult

    calls: list[dict[str, Any]] = []

    def probe(**kw: Any) -> ProbeResult:
        calls.append(kw)
        right_parked = bool(robot.calls("arms"))
        if list(kw) == ["right"] or (list(kw) == ["left"] and right_parked):
            return ProbeResult(True)
        return ProbeResult(False, ManipulationGoalInCollision("sweeps through milk-1"))

    world.probe_arm_configuration = probe
    return calls


def test_a_park_blocked_for_both_arms_parks_the_clear_arm_first(
    cup_world: Any, caplog: pytest.LogCaptureFixture
) -> None:
    """Seed 2: no backing off from the sink (the robot would collide behind), and both
    arms at once swept the milk off the counter; the right arm alone is clear, and with
    it parked the left one is too."""
    from conftest import make_robot

    from executive import NavigationGoalInCollision, ProbeResult
    from plans.navigation import park_clear

    robot = make_robot(cup_world)
    calls = _park_clear_for_one_arm_alone(cup_world, robot)
    cup_world.probe_base_pose = lambda pose: ProbeResult(
        False, NavigationGoalInCollision("behind: the island")
    )
    with caplog.at_level(logging.WARNING, logger="plans.navigation"):
        robot.run(park_clear)
    assert robot.calls("navigation") == []  # nowhere to back off to
    parks = [p.reference().arguments for p in robot.calls("arms")]
    assert parks[0]["right"] == PR2.arm("right").state("carry") and not parks[0]["left"]
    assert parks[1]["left"] == PR2.arm("left").state("carry") and not parks[1]["right"]
    assert [sorted(c) for c in calls] == [["left", "right"], ["right"], ["left"], ["left"]]
    assert not any("although it sweeps" in r.getMessage() for r in caplog.records)


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
    # the first swept; the second passed and was taken (then its release probed: 3rd)
    assert len(calls) == 3
    probed = (*chosen["reach_poses"], *chosen["put_poses"], *chosen["retract_poses"])
    assert calls[1] == (chosen["arm"], probed)
    assert calls[2] == (chosen["arm"], (*chosen["reach_poses"], *chosen["put_poses"]))


def test_placing_falls_back_to_clear_waypoints_when_every_solution_sweeps(
    cup_world: Any, caplog: pytest.LogCaptureFixture
) -> None:
    from plans.checks import check_placing_collisions

    robot, placing = _held_cup_placing(cup_world)
    # all four solutions of a target pose (it and its yaw + pi, each reached straight
    # and from above) sweep
    cup_world.fail_probe["arm"] = {n: _swept_failure() for n in (1, 2, 3, 4)}

    async def check() -> Any:
        return check_placing_collisions(placing).reference().arguments

    with caplog.at_level(logging.WARNING, logger="plans.checks"):
        chosen = robot.run(check)
    calls = cup_world.probe_calls["arm"]
    # 4 swept, then the first one again, its waypoints only, and its release
    assert len(calls) == 6
    probed = (*chosen["reach_poses"], *chosen["put_poses"], *chosen["retract_poses"])
    assert calls[4] == calls[0] == (chosen["arm"], probed)
    assert any("every solution sweeps" in r.getMessage() for r in caplog.records)


def test_placing_reaches_from_above_when_both_straight_reaches_sweep(cup_world: Any) -> None:
    """Seed 3: the straight reaches of the spoon's and the cereal's placings swept through
    the objects placed before; the same target and yaw reached from 0.1 m above is the
    next solution (after the yaw + pi variant), not the swept one taken anyway."""
    from plans.checks import check_placing_collisions
    from plans.pick_place import PLACE_APPROACH_HEIGHT

    robot, placing = _held_cup_placing(cup_world)
    cup_world.fail_probe["arm"] = {n: _swept_failure() for n in (1, 2)}

    async def check() -> Any:
        return check_placing_collisions(placing).reference().arguments

    chosen = robot.run(check)
    calls = cup_world.probe_calls["arm"]
    assert len(calls) == 4  # 2 swept, the third passed, its release
    first_reach = calls[0][1][:2]
    above, *rest = chosen["reach_poses"]
    assert tuple(rest) == first_reach  # the first solution's reach, from above
    assert above.position[2] == pytest.approx(first_reach[0].position[2] + PLACE_APPROACH_HEIGHT)
    assert above.position[:2] == pytest.approx(first_reach[0].position[:2])


def test_placing_does_not_fall_back_past_a_real_collision(cup_world: Any) -> None:
    from executive import ObjectUnreachable
    from plans.checks import check_placing_collisions

    robot, placing = _held_cup_placing(cup_world)
    # all four solutions unreachable, not swept
    cup_world.fail_probe["arm"] = {n: True for n in (1, 2, 3, 4)}

    async def check() -> Any:
        return check_placing_collisions(placing)

    with pytest.raises(ObjectUnreachable):
        robot.run(check)
    assert len(cup_world.probe_calls["arm"]) == 4  # no second pass


def test_delivering_tries_the_next_target_before_taking_a_swept_placing(
    cup_world: Any, caplog: pytest.LogCaptureFixture
) -> None:
    """Seeds 3, 4 and 6: from the first base poses, a placing whose every solution
    sweeps through an object placed before is refused (STRICT_STANDS): the next target
    is tried, and its clear placing is taken; nothing swept is performed."""
    from conftest import make_robot
    from test_plans_fake import perceived_cup

    robot = make_robot(cup_world)
    robot.run(perform, an.action(type="picking-up", object=perceived_cup(cup_world), arm="left"))
    cup_world.probe_calls["arm"].clear()
    solutions = 16  # the cup's 8 placing yaws, each straight and from above
    cup_world.fail_probe["arm"] = {n: _swept_failure() for n in range(1, solutions + 1)}
    with caplog.at_level(logging.INFO, logger="plans.checks"):
        robot.run(
            perform,
            an.action(
                type="delivering",
                object=an.object(name="cup-1", type="cup"),
                target=a.location(spots=3),
            ),
        )
    calls = cup_world.probe_calls["arm"]
    # all of the first target's swept, the next clear (and its release)
    assert len(calls) == solutions + 2
    assert any("not taking one here" in r.getMessage() for r in caplog.records)
    assert not any("taking one whose waypoints" in r.getMessage() for r in caplog.records)
    assert cup_world.attached() == []


def test_a_park_takes_a_configuration_per_arm(cup_world: Any) -> None:
    """The final cleanup parks a holding arm to ``carry`` and a free one to ``park``:
    probed and moved with each arm's own configuration."""
    from functools import partial

    from conftest import make_robot

    from plans.navigation import park_clear

    robot = make_robot(cup_world)
    calls = _scripted_park_probe(cup_world, ok=True)
    robot.run(partial(park_clear, {"left": "park", "right": "carry"}))
    wanted = {"left": PR2.arm("left").state("park"), "right": PR2.arm("right").state("carry")}
    assert calls == [wanted]
    (park,) = robot.calls("arms")
    assert park.reference().arguments["left"] == wanted["left"]
    assert park.reference().arguments["right"] == wanted["right"]


def test_a_park_for_arms_the_robot_lacks_fails_before_anything_moves(cup_world: Any) -> None:
    from functools import partial

    from conftest import make_robot

    from executive import DesignatorInputError
    from plans.navigation import park_clear

    robot = make_robot(cup_world)
    calls = _scripted_park_probe(cup_world, ok=True)
    with pytest.raises(DesignatorInputError, match=r"for each arm of the robot"):
        robot.run(partial(park_clear, {"left": "park", "middle": "carry"}))
    assert calls == [] and not robot.calls("arms") and not robot.calls("navigation")
