"""``sleep`` and ``shielded``: time and cleanup that survive cancellation."""

from __future__ import annotations

import asyncio
from collections.abc import Awaitable
from typing import TypeVar

from ._scheduling import CURRENT_TASK, DeferredCancellation, block_until

__all__ = ["shielded", "sleep"]

T = TypeVar("T")


async def sleep(seconds: float) -> None:
    """Sleep on the loop clock (a mock clock in tests, simulated time in projection).

    A cpl checkpoint: a suspension takes effect here, and after wake-up the sleep continues
    to its **original** deadline (time spent suspended is used up, as in CRAM). Evaporation
    raises :class:`~cpl.Evaporated`.
    """
    if seconds != seconds or seconds in (float("inf"), float("-inf")):
        raise ValueError(f"sleep needs a finite number of seconds, got {seconds!r}")
    loop = asyncio.get_running_loop()
    deadline = loop.time() + max(0.0, seconds)
    task = CURRENT_TASK.get()
    if task is not None:
        task.waiting_on = f"sleeping until t={deadline:.3f}"
    try:
        if seconds <= 0:
            if task is not None and task._suspend_requested:
                await task._suspend_here()
            try:
                await asyncio.sleep(0)
            except asyncio.CancelledError:
                if task is not None and task.evaporation is not None:
                    raise task.evaporation from None
                raise
            return
        while True:
            fut: asyncio.Future[None] = loop.create_future()
            if not await block_until(fut, deadline):
                return
    finally:
        if task is not None:
            task.waiting_on = None


async def shielded(aw: Awaitable[T], timeout: float | None = None) -> T:
    """Run ``aw`` to completion even if the caller is evaporated meanwhile.

    Use it for cleanup that awaits (park the arms, close the drawer) in ``finally`` blocks.
    If the caller was evaporated during the wait, the evaporation is re-raised once ``aw``
    has finished. With ``timeout``, ``aw`` is cancelled after that many seconds of the loop
    clock; then ``TimeoutError`` is raised (or the pending evaporation, if there is one).
    A failure of ``aw`` propagates (after a pending evaporation is recorded, the failure
    wins: it is the more informative one).
    """
    loop = asyncio.get_running_loop()
    inner: asyncio.Future[T] = asyncio.ensure_future(aw)
    deadline = None if timeout is None else loop.time() + timeout
    deferred = DeferredCancellation()
    timed_out = False
    try:
        while not inner.done():
            remaining = None if deadline is None else deadline - loop.time()
            if remaining is not None and remaining <= 0:
                timed_out = True
                inner.cancel("shielded cleanup timed out")
                try:
                    await asyncio.wait([inner])
                except asyncio.CancelledError as exc:
                    deferred.defer(exc)
                break
            try:
                await asyncio.wait([inner], timeout=remaining)
            except asyncio.CancelledError as exc:
                deferred.defer(exc)
    finally:
        pending = deferred.release()
    if pending is not None:
        task = CURRENT_TASK.get()
        if task is not None and task.evaporation is not None:
            pending = task.evaporation
    if timed_out:
        if pending is not None:
            raise pending
        raise TimeoutError(f"shielded cleanup did not finish within {timeout} s")
    if not inner.cancelled() and inner.exception() is not None:
        raise inner.exception()  # type: ignore[misc]
    if pending is not None:
        raise pending
    return inner.result()
