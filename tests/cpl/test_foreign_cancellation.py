"""A cancellation from outside cpl (an anyio cancel scope, ``asyncio.timeout``) unwinding an
inline child (a plan call, ``with_task``, a tag) whose cleanup raises (issue 23, item 4).

Before: ``_run_inline`` replaced the cleanup's failure with a fresh ``CancelledError``
whenever its asyncio task was being cancelled; the scope that cancelled did not recognise
it, and a bare ``CancelledError`` escaped ``cpl.run``. Now a cancellation that is not an
evaporation lets the cleanup's failure propagate, as any Python code would; an ancestor's
evaporation still goes on and the cleanup's failure is recorded and logged.
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Awaitable, Callable
from typing import Any

import anyio
import pytest

import cpl
from cpl.testing import MockClock, TransitionChecker, run_guarded


class CleanupBroke(Exception):
    pass


async def _leaf(raises: bool) -> str:
    try:
        await cpl.sleep(10)
    finally:
        if raises:
            raise CleanupBroke("the cleanup raised")
    return "slept"


@cpl.plan
async def _plan_call(raises: bool) -> str:
    return await _leaf(raises)


async def _via_plan(raises: bool) -> str:
    return await _plan_call(raises)


async def _via_with_task(raises: bool) -> str:
    return await cpl.with_task(_leaf(raises), name="joined")


async def _via_tag(raises: bool) -> str:
    with cpl.with_tags("branch") as tags:
        return await tags.run("branch", _leaf(raises))


INLINE = [
    pytest.param(_via_plan, id="plan-call"),
    pytest.param(_via_with_task, id="with_task"),
    pytest.param(_via_tag, id="tag"),
]


def _run(main: Callable[[], Awaitable[Any]], checker: TransitionChecker) -> Any:
    try:
        return run_guarded(main, clock=MockClock(), instruments=[checker], wall_timeout=20)
    finally:
        checker.assert_clean()


@pytest.mark.parametrize("scope", ["anyio", "asyncio"])
@pytest.mark.parametrize("inline", INLINE)
def test_cleanup_failure_under_a_foreign_cancellation_propagates(
    inline: Callable[[bool], Awaitable[str]], scope: str
) -> None:
    checker = TransitionChecker()

    async def main() -> None:
        if scope == "anyio":
            with anyio.move_on_after(1):
                await inline(True)
        else:
            async with asyncio.timeout(1):
                await inline(True)

    with pytest.raises(CleanupBroke):  # before: a bare CancelledError
        _run(main, checker)
    child = next(t for t in checker.tasks if t.parent is not None)
    assert child.state is cpl.Status.FAILED
    assert isinstance(child.failure, CleanupBroke)
    assert child.evaporation is None  # nobody evaporated it: it failed


@pytest.mark.parametrize("inline", INLINE)
def test_foreign_cancellation_without_a_failing_cleanup_is_still_caught_by_its_scope(
    inline: Callable[[bool], Awaitable[str]],
) -> None:
    checker = TransitionChecker()

    async def main() -> bool:
        with anyio.move_on_after(1) as scope:
            await inline(False)
        return scope.cancelled_caught

    assert _run(main, checker) is True


@pytest.mark.parametrize("inline", INLINE)
def test_evaporation_of_an_ancestor_goes_on_past_a_failing_cleanup(
    inline: Callable[[bool], Awaitable[str]], caplog: pytest.LogCaptureFixture
) -> None:
    checker = TransitionChecker()

    async def main() -> Any:
        holder = cpl.spawn(inline(True), name="holder")
        await cpl.sleep(1)
        holder.evaporate("enough")
        return await holder.join()

    with caplog.at_level(logging.ERROR, logger="cpl.cleanup"):
        assert _run(main, checker) is None
    holder = next(t for t in checker.tasks if t.name == "holder")
    assert holder.state is cpl.Status.EVAPORATED
    broke = [t for t in checker.tasks if isinstance(t.failure, CleanupBroke)]
    assert broke and all(t.evaporation is not None for t in broke)
    assert any("CleanupBroke" in r.getMessage() for r in caplog.records)


def test_evaporation_and_an_anyio_scope_at_once_past_a_failing_cleanup(
    caplog: pytest.LogCaptureFixture,
) -> None:
    """The tag is evaporated in the same instant as the anyio scope around it fires, and
    the plan call inside it has a cleanup that raises (a shape the random evaporations
    found). Before: the cleanup's failure was replaced by a fresh CancelledError that the
    scope did not recognise, and it escaped as a bare CancelledError."""
    checker = TransitionChecker()

    async def branch() -> str:
        with anyio.move_on_after(2) as scope:
            await cpl.tag("t", _plan_call(True))
        return f"scope caught: {scope.cancelled_caught}"

    async def main() -> Any:
        task = cpl.spawn(branch(), name="branch")
        await cpl.sleep(2)
        tag = next(t for t in checker.tasks if t.name == "t")
        tag.evaporate("at the same time")
        return await task.join()

    with caplog.at_level(logging.ERROR, logger="cpl.cleanup"):
        assert _run(main, checker) == "scope caught: True"
    states = {t.name: t.state for t in checker.tasks}
    assert states["t"] is cpl.Status.EVAPORATED
    assert states["_plan_call"] is cpl.Status.FAILED
    assert any("CleanupBroke" in r.getMessage() for r in caplog.records)
