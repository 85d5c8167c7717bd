"""Hang guards: run a scenario on its own event loop in a worker thread, with a deadline.

``pytest-timeout`` cannot stop an ``asyncio.Runner`` that is stuck in its shutdown (it
cancels the remaining tasks and waits for them, which is exactly where a cleanup that
spins or livelocks never ends). :func:`run_guarded` owns its loop instead: it runs the
coroutine in a daemon thread, and when the deadline passes it dumps the live cpl task
trees, stops the loop from outside (``call_soon_threadsafe(loop.stop)``: a spinning loop
still runs callbacks) and closes it *without* waiting for the stuck tasks, then raises
:class:`Hung`. Nothing in the guard waits without a bound, so the guard itself cannot hang;
at worst (a thread blocked in synchronous code that never returns to the loop) a daemon
thread is left behind and the test still fails at its deadline.
"""

from __future__ import annotations

import asyncio
import io
import threading
import warnings
from asyncio import events
from collections.abc import Awaitable, Callable
from typing import Any

from cpl import Clock

__all__ = ["DEFAULT_DEADLINE", "Hung", "call_with_deadline", "run_guarded"]

#: Wall seconds a guarded scenario may take by default (tests take milliseconds; this
#: only bounds a hang).
DEFAULT_DEADLINE = 30.0
#: Wall seconds granted to the loop thread to notice the stop request after a hang.
_STOP_GRACE = 5.0


class Hung(AssertionError):
    """A guarded scenario did not finish before its deadline. ``dump`` holds the task
    trees of the cpl runs in progress at the deadline (CRAM-style ASCII tree)."""

    def __init__(self, message: str, dump: str = "") -> None:
        super().__init__(message + (f"\ncpl task trees at the deadline:\n{dump}" if dump else ""))
        self.dump = dump


def _dump_trees() -> str:
    from cpl.lowlevel import dump_task_tree

    buf = io.StringIO()
    try:
        dump_task_tree(file=buf)
    except Exception as exc:  # a diagnostic must never mask the hang itself
        return f"(could not dump the task trees: {exc!r})"
    return buf.getvalue()


def _cancel_remaining(loop: asyncio.AbstractEventLoop) -> None:
    tasks = [t for t in asyncio.all_tasks(loop) if not t.done()]
    for t in tasks:
        t.cancel()
    if tasks:
        loop.run_until_complete(asyncio.gather(*tasks, return_exceptions=True))


def _discard_stuck_tasks(loop: asyncio.AbstractEventLoop) -> None:
    """Close the coroutines of the tasks a stopped loop left pending, now, in this thread,
    so that they are not closed later by the garbage collector (whose errors would surface
    in some unrelated test). Their ``finally`` blocks run once more and may fail: ignored,
    the run is dead. Never waits."""
    tasks = [t for t in asyncio.all_tasks(loop) if not t.done()]
    events._set_running_loop(loop)  # cleanup code may look the loop up; nothing runs it
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            for task in tasks:
                task._log_destroy_pending = False  # type: ignore[attr-defined]
                try:
                    task.get_coro().close()  # type: ignore[union-attr]
                except BaseException:  # a dead run's cleanup may fail: ignored on purpose
                    pass
    finally:
        events._set_running_loop(None)


def run_guarded(
    main: Callable[..., Awaitable[Any]],
    *args: Any,
    clock: Clock | None = None,
    deadline: float = DEFAULT_DEADLINE,
) -> Any:
    """Run ``main(*args)`` to completion on a fresh event loop (with ``clock`` installed)
    in a worker thread; return its value or re-raise its exception.

    Raises :class:`Hung` if the run, including the loop's shutdown (cancelling leftover
    asyncio tasks, closing async generators), has not finished ``deadline`` wall seconds
    after the start. ``main`` runs in a fresh context (context variables of the caller are
    not visible), like a new ``asyncio.run``.
    """
    if not callable(main):
        raise TypeError(f"run_guarded(main, *args): main is an async callable, got {main!r}")
    if not deadline > 0:
        raise ValueError(f"deadline is a positive number of seconds, got {deadline!r}")
    loop = asyncio.new_event_loop()
    if clock is not None:
        try:
            clock.install(loop)
        except BaseException:
            loop.close()
            raise
    outcome: dict[str, Any] = {}
    stopped = threading.Event()  # set when the guard stopped the loop from outside

    def body() -> None:
        try:
            asyncio.set_event_loop(loop)
            try:
                outcome["value"] = loop.run_until_complete(main(*args))
            except BaseException as exc:
                if not stopped.is_set():
                    outcome["error"] = exc
            if not stopped.is_set():
                _cancel_remaining(loop)
                loop.run_until_complete(loop.shutdown_asyncgens())
        except BaseException as exc:  # shutdown failed (or was stopped by the guard)
            if not stopped.is_set():
                outcome.setdefault("error", exc)
        finally:
            if stopped.is_set():
                _discard_stuck_tasks(loop)
            if clock is not None:
                clock.uninstall(loop)
            asyncio.set_event_loop(None)
            if not loop.is_running():
                loop.close()

    thread = threading.Thread(target=body, name="aiocram-guarded-run", daemon=True)
    thread.start()
    thread.join(deadline)
    if thread.is_alive():
        dump = _dump_in_loop(loop)
        stopped.set()
        try:
            loop.call_soon_threadsafe(loop.stop)
        except RuntimeError:  # closed meanwhile: it finished just now
            pass
        thread.join(_STOP_GRACE)
        raise Hung(
            f"the scenario {getattr(main, '__name__', main)!r} did not finish within "
            f"{deadline} s (wall); its loop was stopped"
            + ("" if not thread.is_alive() else " but its thread is blocked in sync code"),
            dump,
        )
    if "error" in outcome:
        raise outcome["error"]
    return outcome.get("value")


def _dump_in_loop(loop: asyncio.AbstractEventLoop) -> str:
    """Dump the task trees from inside the loop thread (bounded wait), falling back to a
    dump from this thread if the loop does not answer."""
    box: list[str] = []
    done = threading.Event()

    def dump() -> None:
        box.append(_dump_trees())
        done.set()

    try:
        loop.call_soon_threadsafe(dump)
    except RuntimeError:
        return ""
    if done.wait(_STOP_GRACE):
        return box[0]
    return _dump_trees()


def call_with_deadline(
    fn: Callable[..., Any], *args: Any, deadline: float = DEFAULT_DEADLINE
) -> Any:
    """Call the synchronous ``fn(*args)`` in a daemon thread and return its value (or
    re-raise its exception); raise :class:`Hung` after ``deadline`` wall seconds.

    For scenarios that own their loop (``anyio.run``, ``asyncio.run``): the guard cannot
    stop such a loop, so a hung one is left spinning in its daemon thread; prefer
    :func:`run_guarded` when the scenario is a coroutine.
    """
    outcome: dict[str, Any] = {}

    def body() -> None:
        try:
            outcome["value"] = fn(*args)
        except BaseException as exc:
            outcome["error"] = exc

    thread = threading.Thread(target=body, name="aiocram-deadline-call", daemon=True)
    thread.start()
    thread.join(deadline)
    if thread.is_alive():
        raise Hung(
            f"{getattr(fn, '__name__', fn)!r} did not return within {deadline} s (wall)",
            _dump_trees(),
        )
    if "error" in outcome:
        raise outcome["error"]
    return outcome.get("value")
