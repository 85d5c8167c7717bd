"""Blocking drivers off the loop: process modules whose work is a synchronous call.

A real robot's drivers often block (a vendor SDK's ``move_to(...)`` that returns when the
base stops). Called on the event loop, such a call freezes every fluent, monitor and the
live view for its whole duration. A :class:`BlockingProcessModule` says that its work
blocks: it implements :meth:`~BlockingProcessModule.execute_blocking` (a plain function)
and the framework runs it in one of anyio's worker threads (``anyio.to_thread.run_sync``),
so the loop stays responsive while the driver works.

Evaporation still reaches the driver, in three steps:

1. the goal's :class:`CancelRequest` is set (with the reason) and its callbacks run on the
   loop thread: the driver polls ``cancel.requested`` / sleeps with ``cancel.wait(dt)``, or a
   callback sends the hardware its stop command;
2. the framework waits, shielded, up to ``cancel_timeout`` seconds of loop time for the
   driver call to return (a driver that ignores the request is abandoned in its thread,
   and a warning is logged: the loop never blocks on it);
3. as for every module, ``on_cancel(motion)`` runs shielded and time-limited, then the
   evaporation propagates.

A value the driver returns, or a failure it raises, after the cancel request is dropped
(the goal was evaporated); the failure is logged. Progress from inside the driver reaches
the loop through ``anyio.from_thread.run_sync(...)`` (e.g. to set a fluent).

Clocks: thread time is wall time. On a ``MockClock`` with autojump, virtual time jumps
while the loop waits for a driver thread, so give it an ``autojump_threshold`` (real
seconds the loop waits before jumping) or use the system clock.

Where we differ from CRAM: CRAM's process modules run in Lisp threads and block there;
here a module's goal is an asyncio task and only the driver call is threaded.
"""

from __future__ import annotations

import abc
import asyncio
import logging
import threading
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, ClassVar

import anyio
import anyio.to_thread

import cpl

from ._process_module import ProcessModule

if TYPE_CHECKING:
    from ._designator import Designator

__all__ = ["BlockingProcessModule", "CancelRequest"]

log = logging.getLogger("executive.process_modules")


class CancelRequest:
    """The request to stop one blocking driver call, shared between the loop and the
    driver's thread. The driver reads it; the framework sets it on evaporation."""

    __slots__ = ("_callbacks", "_event", "reason")

    def __init__(self) -> None:
        self._event = threading.Event()
        # Set once, before the event (readers that see the event see the reason).
        self.reason: str | None = None
        self._callbacks: list[Callable[[CancelRequest], Any]] = []

    @property
    def requested(self) -> bool:
        """True once the goal was evaporated: stop as soon as you safely can."""
        return self._event.is_set()

    def wait(self, timeout: float | None = None) -> bool:
        """Block the driver's thread up to ``timeout`` wall seconds, waking at once when
        cancellation is requested; returns ``requested``. Use it instead of
        ``time.sleep`` in a driver's polling loop."""
        return self._event.wait(timeout)

    def add_callback(self, fn: Callable[[CancelRequest], Any]) -> None:
        """Call ``fn(request)`` when cancellation is requested (on the loop thread, at the
        moment of the request; at once if it already was). For drivers that block in a
        call they cannot poll from: send the hardware its stop command here. Must be
        quick; an exception is logged."""
        if not callable(fn):
            raise TypeError(f"add_callback(fn): fn is called with the request, got {fn!r}")
        if self.requested:
            self._call(fn)
        else:
            self._callbacks.append(fn)

    def _set(self, reason: str) -> None:
        if self.requested:
            return
        self.reason = reason
        self._event.set()
        callbacks, self._callbacks = self._callbacks, []
        for fn in callbacks:
            self._call(fn)

    def _call(self, fn: Callable[[CancelRequest], Any]) -> None:
        try:
            fn(self)
        except Exception:
            log.exception("cancel-request callback %r failed", fn)

    def __repr__(self) -> str:
        state = f"requested ({self.reason})" if self.requested else "not requested"
        return f"<CancelRequest {state}>"


class BlockingProcessModule(ProcessModule):
    """A process module whose work blocks: implement :meth:`execute_blocking` (a plain
    function run in a worker thread) and, optionally, the async :meth:`on_cancel`.

    The lifecycle (exclusivity, status fluent, task tree, ``on_cancel``) is every module's
    (:class:`ProcessModule`); on top of it, evaporation sets the goal's
    :class:`CancelRequest` and waits up to ``cancel_timeout`` seconds for the driver call
    to return before ``on_cancel`` runs.
    """

    #: This module's work blocks: the framework runs it off the loop.
    blocking: ClassVar[bool] = True

    def __init__(self, name: str | None = None) -> None:
        super().__init__(name)
        # One driver call at a time per module (the module is one piece of hardware); the
        # limiter also keeps a module from taking all of anyio's default worker threads.
        self._limiter = anyio.CapacityLimiter(1)

    @abc.abstractmethod
    def execute_blocking(self, motion: Designator, cancel: CancelRequest) -> Any:
        """Execute one motion, blocking (runs in a worker thread, not on the loop).

        Poll ``cancel.requested`` (or wait with ``cancel.wait(dt)``) and return or raise
        soon after it is set. Raise a low-level plan failure when the motion fails; the
        value returned is ``perform``'s. Do not touch cpl or asyncio objects directly from
        here: use ``anyio.from_thread.run_sync(fn, ...)`` to run ``fn`` on the loop.
        """

    async def execute(self, motion: Designator) -> Any:
        """The framework's bridge: runs :meth:`execute_blocking` in a worker thread and
        handles evaporation (do not override; override :meth:`execute_blocking`)."""
        cancel = CancelRequest()
        worker = asyncio.ensure_future(
            anyio.to_thread.run_sync(self.execute_blocking, motion, cancel, limiter=self._limiter)
        )
        try:
            # asyncio.wait does not cancel ``worker`` when this task is cancelled.
            await asyncio.wait([worker])
        except asyncio.CancelledError as exc:
            reason = str(exc.args[0]) if exc.args else "evaporated"
            cancel._set(reason)
            await self._stop_driver(motion, worker)
            raise
        return worker.result()

    async def _stop_driver(self, motion: Designator, worker: asyncio.Future[Any]) -> None:
        try:
            await cpl.shielded(asyncio.wait([worker]), timeout=self.cancel_timeout)
        except TimeoutError:
            log.warning(
                "process module %s: the driver call for %s did not return within %s s of "
                "the cancel request; abandoned in its worker thread",
                self.name,
                motion.short(),
                self.cancel_timeout,
            )
            worker.cancel()
            return
        if worker.done() and not worker.cancelled() and worker.exception() is not None:
            log.info(
                "process module %s: the driver call for %s ended with %r after the cancel request",
                self.name,
                motion.short(),
                worker.exception(),
            )
