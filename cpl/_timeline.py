"""Timelines: virtual time that belongs to one run inside the loop, not to the loop.

A :class:`Timeline` is a discrete-event clock: its time moves only when the event loop
has nothing else ready (exact quiescence: the loop's ready queue is empty), and then it
jumps to its earliest pending deadline. While a timeline is current (:func:`on_timeline`,
a context variable, so it is inherited by every task started inside the block), every cpl
time reading and deadline uses it instead of the loop clock: ``cpl.sleep``,
``cpl.wait_for(timeout=)``, ``cpl.timeout_policy``, ``cpl.shielded(timeout=)`` and the
tasks' ``start_time``/``end_time`` stamps. Outside it, cpl runs on the loop clock.

What it is for: an imagined run (projection) that lives inside the same event loop as
the real run, whose loop may run on real time (``ScaledClock(1)``). The imagined motions
take their modelled durations on the imagination's own timeline, so a monitor that
sleeps 2 s fires after 2 s of *imagined* time, parallel branches overlap as on the robot,
and imagining still takes no loop time.

Deliberate difference from CRAM: CRAM's ``partially-ordered-clock`` found quiescence with
a wall-clock heuristic (sleep 50 ms, then jump) and was disabled in 2017; here the jump
happens exactly when nothing else in the loop can run, and several timelines (one per
imagination) may advance in one loop without seeing each other's time.

A loop that never goes quiet (a task polling with ``cpl.sleep(0)``) does not stop time:
after :data:`BUSY_PATIENCE` busy loop iterations in a row the timelines jump anyway (a
count of iterations, not a wall-clock delay, so runs stay deterministic). A task that
waits on something outside cpl (a worker thread, I/O, a loop timer) does not hold a
timeline back.
"""

from __future__ import annotations

import asyncio
import collections
import heapq
import itertools
import math
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from typing import Any

__all__ = [
    "Timeline",
    "TimelineTimer",
    "call_at",
    "current_time",
    "current_timeline",
    "on_timeline",
]

#: The timeline cpl reads time from in this context (``None``: the loop clock).
CURRENT_TIMELINE: ContextVar[Timeline | None] = ContextVar("cpl_current_timeline", default=None)

#: Loop iterations in a row that may find the loop busy before timelines jump anyway: a
#: task polling with ``sleep(0)`` (a busy watcher) never lets the loop go quiet, and time
#: must not stop for it (on the robot, time passes while a task computes).
BUSY_PATIENCE = 100

#: The attribute under which a loop carries the driver that advances its timelines (it
#: lives and dies with the loop: no module-level registry).
_DRIVER_ATTR = "_cpl_timeline_driver"


class TimelineTimer:
    """A pending callback on a :class:`Timeline` (what :meth:`Timeline.call_at` returns)."""

    __slots__ = ("_handle", "_timeline", "args", "callback", "cancelled", "when")

    def __init__(
        self, timeline: Timeline, when: float, callback: Callable[..., Any], args: tuple[Any, ...]
    ) -> None:
        self._timeline = timeline
        self.when = when
        self.callback = callback
        self.args = args
        # Invariant: cancelled timers stay in the heap until popped; ``_handle`` is the
        # loop callback that runs this timer once it fell due (``None`` before that).
        self.cancelled = False
        self._handle: asyncio.Handle | None = None

    def cancel(self) -> None:
        """Cancel the callback (a no-op once it ran)."""
        if self.cancelled:
            return
        self.cancelled = True
        if self._handle is not None:
            self._handle.cancel()
        else:
            self._timeline._live -= 1

    def __repr__(self) -> str:
        state = " cancelled" if self.cancelled else ""
        return f"<TimelineTimer at t={self.when:.3f}{state}>"


class Timeline:
    """A discrete-event clock owned by one run (see the module docstring).

    ``start`` is its time at creation (e.g. the loop time when an imagination starts, so
    stamps continue from there). A timeline is driven by the first event loop that
    schedules on it; using it from another loop raises ``RuntimeError``.
    """

    def __init__(self, start: float = 0.0, *, name: str = "timeline") -> None:
        if not (isinstance(start, int | float) and math.isfinite(start)):
            raise ValueError(f"Timeline(start=...) needs a finite number of seconds, got {start!r}")
        self.name = name
        # Invariant: _now only grows, and only in _advance (when the loop is quiescent).
        self._now = float(start)
        # Invariant: a heap of (when, seq, timer); _live counts its timers neither
        # cancelled nor handed to the loop.
        self._heap: list[tuple[float, int, TimelineTimer]] = []
        self._seq = itertools.count()
        self._live = 0
        self._loop: asyncio.AbstractEventLoop | None = None

    def now(self) -> float:
        """The timeline's current time in seconds."""
        return self._now

    @property
    def pending(self) -> int:
        """How many callbacks wait for their deadline."""
        return self._live

    def call_at(self, when: float, callback: Callable[..., Any], *args: Any) -> TimelineTimer:
        """Run ``callback(*args)`` on the running loop once this timeline reaches
        ``when``. Must be called from a running loop (the one driving this timeline)."""
        loop = asyncio.get_running_loop()
        if self._loop is None:
            self._loop = loop
        elif self._loop is not loop:
            raise RuntimeError(
                f"{self!r} is driven by another event loop; create one timeline per loop"
            )
        timer = TimelineTimer(self, float(when), callback, args)
        heapq.heappush(self._heap, (timer.when, next(self._seq), timer))
        self._live += 1
        _driver(loop).wake(self)
        return timer

    def _advance(self) -> bool:
        """Jump to the earliest pending deadline and hand every timer then due to the
        loop. Returns whether timers are still pending."""
        heap = self._heap
        while heap and heap[0][2].cancelled:
            heapq.heappop(heap)
        if not heap:
            return False
        self._now = max(self._now, heap[0][0])
        loop = self._loop
        assert loop is not None
        while heap and heap[0][0] <= self._now:
            timer = heapq.heappop(heap)[2]
            if not timer.cancelled:
                self._live -= 1
                timer._handle = loop.call_soon(timer.callback, *timer.args)
        return self._live > 0

    def __repr__(self) -> str:
        return f"<Timeline {self.name!r} t={self._now:.3f}, {self._live} pending>"


class _Driver:
    """Advances a loop's timelines whenever the loop is quiescent: a callback that runs
    once per loop iteration while some timeline has pending timers (or some task waits
    for quiescence), and jumps them when it finds the loop's ready queue empty (nothing
    else can run)."""

    __slots__ = ("_busy", "_idle", "_loop", "_posted", "_ready", "_waiting")

    def __init__(self, loop: asyncio.AbstractEventLoop) -> None:
        ready = getattr(loop, "_ready", None)
        if not isinstance(ready, collections.deque):
            raise TypeError(
                f"cpl timelines need asyncio's own event loop (one with a ready queue); "
                f"{type(loop).__name__} has none"
            )
        self._loop = loop
        self._ready: collections.deque[Any] = ready
        # Invariant: the timelines with pending timers, in the order they first waited
        # (a dict for a deterministic order); _posted: a _tick is scheduled.
        self._waiting: dict[Timeline, None] = {}
        self._posted = False
        # Invariant: how many ticks in a row found the loop busy (reset by every jump).
        self._busy = 0
        # Invariant: futures to resolve at the next quiescence (wait_quiescent).
        self._idle: list[asyncio.Future[None]] = []

    def wake(self, timeline: Timeline) -> None:
        self._waiting[timeline] = None
        self._post()

    def busy(self) -> bool:
        """Whether anything else is ready to run now."""
        return bool(self._ready)

    def when_quiescent(self, fut: asyncio.Future[None]) -> None:
        """Resolve ``fut`` once the loop is quiescent (before any timeline jumps)."""
        self._idle.append(fut)
        self._post()

    def _post(self) -> None:
        if not self._posted:
            self._posted = True
            self._loop.call_soon(self._tick)

    def _tick(self) -> None:
        self._posted = False
        if not self._waiting and not self._idle:
            self._busy = 0
            return
        if self._ready:
            self._busy += 1
        if not self._ready or self._busy >= BUSY_PATIENCE:
            # quiescent (every task waits), or busy for too long: first the tasks waiting
            # for quiescence run (zero time passes for them), then time jumps
            self._busy = 0
            if self._idle:
                idle, self._idle = self._idle, []
                for fut in idle:
                    if not fut.done():
                        fut.set_result(None)
            else:
                for timeline in list(self._waiting):
                    if not timeline._advance():
                        del self._waiting[timeline]
            if not self._waiting and not self._idle:
                return
        self._post()


def quiescence_driver(loop: asyncio.AbstractEventLoop) -> _Driver | None:
    """The driver of ``loop``'s quiescence, ``None`` for a loop that is not asyncio's own
    (no ready queue to watch)."""
    if not isinstance(getattr(loop, "_ready", None), collections.deque):
        return None
    return _driver(loop)


def _driver(loop: asyncio.AbstractEventLoop) -> _Driver:
    driver = getattr(loop, _DRIVER_ATTR, None)
    if driver is None:
        driver = _Driver(loop)
        setattr(loop, _DRIVER_ATTR, driver)
    return driver


def current_timeline() -> Timeline | None:
    """The timeline cpl reads time from here (``None``: the loop clock)."""
    return CURRENT_TIMELINE.get()


def current_time() -> float:
    """What cpl calls *now* here: the current timeline's time, else the running loop's
    ``loop.time()``."""
    timeline = CURRENT_TIMELINE.get()
    if timeline is not None:
        return timeline._now
    return asyncio.get_running_loop().time()


def call_at(
    loop: asyncio.AbstractEventLoop, when: float, callback: Callable[..., Any], *args: Any
) -> asyncio.TimerHandle | TimelineTimer:
    """Schedule ``callback`` at ``when`` of the current time (timeline or loop)."""
    timeline = CURRENT_TIMELINE.get()
    if timeline is not None:
        return timeline.call_at(when, callback, *args)
    return loop.call_at(when, callback, *args)


@contextmanager
def on_timeline(timeline: Timeline) -> Iterator[Timeline]:
    """Make ``timeline`` the time of cpl inside the block (and of every task started
    inside it)::

        with cpl.on_timeline(cpl.Timeline(start=loop.time())):
            await cpl.sleep(10)   # 10 s of the timeline; no loop time passes

    Not a Timeline: TypeError."""
    if not isinstance(timeline, Timeline):
        raise TypeError(f"on_timeline needs a cpl.Timeline, got {timeline!r}")
    token = CURRENT_TIMELINE.set(timeline)
    try:
        yield timeline
    finally:
        CURRENT_TIMELINE.reset(token)
