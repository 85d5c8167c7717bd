"""Suspension helpers: ``with_task_suspended`` and ``on_suspension``.

Deliberate differences from CRAM, forced by asyncio:

- asyncio cannot preempt, so a suspension takes effect at the next cpl checkpoint
  (``sleep``, ``wait_for``, ``join``, a form waiting for its branches, ``perform``). Code
  that runs without awaiting, or that awaits something that is not a cpl checkpoint (a
  PyBullet call, a raw ``asyncio.sleep``), finishes that step first.
- A task blocked in a checkpoint drops out of its wait when suspended and re-checks after
  wake-up (CRAM's ``retry-after-suspension`` around ``wait-for``); ``sleep`` keeps its
  original deadline.
- ``with_task_suspended`` on a dead task returns at once (CRAM hangs), and suspending a
  suspended task or waking a running one are no-ops (CRAM asserts).
"""

from __future__ import annotations

from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager
from typing import Any

from ._task import Task, _require_task

__all__ = ["on_suspension", "with_task_suspended"]


@asynccontextmanager
async def with_task_suspended(task: Task) -> AsyncIterator[Task]:
    """Suspend ``task`` (and its subtree) for the block; wake it on exit, also when the
    block fails or the caller is evaporated."""
    await task.suspend()
    try:
        yield task
    finally:
        task.wake_up()


@asynccontextmanager
async def on_suspension(handler: Callable[[], Any]) -> AsyncIterator[None]:
    """Run ``handler()`` (sync or async, no arguments) every time the current task is
    suspended while the block runs, before it counts as suspended; handlers of nested
    blocks run innermost first. An exception from a handler propagates in the task."""
    task = _require_task("cpl.on_suspension")
    extras = task._more()
    if extras.suspension_handlers is None:
        extras.suspension_handlers = []
    extras.suspension_handlers.append(handler)
    try:
        yield
    finally:
        extras.suspension_handlers.remove(handler)
