"""retry_with_designator_solutions / retry_with_list_solutions inside with_failure_handling."""

from __future__ import annotations

import logging
from collections.abc import Iterator
from typing import Any

import pytest

import cpl
from executive import (
    ListCursor,
    NavigationGoalInCollision,
    ObjectUnfetchable,
    Pose,
    RuleSet,
    SolutionCursor,
    a,
    an,
    environment,
    retry_with_designator_solutions,
    retry_with_list_solutions,
)


def poses(*xs: float) -> list[Pose]:
    return [Pose((x, 0.0, 0.0)) for x in xs]


def location_rules(solutions: list[Pose]) -> RuleSet:
    rules = RuleSet()

    def gen(d: Any) -> Iterator[Pose]:
        if d.get("reachable-for") == "pr2":
            yield from solutions

    rules.register_location_generator(gen, 20)
    return rules


def run_relocating(
    mrun: Any,
    solutions: list[Pose],
    retries: int,
    fail_until: int,
    **kw: Any,
) -> tuple[list[float], Any]:
    tried: list[float] = []

    async def main() -> Any:
        async with environment(rules=location_rules(solutions)):
            loc = SolutionCursor(a.location(reachable_for="pr2"))
            relocations = cpl.RetryCounter(retries)

            async def body() -> str:
                pose = loc.current.reference()
                tried.append(pose.position[0])
                if len(tried) < fail_until:
                    raise NavigationGoalInCollision(pose=pose)
                return "arrived"

            return await cpl.with_failure_handling(
                body,
                [
                    (
                        NavigationGoalInCollision,
                        lambda f: retry_with_designator_solutions(loc, relocations, **kw),
                    )
                ],
            )

    return tried, mrun(main, name="relocating")


def test_retries_through_the_solutions_until_success(mrun: Any) -> None:
    tried, result = run_relocating(mrun, poses(0, 1, 2, 3), retries=5, fail_until=3)
    assert result == "arrived"
    assert tried == [0.0, 1.0, 2.0]


def test_counter_limits_the_retries_then_rethrows(mrun: Any) -> None:
    obj = an.object(type="cup", name="cup-1")
    with pytest.raises(ObjectUnfetchable) as exc:
        run_relocating(
            mrun,
            poses(0, 1, 2, 3, 4),
            retries=2,
            fail_until=99,
            rethrow=ObjectUnfetchable(object=obj),
        )
    assert exc.value.object is obj
    assert isinstance(exc.value.__cause__, NavigationGoalInCollision)


def test_exhausted_solutions_decline_and_the_failure_propagates(
    mrun: Any, caplog: pytest.LogCaptureFixture
) -> None:
    tried: list[float] = []

    async def main() -> Any:
        async with environment(rules=location_rules(poses(0, 1))):
            loc = SolutionCursor(a.location(reachable_for="pr2"))
            counter = cpl.RetryCounter(10)

            async def body() -> None:
                tried.append(loc.current.reference().position[0])
                raise NavigationGoalInCollision()

            await cpl.with_failure_handling(
                body,
                {
                    NavigationGoalInCollision: lambda f: retry_with_designator_solutions(
                        loc, counter
                    )
                },
            )

    with (
        caplog.at_level(logging.INFO, logger="executive.retry"),
        pytest.raises(NavigationGoalInCollision),
    ):
        mrun(main, name="exhausted")
    assert tried == [0.0, 1.0]
    assert "No samples left" in caplog.text
    assert "Retrying with" in caplog.text


def test_rethrow_may_be_a_class(mrun: Any) -> None:
    with pytest.raises(ObjectUnfetchable, match="Object unfetchable"):
        run_relocating(mrun, poses(0), retries=3, fail_until=99, rethrow=ObjectUnfetchable)


def test_location_retries_skip_nearby_solutions(mrun: Any) -> None:
    near = [Pose((0, 0, 0)), Pose((0.01, 0, 0)), Pose((0.04, 0, 0)), Pose((0.5, 0, 0))]
    tried, result = run_relocating(mrun, near, retries=3, fail_until=2)
    assert result == "arrived" and tried == [0.0, 0.5]
    tried2, _ = run_relocating(mrun, near, retries=3, fail_until=3, distance_threshold=0.005)
    assert tried2 == [0.0, 0.01, 0.04]


def test_action_designators_advance_along_their_groundings(mrun: Any) -> None:
    async def pick(arm: str) -> str:
        return arm

    rules = RuleSet()
    rules.register(
        "action", "picking-up", lambda d: ((pick, {"arm": arm}) for arm in ("right", "left"))
    )
    arms: list[str] = []
    resets: list[Any] = []

    async def main() -> Any:
        async with environment(rules=rules):
            action = SolutionCursor(an.action(type="picking-up"))
            other = SolutionCursor(a.location(pose=Pose()))
            other.current.reference()
            first_other = other.current
            counter = cpl.RetryCounter(5)

            async def body() -> str:
                _plan, args = action.current.reference()
                arms.append(args["arm"])
                if args["arm"] == "right":
                    raise NavigationGoalInCollision()
                return "done"

            result = await cpl.with_failure_handling(
                body,
                [
                    (
                        NavigationGoalInCollision,
                        lambda f: retry_with_designator_solutions(
                            action, counter, reset=[other], on_retry=resets.append
                        ),
                    )
                ],
            )
            assert other.current is not first_other and not other.current.effective
            assert first_other.current() is other.current  # reset equates
            return result

    assert mrun(main, name="arms") == "done"
    assert arms == ["right", "left"]
    assert [d.reference().arguments["arm"] for d in resets] == ["left"]


def test_list_solutions(mrun: Any) -> None:
    used: list[str] = []

    async def main(retries: int, rethrow: Any = None) -> Any:
        grasps = ListCursor(iter(["top", "front", "side"]))
        counter = cpl.RetryCounter(retries)

        async def body() -> str:
            used.append(grasps.current)
            if grasps.current != "side":
                raise NavigationGoalInCollision()
            return grasps.current

        return await cpl.with_failure_handling(
            body,
            [
                (
                    NavigationGoalInCollision,
                    lambda f: retry_with_list_solutions(grasps, counter, rethrow=rethrow),
                )
            ],
        )

    assert mrun(main, 5, name="list") == "side"
    assert used == ["top", "front", "side"]
    used.clear()
    with pytest.raises(ObjectUnfetchable):
        mrun(main, 1, ObjectUnfetchable, name="list-rethrow")
    assert used == ["top", "front"]
    used.clear()
    with pytest.raises(NavigationGoalInCollision):
        mrun(main, 1, name="list-decline")


def test_list_cursor_stops_at_none_and_the_end() -> None:
    cursor = ListCursor([1, None, 3])
    assert cursor.current == 1
    assert cursor.advance() is None  # a None element ends the iteration, as in CRAM
    assert cursor.current == 1
    empty = ListCursor([])
    assert empty.current is None and empty.advance() is None
    single = ListCursor(["only"])
    assert single.advance() is None and single.current == "only"


def test_helpers_reject_bare_designators_and_lists() -> None:
    counter = cpl.RetryCounter(1)
    with pytest.raises(TypeError, match="SolutionCursor"):
        retry_with_designator_solutions(a.location(pose=Pose()), counter)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="ListCursor"):
        retry_with_list_solutions([1, 2], counter)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="designator"):
        SolutionCursor("cup")  # type: ignore[arg-type]
