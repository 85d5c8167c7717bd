"""Knocked objects (issue 26): an object the real robot's motion moves in the true world
is counted once, with the motion that moved it; an object's own pick-up and placing move
it without a knock; a move while only perception runs is a drift, not a knock."""

from __future__ import annotations

import math
from typing import Any

import pytest

import cpl
import plans  # noqa: F401 - the action rules
from aiocram.knocks import KNOCK_ANGLE, KNOCK_DISTANCE, KnockWatcher
from executive import Pose, a, an, current_environment, perform
from projection import FaultProfile, make_world_pair, settle, with_real_robot

SINK_NAV = Pose.from_xyz_yaw(0.75, 0.70, 0.0, 0.0)
CUP_LOOK = Pose((1.3, 0.6, 0.9))
NEIGHBOUR = "cereal-9"
#: On the sink counter in front of the cup: a reach checked at its waypoints only (not
#: along its sweep) passes the arm through a box standing here (tests/plans/test_knocks.py).
IN_THE_SWEEP = Pose((1.2, 0.5, 0.995))
#: Well away from the cup on the sink counter: nothing the robot does here reaches it.
ASIDE = Pose((1.6, -0.4, 0.995))


@pytest.fixture
def worlds() -> Any:
    true, belief = make_world_pair(0)
    yield true, belief
    true.close()
    belief.close()


def _run(
    mrun: Any,
    true: Any,
    belief: Any,
    body: Any,
    *extra: cpl.Instrument,
    first: tuple[cpl.Instrument, ...] = (),
) -> KnockWatcher:
    """Run ``body`` on the real robot with a watcher; ``first``: instruments that see each
    transition before the watcher, ``extra`` after it."""
    watcher = KnockWatcher(true)

    async def main() -> None:
        async with with_real_robot(true, belief, FaultProfile.none()) as env:
            watcher.subscribe(env)
            await body()

    mrun(main, instruments=[*first, watcher, *extra])
    return watcher


async def _detect_cup() -> Any:
    await perform(a.motion(type="going", pose=SINK_NAV))
    await perform(a.motion(type="looking", pose=CUP_LOOK))
    return await perform(a.motion(type="detecting", object=an.object(type="cup")))


def test_a_neighbour_swept_by_the_reach_is_knocked_once_by_that_reach(
    mrun: Any, worlds: Any
) -> None:
    """The arm's reach for the cup sweeps through a cereal box (the plan's sweep check and
    arm motion planning are off: the controller's router reaches straight through it):
    the box is knocked, once, by a moving-tcp of the arm that picks the cup up; the cup,
    moved by its own pick-up, is not."""
    true, belief = worlds
    true.arm_motion_planning = belief.arm_motion_planning = False
    true.spawn_object(NEIGHBOUR, "breakfast-cereal", IN_THE_SWEEP)
    settle(true, 100)
    start = true.object_pose(NEIGHBOUR).position

    async def body() -> None:
        current_environment().world.belief.swept = False  # type: ignore[attr-defined]
        cup = await _detect_cup()
        await perform(an.action(type="fetching", object=cup))

    watcher = _run(mrun, true, belief, body)
    report = watcher.report()
    held = true.attachments.get("cup-1")
    assert held is not None  # the cup was picked up (its own pick-up moved it)
    assert math.dist(true.object_pose(NEIGHBOUR).position, start) > KNOCK_DISTANCE
    assert report.knocked == [NEIGHBOUR]
    (knock,) = report.knocks
    assert knock.motion.kind == "moving-tcp"
    assert knock.motion.action == "picking-up" and knock.motion.subject == "cup-1"
    (arm,) = knock.motion.arms
    assert held.startswith(arm[0] + "_")  # the arm that reached is the arm that holds
    assert knock.distance > KNOCK_DISTANCE or knock.angle > KNOCK_ANGLE
    assert report.drifted == []
    row = report.to_json()
    assert row["knocked"] == [NEIGHBOUR] and row["knocks"][0]["motion"] == "moving-tcp"


def test_own_pick_up_and_placing_knock_nothing(mrun: Any, worlds: Any) -> None:
    """Fetch the cup and put it back down on the counter: the cup moves a lot (lifted,
    carried, placed), a box standing aside does not; nothing is knocked."""
    true, belief = worlds
    true.spawn_object(NEIGHBOUR, "breakfast-cereal", ASIDE)
    settle(true, 100)
    cup_start = true.object_pose("cup-1").position

    async def body() -> None:
        cup = await _detect_cup()
        fetched = await perform(an.action(type="fetching", object=cup))
        target = a.location(pose=Pose(cup_start))
        await perform(an.action(type="delivering", object=fetched, target=target))

    watcher = _run(mrun, true, belief, body)
    report = watcher.report()
    assert "cup-1" not in true.attachments  # placed
    assert true.object_pose("cup-1").position[2] > 0.85  # on the counter again
    assert report.knocks == [] and report.knocked == []


def test_a_teleport_during_an_arm_motion_is_a_knock_by_that_motion(mrun: Any, worlds: Any) -> None:
    """An injected push: while the left arm moves, a box across the counter is moved
    3 cm in the true world. It is counted once, by that arm motion; the base's drive
    before it and the torso motion after it knock nothing."""
    true, belief = worlds
    true.spawn_object(NEIGHBOUR, "breakfast-cereal", ASIDE)
    settle(true, 100)
    carry = true.robot.arm("left").state("carry")

    async def push_midway() -> None:
        await cpl.sleep(0.3)
        p = true.object_pose(NEIGHBOUR)
        x, y, z = p.position
        true.set_object_pose(NEIGHBOUR, Pose((x + 0.03, y, z), p.orientation))

    async def body() -> None:
        await perform(a.motion(type="going", pose=SINK_NAV))
        arm = a.motion(
            type="moving-arm-joints",
            left_joint_states=carry,
        )
        await cpl.par(perform(arm), push_midway())
        await perform(a.motion(type="moving-torso", joint_angle=0.1))

    watcher = _run(mrun, true, belief, body)
    report = watcher.report()
    assert report.knocked == [NEIGHBOUR]
    (knock,) = report.knocks
    assert (knock.motion.kind, knock.motion.arms) == ("moving-arm-joints", ("left",))
    assert knock.motion.action is None  # a bare motion, inside no action
    assert knock.distance == pytest.approx(0.03, abs=0.005)


def test_a_move_while_only_perception_runs_is_a_drift(mrun: Any, worlds: Any) -> None:
    true, belief = worlds
    true.spawn_object(NEIGHBOUR, "breakfast-cereal", ASIDE)
    settle(true, 100)

    async def push_midway() -> None:
        await cpl.sleep(0.1)
        p = true.object_pose(NEIGHBOUR)
        x, y, z = p.position
        true.set_object_pose(NEIGHBOUR, Pose((x, y + 0.05, z), p.orientation))

    async def body() -> None:
        await perform(a.motion(type="going", pose=SINK_NAV))
        await perform(a.motion(type="looking", pose=CUP_LOOK))
        detect = a.motion(type="detecting", object=an.object(type="cup"))
        await cpl.par(perform(detect), push_midway())

    report = _run(mrun, true, belief, body).report()
    assert report.knocks == []
    assert report.drifted == [NEIGHBOUR]


def test_tolerances_are_checked() -> None:
    with pytest.raises(ValueError, match="distance"):
        KnockWatcher(object(), distance=0.0)
    with pytest.raises(ValueError, match="angle"):
        KnockWatcher(object(), angle=-1.0)


class _TurnDuring(cpl.Instrument):
    """Turns object ``name`` by ``angle`` rad about the vertical in the true world when
    the first real ``moving-tcp`` inside an ``action`` starts while the cup is free (an
    injected push, during that motion: the watcher, an instrument before this one, has
    taken its checkpoint). In a ``placing`` that is the retract, after the release."""

    def __init__(self, true: Any, action: str, name: str, angle: float = 0.15) -> None:
        self.true, self.action, self.name, self.angle = true, action, name, angle
        self.done = False

    def task_status_changed(self, task: Any, old: Any, new: Any) -> None:
        from executive import action_of

        motion = (task.annotations or {}).get("motion")
        if self.done or new is not cpl.Status.RUNNING or motion is None:
            return
        if motion.type != "moving-tcp" or cpl.within(task, cpl.Subtree.IMAGINED):
            return
        if self.action == "placing" and "cup-1" in self.true.attachments:
            return  # not released yet
        t = task
        while t is not None and getattr(action_of(t), "type", None) != self.action:
            t = t.parent
        if t is None:
            return
        self.done = True
        p = self.true.object_pose(self.name)
        turn = Pose.from_xyz_yaw(0.0, 0.0, 0.0, self.angle).as_rotation()
        self.true.set_object_pose(
            self.name, Pose(p.position, tuple((turn * p.as_rotation()).as_quat()))
        )


@pytest.mark.parametrize("turned", ["cup-1", "bowl-1"])
def test_a_push_during_the_cups_pick_up_knocks_a_neighbour_not_the_cup(
    mrun: Any, worlds: Any, turned: str
) -> None:
    """The same injected push during the reach for the cup: the cup's own pick-up moving
    the cup is no knock (counted as ``own``); moving the bowl beside it is one, by that
    reach."""
    true, belief = worlds

    async def body() -> None:
        cup = await _detect_cup()
        await perform(an.action(type="fetching", object=cup))

    injector = _TurnDuring(true, "picking-up", turned)
    report = _run(mrun, true, belief, body, injector).report()
    assert injector.done
    assert "cup-1" in true.attachments
    if turned == "cup-1":
        assert report.knocks == []
        assert report.own == ["cup-1"]
    else:
        assert report.knocked == ["bowl-1"]
        (knock,) = report.knocks
        assert knock.motion.kind == "moving-tcp" and knock.motion.subject == "cup-1"
        assert knock.motion.action == "picking-up"
        assert knock.angle == pytest.approx(0.15, abs=0.03)


@pytest.mark.parametrize("turned", ["cup-1", "bowl-1"])
def test_an_object_moving_as_its_own_placing_retracts_is_not_knocked(
    mrun: Any, worlds: Any, turned: str
) -> None:
    """The decision for an object placed unstably: one that moves after its release
    while its own placing retracts (injected: turned 0.3 rad) is a placing failure, not
    a knock (``own``; the truth measures it toppled or not delivered). The bowl moved by
    the same retract is knocked by it."""
    true, belief = worlds
    cup_start = true.object_pose("cup-1").position  # put back where it stood

    async def body() -> None:
        cup = await _detect_cup()
        fetched = await perform(an.action(type="fetching", object=cup))
        target = a.location(pose=Pose(cup_start))
        await perform(an.action(type="delivering", object=fetched, target=target))

    injector = _TurnDuring(true, "placing", turned, angle=0.3)
    report = _run(mrun, true, belief, body, injector).report()
    assert injector.done and "cup-1" not in true.attachments
    if turned == "cup-1":
        assert report.knocks == [] and report.own == ["cup-1"]
    else:
        assert report.knocked == ["bowl-1"]
        (knock,) = report.knocks
        assert (knock.motion.action, knock.motion.subject) == ("placing", "cup-1")


class _BoxInTheHand(cpl.Instrument):
    """When the first real ``moving-arm-joints`` ends, spawns a box overlapping the
    right gripper in the true world (before the watcher sees the end)."""

    def __init__(self, true: Any) -> None:
        self.true, self.done = true, False

    def task_status_changed(self, task: Any, old: Any, new: Any) -> None:
        motion = (task.annotations or {}).get("motion")
        if self.done or not new.dead or motion is None or motion.type != "moving-arm-joints":
            return
        self.done = True
        frame = self.true.robot.arm("right").tool_frame
        self.true.spawn_object(
            NEIGHBOUR, "breakfast-cereal", self.true.link_pose(frame), allow_overlap=True
        )


def test_an_object_left_pressed_by_a_motion_is_knocked_by_that_motion(
    mrun: Any, worlds: Any
) -> None:
    """The right arm's motion ends pressing into a box (injected: the box appears in the
    gripper as the motion ends); the physics pushes the box out only during the next
    motion, the left gripper closing. The knock is the right arm's, the closing is
    listed beside it."""
    true, belief = worlds
    carry = true.robot.arm("right").state("carry")

    async def body() -> None:
        await perform(a.motion(type="moving-arm-joints", right_joint_states=carry))
        await perform(a.motion(type="closing-gripper", gripper="left"))

    injector = _BoxInTheHand(true)
    report = _run(mrun, true, belief, body, first=(injector,)).report()
    assert injector.done
    assert report.knocked == [NEIGHBOUR]
    (knock,) = report.knocks
    assert (knock.motion.kind, knock.motion.arms) == ("moving-arm-joints", ("right",))
    assert [(m.kind, m.arms) for m in knock.others] == [("closing-gripper", ("left",))]


class _Throw(cpl.Instrument):
    """When the first real ``closing-gripper`` starts, throws the box up at 6 m/s in the
    true world (after the watcher's checkpoint): it flies and falls for about 1.2 s."""

    def __init__(self, true: Any) -> None:
        self.true, self.done = true, False

    def task_status_changed(self, task: Any, old: Any, new: Any) -> None:
        import pybullet as pb

        motion = (task.annotations or {}).get("motion")
        if self.done or new is not cpl.Status.RUNNING or motion is None:
            return
        if motion.type != "closing-gripper":
            return
        self.done = True
        body = self.true.body_of(NEIGHBOUR)
        pb.resetBaseVelocity(
            body, (0.0, 0.0, 6.0), (0.0, 0.0, 0.0), physicsClientId=self.true.client
        )


def test_an_object_still_moving_from_a_knock_is_not_knocked_again(mrun: Any, worlds: Any) -> None:
    """A box set flying during a short gripper motion (injected) is still in the air
    when the next motions start: it is knocked once, by the gripper motion; its fall
    during the next motions continues that knock."""
    true, belief = worlds
    true.spawn_object(NEIGHBOUR, "breakfast-cereal", ASIDE)
    settle(true, 100)

    async def body() -> None:
        await perform(a.motion(type="closing-gripper", gripper="left"))
        for _ in range(4):
            await perform(a.motion(type="opening-gripper", gripper="right"))
            await perform(a.motion(type="closing-gripper", gripper="right"))

    injector = _Throw(true)
    report = _run(mrun, true, belief, body, injector).report()
    assert injector.done
    assert report.knocked == [NEIGHBOUR]
    (knock,) = report.knocks
    assert (knock.motion.kind, knock.motion.arms) == ("closing-gripper", ("left",))


# ------------------------------------------------------------------- the campaign
def _record(seed: int, proj: bool, knocks: list[tuple[str, str, list[str], str]]) -> Any:
    """A run record as the demo writes it, with ``knocks``: (object, motion, arms,
    action)."""
    from aiocram.campaign import INVARIANTS

    return {
        "seed": seed,
        "fault_rate": 0.0,
        "projection": proj,
        "objects": {"o": {"claimed": True, "delivered": True, "where": "island"}},
        "invariants": dict.fromkeys(INVARIANTS, True),
        "violations": {},
        "knocked": list(dict.fromkeys(k[0] for k in knocks)),
        "knocks": [
            {"object": o, "motion": m, "arms": arms, "action": act} for o, m, arms, act in knocks
        ],
        "drifted": [],
    }


def test_the_campaign_counts_knocked_objects_per_cell_and_by_motion() -> None:
    from aiocram.campaign import knock_lines, summarise

    runs = [
        _record(
            1,
            True,
            [
                ("cup-1", "moving-tcp", ["right"], "picking-up"),
                ("cup-1", "going", [], "navigating"),  # the same object again
                ("bowl-1", "moving-tcp", ["right"], "placing"),
            ],
        ),
        _record(2, True, []),
        _record(1, False, [("milk-1", "moving-arm-joints", ["left"], "parking-arms")]),
        {  # a crashed run: nothing measured, counts zero
            "seed": 2,
            "fault_rate": 0.0,
            "projection": False,
            "error": "RuntimeError: x",
            "objects": {},
            "planned": ["o"],
            "invariants": {},
        },
    ]
    rows = {r["projection"]: r for r in summarise(runs)["rows"]}
    assert (rows[True]["knocked"], rows[True]["knocks"], rows[True]["runs_knocking"]) == (2, 3, 1)
    assert rows[True]["knocked_by"] == {"going": 1, "moving-tcp right": 2}
    assert rows[True]["knocked_in"] == {"navigating": 1, "picking-up": 1, "placing": 1}
    assert (rows[False]["knocked"], rows[False]["runs_knocking"]) == (1, 1)
    assert knock_lines(summarise(runs)["rows"]) == [
        "knocked (without projection, faults 0): moving-arm-joints left 1",
        "knocked (with projection, faults 0): moving-tcp right 2, going 1",
    ]


# ----------------------------------------------------------------------- the demo
def test_the_demo_reports_a_knock_in_its_record_and_summary() -> None:
    """A plan handed to the demo drives the base while a box beside the route is pushed
    in the true world: the report, its JSON record (what the campaign aggregates) and
    the console summary name the box and the drive."""
    from rich.console import Console

    from aiocram.demo import DemoConfig, print_report, run_demo

    async def drive_past_a_push(world: Any, config: Any) -> dict[str, Any]:
        world.spawn_object(NEIGHBOUR, "breakfast-cereal", ASIDE)

        async def push() -> None:
            await cpl.sleep(0.5)
            p = world.object_pose(NEIGHBOUR)
            x, y, z = p.position
            world.set_object_pose(NEIGHBOUR, Pose((x, y - 0.04, z), p.orientation))

        await cpl.par(perform(a.motion(type="going", pose=SINK_NAV)), push())
        return {}

    config = DemoConfig(objects=("bowl",), seed=1, live=False, projection=False)
    report = run_demo(config, plan=drive_past_a_push)
    assert report.knocks is not None and report.knocks.knocked == [NEIGHBOUR]
    record = report.to_json()
    assert record["knocked"] == [NEIGHBOUR]
    assert [(k["object"], k["motion"]) for k in record["knocks"]] == [(NEIGHBOUR, "going")]
    console = Console(width=100, record=True, color_system=None)
    print_report(report, console)
    text = console.export_text()
    assert "1 object knocked by the robot (true world; each knock is in plans.log):" in text
    assert f"  {NEIGHBOUR}: once, by going" in text
