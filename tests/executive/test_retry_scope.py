"""retry_scope: the one-line retry scope (cursor, list and counter-only scopes)."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest

import cpl
from executive import (
    ListCursor,
    NavigationGoalInCollision,
    ObjectUnfetchable,
    ObjectUnreachable,
    Pose,
    RuleSet,
    SolutionCursor,
    a,
    environment,
    retry_scope,
)


def _rules(xs: list[float]) -> RuleSet:
    rules = RuleSet()

    def gen(d: Any) -> Iterator[Pose]:
        if d.get("reachable-for") == "pr2":
            yield from (Pose((x, 0.0, 0.0)) for x in xs)

    rules.register_location_generator(gen, 20)
    return rules


def _relocating(xs: list[float], retries: int, fail_until: int) -> tuple[list[float], Any]:
    tried: list[float] = []

    async def main() -> Any:
        async with environment(rules=_rules(xs)):
            spots = SolutionCursor(a.location(reachable_for="pr2"))

            @retry_scope(
                NavigationGoalInCollision,
                spots,
                cpl.RetryCounter(retries),
                rethrow=lambda f: ObjectUnfetchable(f"gave up after {f}"),
            )
            async def go() -> str:
                pose = spots.current.reference()
                tried.append(pose.position[0])
                if len(tried) < fail_until:
                    raise NavigationGoalInCollision(pose=pose)
                return "there"

            return await go()

    try:
        return tried, cpl.run(main)
    except Exception as exc:
        return tried, exc


def test_a_cursor_scope_tries_the_next_solutions_until_one_works() -> None:
    tried, result = _relocating([1.0, 2.0, 3.0], retries=5, fail_until=3)
    assert result == "there"
    assert tried == [1.0, 2.0, 3.0]


def test_a_cursor_scope_rethrows_when_the_counter_runs_out() -> None:
    tried, result = _relocating([1.0, 2.0, 3.0, 4.0], retries=1, fail_until=10)
    assert tried == [1.0, 2.0]
    assert isinstance(result, ObjectUnfetchable)
    assert isinstance(result.__cause__, NavigationGoalInCollision)


def test_a_cursor_scope_rethrows_when_the_solutions_run_out() -> None:
    tried, result = _relocating([1.0, 2.0], retries=10, fail_until=10)
    assert tried == [1.0, 2.0]
    assert isinstance(result, ObjectUnfetchable)


def test_a_counter_scope_recovers_before_each_retry_then_rethrows() -> None:
    events: list[str] = []

    async def recover() -> None:
        events.append("recover")

    @retry_scope(
        ObjectUnreachable,
        None,
        cpl.RetryCounter(2),
        before_retry=recover,
        rethrow=ObjectUnfetchable,
    )
    async def pick() -> None:
        events.append("pick")
        raise ObjectUnreachable()

    with pytest.raises(ObjectUnfetchable) as info:
        cpl.run(pick)
    assert events == ["pick", "recover", "pick", "recover", "pick"]
    assert isinstance(info.value.__cause__, ObjectUnreachable)


def test_a_scope_without_rethrow_lets_the_failure_through_and_ignores_others() -> None:
    calls: list[int] = []

    @retry_scope(ObjectUnreachable, None, cpl.RetryCounter(1))
    async def body() -> None:
        calls.append(1)
        raise ObjectUnreachable("still")

    with pytest.raises(ObjectUnreachable, match="still"):
        cpl.run(body)
    assert len(calls) == 2

    @retry_scope(ObjectUnreachable, None, cpl.RetryCounter(5))
    async def other() -> None:
        calls.append(2)
        raise KeyError("not handled")

    with pytest.raises(KeyError):
        cpl.run(other)
    assert calls.count(2) == 1


def test_a_list_scope_walks_the_list() -> None:
    seen: list[int] = []
    cursor = ListCursor([1, 2, 3])

    @retry_scope(ValueError, cursor, cpl.RetryCounter(5), on_retry=seen.append)
    async def body() -> int:
        if cursor.current < 3:
            raise ValueError(cursor.current)
        return int(cursor.current)

    assert cpl.run(body) == 3
    assert seen == [2, 3]


@pytest.mark.parametrize(
    ("args", "kwargs", "match"),
    [
        ((KeyboardInterrupt, None, cpl.RetryCounter(1)), {}, "failure classes"),
        ((ValueError, "cursor", cpl.RetryCounter(1)), {}, "SolutionCursor"),
        ((ValueError, None, 3), {}, "retry counter"),
        ((ValueError, None, cpl.RetryCounter(1)), {"rethrow": 3}, "rethrow"),
        ((ValueError, None, cpl.RetryCounter(1)), {"on_retry": print}, "needs a cursor"),
        ((ValueError, ListCursor([1]), cpl.RetryCounter(1)), {"before_retry": print}, "on_retry"),
    ],
)
def test_misuse_is_a_type_error_at_decoration(args: Any, kwargs: Any, match: str) -> None:
    with pytest.raises(TypeError, match=match):
        retry_scope(*args, **kwargs)


@pytest.mark.parametrize("cursor_kind", ["designator", "list", "none"])
def test_a_malformed_designator_is_never_retried_nor_rethrown(cursor_kind: str) -> None:
    """A DesignatorInputError (a misspelt name) leaves every kind of scope as itself, even
    when the scope's ``on`` covers designator errors; a plain DesignatorError is retried."""
    from executive import DesignatorError, DesignatorInputError

    def run(error: Exception) -> tuple[int, BaseException | None]:
        tries = 0

        async def main() -> None:
            nonlocal tries
            async with environment(rules=_rules([1.0, 2.0, 3.0])):
                cursor: Any = {
                    "designator": SolutionCursor(a.location(reachable_for="pr2")),
                    "list": ListCursor([1, 2, 3]),
                    "none": None,
                }[cursor_kind]

                @retry_scope(
                    DesignatorError,
                    cursor,
                    cpl.RetryCounter(5),
                    rethrow=lambda f: ObjectUnreachable(f"gave up after {f}"),
                )
                async def body() -> None:
                    nonlocal tries
                    tries += 1
                    raise error

                await body()

        try:
            cpl.run(main)
        except Exception as exc:
            return tries, exc
        return tries, None

    tries, exc = run(DesignatorInputError("(on ...): no link 'nosuch'; did you mean sink?"))
    assert tries == 1
    assert isinstance(exc, DesignatorInputError) and "did you mean sink" in str(exc)
    tries, exc = run(DesignatorError("the costmap is empty"))
    assert tries == 3 if cursor_kind != "none" else tries == 6
    assert isinstance(exc, ObjectUnreachable)
