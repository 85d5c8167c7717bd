"""Resources: what two concurrent goals on one robot part do (executive._resources).

An action claims the parts its plan registered for its whole duration; a goal from a task
outside its subtree that needs one fails at once with ResourceConflict, before it reaches
a process module; motions outside any action keep CRAM's one-goal-at-a-time queueing."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest

import cpl
from executive import (
    DesignatorError,
    HighLevelFailure,
    LowLevelFailure,
    Pose,
    Resource,
    ResourceConflict,
    ResourceKind,
    RuleSet,
    a,
    an,
    environment,
    perform,
    with_process_modules,
)
from executive.testing import FakeProcessModule

LEFT = Pose((0.4, 0.2, 1.0), frame="base_footprint")
RIGHT = Pose((0.4, -0.2, 1.0), frame="base_footprint")


@cpl.plan(name="reach")
async def reach(arm: str, pose: Pose) -> str:
    """Move one arm's tool to ``pose`` (a moving-tcp motion)."""
    await perform(a.motion(type="moving-tcp", **{f"{arm}_pose": pose}))
    return f"{arm} at {pose.position}"


@cpl.plan(name="grab")
async def grab(arm: str, pose: Pose) -> str:
    """Open the gripper and reach, together (sub-actions of the claiming action), then
    close the gripper."""
    await cpl.par(
        perform(an.action(type="opening-hand", gripper=arm)),
        perform(an.action(type="reaching", arm=arm, pose=pose)),
    )
    await perform(a.motion(type="gripping", gripper=arm))
    return f"grabbed with {arm}"


@cpl.plan(name="open-hand")
async def open_hand(gripper: str) -> None:
    await perform(a.motion(type="opening-gripper", gripper=gripper))


@cpl.plan(name="drive")
async def drive(pose: Pose) -> None:
    await perform(a.motion(type="going", pose=pose))


@cpl.plan(name="watch")
async def watch(seconds: float) -> None:
    """Keep the head still for ``seconds`` (a shared use of the head)."""
    await cpl.sleep(seconds)


@cpl.plan(name="two-reaches")
async def two_reaches(arm: str) -> None:
    """Two sub-actions on one arm at once, inside an action that claims it."""
    await cpl.par(
        perform(an.action(type="reaching", arm=arm, pose=LEFT)),
        perform(an.action(type="reaching", arm=arm, pose=RIGHT)),
    )


def hand(args: Any) -> tuple[Resource, ...]:
    return Resource.arm(args["arm"]), Resource.gripper(args["arm"])


def make_rules() -> RuleSet:
    rules = RuleSet()

    def reaching(d: Any) -> Iterator[Any]:
        yield reach, {"arm": d["arm"], "pose": d["pose"]}

    def grabbing(d: Any) -> Iterator[Any]:
        yield grab, {"arm": d["arm"], "pose": d["pose"]}

    def opening(d: Any) -> Iterator[Any]:
        yield open_hand, {"gripper": d["gripper"]}

    def going(d: Any) -> Iterator[Any]:
        yield drive, {"pose": d["pose"]}

    def watching(d: Any) -> Iterator[Any]:
        yield watch, {"seconds": d["seconds"]}

    def reaching_twice(d: Any) -> Iterator[Any]:
        yield two_reaches, {"arm": d["arm"]}

    rules.register("action", "reaching", reaching)
    rules.register("action", "grabbing", grabbing)
    rules.register("action", "opening-hand", opening)
    rules.register("action", "going", going)
    rules.register("action", "watching", watching)
    rules.register("action", "reaching-twice", reaching_twice)
    rules.register_resources(reach, lambda args: (Resource.arm(args["arm"]),))
    rules.register_resources(grab, hand)
    rules.register_resources(open_hand, lambda args: (Resource.gripper(args["gripper"]),))
    rules.register_resources(drive, lambda _args: (Resource.base(),))
    rules.register_resources(watch, lambda _args: (Resource.head(),), shared=True)
    rules.register_resources(two_reaches, lambda args: (Resource.arm(args["arm"]),))
    return rules


ARMS = frozenset({Resource.arm("left"), Resource.arm("right")})
GRIPPERS = frozenset({Resource.gripper("left"), Resource.gripper("right")})


def modules(delay: float = 1.0, arms: frozenset[Resource] = ARMS) -> dict[str, FakeProcessModule]:
    return {
        "arms": FakeProcessModule("arms", accepts={"moving-tcp"}, delay=delay, resources=arms),
        "grippers": FakeProcessModule(
            "grippers",
            accepts={"opening-gripper", "gripping"},
            delay=delay,
            resources=GRIPPERS,
        ),
        "navigation": FakeProcessModule(
            "navigation", accepts="going", delay=delay, resources={Resource.base()}
        ),
        "ptu": FakeProcessModule("ptu", accepts="looking", delay=delay),
    }


def run(mrun: Any, pms: dict[str, FakeProcessModule], body: Any, name: str = "run") -> Any:
    async def main() -> Any:
        async with environment(rules=make_rules(), process_modules=pms.values()):
            return await body()

    return mrun(main, name=name)


def tool_goals(pm: FakeProcessModule) -> list[tuple[Any, Any]]:
    return [(m.get("left-pose"), m.get("right-pose")) for m in pm.calls]


# --------------------------------------------------------------------------- the value
def test_resource_values_name_their_part_or_say_what_is_wrong() -> None:
    assert Resource.arm("left") == Resource(ResourceKind.ARM, "left")
    assert str(Resource.arm("left")) == "arm 'left'" and str(Resource.base()) == "base"
    assert repr(Resource.gripper("right")) == "Resource.gripper('right')"
    with pytest.raises(ValueError, match=r"names its part: Resource.arm\('left'\)"):
        Resource(ResourceKind.ARM)
    with pytest.raises(ValueError, match="a robot has one base"):
        Resource(ResourceKind.BASE, "front")
    with pytest.raises(TypeError, match=r"executive\.ResourceKind"):
        Resource("arm", "left")  # type: ignore[arg-type]


def test_register_resources_checks_its_arguments() -> None:
    rules = RuleSet()
    with pytest.raises(TypeError, match="plan function an action rule yields or a motion"):
        rules.register_resources(42, lambda args: ())
    with pytest.raises(TypeError, match="function of the grounding's arguments"):
        rules.register_resources(reach, "arm")  # type: ignore[arg-type]
    with rules.restoring():
        rules.register_resources(reach, lambda args: ())
        assert rules.resources_for(reach) is not None
        assert rules.child().resources_for(reach) is not None  # a child sees it
    assert rules.resources_for(reach) is None  # restored
    frozen = RuleSet(parent=None, name="frozen")
    frozen.freeze()
    with pytest.raises(RuntimeError, match="frozen"):
        frozen.register_resources(reach, lambda args: ())


def test_the_conflict_is_neither_a_low_nor_a_high_level_failure() -> None:
    # handlers that ignore (perform_ignoring) or retry those never swallow it
    assert not issubclass(ResourceConflict, (LowLevelFailure, HighLevelFailure))
    assert issubclass(ResourceConflict, cpl.PlanFailure)


# ---------------------------------------------------------------------- two actions
def test_two_actions_on_one_arm_fail_before_the_second_moves(mrun: Any) -> None:
    pms = modules()

    async def body() -> Any:
        return await cpl.par(
            perform(an.action(type="reaching", arm="left", pose=LEFT)),
            perform(an.action(type="reaching", arm="left", pose=RIGHT)),
        )

    with pytest.raises(ResourceConflict) as caught:
        run(mrun, pms, body, name="conflict")
    failure = caught.value
    assert failure.resource == Resource.arm("left")
    assert failure.task != failure.holder_task  # both tasks are named
    assert "reaching" in failure.goal and "reaching" in failure.holder
    message = str(failure)
    assert "needs the arm 'left'" in message
    assert "one after the other" in message and "(right is free)" in message
    # the conflict came before either reached the arm module (the winner yields between
    # its claim and its plan: the par evaporated it there)
    assert pms["arms"].calls == []


def test_two_arms_work_together(mrun: Any) -> None:
    pms = modules()

    async def body() -> Any:
        return await cpl.par(
            perform(an.action(type="grabbing", arm="left", pose=LEFT)),
            perform(an.action(type="grabbing", arm="right", pose=RIGHT)),
        )

    assert run(mrun, pms, body) == ["grabbed with left", "grabbed with right"]
    assert sorted(map(str, tool_goals(pms["arms"]))) == sorted(
        map(str, [(LEFT, None), (None, RIGHT)])
    )
    assert len(pms["grippers"].completed) == 4  # two openings, two grips


def test_an_action_and_a_gripper_action_on_one_hand_conflict(mrun: Any) -> None:
    pms = modules()

    async def body() -> Any:
        return await cpl.par(
            perform(an.action(type="grabbing", arm="left", pose=LEFT)),
            perform(an.action(type="opening-hand", gripper="left")),
        )

    with pytest.raises(ResourceConflict, match="needs the gripper 'left'"):
        run(mrun, pms, body)
    assert pms["grippers"].calls == [] and pms["arms"].calls == []


def test_two_goings_conflict_on_the_base(mrun: Any) -> None:
    pms = modules()
    far = Pose((3.0, 0.0, 0.0))

    async def body() -> Any:
        return await cpl.par(
            perform(an.action(type="going", pose=Pose((1.0, 0.0, 0.0)))),
            perform(an.action(type="going", pose=far)),
        )

    with pytest.raises(ResourceConflict, match="needs the base"):
        run(mrun, pms, body)
    assert pms["navigation"].calls == []


def test_a_bare_motion_from_outside_fails_while_an_action_holds_the_arm(mrun: Any) -> None:
    pms = modules()

    async def body() -> Any:
        return await cpl.par(
            perform(an.action(type="reaching", arm="left", pose=LEFT)),
            perform(a.motion(type="moving-tcp", left_pose=RIGHT)),
        )

    with pytest.raises(ResourceConflict, match=r"motion \(type moving-tcp\).*arm 'left'"):
        run(mrun, pms, body)
    assert (RIGHT, None) not in tool_goals(pms["arms"])


def test_an_action_fails_on_an_arm_a_bare_motion_is_moving(mrun: Any) -> None:
    pms = modules()

    async def body() -> Any:
        return await cpl.par(
            perform(a.motion(type="moving-tcp", left_pose=RIGHT)),
            perform(an.action(type="reaching", arm="left", pose=LEFT)),
        )

    with pytest.raises(ResourceConflict, match="needs the arm 'left'"):
        run(mrun, pms, body)
    assert (LEFT, None) not in tool_goals(pms["arms"])


# ------------------------------------------------------------- inside one action
def test_the_claiming_actions_subtree_uses_its_parts_freely(mrun: Any) -> None:
    # grab claims the left arm and gripper; its par of two sub-actions (gripper, arm) and
    # its own motions run inside the claim
    pms = modules()

    async def body() -> Any:
        return await perform(an.action(type="grabbing", arm="left", pose=LEFT))

    assert run(mrun, pms, body, name="grab") == "grabbed with left"
    assert [m.type for m in pms["grippers"].completed] == ["opening-gripper", "gripping"]
    assert tool_goals(pms["arms"]) == [(LEFT, None)]


def test_two_sibling_sub_actions_on_one_arm_conflict_inside_the_claim(mrun: Any) -> None:
    # the innermost holder decides: the first reaching holds the arm within the claim of
    # reaching-twice, and its sibling is outside the first reaching's subtree
    pms = modules()

    async def body() -> Any:
        return await perform(an.action(type="reaching-twice", arm="left"))

    with pytest.raises(ResourceConflict, match="needs the arm 'left'"):
        run(mrun, pms, body)
    assert (None, RIGHT) not in tool_goals(pms["arms"])
    assert (RIGHT, None) not in tool_goals(pms["arms"])


def test_claims_end_with_the_action_also_when_it_fails(mrun: Any) -> None:
    pms = modules()
    pms["arms"].fail_on = {1: LowLevelFailure}

    async def body() -> Any:
        with pytest.raises(LowLevelFailure):
            await perform(an.action(type="reaching", arm="left", pose=LEFT))
        with pytest.raises(ResourceConflict):
            await cpl.par(
                perform(an.action(type="reaching", arm="left", pose=LEFT)),
                perform(an.action(type="reaching", arm="left", pose=RIGHT)),
            )
        # after the failure and the evaporation, the arm is free again: in sequence both run
        await perform(an.action(type="reaching", arm="left", pose=LEFT))
        return await perform(an.action(type="reaching", arm="left", pose=RIGHT))

    assert run(mrun, pms, body) == f"left at {RIGHT.position}"


def test_a_derived_environment_shares_the_claims(mrun: Any) -> None:
    pms = modules()
    extra = FakeProcessModule("extra", accepts="moving-arm-joints")

    async def second() -> None:
        async with with_process_modules(extra):
            await perform(an.action(type="reaching", arm="left", pose=RIGHT))

    async def body() -> Any:
        return await cpl.par(perform(an.action(type="reaching", arm="left", pose=LEFT)), second())

    with pytest.raises(ResourceConflict):
        run(mrun, pms, body)


# ------------------------------------------------------------------- without actions
def test_bare_motions_on_one_module_keep_crams_queue(mrun: Any) -> None:
    # outside any action nothing is claimed: one goal at a time, FIFO (CRAM's pm-execute)
    pms = modules(delay=1.0)

    async def body() -> Any:
        await cpl.par(
            perform(a.motion(type="moving-tcp", left_pose=LEFT)),
            perform(a.motion(type="moving-tcp", left_pose=RIGHT)),
        )

    run(mrun, pms, body)
    assert [m.get("left-pose") for m in pms["arms"].completed] == [LEFT, RIGHT]


def test_parts_of_a_kind_no_module_declares_are_not_checked(mrun: Any) -> None:
    # the fake ptu declares no head: looking uses the head, unchecked, and, as no action
    # claims it, two lookings queue
    pms = modules()

    async def body() -> Any:
        await cpl.par(
            perform(a.motion(type="looking", direction="forward")),
            perform(a.motion(type="looking", direction="forward")),
        )

    run(mrun, pms, body)
    assert len(pms["ptu"].completed) == 2


# ------------------------------------------------------------------------ shared use
def test_shared_claims_coexist_and_conflict_with_an_exclusive_one(mrun: Any) -> None:
    pms = modules()

    async def together() -> Any:
        await cpl.par(
            perform(an.action(type="watching", seconds=1.0)),
            perform(an.action(type="watching", seconds=2.0)),
            perform(a.motion(type="looking", direction="forward")),
        )

    run(mrun, pms, together)
    assert len(pms["ptu"].completed) == 1

    async def against_a_look() -> Any:
        await cpl.par(
            perform(an.action(type="watching", seconds=1.0)),
            perform(an.action(type="looking-exclusively")),
        )

    @cpl.plan(name="look-hard")
    async def look_hard() -> None:
        await perform(a.motion(type="looking", direction="forward"))

    async def main() -> Any:
        rules = make_rules()
        rules.register("action", "looking-exclusively", lambda d: iter([(look_hard, {})]))
        rules.register_resources(look_hard, lambda _args: (Resource.head(),))
        async with environment(rules=rules, process_modules=modules().values()):
            await against_a_look()

    with pytest.raises(ResourceConflict, match="needs the head"):
        mrun(main)


# ------------------------------------------------------------------------ robot parts
def test_a_part_the_robot_does_not_have_is_a_designator_error(mrun: Any) -> None:
    pms = modules(arms=frozenset({Resource.arm("right")}))

    async def body() -> Any:
        await perform(an.action(type="reaching", arm="left", pose=LEFT))

    with pytest.raises(DesignatorError, match=r"needs the arm 'left', which this robot does not"):
        run(mrun, pms, body)
    assert pms["arms"].calls == []


def test_environment_parts_are_its_modules_parts(mrun: Any) -> None:
    pms = modules()

    async def body() -> Any:
        from executive import current_environment

        return current_environment().resources

    assert run(mrun, pms, body) == ARMS | GRIPPERS | {Resource.base()}


def test_a_handler_answers_the_conflict_by_sequencing_the_goals(mrun: Any) -> None:
    # the conflict is a plan failure raised before anything moved: a handler can do what
    # it says (perform them one after the other) and both goals happen, in order
    pms = modules()
    goals = [an.action(type="reaching", arm="left", pose=pose) for pose in (LEFT, RIGHT)]
    handled: list[BaseException] = []

    async def together() -> Any:
        return await cpl.par(*(perform(goal) for goal in goals))

    async def one_after_the_other(failure: BaseException) -> None:
        handled.append(failure)
        assert pms["arms"].calls == []  # nothing moved before the handler
        cpl.return_([await perform(goal) for goal in goals])

    async def body() -> Any:
        return await cpl.with_failure_handling(together, [(ResourceConflict, one_after_the_other)])

    assert run(mrun, pms, body) == [f"left at {LEFT.position}", f"left at {RIGHT.position}"]
    assert tool_goals(pms["arms"]) == [(LEFT, None), (RIGHT, None)]
    assert [type(f) for f in handled] == [ResourceConflict]
