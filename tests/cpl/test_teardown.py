"""Evaporation while a task tears down its children (the hang of issue 11) and
cancellation that keeps arriving while cleanup waits (anyio's cancel scopes, issue 18).

Every run is guarded: a hang fails the test with the task tree instead of blocking the
suite.
"""

from __future__ import annotations

import asyncio
import time
from typing import Any

import anyio
import pytest

import cpl
from cpl.testing import MockClock, TransitionChecker, run_guarded

CLOCKS = [pytest.param(lambda: None, id="system"), pytest.param(MockClock, id="mock")]


def guarded(fn: Any, clock: Any = None, checker: TransitionChecker | None = None) -> Any:
    checker = checker or TransitionChecker()
    try:
        return run_guarded(fn, clock=clock, instruments=[checker], wall_timeout=20.0)
    finally:
        checker.assert_clean()


@pytest.mark.parametrize("make_clock", CLOCKS)
def test_par_failure_arriving_while_a_branch_tears_down_its_helper(make_clock: Any) -> None:
    """The repro of issue 11: `branch` returned and waits for `helper`'s awaiting cleanup
    when the failing sibling makes par evaporate it."""
    cleanups: list[str] = []

    async def helper() -> None:
        try:
            await asyncio.Event().wait()
        finally:
            await asyncio.sleep(0.05)
            cleanups.append("helper")

    async def branch() -> str:
        cpl.spawn(helper(), name="helper")
        await asyncio.sleep(0.01)
        return "ok"

    async def failing() -> None:
        await asyncio.sleep(0.02)
        cpl.fail("boom")

    async def plan() -> None:
        await cpl.par(failing(), branch())

    with pytest.raises(cpl.PlanFailure, match="boom"):
        guarded(plan, make_clock())
    assert cleanups == ["helper"]


@pytest.mark.parametrize("make_clock", CLOCKS)
def test_evaporating_a_parent_whose_body_returned_waits_for_its_child(make_clock: Any) -> None:
    """A spawned parent is evaporated 40 ms after its body returned, while its child's
    finally still sleeps: the parent dies once the child is dead, with its body's
    outcome, and the child's cleanup ran exactly once."""
    cleanups: list[float] = []
    seen: dict[str, Any] = {}

    async def child() -> None:
        try:
            await cpl.sleep(100)
        finally:
            await cpl.shielded(cpl.sleep(0.1))
            cleanups.append(asyncio.get_running_loop().time())

    async def parent() -> str:
        cpl.spawn(child(), name="child")
        await cpl.sleep(0.01)
        return "parent done"

    async def main() -> None:
        p = cpl.spawn(parent(), name="parent")
        await cpl.sleep(0.05)  # the body returned at 0.01; the child cleans up until 0.11
        assert p.alive
        p.evaporate("late evaporation")
        seen["value"] = await p.join()
        seen["state"] = p.state
        seen["joined_at"] = asyncio.get_running_loop().time()

    guarded(main, make_clock())
    assert len(cleanups) == 1
    assert seen["value"] == "parent done"
    assert seen["state"] is cpl.Status.SUCCEEDED
    assert seen["joined_at"] >= cleanups[0]


@pytest.mark.parametrize("make_clock", CLOCKS)
def test_pursue_loser_tearing_down_is_evaporated_again(make_clock: Any) -> None:
    """pursue's loser has returned and waits for its helper's cleanup when the outer
    pursue evaporates the whole form."""
    cleanups: list[str] = []

    async def helper() -> None:
        try:
            await cpl.sleep(100)
        finally:
            await cpl.shielded(cpl.sleep(0.2))
            cleanups.append("helper")

    async def loser() -> None:
        cpl.spawn(helper(), name="helper")
        await cpl.sleep(0.01)

    async def inner() -> Any:
        return await cpl.pursue(loser, lambda: cpl.sleep(100))

    async def main() -> Any:
        return await cpl.pursue(inner, lambda: cpl.sleep(0.05))

    guarded(main, make_clock())
    assert cleanups == ["helper"]


@pytest.mark.parametrize("make_clock", CLOCKS)
def test_asyncio_timeout_around_top_level_firing_during_teardown(make_clock: Any) -> None:
    cleanups: list[str] = []

    async def helper() -> None:
        try:
            await cpl.sleep(100)
        finally:
            await cpl.shielded(cpl.sleep(0.2))
            cleanups.append("helper")

    async def plan() -> str:
        cpl.spawn(helper(), name="helper")
        await cpl.sleep(0.01)
        return "done"

    async def app() -> str:
        try:
            async with asyncio.timeout(0.05):  # fires while the root tears down
                return await cpl.top_level(plan)
        except TimeoutError:
            return "timed out"

    def run_app() -> Any:
        clock = make_clock()

        def factory() -> asyncio.AbstractEventLoop:
            loop = asyncio.new_event_loop()
            if clock is not None:
                clock.install(loop)
            return loop

        with asyncio.Runner(loop_factory=factory) as runner:
            return runner.run(app())

    import threading

    result: dict[str, Any] = {}
    thread = threading.Thread(target=lambda: result.setdefault("v", run_app()), daemon=True)
    thread.start()
    thread.join(20)
    assert not thread.is_alive(), "asyncio.timeout around cpl.top_level hung"
    # The body had returned before the timeout fired: the root keeps its value, then the
    # cancellation propagates to the timeout.
    assert result["v"] == "timed out"
    assert cleanups == ["helper"]


def _anyio_par_with_cleanup(cleanups: list[str]) -> Any:
    async def branch() -> None:
        try:
            await cpl.sleep(10)
        finally:
            await cpl.shielded(cpl.sleep(0.5))
            cleanups.append("branch")

    async def main() -> str:
        with anyio.move_on_after(0.05) as scope:
            await cpl.par(branch, lambda: cpl.sleep(10))
        return "cancelled" if scope.cancelled_caught else "not cancelled"

    return main


@pytest.mark.parametrize("make_clock", CLOCKS)
def test_anyio_scope_around_a_form_whose_branch_cleans_up(make_clock: Any) -> None:
    """Issue 18: anyio re-delivers its cancellation every loop iteration; the cleanup
    wait must not spin (CPU) nor livelock the mock clock."""
    cleanups: list[str] = []
    cpu0, wall0 = time.process_time(), time.monotonic()
    assert guarded(_anyio_par_with_cleanup(cleanups), make_clock()) == "cancelled"
    cpu, wall = time.process_time() - cpu0, time.monotonic() - wall0
    assert cleanups == ["branch"]
    if make_clock() is None:
        # 0.5 s of cleanup on the system clock: the loop must sleep through it. Busy
        # waiting used all of it (0.53 s CPU of 0.58 s wall); idle waiting a few ms.
        assert wall >= 0.5
        assert cpu < 0.5 * wall, (cpu, wall)
