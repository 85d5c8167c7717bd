"""Before-unwinding handlers and inner forms that handle failures themselves (issue 23,
item 5).

CRAM signals failures through ``handler-bind``: the innermost handler runs first, and
``try-in-order``'s own (moving on to the next alternative) is innermost. So an outer
before-unwinding handler sees only what the inner forms give up on: the composite failure
of ``try_in_order`` when every alternative failed (once), a failure an inner
``with_failure_handling`` declined. Before the fix, the outer handler ran first and won.
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable
from typing import Any

import pytest

import cpl
from cpl.testing import MockClock


async def blocked(what: str = "blocked") -> None:
    await cpl.sleep(1)
    cpl.fail(what)


@cpl.plan
async def blocked_plan() -> None:
    await cpl.sleep(1)
    cpl.fail("blocked plan")


async def clear() -> str:
    await cpl.sleep(1)
    return "clear"


def _outer(body: Callable[[], Awaitable[Any]], decline: bool = False) -> tuple[Any, list[Any]]:
    """Run ``body`` under an outer before-unwinding handler that returns "outer" (or
    declines); what it returned and the failures the handler saw."""
    seen: list[Any] = []

    def handler(failure: cpl.PlanFailure) -> None:
        seen.append(failure)
        if not decline:
            cpl.return_("outer")

    async def main() -> Any:
        return await cpl.with_failure_handling(
            body, {cpl.PlanFailure: handler}, before_unwinding=True
        )

    try:
        result: Any = cpl.run(main, clock=MockClock(), timeout=100)
    except cpl.PlanFailure as failure:
        result = failure
    return result, seen


FIRST_FAILS = [
    pytest.param(lambda: cpl.try_in_order(blocked(), clear()), id="try_in_order"),
    pytest.param(lambda: cpl.try_in_order(blocked_plan(), clear()), id="plan-call-step"),
    pytest.param(lambda: cpl.try_in_order(cpl.tag("b", blocked()), clear()), id="tag-step"),
    pytest.param(lambda: cpl.try_in_order(cpl.Task(blocked(), name="t"), clear()), id="task-step"),
    pytest.param(
        lambda: cpl.try_each_in_order([1, 2], lambda v: blocked() if v == 1 else clear()),
        id="try_each_in_order",
    ),
]


@pytest.mark.parametrize("body", FIRST_FAILS)
def test_try_in_order_handles_its_alternatives_first(body: Callable[[], Awaitable[Any]]) -> None:
    result, seen = _outer(body)
    assert (result, seen) == ("clear", [])  # before: ("outer", [PlanFailure("blocked")])


def test_outer_handler_sees_the_composite_once_when_every_alternative_failed() -> None:
    result, seen = _outer(lambda: cpl.try_in_order(blocked("a"), blocked("b")))
    assert result == "outer"
    assert len(seen) == 1 and isinstance(seen[0], cpl.CompositeFailure)
    assert [str(f) for f in seen[0].failures] == ["a", "b"]


def test_declining_outer_handler_lets_the_composite_propagate_seen_once() -> None:
    result, seen = _outer(lambda: cpl.try_in_order(blocked("a"), blocked_plan()), decline=True)
    assert isinstance(result, cpl.CompositeFailure)
    assert seen == [result]


def test_inner_with_failure_handling_that_retries_wins() -> None:
    attempts = [0]

    async def body() -> str:
        attempts[0] += 1
        if attempts[0] < 3:
            cpl.fail(f"attempt {attempts[0]}")
        return f"inner after {attempts[0]}"

    def again(_failure: cpl.PlanFailure) -> None:
        cpl.retry()

    result, seen = _outer(lambda: cpl.with_failure_handling(body, {cpl.PlanFailure: again}))
    assert (result, seen) == ("inner after 3", [])


def test_inner_with_failure_handling_that_declines_passes_the_failure_outward_once() -> None:
    declined: list[Any] = []

    async def inner() -> None:
        await cpl.with_failure_handling(lambda: blocked("x"), {cpl.PlanFailure: declined.append})

    result, seen = _outer(inner)
    assert result == "outer"
    assert [str(f) for f in declined] == ["x"] and seen == declined


def test_inner_handling_is_per_type() -> None:
    """An inner form that handles only ``KeyError`` holds back nothing else: the outer
    handler still runs before unwinding for a plan failure."""
    cleanup_ran_before_handler: list[bool] = []
    cleaned: list[str] = []

    async def body() -> None:
        try:
            await blocked("p")
        finally:
            cleaned.append("cleanup")

    async def inner() -> None:
        await cpl.with_failure_handling(body, {KeyError: lambda f: None})

    seen: list[Any] = []

    def handler(failure: cpl.PlanFailure) -> None:
        cleanup_ran_before_handler.append(bool(cleaned))
        seen.append(failure)
        cpl.return_("outer")

    async def main() -> Any:
        return await cpl.with_failure_handling(
            inner, {cpl.PlanFailure: handler}, before_unwinding=True
        )

    assert cpl.run(main, clock=MockClock(), timeout=100) == "outer"
    assert cleanup_ran_before_handler == [False]  # it ran at the signal, before unwinding


@pytest.mark.parametrize(
    "body",
    [
        pytest.param(lambda: cpl.try_all(blocked(), clear()), id="try_all"),
        pytest.param(lambda: cpl.pursue(clear(), cpl.sleep(10)), id="pursue-loser"),
    ],
)
def test_parallel_forms_do_not_show_handled_branch_failures(
    body: Callable[[], Awaitable[Any]],
) -> None:
    assert _outer(body) == ("clear", [])


def test_inner_before_unwinding_retry_wins_over_the_outer_handler() -> None:
    attempts = [0]

    async def body() -> str:
        attempts[0] += 1
        if attempts[0] < 3:
            cpl.fail(f"attempt {attempts[0]}")
        return f"inner after {attempts[0]}"

    def again(_failure: cpl.PlanFailure) -> None:
        cpl.retry()

    result, seen = _outer(
        lambda: cpl.with_failure_handling(body, {cpl.PlanFailure: again}, before_unwinding=True)
    )
    assert (result, seen) == ("inner after 3", [])
