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
from contextvars import ContextVar
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from ._task import Task

__all__ = ["CURRENT_TASK", "block_until"]

#: The cpl task whose code is running (``None`` outside any cpl task). asyncio copies the
#: context into each new asyncio task; each cpl task sets it at its start.
CURRENT_TASK: ContextVar[Task | None] = ContextVar("cpl_current_task", default=None)


def _wake(fut: asyncio.Future[Any]) -> None:
    if not fut.done():
        fut.set_result(None)


async def block_until(fut: asyncio.Future[Any], deadline: float | None = None) -> bool:
    """Block the current task until ``fut`` is done or the loop clock reaches ``deadline``.

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
        if loop.time() >= deadline:
            return False
        timer = loop.call_at(deadline, _wake, fut)
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
    if deadline is not None and loop.time() >= deadline:
        return False
    return True
