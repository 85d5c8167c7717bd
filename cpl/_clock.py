"""Clocks: which time the event loop runs on.

All cpl timing (``sleep``, ``wait_for`` timeouts, deadlines) reads ``loop.time()`` and
schedules with ``loop.call_at``. A :class:`Clock` is a policy installed on one loop:

- :class:`SystemClock`: real (monotonic) time; installing it changes nothing.
- :class:`MockClock`: virtual time that only moves when the loop is idle (autojump) or by
  :meth:`MockClock.jump`; a plan that sleeps for an hour finishes at once.
- :class:`ScaledClock`: simulated time running ``factor`` times faster than wall time.

Virtual clocks patch the loop's ``time`` method and wrap its selector's ``select`` (the trick
of aiotools' ``VirtualClock`` and trio's autojump ``MockClock``), so they need a selector
event loop (the default on Linux and macOS; not the Windows proactor loop, nor uvloop).
"""

from __future__ import annotations

import asyncio
import math
import threading
import time
from abc import ABC, abstractmethod
from collections.abc import Callable
from typing import Any

__all__ = ["Clock", "MockClock", "ScaledClock", "SystemClock", "current_clock"]


class Clock(ABC):
    """A time policy for an event loop: ``install(loop)`` before running it."""

    @abstractmethod
    def install(self, loop: asyncio.AbstractEventLoop) -> None:
        """Make ``loop`` run on this clock. Call it before the loop schedules any timer."""

    @abstractmethod
    def uninstall(self, loop: asyncio.AbstractEventLoop) -> None:
        """Give ``loop`` back its own time. Timers already scheduled keep their deadlines."""

    @abstractmethod
    def now(self) -> float:
        """The current time of this clock, in seconds (what ``loop.time()`` returns)."""

    @property
    def rate(self) -> float:
        """How many clock seconds pass per wall second: 1 for real time, ``math.inf`` for
        as fast as possible (time jumps whenever the loop is idle)."""
        return 1.0


class SystemClock(Clock):
    """Real time: the loop's own monotonic clock. Installing it only records it as the
    loop's clock (:func:`current_clock`)."""

    def install(self, loop: asyncio.AbstractEventLoop) -> None:
        _register(loop, self)

    def uninstall(self, loop: asyncio.AbstractEventLoop) -> None:
        _unregister(loop, self)

    def now(self) -> float:
        return time.monotonic()

    def __repr__(self) -> str:
        return "SystemClock()"


def _noop() -> None:
    pass


#: The attribute under which a loop carries its installed clock. The clock belongs to the
#: loop (no module-level registry): it lives and dies with the loop object.
_LOOP_ATTR = "_cpl_clock"


def _register(loop: asyncio.AbstractEventLoop, clock: Clock) -> None:
    setattr(loop, _LOOP_ATTR, clock)


def _unregister(loop: asyncio.AbstractEventLoop, clock: Clock) -> None:
    if getattr(loop, _LOOP_ATTR, None) is clock:
        delattr(loop, _LOOP_ATTR)


def current_clock() -> Clock:
    """The clock the running event loop runs on: the one installed with
    ``cpl.run(..., clock=...)`` or ``Clock.install``, else a :class:`SystemClock` (the loop's
    own monotonic time). Outside a running loop: ``RuntimeError``, as asyncio's own
    ``get_running_loop``."""
    loop = asyncio.get_running_loop()
    clock = getattr(loop, _LOOP_ATTR, None)
    return clock if isinstance(clock, Clock) else SystemClock()


#: asyncio runs a timer when ``when < time() + resolution``; past about 1.7e7 s a float
#: cannot hold ``time() + resolution`` any more, and virtual time must step by hand.
_RESOLUTION = time.get_clock_info("monotonic").resolution


def _coarse(t: float) -> bool:
    return t + _RESOLUTION <= t


class _VirtualClock(Clock):
    """Virtual time ``base + (real - real_start) * rate``, optionally jumping when idle.

    ``base`` starts at ``start`` and grows by jumps (manual or automatic). Installed on one
    loop at a time.
    """

    def __init__(self, *, rate: float, autojump: bool, start: float, threshold: float) -> None:
        if not threshold >= 0:
            raise ValueError(f"autojump_threshold must be >= 0 seconds, got {threshold!r}")
        self._rate = rate
        self._autojump = autojump
        self._threshold = threshold
        self._base = float(start)
        self._real_start = time.monotonic()
        self._lock = threading.Lock()
        self._loop: asyncio.AbstractEventLoop | None = None
        self._selector: Any = None
        self._real_select: Callable[[float | None], Any] | None = None

    def now(self) -> float:
        if self._rate == 0:
            return self._base
        return self._base + (time.monotonic() - self._real_start) * self._rate

    def jump(self, seconds: float) -> None:
        """Advance virtual time by ``seconds`` (``>= 0``); timers now due fire soon.

        Safe to call from any thread; it wakes the installed loop.
        """
        if not seconds >= 0:
            raise ValueError(f"jump({seconds!r}): time cannot go backwards; pass seconds >= 0")
        with self._lock:
            self._base += seconds
        loop = self._loop
        if loop is not None and not loop.is_closed():
            try:
                loop.call_soon_threadsafe(_noop)
            except RuntimeError:  # closed meanwhile: nothing to wake
                pass

    def _advance_to(self, target: float) -> None:
        """Move time to ``target``, always forward, and far enough for asyncio to see the
        timer at ``target`` as due even where floats are coarse."""
        with self._lock:
            current = self.now()
            new = max(target, math.nextafter(current, math.inf))
            if _coarse(new):
                new = math.nextafter(new, math.inf)
            if self._rate == 0:
                self._base = new
            else:
                self._base += new - current

    def _select(self, timeout: float | None) -> Any:
        real_select = self._real_select
        assert real_select is not None, "select wrapper called on an uninstalled clock"
        if timeout is None or timeout <= 0:
            events = real_select(timeout)
            if timeout is not None and not events and self._rate == 0 and _coarse(self._base):
                # A timer due "now" that asyncio's due test cannot see: step one ulp.
                self._advance_to(self._base)
            return events
        if self._autojump:
            target = self.now() + timeout
            events = real_select(self._threshold)
            if events:
                return events
            self._advance_to(target)
            return []
        if self._rate == 0:
            # Manual time: nothing moves until I/O, call_soon_threadsafe or jump() wakes us.
            return real_select(None)
        return real_select(timeout / self._rate)

    def install(self, loop: asyncio.AbstractEventLoop) -> None:
        """Patch ``loop.time`` and the loop's selector.

        Raises ``RuntimeError`` if this clock already drives another loop (make one clock per
        loop) and ``TypeError`` for a loop without a selector (use
        ``asyncio.SelectorEventLoop``).
        """
        if self._loop is loop:
            return
        if self._loop is not None:
            raise RuntimeError(
                f"{self!r} is already installed on another loop; create one clock per loop "
                "or uninstall it first"
            )
        selector = getattr(loop, "_selector", None)
        if selector is None or not callable(getattr(selector, "select", None)):
            raise TypeError(
                f"{type(self).__name__} needs a selector event loop (asyncio.SelectorEventLoop);"
                f" {type(loop).__name__} has no selector to wrap"
            )
        self._real_select = selector.select
        self._selector = selector
        self._real_start = time.monotonic()
        self._loop = loop
        loop.time = self.now  # type: ignore[method-assign]
        selector.select = self._select
        _register(loop, self)

    @property
    def rate(self) -> float:
        return math.inf if self._autojump else self._rate

    def uninstall(self, loop: asyncio.AbstractEventLoop) -> None:
        """Restore ``loop.time`` and its selector. Raises ``ValueError`` for another loop.

        The clock's own time keeps its value (``now()``) for a later ``install``.
        """
        if loop is not self._loop:
            raise ValueError(f"{self!r} is not installed on {loop!r}")
        with self._lock:
            self._base = self.now()
        vars(loop).pop("time", None)
        vars(self._selector).pop("select", None)
        _unregister(loop, self)
        self._loop = None
        self._selector = None
        self._real_select = None


class MockClock(_VirtualClock):
    """Virtual time for tests: starts at ``start`` and moves only by jumps.

    With ``autojump=True`` (default), whenever the loop would block waiting for its next
    timer and no I/O is ready after ``autojump_threshold`` real seconds (default 0: at once),
    time jumps to that timer: ``await asyncio.sleep(1000)`` returns immediately with
    ``loop.time()`` 1000 s later, and timers keep their order. Work in other threads
    (``run_in_executor``) does not hold time back unless it finishes within the threshold.

    With ``autojump=False``, time moves only by :meth:`jump`; an idle loop blocks until I/O,
    ``call_soon_threadsafe`` or a ``jump()`` from another thread wakes it (as trio's
    ``MockClock`` with rate 0), so a test that awaits a timer without jumping hangs.
    """

    def __init__(
        self, autojump: bool = True, start: float = 0.0, *, autojump_threshold: float = 0.0
    ) -> None:
        super().__init__(rate=0.0, autojump=autojump, start=start, threshold=autojump_threshold)

    def __repr__(self) -> str:
        return f"MockClock(autojump={self._autojump}, now={self.now()!r})"


class ScaledClock(_VirtualClock):
    """Simulated time running ``factor`` times faster than the wall clock.

    ``factor=1`` is real-time speed (starting at ``start``); ``factor=2`` makes a 10 s sleep
    take 5 s of wall time. ``factor=None`` or ``math.inf`` means as fast as possible: time
    jumps to the next timer whenever the loop is idle (like ``MockClock(autojump=True)``).
    :meth:`jump` advances time by hand. Raises ``ValueError`` for a factor that is not > 0
    (use ``MockClock(autojump=False)`` for frozen time).
    """

    def __init__(self, factor: float | None, start: float = 0.0) -> None:
        if factor is None or factor == math.inf:
            super().__init__(rate=0.0, autojump=True, start=start, threshold=0.0)
        elif factor > 0 and factor != math.inf:
            super().__init__(rate=float(factor), autojump=False, start=start, threshold=0.0)
        else:
            raise ValueError(
                f"ScaledClock factor must be > 0 (or None/math.inf for as fast as possible), "
                f"got {factor!r}; use MockClock(autojump=False) to freeze time"
            )
        self.factor = math.inf if factor is None else float(factor)

    def set_factor(self, factor: float | None) -> None:
        """Change the speed from now on: time so far is kept, timers keep their deadlines
        (a pending 10 s sleep started at factor 1 ends after the remaining simulated time
        at the new speed); ``None``/``math.inf`` = as fast as possible. Call it on the
        loop's thread (e.g. from ``loop.call_soon_threadsafe``): it wakes a loop waiting
        at the old speed. Raises ``ValueError`` as the constructor does."""
        if factor is not None and factor != math.inf and not factor > 0:
            raise ValueError(
                f"ScaledClock factor must be > 0 (or None/math.inf for as fast as possible), "
                f"got {factor!r}"
            )
        with self._lock:
            self._base = self.now()
            self._real_start = time.monotonic()
            if factor is None or factor == math.inf:
                self._rate, self._autojump = 0.0, True
            else:
                self._rate, self._autojump = float(factor), False
        self.factor = math.inf if factor is None else float(factor)
        loop = self._loop
        if loop is not None and not loop.is_closed():
            try:
                loop.call_soon_threadsafe(_noop)
            except RuntimeError:  # closed meanwhile: nothing to wake
                pass

    def __repr__(self) -> str:
        return f"ScaledClock({self.factor!r}, now={self.now()!r})"
