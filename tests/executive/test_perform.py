"""perform: motions to process modules, actions to plans, and the errors."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest

import cpl
from executive import (
    DesignatorError,
    GripperClosedCompletely,
    ManipulationPoseUnreachable,
    NavigationPoseUnreachable,
    NoProcessModule,
    Pose,
    RuleSet,
    a,
    an,
    environment,
    perform,
    with_process_modules,
)
from executive.testing import FakeProcessModule

HOME = Pose((0.0, 0.0, 0.0))


def test_motion_goes_to_the_module_that_accepts_it(mrun: Any) -> None:
    nav = FakeProcessModule("navigation", accepts="going", result="arrived")
    torso = FakeProcessModule("torso", accepts="moving-torso", result="lifted")

    async def main() -> tuple[Any, Any]:
        async with with_process_modules(nav, torso):
            r1 = await perform(a.motion(type="going", pose=HOME))
            r2 = await perform(a.motion(type="moving-torso", joint_angle=0.2))
            return r1, r2

    assert mrun(main, name="dispatch") == ("arrived", "lifted")
    assert [m.type for m in nav.calls] == ["going"]
    assert [m.type for m in torso.calls] == ["moving-torso"]
    tree = cpl.task_tree("dispatch")
    assert tree is not None
    goal = tree.find("navigation")
    assert goal is not None and goal.kind == "task" and goal.succeeded
    assert goal.annotations["motion"].startswith("<a motion (type going)")


def test_no_process_module_names_the_motion(mrun: Any) -> None:
    torso = FakeProcessModule("torso", accepts="moving-torso")

    async def main() -> None:
        async with with_process_modules(torso):
            await perform(a.motion(type="going", pose=HOME))

    with pytest.raises(
        NoProcessModule,
        match=r"no running process module accepts <a motion "
        r"\(type going\).*torso",
    ) as exc:
        mrun(main, name="nopm")
    assert exc.value.motion.type == "going"

    async def outside() -> None:
        await perform(a.motion(type="going", pose=HOME))

    with pytest.raises(NoProcessModule, match="none"):
        mrun(outside, name="nopm2")


def test_motion_is_referenced_before_dispatch(mrun: Any) -> None:
    nav = FakeProcessModule("navigation", accepts="going")

    async def main() -> None:
        async with with_process_modules(nav):
            await perform(a.motion(type="going"))

    with pytest.raises(DesignatorError, match="needs a pose or target"):
        mrun(main, name="bad-motion")
    assert nav.calls == []


def test_candidates_are_tried_in_order_and_the_first_failure_wins(mrun: Any) -> None:
    first = FakeProcessModule("first", accepts="going", fail_on={1: NavigationPoseUnreachable})
    second = FakeProcessModule("second", accepts="going", result="second")
    composite = cpl.CompositeFailure([GripperClosedCompletely(), ManipulationPoseUnreachable()])
    third = FakeProcessModule("third", accepts="going", fail_on={1: composite})

    async def fallback() -> Any:
        async with with_process_modules(first, second):
            return await perform(a.motion(type="going", pose=HOME))

    assert mrun(fallback, name="fallback") == "second"
    assert len(first.calls) == 1 and len(second.calls) == 1

    async def all_fail() -> Any:
        async with with_process_modules(third):
            return await perform(a.motion(type="going", pose=HOME))

    with pytest.raises(GripperClosedCompletely):
        mrun(all_fail, name="all-fail")


async def fetch_plan(object: Any, arm: str) -> str:
    await perform(a.motion(type="going", pose=HOME))
    return f"fetched {object.type} with {arm}"


@cpl.plan(name="pick-up")
async def pick_up_plan(object: Any, arm: str) -> str:
    await perform(a.motion(type="gripping", gripper=arm))
    return f"picked {object.type}"


def test_action_runs_its_plan_with_the_designator_on_the_node(mrun: Any) -> None:
    rules = RuleSet()

    def fetching(d: Any) -> Iterator[Any]:
        yield fetch_plan, {"object": d["object"], "arm": d.get("arm", "right")}

    def picking_up(d: Any) -> Iterator[Any]:
        for arm in ("right", "left"):
            yield pick_up_plan, {"object": d["object"], "arm": arm}

    rules.register("action", "fetching", fetching)
    rules.register("action", "picking-up", picking_up)
    nav = FakeProcessModule("navigation", accepts="going")
    grippers = FakeProcessModule("grippers", accepts="gripping")
    cup = an.object(type="cup", name="cup-1")

    async def main() -> tuple[str, str]:
        async with environment(rules=rules, process_modules=[nav, grippers]):
            r1 = await perform(an.action(type="fetching", object=cup))
            r2 = await perform(an.action(type="picking-up", object=cup))
            return r1, r2

    assert mrun(main, name="actions") == ("fetched cup with right", "picked cup")
    tree = cpl.task_tree("actions")
    assert tree is not None
    fetch = tree.find("fetching")  # a plain async function: named after the action type
    assert fetch is not None and fetch.kind == "plan"
    assert fetch.annotations["designator"].startswith("<an action (type fetching)")
    assert "fetch_plan" in fetch.annotations["resolved"]
    assert fetch.arguments["arm"] == "'right'"
    assert fetch.find("navigation") is not None  # the motion's goal is below the plan
    pick = tree.find("pick-up")  # a @cpl.plan keeps its own name
    assert pick is not None and pick.kind == "plan"
    assert pick.annotations["designator"].startswith("<an action (type picking-up)")
    goal = pick.find("grippers")
    assert goal is not None and "(gripper right)" in goal.annotations["motion"]


def test_objects_and_locations_cannot_be_performed(mrun: Any) -> None:
    async def main(d: Any) -> None:
        await perform(d)

    with pytest.raises(DesignatorError, match="cannot perform object"):
        mrun(main, an.object(type="cup"), name="perf-obj")
    with pytest.raises(DesignatorError, match="cannot perform location"):
        mrun(main, a.location(pose=HOME), name="perf-loc")
    with pytest.raises(TypeError, match="action or motion designator"):
        mrun(main, "going", name="perf-str")


def test_unresolvable_action_is_a_designator_error(mrun: Any) -> None:
    async def main() -> None:
        await perform(an.action(type="dancing"))

    with pytest.raises(DesignatorError, match="no action rule for type 'dancing'"):
        mrun(main, name="dance")


def test_action_rule_naming_a_sync_function_is_a_typeerror(mrun: Any) -> None:
    rules = RuleSet()
    rules.register("action", "sync", lambda d: iter([(lambda: 42, {})]))

    async def main() -> None:
        async with environment(rules=rules):
            await perform(an.action(type="sync"))

    with pytest.raises(TypeError, match="async plan functions"):
        mrun(main, name="sync-plan")


def test_positional_arguments_in_a_grounding(mrun: Any) -> None:
    async def add(x: int, y: int) -> int:
        return x + y

    rules = RuleSet()
    rules.register("action", "adding", lambda d: iter([(add, (d["x"], 2))]))

    async def main() -> int:
        async with environment(rules=rules):
            return await perform(an.action(type="adding", x=40))

    assert mrun(main, name="positional") == 42


def test_a_failed_motion_leaves_no_failure_traceback_frame_failure_cycle(mrun: Any) -> None:
    """perform keeps the first failure in a local while it tries the other candidates;
    once raised, that local must not hold the failure, or failure -> traceback -> frame ->
    failure is a reference cycle only a (full) garbage collection frees."""
    nav = FakeProcessModule("nav", accepts="going", fail_on={1: NavigationPoseUnreachable})
    caught: list[BaseException] = []

    async def main() -> None:
        async with with_process_modules(nav):
            try:
                await perform(a.motion(type="going", pose=HOME))
            except NavigationPoseUnreachable as failure:
                caught.append(failure)

    mrun(main, name="no-cycle")
    (failure,) = caught
    frames = []
    tb = failure.__traceback__
    while tb is not None:
        frames.append(tb.tb_frame)
        tb = tb.tb_next
    perform_frames = [f for f in frames if f.f_code.co_name == "_perform_motion"]
    assert perform_frames, "the failure passed through perform"
    for frame in frames:
        assert all(value is not failure for value in frame.f_locals.values()), (
            f"{frame.f_code.co_name} still holds the failure"
        )
