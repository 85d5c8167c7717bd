"""``sleep`` and ``shielded``: time and cleanup that survive cancellation."""

from __future__ import annotations

import asyncio
from collections.abc import Awaitable, Callable
from typing import TypeVar

from ._scheduling import CURRENT_TASK, DeferredCancellation, block_until
from ._timeline import call_at, current_time, quiescence_driver

__all__ = ["shielded", "sleep", "wait_quiescent"]

T = TypeVar("T")


async def sleep(seconds: float) -> None:
    """Sleep ``seconds`` of the current time: the current :class:`~cpl.Timeline`'s (projected
    time inside a projection), else the loop clock's (a mock clock in tests, simulated
    time on the simulated robot).

    A cpl checkpoint: a suspension takes effect here, and after wake-up the sleep continues
    to its **original** deadline (time spent suspended is used up, as in CRAM). Evaporation
    raises :class:`~cpl.Evaporated`.
    """
    if seconds != seconds or seconds in (float("inf"), float("-inf")):
        raise ValueError(f"sleep needs a finite number of seconds, got {seconds!r}")
    loop = asyncio.get_running_loop()
    deadline = current_time() + max(0.0, seconds)
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
    clock (of the current :class:`~cpl.Timeline`, if there is one); then ``TimeoutError``
    is raised (or the pending evaporation, if there is one).
    A failure of ``aw`` propagates (after a pending evaporation is recorded, the failure
    wins: it is the more informative one).
    """
    loop = asyncio.get_running_loop()
    inner: asyncio.Future[T] = asyncio.ensure_future(aw)
    deadline = None if timeout is None else current_time() + timeout
    deferred = DeferredCancellation()
    timed_out = False
    try:
        while not inner.done():
            if deadline is not None and current_time() >= deadline:
                timed_out = True
                inner.cancel("shielded cleanup timed out")
                try:
                    await asyncio.wait([inner])
                except asyncio.CancelledError as exc:
                    deferred.defer(exc)
                break
            # wait for ``inner`` or the deadline (on the current time: loop or timeline)
            woken: asyncio.Future[None] = loop.create_future()
            wake = _waker(woken)
            inner.add_done_callback(wake)
            timer = None if deadline is None else call_at(loop, deadline, wake, inner)
            try:
                await woken
            except asyncio.CancelledError as exc:
                deferred.defer(exc)
            finally:
                inner.remove_done_callback(wake)
                if timer is not None:
                    timer.cancel()
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


def _waker(fut: asyncio.Future[None]) -> Callable[[object], None]:
    def wake(_: object) -> None:
        if not fut.done():
            fut.set_result(None)

    return wake


async def wait_quiescent() -> None:
    """Return once every other task that can run has run (the event loop is quiescent:
    nothing else is ready), before any timeline moves; after at most
    ``cpl._timeline.BUSY_PATIENCE`` loop iterations when the loop never goes quiet. A cpl
    checkpoint (suspension and evaporation take effect here), and always at least one
    switch to the loop.

    What it is for: a step whose effect others react to (a motion, and the monitor that
    watches it) lets them react before the next step starts, whatever the number of
    task switches their reaction takes. On a loop without asyncio's ready queue (not
    asyncio's own loop), it is one switch (``cpl.sleep(0)``)."""
    task = CURRENT_TASK.get()
    if task is not None and task._suspend_requested:
        await task._suspend_here()
    try:  # the one switch (sleep(0) without its bookkeeping: this runs for every motion)
        await asyncio.sleep(0)
    except asyncio.CancelledError:
        if task is not None and task.evaporation is not None:
            raise task.evaporation from None
        raise
    loop = asyncio.get_running_loop()
    driver = quiescence_driver(loop)
    if driver is None or not driver.busy():
        return  # most often nothing else became ready meanwhile
    while True:
        fut: asyncio.Future[None] = loop.create_future()
        driver.when_quiescent(fut)
        await block_until(fut)
        if fut.done() and (task is None or not task._suspend_requested):
            return
