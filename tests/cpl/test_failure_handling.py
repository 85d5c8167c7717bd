"""with_failure_handling, retry, return_, RetryCounter, with_retry."""

from __future__ import annotations

import asyncio
from typing import Any

import pytest

import cpl


class NavFailure(cpl.PlanFailure):
    pass


class GripFailure(cpl.PlanFailure):
    pass


def test_retry_reruns_body_until_counter_exhausted(mrun):
    attempts: list[int] = []
    counter = cpl.RetryCounter(3)

    async def body():
        attempts.append(len(attempts))
        raise NavFailure("blocked")

    def handler(f):
        if counter.do_retry():
            cpl.retry()

    async def main():
        await cpl.with_failure_handling(body, [(NavFailure, handler)])

    with pytest.raises(NavFailure):
        mrun(main)
    assert len(attempts) == 4
    assert counter.remaining == 0 and counter.used == 3


def test_retry_then_success(mrun):
    attempts = []

    async def body():
        attempts.append(1)
        if len(attempts) < 3:
            raise NavFailure("again")
        return "arrived"

    async def main():
        return await cpl.with_failure_handling(body, {NavFailure: lambda f: cpl.retry()})

    assert mrun(main) == "arrived"
    assert len(attempts) == 3


def test_return_from_handler(mrun):
    async def body():
        raise GripFailure("slipped")

    async def main():
        return await cpl.with_failure_handling(
            body, [(GripFailure, lambda f: cpl.return_("gave up"))]
        )

    assert mrun(main) == "gave up"


def test_decline_tries_next_matching_clause_then_same_object_propagates(mrun):
    boom = NavFailure("x")
    calls: list[Any] = []

    async def body():
        raise boom

    async def async_decline(f):
        calls.append(("async", f))

    async def main():
        await cpl.with_failure_handling(
            body,
            [
                (GripFailure, lambda f: calls.append("grip")),
                (NavFailure, lambda f: calls.append(("first", f))),
                (cpl.PlanFailure, async_decline),
            ],
        )

    with pytest.raises(NavFailure) as info:
        mrun(main)
    assert info.value is boom
    assert calls == [("first", boom), ("async", boom)]


def test_later_clause_can_retry_after_earlier_declines(mrun):
    attempts = []

    async def body():
        attempts.append(1)
        if len(attempts) == 1:
            raise NavFailure("once")
        return "ok"

    async def main():
        return await cpl.with_failure_handling(
            body, [(NavFailure, lambda f: None), (cpl.PlanFailure, lambda f: cpl.retry())]
        )

    assert mrun(main) == "ok"


def test_retry_and_return_from_body(mrun):
    state = {"n": 0}

    async def body():
        state["n"] += 1
        if state["n"] < 2:
            cpl.retry()
        cpl.return_("from body")

    async def main():
        return await cpl.with_failure_handling(body, [])

    assert mrun(main) == "from body"
    assert state["n"] == 2


def test_handler_raising_new_failure_propagates(mrun):
    async def body():
        raise NavFailure("low level")

    def translate(f):
        raise GripFailure("high level")

    async def main():
        await cpl.with_failure_handling(
            body, [(NavFailure, translate), (GripFailure, lambda f: cpl.return_(1))]
        )

    with pytest.raises(GripFailure):
        mrun(main)


def test_child_task_failures_are_handled(mrun):
    boom = NavFailure("child")

    async def child():
        await cpl.sleep(1)
        raise boom

    async def main():
        async def body():
            await cpl.par(child(), cpl.sleep(5))

        return await cpl.with_failure_handling(body, [(NavFailure, lambda f: cpl.return_(f))])

    assert mrun(main) is boom


def test_error_clause_catches_programming_errors_only_when_named(mrun):
    async def body():
        raise KeyError("missing")

    async def main():
        with pytest.raises(KeyError):
            await cpl.with_failure_handling(body, [(cpl.PlanFailure, lambda f: cpl.return_(1))])
        return await cpl.with_failure_handling(body, [(KeyError, lambda f: cpl.return_("handled"))])

    assert mrun(main) == "handled"


def test_evaporation_is_never_handled(mrun):
    handled = []

    async def body():
        await cpl.sleep(100)

    async def guarded():
        await cpl.with_failure_handling(body, [(Exception, lambda f: handled.append(f))])

    async def main():
        await cpl.pursue(guarded(), cpl.sleep(1))

    mrun(main)
    assert handled == []


@pytest.mark.parametrize("bad", [asyncio.CancelledError, cpl.Evaporated, BaseException, int])
def test_clause_types_validated(bad):
    async def body():
        return 1

    async def main():
        await cpl.with_failure_handling(body, [(bad, lambda f: None)])

    with pytest.raises(TypeError):
        asyncio.run(main())


def test_body_must_be_callable_not_coroutine():
    async def body():
        return 1

    async def main():
        coro = body()
        try:
            await cpl.with_failure_handling(coro, [])  # type: ignore[arg-type]
        finally:
            coro.close()

    with pytest.raises(TypeError, match="zero-argument async callable"):
        asyncio.run(main())


def test_works_outside_top_level():
    attempts = []

    async def body():
        attempts.append(1)
        if len(attempts) < 2:
            raise NavFailure("x")
        return "ok"

    assert (
        asyncio.run(cpl.with_failure_handling(body, [(NavFailure, lambda f: cpl.retry())])) == "ok"
    )


def test_retry_outside_handling_is_an_error(mrun):
    async def main():
        cpl.retry()

    with pytest.raises(RuntimeError, match="outside any with_failure_handling"):
        mrun(main)


def test_nested_counters_reset_on_outer_retry(mrun):
    """CRAM's three-level structure: inner counters are re-created on every outer retry."""
    log = []
    outer = cpl.RetryCounter(2, name="relocations")

    async def inner_level():
        regrasps = cpl.RetryCounter(1, name="regrasps")

        async def grasp():
            log.append(("grasp", outer.remaining, regrasps.remaining))
            raise GripFailure("slip")

        def on_grip(f):
            if regrasps.do_retry():
                cpl.retry()
            raise NavFailure("unreachable from here")

        await cpl.with_failure_handling(grasp, [(GripFailure, on_grip)])

    async def main():
        await cpl.with_failure_handling(
            inner_level, [(NavFailure, lambda f: outer.do_retry() and cpl.retry())]
        )

    with pytest.raises(NavFailure):
        mrun(main)
    assert log == [
        ("grasp", 2, 1),
        ("grasp", 2, 0),
        ("grasp", 1, 1),
        ("grasp", 1, 0),
        ("grasp", 0, 1),
        ("grasp", 0, 0),
    ]


def test_with_retry_sugar(mrun):
    attempts = []
    before: list[Any] = []

    async def body():
        attempts.append(1)
        raise NavFailure("blocked")

    async def main():
        await cpl.with_retry(
            body,
            on=NavFailure,
            counter=2,
            before_retry=before.append,
            rethrow=lambda f: GripFailure("gave up"),
        )

    with pytest.raises(GripFailure) as info:
        mrun(main)
    assert len(attempts) == 3 and len(before) == 2
    assert isinstance(info.value.__cause__, NavFailure)


def test_retry_counter_validation_and_reset():
    c = cpl.RetryCounter(1)
    assert c.do_retry() and not c.do_retry()
    c.reset()
    assert c.remaining == 1
    with pytest.raises(ValueError):
        cpl.RetryCounter(-1)


def test_fail_forms():
    with pytest.raises(cpl.PlanFailure, match=r"Plan failure\."):
        cpl.fail()
    with pytest.raises(cpl.PlanFailure, match="text") as info:
        cpl.fail("text", object="cup")
    assert info.value.details == {"object": "cup"}
    with pytest.raises(NavFailure):
        cpl.fail(NavFailure)
    f = NavFailure("same")
    with pytest.raises(NavFailure) as info2:
        cpl.fail(f)
    assert info2.value is f
    with pytest.raises(TypeError, match="PlanFailure"):
        cpl.fail(ValueError)  # type: ignore[arg-type]
    with pytest.raises(TypeError):
        cpl.fail(ValueError("x"))  # type: ignore[arg-type]
