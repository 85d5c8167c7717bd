"""A task of its own runs its body through ``cpl._task._Driver`` (the coroutine protocol
by hand, no wrapper coroutine frame). These tests pin the paths where it hands over to a
real coroutine or is driven unusually: evaporated before its first step, waiting for a
partial order or a pending suspension first, a body that ends with children alive, an
asyncio task cancelled or closed before it ran, and asyncio's introspection."""

from __future__ import annotations

import asyncio
import gc
import warnings
from typing import Any

import pytest

import cpl
from cpl._task import _Driver


def test_a_started_task_runs_on_a_driver_and_its_stack_is_the_bodys(mrun: Any) -> None:
    async def body() -> None:
        await cpl.sleep(10)

    async def main() -> Any:
        t = cpl.spawn(body(), name="body")
        await cpl.sleep(1)
        atask = t._atask
        assert atask is not None
        coro = atask.get_coro()
        stack = atask.get_stack()
        shown = repr(atask)
        t.evaporate()
        await t.join()
        return type(coro) is _Driver, [f.f_code.co_name for f in stack], shown, t.state

    is_driver, stack, shown, state = mrun(main)
    assert is_driver
    assert stack == ["body"]
    assert "coro=<cpl task 'body'()>" in shown
    assert state is cpl.Status.EVAPORATED


def test_evaporated_before_its_first_step_it_never_runs_its_body(mrun: Any) -> None:
    ran: list[str] = []

    async def body() -> None:
        ran.append("body")

    async def main() -> Any:
        t = cpl.spawn(body(), name="body")  # scheduled, not entered yet
        t.evaporate("at once")
        await t.join()
        return t.state, t.start_time is not None

    assert mrun(main) == (cpl.Status.EVAPORATED, False)
    assert ran == []


def test_a_body_that_returns_with_children_alive_tears_them_down_first(mrun: Any) -> None:
    log: list[str] = []

    async def grandchild() -> None:
        try:
            await cpl.sleep(100)
        finally:
            await cpl.shielded(cpl.sleep(2))
            log.append("grandchild cleaned up")

    async def child() -> str:
        cpl.spawn(grandchild(), name="grandchild")
        await cpl.sleep(1)
        return "value"

    async def main() -> Any:
        t = cpl.spawn(child(), name="child")
        value = await t.join()
        log.append(f"joined at {asyncio.get_running_loop().time()}")
        return value, t.state

    assert mrun(main) == ("value", cpl.Status.SUCCEEDED)
    assert log == ["grandchild cleaned up", "joined at 3.0"]


def test_a_failing_body_with_children_alive_fails_after_their_teardown(mrun: Any) -> None:
    async def grandchild() -> None:
        try:
            await cpl.sleep(100)
        finally:
            await cpl.shielded(cpl.sleep(2))

    async def child() -> None:
        g = cpl.spawn(grandchild(), name="grandchild")
        await cpl.sleep(1)
        assert g.alive
        raise cpl.PlanFailure("boom")

    async def main() -> Any:
        t = cpl.spawn(child(), name="child")
        with pytest.raises(cpl.PlanFailure, match="boom"):
            await t.join()
        (g,) = t.children
        return t.state, g.state, asyncio.get_running_loop().time()

    assert mrun(main) == (cpl.Status.FAILED, cpl.Status.EVAPORATED, 3.0)


def test_a_pending_suspension_at_the_first_step_is_honoured(mrun: Any) -> None:
    log: list[str] = []

    async def body() -> None:
        log.append(f"body at {asyncio.get_running_loop().time()}")

    async def main() -> Any:
        t = cpl.spawn(body(), name="body")
        t._suspend_requested = True  # what suspend() sets before the task reaches a checkpoint
        await cpl.sleep(1)
        state = t.state
        t.wake_up()
        await t.join()
        return state, t.state

    assert mrun(main) == (cpl.Status.SUSPENDED, cpl.Status.SUCCEEDED)
    assert log == ["body at 1.0"]


def test_cancelled_from_outside_before_its_first_step_it_is_evaporated(mrun: Any) -> None:
    """asyncio's cancel() before the task ran: the body never starts; the task is recorded
    EVAPORATED (cancelled outside cpl) instead of staying CREATED forever."""
    ran: list[str] = []

    async def body() -> None:
        ran.append("body")

    async def main() -> Any:
        t = cpl.spawn(body(), name="body")
        assert t._atask is not None
        t._atask.cancel()
        await cpl.sleep(0)
        await cpl.sleep(0)
        return t.state, t.evaporation

    state, evaporation = mrun(main)
    assert state is cpl.Status.EVAPORATED
    assert evaporation is not None and "outside cpl" in str(evaporation)
    assert ran == []


def test_closing_a_driver_that_never_ran_closes_the_body() -> None:
    """An abandoned loop closes its tasks' coroutines: the body is closed too (no "never
    awaited" warning from the garbage collector)."""

    async def body() -> None:
        await asyncio.sleep(1)

    t = cpl.Task(body(), name="body", _register=False)
    driver = _Driver(t)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        driver.close()
        gc.collect()
    assert t._aw is None
