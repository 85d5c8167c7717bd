"""What evaporation does to anyio constructs inside a plan (issue 18's decision).

Evaporation is a native asyncio cancellation of the evaporated task, as
``asyncio.Task.cancel`` and ``asyncio.timeout`` are. anyio cannot shield against those, so:

- an ``anyio.CancelScope(shield=True)`` inside a plan does **not** stop evaporation; cleanup
  that must finish is wrapped in ``cpl.shielded(...)`` instead;
- ``anyio.to_thread.run_sync`` (whatever ``abandon_on_cancel`` says) returns at once on
  evaporation and the worker thread runs on, abandoned; ``cpl.shielded(to_thread...)`` waits
  for the thread before the evaporation goes on.
"""

from __future__ import annotations

import threading
import time
from typing import Any

import anyio
import anyio.to_thread

import cpl
from cpl.testing import MockClock, TransitionChecker, run_guarded


def guarded(fn: Any, clock: Any = None) -> Any:
    checker = TransitionChecker()
    try:
        return run_guarded(fn, clock=clock, instruments=[checker], wall_timeout=20.0)
    finally:
        checker.assert_clean()


def test_evaporation_goes_through_an_anyio_shielded_scope() -> None:
    events: list[str] = []

    async def worker() -> None:
        with anyio.CancelScope(shield=True):
            try:
                await cpl.sleep(10)
                events.append("finished shielded sleep")
            except BaseException as exc:
                events.append(type(exc).__name__)
                raise

    async def main() -> cpl.Status:
        t = cpl.spawn(worker(), name="worker")
        await cpl.sleep(1)
        t.evaporate("stop")
        await t.join()
        return t.state

    assert guarded(main, MockClock()) is cpl.Status.EVAPORATED
    assert events == ["Evaporated"]


def test_cpl_shielded_protects_cleanup_from_evaporation_where_anyio_shield_does_not() -> None:
    events: list[str] = []

    async def worker() -> None:
        try:
            await cpl.sleep(10)
        finally:
            await cpl.shielded(cpl.sleep(2))
            events.append("cleanup done")

    async def main() -> float:
        loop_time = anyio.current_time
        t = cpl.spawn(worker(), name="worker")
        await cpl.sleep(1)
        t.evaporate("stop")
        await t.join()
        return loop_time()

    assert guarded(main, MockClock()) == 3.0
    assert events == ["cleanup done"]


def test_to_thread_is_abandoned_on_evaporation_unless_shielded_by_cpl() -> None:
    release = threading.Event()
    finished: list[str] = []

    def blocking(tag: str) -> None:
        release.wait(5)
        finished.append(tag)

    async def plain() -> None:
        await anyio.to_thread.run_sync(blocking, "plain", abandon_on_cancel=False)

    async def with_shield() -> None:
        await cpl.shielded(anyio.to_thread.run_sync(blocking, "shielded"))

    async def main() -> tuple[list[str], list[str]]:
        t = cpl.spawn(plain(), name="plain")
        await cpl.sleep(0.05)
        t.evaporate("stop")
        await t.join()
        after_plain = list(finished)  # the thread still blocks: abandoned
        s = cpl.spawn(with_shield(), name="shielded")
        await cpl.sleep(0.05)
        s.evaporate("stop")
        threading.Timer(0.1, release.set).start()
        await s.join()  # waits for the thread of the shielded call
        return after_plain, list(finished)

    after_plain, after_shielded = guarded(main)
    assert after_plain == []
    assert "shielded" in after_shielded
    deadline = time.monotonic() + 5
    while "plain" not in finished and time.monotonic() < deadline:
        time.sleep(0.01)
    assert "plain" in finished  # the abandoned thread ran on to its end
