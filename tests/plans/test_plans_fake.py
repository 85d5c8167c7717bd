"""Every plan against the fakes: the recovery it claims and the failure it raises when its
retries run out, with CRAM HEAD's counts."""

from __future__ import annotations

import math
from typing import Any

import pytest
from conftest import DRAWER, HANDLE, PR2, make_robot

import cpl
import executive
from executive import (
    ContainerOpeningProbe,
    EnvironmentManipulationImpossible,
    GripperClosedCompletely,
    LookingHighLevelFailure,
    ManipulationGoalInCollision,
    ManipulationPoseUnreachable,
    NavigationGoalInCollision,
    NavigationPoseUnreachable,
    ObjectNowhereToBeFound,
    ObjectUndeliverable,
    ObjectUnfetchable,
    PerceptionObjectNotFound,
    Pose,
    ProbeResult,
    PtuGoalNotReached,
    a,
    an,
    knowledge,
    perform,
)
from executive.events import ContainerClosed, ContainerOpened, ObjectAttached, RobotStateChanged
from executive.testing import InMemoryWorld
from plans import retry_ledger
from plans.pick_place import placing_waypoints

CUP = Pose((1.3, 0.6, 0.9))

#: The PR2-like robot's standard-gripper -> tool rotation (both arms have the same).
TOOL = PR2.arm("right").standard_to_tool


def perceived_cup(world: InMemoryWorld) -> executive.ObjectDesignator:
    return an.object(
        type="cup",
        name="cup-1",
        pose=CUP,
        transform=world.object_pose("cup-1", "base_footprint").to_transform("cup-1"),
    )


# ------------------------------------------------------------------------- atomic actions
def test_going_propagates_navigation_failure_and_emits_state_change(cup_world):
    robot = make_robot(cup_world, navigation={1: NavigationPoseUnreachable})
    with pytest.raises(NavigationPoseUnreachable):
        robot.run(perform, an.action(type="going", target=Pose((1, 0, 0))))
    assert len(robot.calls("navigation")) == 1  # counter 0: no retry
    assert any(isinstance(e, RobotStateChanged) for e in cup_world.events)


def test_looking_keeps_heads_zero_retries(cup_world):
    robot = make_robot(cup_world, ptu={1: PtuGoalNotReached})
    with pytest.raises(PtuGoalNotReached):
        robot.run(perform, an.action(type="looking", target=Pose((1, 0, 1))))
    assert len(robot.calls("ptu")) == 1


def test_detecting_retries_four_times_then_propagates(cup_world):
    robot = make_robot(cup_world, perception={i: PerceptionObjectNotFound for i in range(1, 6)})
    with pytest.raises(PerceptionObjectNotFound):
        robot.run(perform, an.action(type="detecting", object=an.object(type="cup")))
    assert len(robot.calls("perception")) == 5


def test_detecting_equates_and_returns_the_result(cup_world):
    robot = make_robot(cup_world, perception={1: PerceptionObjectNotFound})
    obj = an.object(type="cup")
    found = robot.run(perform, an.action(type="detecting", object=obj))
    assert found.get("name") == "cup-1" and obj.current() is found
    assert cup_world.perceived == [found]


def test_arm_sequence_ignores_intermediate_failures_only(cup_world):
    poses = (Pose((0.5, 0, 1), frame="base_footprint"), Pose((0.6, 0, 1), frame="base_footprint"))
    robot = make_robot(cup_world, arms={1: ManipulationPoseUnreachable})
    robot.run(perform, an.action(type="reaching", left_poses=poses))
    assert len(robot.calls("arms")) == 2
    robot = make_robot(cup_world, arms={2: ManipulationPoseUnreachable})
    with pytest.raises(ManipulationPoseUnreachable):
        robot.run(perform, an.action(type="lifting", left_poses=poses, right_poses=poses[:1]))
    first = robot.calls("arms")[0].reference().arguments
    assert first["left"] == poses[0] and first["right"] == poses[0]


def test_gripping_regrips_once(cup_world):
    robot = make_robot(cup_world, grippers={1: GripperClosedCompletely})
    robot.run(perform, an.action(type="gripping", gripper="left", effort=50.0))
    robot = make_robot(cup_world, grippers={1: GripperClosedCompletely, 2: GripperClosedCompletely})
    with pytest.raises(GripperClosedCompletely):
        robot.run(perform, an.action(type="gripping", gripper="left"))
    robot = make_robot(cup_world, grippers={1: GripperClosedCompletely})
    robot.run(perform, an.action(type="releasing", gripper="left"))  # ignored


def test_positioning_arm_uses_knowledge_and_ignores_failures(cup_world):
    robot = make_robot(cup_world, arms={1: ManipulationPoseUnreachable})
    robot.run(perform, an.action(type="positioning-arm", left_configuration="park"))
    args = robot.calls("arms")[0].reference().arguments
    assert args["left"] == PR2.arm("left").state("park") and args["right"] is None


# ------------------------------------------------------------------------ pick and place
def test_picking_up_solutions_are_arm_major_grasp_minor(cup_world):
    robot = make_robot(cup_world)

    async def solutions():
        action = an.action(type="picking-up", object=perceived_cup(cup_world))
        return [
            (g.arguments["arm"], g.arguments["grasp"], g.arguments["reach_poses"])
            for g in action.solutions()
        ]

    grasps = knowledge.grasps("cup")
    found = robot.run(solutions)
    # each arm and grasp twice: straight, then from above (plans.pick_place._approaches)
    assert [(arm, g) for arm, g, _ in found] == [
        (arm, g) for arm in ("right", "left") for g in grasps for _ in range(2)
    ]
    for (_, _, straight), (_, _, above) in zip(found[::2], found[1::2]):
        assert len(straight) == 2 and above[1:] == straight
        assert above[0].position[2] == pytest.approx(straight[0].position[2] + 0.2)
        assert above[0].position[:2] == pytest.approx(straight[0].position[:2])


class _Reversed:
    """Preferences that put the rules' last (arm, grasp) first."""

    def __init__(self) -> None:
        self.asked: list[tuple[str, str]] = []

    def order_choices(self, action, obj, choices):
        self.asked.append((action, obj))
        return list(reversed(choices))


def _pick_choices(robot) -> list[tuple[str, str]]:
    async def solutions():
        action = an.action(type="picking-up", object=perceived_cup(robot.world))
        return [(g.arguments["arm"], g.arguments["grasp"]) for g in action.solutions()]

    return robot.run(solutions)[::2]  # each pair twice (straight, from above)


def test_picking_up_solutions_follow_the_environments_preferences(cup_world):
    robot = make_robot(cup_world)
    robot.preferences = _Reversed()
    rules_order = [(arm, g) for arm in ("right", "left") for g in knowledge.grasps("cup")]
    assert _pick_choices(robot) == list(reversed(rules_order))
    assert robot.preferences.asked == [("picking-up", "cup")]


def test_preferences_may_only_reorder(cup_world):
    class Adding:
        def order_choices(self, action, obj, choices):
            return [*choices, ("right", "made-up")]

    robot = make_robot(cup_world)
    robot.preferences = Adding()
    with pytest.raises(TypeError, match="reordering"):
        _pick_choices(robot)


def test_picking_up_sequence_and_attachment(cup_world):
    robot = make_robot(cup_world)
    action = an.action(type="picking-up", object=perceived_cup(cup_world), arm="left")
    robot.run(perform, action)
    types = [m.type for m in robot.pms["arms"].calls]
    assert types == ["moving-tcp"] * 5
    attached = [e for e in cup_world.events if isinstance(e, ObjectAttached)]
    assert attached[0].arm == "left" and cup_world.object_in_hand("left") == "cup-1"
    arguments = action.reference().arguments
    assert isinstance(arguments, dict)
    expected = knowledge.grasp_poses(
        "cup", "back", arguments["object_designator"]["transform"], TOOL
    )
    assert robot.calls("arms")[4].reference().arguments["left"] == expected[4]


def test_picking_up_propagates_grip_failure(cup_world):
    robot = make_robot(cup_world, grippers={2: GripperClosedCompletely, 3: GripperClosedCompletely})
    with pytest.raises(GripperClosedCompletely):
        robot.run(
            perform, an.action(type="picking-up", object=perceived_cup(cup_world), arm="left")
        )
    assert cup_world.attached() == []


def test_placing_derives_the_grasp_from_the_object_in_hand(cup_world):
    """Quirk fixed: a cup picked with its *front* grasp is placed with the front grasp (HEAD
    used the type's first grasp, back)."""
    robot = make_robot(cup_world)
    action = an.action(
        type="picking-up", object=perceived_cup(cup_world), arm="right", grasp="front"
    )
    robot.run(perform, action)
    target = Pose((0.6, 0.1, 0.8), frame="base_footprint")

    async def grounding():
        return an.action(type="placing", target=a.location(pose=target)).reference()

    ground = robot.run(grounding)
    assert ground.arguments["grasp"] == "front" and ground.arguments["arm"] == "right"
    nominal = knowledge.grasp_poses("cup", "front", target.to_transform(), TOOL)
    assert ground.arguments["put_poses"][0].isclose(nominal[2], 1e-6, 1e-6)
    robot.run(perform, an.action(type="placing", target=a.location(pose=target)))
    assert cup_world.attached() == []
    assert cup_world.object_pose("cup-1", "base_footprint").isclose(target, 1e-6, 1e-6)


def test_placing_waypoints_match_grasp_poses():
    obj_t_tool = knowledge.grasp_poses("bowl", "top", Pose().to_transform(), TOOL)[2].to_transform()
    target = Pose.from_xyz_yaw(0.7, 0.1, 0.8, 0.3, frame="base_footprint")
    name, poses = placing_waypoints("bowl", obj_t_tool, target, TOOL)
    assert name == "top"
    for got, want in zip(poses, knowledge.grasp_poses("bowl", "top", target.to_transform(), TOOL)):
        assert got.isclose(want, 1e-6, 1e-6)


# --------------------------------------------------------------------- navigating/turning
def test_navigating_skips_blocked_samples(cup_world):
    robot = make_robot(cup_world)
    target = Pose((2.0, 0.0, 0.0))
    cup_world.blocked_poses = [Pose((1.5, 0, 0)), Pose((1.4, 0, 0))]
    loc = a.location(reachable_for="pr2", location=a.location(pose=target))
    robot.run(perform, an.action(type="navigating", location=loc))
    assert cup_world.robot_pose().isclose(Pose((1.3, 0, 0)))
    assert len(cup_world.probe_calls["base"]) == 3


def test_navigating_gives_up_after_thirty_samples(cup_world):
    robot = make_robot(cup_world)
    cup_world.fail_probe["base"] = {n: True for n in range(1, 100)}
    loc = a.location(reachable_for="pr2", location=a.location(pose=Pose((2, 0, 0))))
    with pytest.raises(NavigationGoalInCollision):
        robot.run(perform, an.action(type="navigating", location=loc))
    assert len(cup_world.probe_calls["base"]) == 31  # the first sample and 30 retries
    assert robot.calls("navigation") == []


def test_turning_towards_turns_the_base_on_a_ptu_failure(cup_world):
    robot = make_robot(cup_world, ptu={1: PtuGoalNotReached})
    robot.run(perform, an.action(type="turning-towards", target=a.location(pose=Pose((0, 2, 1)))))
    assert math.isclose(cup_world.robot_pose().yaw, math.pi / 2)
    looks = [m.get("direction") or m.get("target") for m in robot.calls("ptu")]
    assert len(looks) == 3 and looks[1] == "forward"


def test_turning_towards_gives_up_after_one_turn(cup_world):
    robot = make_robot(cup_world, ptu={1: PtuGoalNotReached, 3: PtuGoalNotReached})
    with pytest.raises(LookingHighLevelFailure):
        robot.run(perform, an.action(type="turning-towards", target=Pose((0, 2, 1))))
    assert len(robot.calls("navigation")) == 1


# ------------------------------------------------------------------------------ searching
def test_searching_looks_again_from_the_raised_torso(cup_world):
    # the detecting action retries 4x (5 calls); then the search raises the torso once
    robot = make_robot(cup_world, perception={i: PerceptionObjectNotFound for i in range(1, 6)})
    found = robot.run(
        perform,
        an.action(type="searching", object=an.object(type="cup"), location=a.location(spots=3)),
    )
    assert found.get("name") == "cup-1"
    looked_at = [m.get("target").reference() for m in robot.calls("ptu")]
    assert [p.position[1] for p in looked_at] == [0.0, 0.0]
    (torso,) = robot.calls("torso")
    assert torso.get("joint-angle") == pytest.approx(0.33)


def test_searching_walks_the_search_locations(cup_world):
    # both looks at the first spot fail (2 x 5 calls): the search moves to the next spot
    robot = make_robot(cup_world, perception={i: PerceptionObjectNotFound for i in range(1, 11)})
    found = robot.run(
        perform,
        an.action(type="searching", object=an.object(type="cup"), location=a.location(spots=3)),
    )
    assert found.get("name") == "cup-1"
    looked_at = [m.get("target").reference() for m in robot.calls("ptu")]
    assert [p.position[1] for p in looked_at] == [0.0, 0.0, pytest.approx(0.2)]


def test_searching_gives_up_after_nine_retries(cup_world):
    robot = make_robot(cup_world, perception={i: PerceptionObjectNotFound for i in range(1, 999)})

    async def search():
        with retry_ledger() as ledger:
            try:
                await perform(
                    an.action(
                        type="searching",
                        object=an.object(type="cup"),
                        location=a.location(spots=20),
                    )
                )
            finally:
                counts.update(ledger)

    counts: dict[str, int] = {}
    with pytest.raises(ObjectNowhereToBeFound):
        robot.run(search)
    assert counts["search"] == 9 and counts["search-torso"] == 10
    assert len(robot.calls("perception")) == 10 * 2 * 5  # 10 spots, 2 looks, 5 detections


# ------------------------------------------------------------------------------- fetching
def fetch(robot, world, **props):
    return robot.run(perform, an.action(type="fetching", object=perceived_cup(world), **props))


def test_fetching_relocates_when_no_pick_solution_is_reachable(cup_world):
    robot = make_robot(cup_world)
    # all 20 (arm, grasp, approach) fail: 2 arms x the cup's 5 grasps x straight/above
    cup_world.fail_probe["arm"] = {n: True for n in range(1, 21)}
    fetch(robot, cup_world)
    drives = [m.reference().arguments["pose"] for m in robot.calls("navigation", "going")]
    # the second base pose, then the back-off before the arms are parked
    assert [round(p.position[0], 2) for p in drives] == [0.8, 0.7, 0.45]
    assert cup_world.object_in_hand("right") == "cup-1"  # 21st probe: right arm, back grasp


def test_fetching_uses_the_next_grasp_then_the_other_arm(cup_world):
    robot = make_robot(cup_world)
    # the right arm's solutions, then the left back grasp's (each straight and from above)
    cup_world.fail_probe["arm"] = {n: True for n in range(1, 11)}
    fetch(robot, cup_world)
    assert cup_world.object_in_hand("left") == "cup-1"
    attached = next(e for e in cup_world.events if isinstance(e, ObjectAttached))
    assert attached.arm == "left"


def test_fetching_regrasps_once_after_gripper_failures(cup_world):
    # gripping fails twice (the grip's own regrip), regrasp, then succeeds
    robot = make_robot(cup_world, grippers={2: GripperClosedCompletely, 3: GripperClosedCompletely})

    async def go():
        with retry_ledger() as ledger:
            await perform(an.action(type="fetching", object=perceived_cup(cup_world)))
            return dict(ledger)

    ledger = robot.run(go)
    assert ledger["regrasps"] == 1 and "relocations" not in ledger
    assert cup_world.object_in_hand("right") == "cup-1"


def test_fetching_gives_up_after_exactly_ten_relocations(cup_world):
    robot = make_robot(cup_world)
    cup_world.fail_probe["arm"] = {n: True for n in range(1, 1000)}

    async def go():
        with retry_ledger() as ledger:
            try:
                await perform(an.action(type="fetching", object=perceived_cup(cup_world)))
            finally:
                counts.update(ledger)

    counts: dict[str, int] = {}
    with pytest.raises(ObjectUnfetchable):
        robot.run(go)
    assert counts["relocations"] == 10
    assert len(robot.calls("navigation", "going")) == 11


# ----------------------------------------------------------------------------- delivering
def holding_cup(world):
    robot = make_robot(world)
    robot.run(perform, an.action(type="picking-up", object=perceived_cup(world), arm="left"))
    return robot


def targets(n):
    return a.location(spots=n)


def test_delivering_takes_the_next_target_when_a_pose_is_unstable(cup_world):
    robot = holding_cup(cup_world)
    cup_world.unstable_poses = [Pose((1.0, 0.0, 0.8))]
    robot.run(
        perform,
        an.action(type="delivering", object=an.object(name="cup-1", type="cup"), target=targets(5)),
    )
    assert cup_world.attached() == []
    assert cup_world.object_pose("cup-1").isclose(Pose((1.0, 0.2, 0.8)), 1e-6, 1e-6)


def test_delivering_counts(cup_world):
    """Every placing check fails: target scope 2 retries per relocation, 5 relocations
    per outer attempt, 2 outer retries -> ObjectUndeliverable."""
    robot = holding_cup(cup_world)
    cup_world.fail_probe["arm"] = {n: True for n in range(1, 1000)}

    async def go():
        with retry_ledger() as ledger:
            try:
                await perform(
                    an.action(
                        type="delivering",
                        object=an.object(name="cup-1", type="cup"),
                        target=targets(200),
                    )
                )
            finally:
                counts.update(ledger)

    counts: dict[str, int] = {}
    with pytest.raises(ObjectUndeliverable) as failure:
        robot.run(go)
    # the failure names what was tried and why the last try failed
    assert (
        "no delivery pose reached from 18 base pose(s) navigated to, 54 placing target(s) "
        "checked there; last: ObjectUnreachable" in str(failure.value)
    )
    assert counts["deliver-targets"] == 2
    assert counts["relocations"] == 3 * 5
    assert counts["targets"] == 3 * 6 * 2
    # each placing check probes the 8 placing yaws of a round type (cup), each reached
    # straight and from above
    assert len(cup_world.probe_calls["arm"]) == 3 * 6 * 3 * 8 * 2


# --------------------------------------------------------------------- accessing/sealing
def test_accessing_relocates_then_opens_the_drawer(cup_world):
    robot = make_robot(cup_world)
    cup_world.fail_probe["arm"] = {1: True}
    location = a.location(("side", "front"), in_=DRAWER)
    robot.run(perform, an.action(type="accessing", location=location, distance=0.3))
    assert len(robot.calls("navigation", "going")) == 2
    opened = [e for e in cup_world.events if isinstance(e, ContainerOpened)]
    assert opened[0].distance == 0.3
    assert cup_world.joint_states["sink_area_left_upper_drawer_main"] == 0.3


class _PushingDrawerWorld(InMemoryWorld):
    """A fake world model that also answers the optional opening probe: opening the
    drawer from the first ``pushes`` base poses would push it into the robot."""

    def __init__(self, pushes: int, **kw: Any) -> None:
        super().__init__(**kw)
        self.pushes = pushes
        self.opening_probes: list[tuple[Any, float, str]] = []

    def probe_container_opening(self, container: Any, distance: float, arm: str) -> ProbeResult:
        self.opening_probes.append((container, distance, arm))
        if len(self.opening_probes) <= self.pushes:
            return ProbeResult(False, ManipulationGoalInCollision("into the right forearm"))
        return ProbeResult(True)


def test_accessing_relocates_when_the_drawer_would_be_pushed_into_the_robot(cup_world):
    world = _PushingDrawerWorld(
        2,
        objects={n: o.pose for n, o in cup_world.objects.items()},
        types={n: o.type for n, o in cup_world.objects.items()},
        links=cup_world.links,
        robot=cup_world.robot,
    )
    assert isinstance(world, ContainerOpeningProbe)
    robot = make_robot(world)
    location = a.location(("side", "front"), in_=DRAWER)
    robot.run(perform, an.action(type="accessing", location=location, distance=0.3))
    assert len(world.opening_probes) == 3 and world.opening_probes[0][1:] == (0.3, "left")
    assert len(robot.calls("navigation", "going")) == 3  # two relocations
    opened = [e for e in world.events if isinstance(e, ContainerOpened)]
    assert len(opened) == 1 and world.joint_states["sink_area_left_upper_drawer_main"] == 0.3


def test_accessing_gives_up_after_ten_relocations_then_five_with_the_other_arm(cup_world):
    from plans.environment_access import ENVIRONMENT_RELOCATIONS, OTHER_ARM_RELOCATIONS

    robot = make_robot(cup_world)
    cup_world.fail_probe["arm"] = {n: True for n in range(1, 1000)}
    with pytest.raises(EnvironmentManipulationImpossible, match=r"^cannot open .*left, right"):
        robot.run(perform, an.action(type="accessing", location=a.location(in_=DRAWER)))
    arms = [call[0] for call in cup_world.probe_calls["arm"]]
    assert arms == ["left"] * (ENVIRONMENT_RELOCATIONS + 1) + ["right"] * (
        OTHER_ARM_RELOCATIONS + 1
    )


def test_accessing_without_a_handle_is_impossible():
    world = InMemoryWorld(robot=PR2)
    robot = make_robot(world)
    with pytest.raises(EnvironmentManipulationImpossible, match=r"^cannot close "):
        robot.run(perform, an.action(type="sealing", location=a.location(in_=DRAWER)))
    assert HANDLE not in world.links


# ---------------------------------------------------------------------------- transporting
def test_transport_evaporated_after_opening_still_closes_the_drawer(cup_world):
    robot = make_robot(cup_world)
    robot.pms["perception"].delay = 5.0  # searching takes a while

    async def go():
        transport = cpl.spawn(
            perform(
                an.action(
                    type="transporting",
                    object=an.object(type="cup"),
                    location=a.location(in_=DRAWER),
                    target=targets(3),
                )
            ),
            name="transport",
        )
        while not any(isinstance(e, ContainerOpened) for e in cup_world.events):
            await cpl.sleep(0.5)
        transport.evaporate()
        assert await transport.join() is None

    robot.run(go)
    assert any(isinstance(e, ContainerClosed) for e in cup_world.events)
    assert cup_world.joint_states["sink_area_left_upper_drawer_main"] == pytest.approx(0.0)


def test_transport_drops_at_the_sink_when_undeliverable(cup_world):
    robot = make_robot(cup_world)
    cup_world.fail_probe["stability"] = {n: True for n in range(1, 1000)}
    result = robot.run(
        perform,
        an.action(
            type="transporting",
            object=an.object(type="cup"),
            location=a.location(spots=1),
            target=targets(3),
        ),
    )
    assert result is None and cup_world.attached() == []
    assert cup_world.robot_pose().isclose(Pose((0.7, -0.2, 0.0)))


def test_dropping_at_the_sink_checks_its_placing_first(cup_world):
    """Seeds 5, 7 and 9: the drop's first placing solution had no IK, and the milk,
    released in ``carry`` beside the robot, leaned against it and was dragged along by
    every later drive. The drop's placing is probed like a delivery's: the first
    solution is unreachable, the next one is performed."""
    from plans.deliver import drop_at_sink

    robot = holding_cup(cup_world)
    before = len(robot.calls("arms"))
    cup_world.probe_calls["arm"].clear()
    cup_world.fail_probe["arm"] = {1: True}
    robot.run(drop_at_sink, an.object(name="cup-1", type="cup"))
    probes = cup_world.probe_calls["arm"]
    # the first solution fails; the second passes, and then its release is probed
    assert len(probes) == 3 and probes[2][1] == probes[1][1][: len(probes[2][1])]
    moved = [
        m.reference().arguments["left"]
        for m in robot.calls("arms")[before:]
        if m.type == "moving-tcp"
    ]
    assert any(p.isclose(probes[1][1][0]) for p in moved)  # the second solution's reach
    assert not any(p.isclose(probes[0][1][0]) for p in moved)  # not the unreachable one
    assert cup_world.attached() == []
