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
"""

from __future__ import annotations

import threading
from collections.abc import Awaitable, Callable, Iterable
from typing import Any

from ._clock import MockClock
from ._instruments import Instrument
from ._runtime import run
from ._status import LEGAL_TRANSITIONS, Status
from ._task import Task

__all__ = ["HangDetected", "MockClock", "TransitionChecker", "run_guarded"]


class TransitionChecker(Instrument):
    """Records every task of a run and every status change; flags illegal transitions.

    After the run, ``checker.illegal`` should be empty and ``checker.alive()`` too
    (:meth:`assert_clean` checks both, with a message naming the offenders).
    """

    def __init__(self) -> None:
        self.transitions: list[tuple[tuple[str, ...], Status, Status]] = []
        self.illegal: list[tuple[tuple[str, ...], Status, Status]] = []
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

    def assert_clean(self) -> None:
        """Raise ``AssertionError`` naming illegal transitions or tasks left alive."""
        if self.illegal:
            raise AssertionError(f"illegal status transitions: {self.illegal}")
        left = self.alive()
        if left:
            raise AssertionError(f"tasks left alive: {left}")


class HangDetected(AssertionError):
    """A guarded run did not end within its wall-clock limit. ``tree`` is the text dump
    of the task tree at that moment (best effort)."""

    def __init__(self, message: str, tree: str) -> None:
        super().__init__(f"{message}\n{tree}")
        self.tree = tree


class _Roots(Instrument):
    def __init__(self) -> None:
        self.roots: list[Task] = []

    def run_started(self, root: Task) -> None:
        self.roots.append(root)


def run_guarded(
    fn: Callable[..., Awaitable[Any]] | Awaitable[Any],
    *args: Any,
    wall_timeout: float = 30.0,
    instruments: Iterable[Instrument] = (),
    **run_kwargs: Any,
) -> Any:
    """``cpl.run(fn, *args, **run_kwargs)`` in a daemon thread, waited for at most
    ``wall_timeout`` wall seconds; returns its value or re-raises its exception.

    A run still going after that raises :class:`HangDetected` with the task tree. The
    stuck thread is abandoned (a daemon: it does not keep the process alive), because a
    loop whose tasks never die cannot be stopped from outside (``asyncio.Runner``'s
    shutdown would hang too). Use it for tests whose failure mode is a hang.
    """
    roots = _Roots()
    outcome: dict[str, Any] = {}

    def target() -> None:
        try:
            outcome["value"] = run(fn, *args, instruments=[*instruments, roots], **run_kwargs)
        except BaseException as exc:  # handed to the calling thread
            outcome["error"] = exc

    thread = threading.Thread(target=target, name="cpl-run-guarded", daemon=True)
    thread.start()
    thread.join(wall_timeout)
    if thread.is_alive():
        from .lowlevel import render_roots

        raise HangDetected(
            f"the run did not end within {wall_timeout} s of wall time", render_roots(roots.roots)
        )
    if "error" in outcome:
        raise outcome["error"]
    return outcome.get("value")
