""" "Cannot hang" holds on every path out of a run (issue 23, item 4).

- the caller of ``top_level`` is cancelled (``asyncio.timeout``, ``anyio.move_on_after``, a
  cancelled main task of ``cpl.run``) while a cleanup is stuck: ``cleanup_timeout``
  bounds the wait;
- a plan that catches ``BaseException`` around its waits is abandoned once, never
  re-driven in a loop;
- plain asyncio tasks the plan left running do not hold ``cpl.run`` forever;
- evaporating deep chains of plan calls neither overflows the stack nor hangs.

Every scenario runs behind a wall-clock guard that cannot hang itself; the assertions
are about loop time (virtual under ``MockClock``) or counts, never wall-clock time.
"""

from __future__ import annotations

import asyncio
import gc
import logging
from typing import Any

import anyio
import pytest

import cpl
from cpl.testing import MockClock, TransitionChecker, call_guarded, run_app_guarded

STUCK = 1000.0  # seconds of loop time a stuck cleanup would take


def _stuck_plan() -> Any:
    async def plan() -> None:
        try:
            await cpl.sleep(100)
        finally:
            await cpl.shielded(asyncio.sleep(STUCK))  # a cleanup that does not end in time

    return plan


@pytest.mark.parametrize("scope", ["asyncio.timeout", "anyio.move_on_after"])
def test_cancelled_caller_waits_at_most_cleanup_timeout(
    scope: str, caplog: pytest.LogCaptureFixture
) -> None:
    """Before: top_level waited for the root with no deadline (here: until the stuck
    cleanup ended, 1000 s of loop time later)."""
    seen: dict[str, Any] = {}

    async def app() -> None:
        loop = asyncio.get_running_loop()
        start = loop.time()
        try:
            if scope == "asyncio.timeout":
                async with asyncio.timeout(0.5):
                    await cpl.top_level(_stuck_plan(), timeout=30, cleanup_timeout=2)
            else:
                with anyio.move_on_after(0.5):
                    await cpl.top_level(_stuck_plan(), timeout=30, cleanup_timeout=2)
                seen["outcome"] = "moved on"
        except TimeoutError:
            seen["outcome"] = "timed out"
        seen["elapsed"] = loop.time() - start

    with caplog.at_level(logging.ERROR, logger="cpl"):
        run_app_guarded(app, clock=MockClock(), wall_timeout=20)
    assert seen["outcome"] == ("timed out" if scope == "asyncio.timeout" else "moved on")
    assert 2.5 <= seen["elapsed"] < 10  # 0.5 s until the cancel, at most 2 s of cleanup
    assert any("did not end within cleanup_timeout=2" in r.message for r in caplog.records)


def test_cancelled_main_task_of_run_with_stuck_cleanup_returns() -> None:
    """Ctrl-C cancels cpl.run's main task. Before: top_level waited forever for the stuck
    cleanup (and Runner.close would have waited again)."""

    async def plan() -> None:
        me = asyncio.current_task()
        main = next(t for t in asyncio.all_tasks() if t is not me)  # runs top_level
        asyncio.get_running_loop().call_later(0.05, main.cancel)
        try:
            await cpl.sleep(100)
        finally:
            await cpl.shielded(asyncio.sleep(STUCK))

    with pytest.raises(asyncio.CancelledError):
        call_guarded(lambda: cpl.run(plan, cleanup_timeout=0.2), wall_timeout=20)


_CTRL_C = """
import asyncio, os, signal, sys
import cpl

async def plan():
    asyncio.get_running_loop().call_later(0.2, os.kill, os.getpid(), signal.SIGINT)
    try:
        await cpl.sleep(100)
    finally:
        await cpl.shielded(asyncio.sleep(1000))  # stuck cleanup

try:
    cpl.run(plan, timeout=30, cleanup_timeout=0.5)
except KeyboardInterrupt:
    print("interrupted")
    sys.exit(0)
"""


def test_one_ctrl_c_with_a_stuck_cleanup_ends_the_process() -> None:
    """A real SIGINT (asyncio.Runner cancels the main task). Before: the process hung in
    top_level waiting for the cleanup."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    root = Path(cpl.__file__).resolve().parent.parent
    proc = subprocess.run(
        [sys.executable, "-c", _CTRL_C],
        capture_output=True,
        text=True,
        timeout=60,
        cwd=root,
        env={**os.environ, "PYTHONPATH": str(root)},
    )
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "interrupted"
    assert "did not end within cleanup_timeout=0.5" in proc.stderr


def test_plan_swallowing_base_exception_is_abandoned_not_spun(
    caplog: pytest.LogCaptureFixture,
) -> None:
    """Before: closing the abandoned coroutine threw GeneratorExit into the plan, which
    caught it and the RuntimeError of ``cpl.sleep`` with no running loop, and looped with
    no await: 100 % CPU forever (here bounded by ``LIMIT`` so that the test ends)."""
    LIMIT = 100_000
    rounds = [0]

    async def plan() -> None:
        while rounds[0] < LIMIT:
            rounds[0] += 1
            try:
                await cpl.sleep(10)
            except BaseException:  # the misbehaviour under test
                pass

    with caplog.at_level(logging.WARNING, logger="cpl"), pytest.raises(cpl.RunTimeout) as exc:
        call_guarded(lambda: cpl.run(plan, timeout=0.1, cleanup_timeout=0.1), wall_timeout=20)
    assert [t.name for t in exc.value.stuck] == ["plan"]
    # evaporation (1), a wait for the cleanup, the close (1 more): never re-driven
    assert rounds[0] <= 5
    assert any("refused to close" in r.message for r in caplog.records)


def test_swallowing_branches_are_kept_not_left_to_the_collector() -> None:
    """Closing a task whose body awaits a coroutine that refuses to close detaches that
    coroutine, still suspended; left to the garbage collector, it would be closed again
    with no loop, and spin."""
    LIMIT = 100_000
    rounds: dict[int, int] = {0: 0, 1: 0, 2: 0}

    async def swallow(k: int) -> None:
        while rounds[k] < LIMIT:
            rounds[k] += 1
            try:
                await cpl.sleep(10)
            except BaseException:  # the misbehaviour under test
                pass

    async def wrapper() -> None:
        await swallow(0)  # the task's body is wrapper; swallow is awaited inside it

    async def plan() -> None:
        cpl.spawn(cpl.par(swallow(1), swallow(2)), name="branches")
        await wrapper()

    with pytest.raises(cpl.RunTimeout):
        call_guarded(lambda: cpl.run(plan, timeout=0.1, cleanup_timeout=0.1), wall_timeout=20)
    gc.collect()
    assert max(rounds.values()) <= 5, rounds


def test_asyncio_task_left_running_does_not_hold_run() -> None:
    """A plain asyncio task that ignores cancellation: before, Runner.close waited for it
    forever. Now it gets ``cleanup_timeout`` and is abandoned."""
    cancels = [0]

    async def stubborn() -> None:
        while True:
            try:
                await asyncio.sleep(STUCK)
            except asyncio.CancelledError:
                cancels[0] += 1

    async def plan() -> str:
        asyncio.get_running_loop().create_task(stubborn())
        await cpl.sleep(0.01)
        return "done"

    assert call_guarded(lambda: cpl.run(plan, cleanup_timeout=0.2), wall_timeout=20) == "done"
    assert cancels[0] == 1


@cpl.plan
async def _chain(n: int, cleanups: list[int]) -> None:
    try:
        if n == 0:
            await cpl.sleep(1000)
        else:
            await _chain(n - 1, cleanups)
    finally:
        cleanups.append(n)


@pytest.mark.parametrize("instrumented", [False, True], ids=["bare", "checker"])
@pytest.mark.parametrize("depth", [260, 1000])
def test_evaporating_a_deep_chain_of_plan_calls(depth: int, instrumented: bool) -> None:
    """Before: a chain of ~250 nested plan calls overflowed the stack (RecursionError),
    and with a TransitionChecker attached the run hung."""
    cleanups: list[int] = []
    checker = TransitionChecker()

    async def main() -> Any:
        chain = cpl.spawn(_chain(depth, cleanups), name="chain")
        await cpl.sleep(1)
        chain.evaporate("enough")
        return await chain.join()

    instruments = [checker] if instrumented else []
    result = call_guarded(
        lambda: cpl.run(main, clock=MockClock(), instruments=instruments), wall_timeout=60
    )
    assert result is None
    assert cleanups == list(range(depth + 1))  # innermost first, each once
    if instrumented:
        checker.assert_clean()
        evaporated = [t for t in checker.tasks if t.state is cpl.Status.EVAPORATED]
        assert len(evaporated) == depth + 2  # the spawned task and every plan call
