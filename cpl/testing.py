"""Test helpers for cpl code.

- :class:`MockClock` runs a loop on virtual time: install it with ``cpl.run(fn,
  clock=MockClock())``, or by hand on a fresh loop::

      loop = asyncio.new_event_loop()
      clock = MockClock()
      clock.install(loop)
      try:
          loop.run_until_complete(main())
      finally:
          clock.uninstall(loop)
          loop.close()

- :class:`TransitionChecker` is an instrument that records every task of a run and every
  status change, and flags illegal transitions and tasks left alive.
- :func:`run_guarded` is ``cpl.run`` with a wall-clock hang guard that cannot itself hang:
  a plan that never ends fails with :class:`HangDetected` and a dump of its task tree.
  :func:`run_app_guarded` does the same for any coroutine (an asyncio application that
  embeds top levels), :func:`call_guarded` for a synchronous call that runs its own loop
  (``anyio.run``, ``asyncio.run``).

Why the guards own their loop: ``pytest-timeout`` cannot stop an ``asyncio.Runner`` stuck
in its shutdown (it cancels the remaining tasks and waits for them, which is exactly where
a cleanup that spins or livelocks never ends). :func:`run_app_guarded` runs the loop in a
daemon thread; at the deadline it renders the run's task trees, stops the loop from
outside (``call_soon_threadsafe(loop.stop)``: a spinning loop still runs callbacks),
closes the stuck tasks' coroutines without awaiting anything and closes the loop. Nothing
in it waits without a bound; at worst (a thread blocked in synchronous code that never
returns to the loop) a daemon thread is left behind, and the test still fails on time.
"""

from __future__ import annotations

import asyncio
import threading
import warnings
from asyncio import events
from collections.abc import Awaitable, Callable, Iterable
from typing import Any

from ._clock import Clock, MockClock
from ._instruments import Instrument
from ._runtime import RunTimeout, current_roots, top_level
from ._status import LEGAL_TRANSITIONS, Status
from ._task import Task

__all__ = [
    "HangDetected",
    "MockClock",
    "TransitionChecker",
    "call_guarded",
    "run_app_guarded",
    "run_guarded",
]

Transition = tuple[tuple[str, ...], Status, Status]

#: Wall seconds granted to a stopped loop's thread to notice the stop request.
_STOP_GRACE = 5.0


class TransitionChecker(Instrument):
    """Records every task of a run and every status change; flags illegal transitions.

    After the run, ``checker.illegal`` should be empty and ``checker.alive()`` too
    (:meth:`assert_clean` checks both, with a message naming the offenders). One checker
    may observe several runs.
    """

    def __init__(self) -> None:
        # Every transition seen, in order: (task path, old, new).
        self.transitions: list[Transition] = []
        # The subset of ``transitions`` that Status' life cycle does not allow.
        self.illegal: list[Transition] = []
        # Every task of the observed runs (roots included), in creation order.
        self.tasks: list[Task] = []

    def task_spawned(self, task: Task) -> None:
        self.tasks.append(task)

    def run_started(self, root: Task) -> None:
        self.tasks.append(root)

    def task_status_changed(self, task: Task, old: Status, new: Status) -> None:
        rec = (task.path, old, new)
        self.transitions.append(rec)
        if new not in LEGAL_TRANSITIONS[old]:
            self.illegal.append(rec)

    def alive(self) -> list[Task]:
        """The recorded tasks that are not dead."""
        return [t for t in self.tasks if t.alive]

    def problems(self) -> list[str]:
        """One line per illegal transition and per task left alive (empty if all is well)."""
        out = [
            f"illegal status transition {old.name} -> {new.name} of task {'/'.join(path)}"
            for path, old, new in self.illegal
        ]
        for t in self.alive():
            doing = f", {t.waiting_on}" if t.waiting_on else ""
            out.append(f"task left alive: {'/'.join(t.path)} ({t.state.name}{doing})")
        return out

    def assert_clean(self) -> None:
        """Raise ``AssertionError`` naming illegal transitions and tasks left alive."""
        problems = self.problems()
        if problems:
            raise AssertionError("cpl run checker:\n  " + "\n  ".join(problems))

    def forget_alive(self) -> list[Task]:
        """Stop tracking the tasks alive now and return them (after a run that hung: the
        hang is the failure, its stuck tasks are not reported a second time)."""
        alive = self.alive()
        self.tasks = [t for t in self.tasks if not t.alive]
        return alive


class HangDetected(AssertionError):
    """A guarded run did not end within its wall-clock limit. ``tree`` is the text dump
    of the run's task trees at that moment (best effort)."""

    def __init__(self, message: str, tree: str) -> None:
        super().__init__(f"{message}\n{tree}")
        self.tree = tree


def _render_loop_roots(loop: asyncio.AbstractEventLoop) -> str:
    from .lowlevel import render_roots

    roots = [r for r in current_roots() if r._atask is not None and r._atask.get_loop() is loop]
    return render_roots(roots)


def _render_in_loop(loop: asyncio.AbstractEventLoop) -> str:
    """Render the loop's task trees from inside its thread (bounded wait), falling back to
    rendering from this thread if the loop does not answer."""
    box: list[str] = []
    done = threading.Event()

    def render() -> None:
        box.append(_render_loop_roots(loop))
        done.set()

    try:
        loop.call_soon_threadsafe(render)
    except RuntimeError:  # closed meanwhile
        return "(the run ended while its tree was being rendered)\n"
    if done.wait(_STOP_GRACE):
        return box[0]
    return _render_loop_roots(loop)


def _cancel_remaining(loop: asyncio.AbstractEventLoop) -> None:
    tasks = [t for t in asyncio.all_tasks(loop) if not t.done()]
    for t in tasks:
        t.cancel()
    if tasks:
        loop.run_until_complete(asyncio.gather(*tasks, return_exceptions=True))


def _discard_stuck_tasks(loop: asyncio.AbstractEventLoop) -> None:
    """Close the coroutines of the tasks a stopped loop left pending, now and in its own
    thread, so that the garbage collector does not close them later (its errors would
    surface in some unrelated test). Their ``finally`` blocks run once more and may fail:
    ignored on purpose, the run is dead and already reported. Never waits."""
    tasks = [t for t in asyncio.all_tasks(loop) if not t.done()]
    events._set_running_loop(loop)  # cleanup code may look the loop up; nothing runs it
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            for task in tasks:
                task._log_destroy_pending = False  # type: ignore[attr-defined]
                coro = task.get_coro()
                try:
                    if coro is not None and hasattr(coro, "close"):
                        coro.close()
                except BaseException:  # a dead run's cleanup may fail: ignored on purpose
                    pass
    finally:
        events._set_running_loop(None)


def run_app_guarded(
    main: Callable[..., Awaitable[Any]],
    *args: Any,
    clock: Clock | None = None,
    wall_timeout: float = 30.0,
    debug: bool | None = None,
) -> Any:
    """Run ``main(*args)`` to completion on a fresh event loop (with ``clock`` installed)
    in a daemon thread; return its value or re-raise its exception.

    Raises :class:`HangDetected`, with the task trees of the top levels on that loop, if
    the run, including the loop's shutdown (cancelling leftover asyncio tasks, closing
    async generators), has not finished ``wall_timeout`` wall seconds after the start.
    ``main`` runs in a fresh context, like a new ``asyncio.run``.
    """
    if not callable(main):
        raise TypeError(f"run_app_guarded(main, *args): main is an async callable, got {main!r}")
    if not wall_timeout > 0:
        raise ValueError(f"wall_timeout is a positive number of seconds, got {wall_timeout!r}")
    loop = asyncio.new_event_loop()
    if debug is not None:
        loop.set_debug(debug)
    if clock is not None:
        try:
            clock.install(loop)
        except BaseException:
            loop.close()
            raise
    outcome: dict[str, Any] = {}
    stopped = threading.Event()  # set when the guard stops the loop from outside

    def body() -> None:
        try:
            events.set_event_loop(loop)
            try:
                outcome["value"] = loop.run_until_complete(main(*args))
            except BaseException as exc:
                if not stopped.is_set():
                    outcome["error"] = exc
            if not stopped.is_set():
                error = outcome.get("error")
                if isinstance(error, RunTimeout) and error.stuck:
                    _discard_stuck_tasks(loop)  # cpl already gave up on them: do not wait
                else:
                    _cancel_remaining(loop)
                loop.run_until_complete(loop.shutdown_asyncgens())
        except BaseException as exc:  # the shutdown failed, or the guard stopped it
            if not stopped.is_set():
                outcome.setdefault("error", exc)
        finally:
            if stopped.is_set():
                _discard_stuck_tasks(loop)
            if clock is not None:
                clock.uninstall(loop)
            events.set_event_loop(None)
            if not loop.is_running():
                loop.close()

    thread = threading.Thread(target=body, name="cpl-run-guarded", daemon=True)
    thread.start()
    thread.join(wall_timeout)
    if thread.is_alive():
        tree = _render_in_loop(loop)
        stopped.set()
        try:
            loop.call_soon_threadsafe(loop.stop)
        except RuntimeError:  # closed meanwhile: it finished just now
            pass
        thread.join(_STOP_GRACE)
        blocked = " (its thread is blocked in synchronous code)" if thread.is_alive() else ""
        name = getattr(main, "__name__", repr(main))
        raise HangDetected(
            f"the run of {name!r} did not end within {wall_timeout} s of wall time; its loop "
            f"was stopped{blocked}",
            tree,
        )
    if "error" in outcome:
        raise outcome["error"]
    return outcome.get("value")


def run_guarded(
    fn: Callable[..., Awaitable[Any]] | Awaitable[Any],
    *args: Any,
    wall_timeout: float = 30.0,
    instruments: Iterable[Instrument] = (),
    clock: Clock | None = None,
    debug: bool | None = None,
    **top_level_kwargs: Any,
) -> Any:
    """``cpl.run(fn, *args, clock=clock, instruments=instruments, **top_level_kwargs)``
    guarded by :func:`run_app_guarded`: returns the plan's value or re-raises its failure;
    a run still going after ``wall_timeout`` wall seconds raises :class:`HangDetected`
    with the task tree, and its loop is stopped. Use it for tests whose failure mode is a
    hang. ``top_level_kwargs``: ``name``, ``history``, ``timeout``, ``cleanup_timeout``.
    """
    instruments = list(instruments)

    async def run_top_level() -> Any:
        return await top_level(fn, *args, instruments=instruments, **top_level_kwargs)

    run_top_level.__name__ = getattr(fn, "__name__", "plan")
    return run_app_guarded(run_top_level, clock=clock, wall_timeout=wall_timeout, debug=debug)


def call_guarded(fn: Callable[..., Any], *args: Any, wall_timeout: float = 30.0) -> Any:
    """Call the synchronous ``fn(*args)`` in a daemon thread and return its value (or
    re-raise its exception); raise :class:`HangDetected` after ``wall_timeout`` seconds.

    For scenarios that own their loop (``anyio.run``, ``asyncio.run``): such a loop
    cannot be stopped from outside, so a hung one is left running in its daemon thread;
    prefer :func:`run_app_guarded` when the scenario is a coroutine.
    """
    outcome: dict[str, Any] = {}

    def body() -> None:
        try:
            outcome["value"] = fn(*args)
        except BaseException as exc:  # handed to the calling thread
            outcome["error"] = exc

    thread = threading.Thread(target=body, name="cpl-call-guarded", daemon=True)
    thread.start()
    thread.join(wall_timeout)
    if thread.is_alive():
        from .lowlevel import render_roots

        raise HangDetected(
            f"{getattr(fn, '__name__', fn)!r} did not return within {wall_timeout} s of wall time",
            render_roots(current_roots()),
        )
    if "error" in outcome:
        raise outcome["error"]
    return outcome.get("value")
