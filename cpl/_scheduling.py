"""cpl checkpoints: the one place where a task blocks.

Every cpl wait (``sleep``, ``wait_for``, ``join``, the form supervisors) blocks through
:func:`block_until`. That is what makes suspension and evaporation work the same way
everywhere:

- **Suspension**: a suspend request resolves the future a task is blocked on (a spurious
  wake-up) and the next call of :func:`block_until` suspends the task there. Callers
  therefore *always* loop and re-check their condition, keeping their absolute deadline:
  an interrupted ``wait_for`` re-checks its fluent and an interrupted ``sleep`` keeps its
  original deadline.
- **Evaporation**: the asyncio cancellation that evaporation uses arrives here as
  ``CancelledError``; it is re-raised as the task's :class:`~cpl.Evaporated` record (who
  and why). A cancellation that cpl did not request is re-raised unchanged.
"""

from __future__ import annotations

import asyncio
import sys
from contextvars import ContextVar
from typing import TYPE_CHECKING, Any

from ._timeline import call_at, current_time

if TYPE_CHECKING:
    from ._task import Task

__all__ = ["CURRENT_TASK", "DeferredCancellation", "block_until"]

#: The cpl task whose code is running (``None`` outside any cpl task). asyncio copies the
#: context into each new asyncio task; each cpl task sets it at its start.
CURRENT_TASK: ContextVar[Task | None] = ContextVar("cpl_current_task", default=None)


def _wake(fut: asyncio.Future[Any]) -> None:
    if not fut.done():
        fut.set_result(None)


async def block_until(fut: asyncio.Future[Any], deadline: float | None = None) -> bool:
    """Block the current task until ``fut`` is done or the current time (the current
    :class:`~cpl.Timeline`'s, else the loop clock's) reaches ``deadline``.

    Returns ``True`` when woken (``fut`` done, or a spurious wake-up by a suspension: the
    caller must re-check its condition) and ``False`` when ``deadline`` passed. Suspends the
    task first if a suspension is pending. On evaporation raises :class:`~cpl.Evaporated`;
    ``fut`` is cancelled by asyncio in that case, so pass a future of your own.
    """
    task = CURRENT_TASK.get()
    if task is not None and task._suspend_requested:
        await task._suspend_here()
        return True
    loop = asyncio.get_running_loop()
    if fut.done():
        return True
    timer = None
    if deadline is not None:
        if current_time() >= deadline:
            return False
        timer = call_at(loop, deadline, _wake, fut)
    if task is not None:
        task._blocked_on = fut
    try:
        await fut
    except asyncio.CancelledError:
        if (
            task is not None
            and task.evaporation is not None
            and asyncio.current_task() is task._atask
        ):
            raise task.evaporation from None
        raise
    finally:
        if timer is not None:
            timer.cancel()
        if task is not None:
            task._blocked_on = None
    if deadline is not None and current_time() >= deadline:
        return False
    return True


class DeferredCancellation:
    """Holds back the cancellation that arrives while cleanup waits, so that cleanup is
    never cut short; :meth:`close` re-raises it once the wait is over.

    Used by every wait that must finish (a task waiting for its children to die, a form
    waiting for its evaporated branches, ``cpl.shielded``)::

        deferred = DeferredCancellation()
        try:
            while not done():
                try:
                    await fut
                except asyncio.CancelledError as exc:
                    deferred.defer(exc)
        finally:
            deferred.close()          # re-raises the first deferred cancellation

    anyio re-delivers a cancel scope's cancellation on every loop iteration while the task
    stays inside the cancelled scope (asyncio's own ``timeout`` cancels once). Catching and
    waiting again would spin the CPU and, on a clock that advances only when the loop is
    idle (``MockClock``), never let time move. So once a first cancellation is deferred,
    the rest of the wait runs inside a *shielded* anyio cancel scope, which takes the task
    out of the cancelled scope until :meth:`close`; then anyio resumes delivering and the
    deferred cancellation propagates to the scope that asked for it. anyio is only touched
    when it is already imported (no scope can exist otherwise).
    """

    __slots__ = ("_shield", "pending")

    def __init__(self) -> None:
        # Invariant: pending is the first cancellation caught, or None; _shield is set only
        # while pending is set and anyio was imported, and is exited by close().
        self.pending: BaseException | None = None
        self._shield: Any = None

    def defer(self, exc: BaseException) -> None:
        """Record ``exc`` (only the first one counts) and shield the rest of the wait."""
        if self.pending is not None:
            return
        self.pending = exc
        anyio = sys.modules.get("anyio")
        if anyio is not None:
            scope = anyio.CancelScope(shield=True)
            scope.__enter__()
            self._shield = scope

    def release(self) -> BaseException | None:
        """Leave the shield and return the deferred cancellation (``None`` if none came).
        Call it in the same task that deferred, once the wait is over."""
        scope, self._shield = self._shield, None
        if scope is not None:
            scope.__exit__(None, None, None)
        pending, self.pending = self.pending, None
        return pending

    def close(self) -> None:
        """:meth:`release`, then re-raise the deferred cancellation, if any. Call it in a
        ``finally`` block of the same task that deferred."""
        pending = self.release()
        if pending is not None:
            raise pending
