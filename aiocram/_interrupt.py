"""Ctrl-C during a demo run: the first one evaporates the plan, the second aborts.

The first SIGINT prints ``interrupted, cleaning up (Ctrl-C again to abort)``, switches the
run's clock to full speed (the shielded cleanup, e.g. parking the arms, must not take
minutes of wall time at ``--speed 1``) and evaporates the plan's root task from the event
loop; the plan's ``finally`` blocks then run as after any evaporation, and the command
goes on to write its pictures and summary. The second SIGINT kills the helper processes
the run forked (:meth:`Interrupts.adopt`), calls ``on_abort`` (which saves what can be
saved with plain renames) and leaves at once with status 130
(``os._exit``: no traceback, no waiting for tasks).

asyncio's own ``Runner`` installs a SIGINT handler that cancels the main task and then
raises ``KeyboardInterrupt`` (a traceback); it leaves an already installed handler alone,
so installing ours before ``cpl.run`` replaces that behaviour for the run.
"""

from __future__ import annotations

import asyncio
import math
import os
import signal
import sys
from collections.abc import Callable
from types import FrameType, TracebackType
from typing import Any

__all__ = ["EXIT_INTERRUPTED", "Interrupts"]

#: The exit status of a command ended by Ctrl-C (128 + SIGINT), as shells report it.
EXIT_INTERRUPTED = 130

MESSAGE = "interrupted, cleaning up (Ctrl-C again to abort)"


class Interrupts:
    """A context manager that owns SIGINT while a run is going (main thread only).

    :meth:`attach` names the loop and the root task once the run has started; a Ctrl-C
    that comes before that is remembered and acted on at :meth:`attach`."""

    def __init__(self, on_abort: Callable[[], None] = lambda: None) -> None:
        self.on_abort = on_abort
        self.count = 0  # Ctrl-C presses seen
        self._loop: asyncio.AbstractEventLoop | None = None
        self._root: Any = None
        self._saved: Any = None
        #: forked helper processes (e.g. the demo's picture worker) that an abort kills
        #: before ``on_abort`` runs, so that none outlives the command (invariant: pids of
        #: children of this process not yet waited for)
        self._children: set[int] = set()

    @property
    def interrupted(self) -> bool:
        return self.count > 0

    def __enter__(self) -> Interrupts:
        self._saved = signal.signal(signal.SIGINT, self._handle)
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        signal.signal(signal.SIGINT, self._saved)
        self._loop = self._root = None

    def attach(self, root: Any) -> None:
        """Call from inside the run (on its loop) with the task to evaporate."""
        self._loop = asyncio.get_running_loop()
        self._root = root
        if self.interrupted:
            self._evaporate()

    def adopt(self, pid: int) -> None:
        """Kill the child process ``pid`` (SIGKILL, then reap it) if the run is aborted
        before :meth:`release`; e.g. a helper that writes into a staging directory that
        the abort is about to move or remove."""
        self._children.add(pid)

    def release(self, pid: int) -> None:
        """The child ``pid`` was waited for: an abort leaves it alone."""
        self._children.discard(pid)

    def _kill_children(self) -> None:
        for pid in sorted(self._children):
            try:
                os.kill(pid, signal.SIGKILL)
                os.waitpid(pid, 0)
            except (ProcessLookupError, ChildProcessError):
                pass  # gone already
        self._children.clear()

    def _handle(self, signum: int, frame: FrameType | None) -> None:
        self.count += 1
        if self.count == 1:
            print(MESSAGE, file=sys.stderr, flush=True)
            loop = self._loop
            if loop is not None and not loop.is_closed():
                try:
                    loop.call_soon_threadsafe(self._evaporate)
                except RuntimeError:  # the loop closed meanwhile: nothing left to stop
                    pass
            return
        if sys.stdout.isatty():
            sys.stdout.write("\x1b[?25h\n")  # a live view hid the cursor: show it again
        print("aborted", file=sys.stderr, flush=True)
        try:
            self._kill_children()
            self.on_abort()
        finally:
            sys.stdout.flush()
            os._exit(EXIT_INTERRUPTED)

    def _evaporate(self) -> None:
        import cpl

        try:
            clock = cpl.current_clock()
        except RuntimeError:  # pragma: no cover - called on the loop, so one is running
            clock = None
        if isinstance(clock, cpl.ScaledClock) and clock.factor != math.inf:
            clock.set_factor(None)  # the cleanup at full speed
        root = self._root
        if root is not None and root.alive:
            root.evaporate("interrupted by Ctrl-C")
