"""Running plans: ``run``, ``top_level``, and the trees of named top levels.

A *run* is one top-level task with everything below it. Instruments, and the live tasks
of the tree, belong to the run. The one process-wide store is :class:`RunHistory`, which
keeps the last run of each *named* top level (CRAM's ``*top-level-task-trees*``) so that
``cpl.task_tree(name)`` works after ``run`` returned; pass ``history=`` to use your own.
"""

from __future__ import annotations

import asyncio
import weakref
from collections import OrderedDict
from collections.abc import Awaitable, Callable, Iterable
from typing import TYPE_CHECKING, Any

from ._cleanup import log_cleanup_failures
from ._failure_handling import _Retry, _Return
from ._instruments import Instrument, InstrumentSet
from ._scheduling import CURRENT_TASK
from ._task import Task, as_coroutine, wait_dead

if TYPE_CHECKING:
    from ._tree import TaskNode

__all__ = ["Run", "RunHistory", "current_roots", "run", "task_tree", "top_level"]


class Run:
    """One top-level run: its root task and its instruments."""

    __slots__ = ("__weakref__", "instruments", "name", "root")

    def __init__(self, name: str, instruments: Iterable[Instrument]) -> None:
        self.name = name
        self.instruments = InstrumentSet(instruments)
        self.root: Task | None = None


class RunHistory:
    """The last run of each named top level (bounded: the oldest names are dropped)."""

    def __init__(self, max_names: int = 64) -> None:
        self._roots: OrderedDict[str, Task] = OrderedDict()
        self._snapshots: dict[str, TaskNode] = {}
        self.max_names = max_names

    def record(self, name: str, root: Task) -> None:
        self._roots[name] = root
        self._roots.move_to_end(name)
        self._snapshots.pop(name, None)
        while len(self._roots) > self.max_names:
            old, _ = self._roots.popitem(last=False)
            self._snapshots.pop(old, None)

    def tree(self, name: str) -> TaskNode | None:
        """The snapshot of the last run of ``name`` (``None`` if it never ran)."""
        if name not in self._roots:
            return None
        snap = self._snapshots.get(name)
        if snap is None:
            from ._tree import snapshot

            snap = self._snapshots[name] = snapshot(self._roots[name])
        return snap

    def root(self, name: str) -> Task | None:
        return self._roots.get(name)

    def clear(self) -> None:
        self._roots.clear()
        self._snapshots.clear()


DEFAULT_HISTORY = RunHistory()
# The roots of runs in progress (weak: a finished run is not kept alive by this set); used
# by lowlevel.dump_task_tree from a signal handler.
_ACTIVE: weakref.WeakSet[Task] = weakref.WeakSet()


def current_roots() -> list[Task]:
    """Root tasks of the top levels running now in this process."""
    return list(_ACTIVE)


def task_tree(name: str, history: RunHistory | None = None) -> TaskNode | None:
    """The task-tree snapshot of the last run of the named top level ``name``."""
    return (history or DEFAULT_HISTORY).tree(name)


async def top_level(
    fn: Callable[..., Awaitable[Any]] | Awaitable[Any],
    *args: Any,
    name: str | None = None,
    instruments: Iterable[Instrument] = (),
    history: RunHistory | None = None,
) -> Any:
    """Run a plan as a top-level task inside a running event loop.

    Returns the plan's value or raises its failure (the same object), and returns only when
    every task it started is dead. Top levels do not nest (``RuntimeError``). If the caller
    is cancelled, the plan is evaporated and waited for, then the cancellation propagates.
    """
    if CURRENT_TASK.get() is not None:
        raise RuntimeError(
            "top-level calls cannot be nested: you are already inside cpl task "
            f"{CURRENT_TASK.get()!r}; call the plan directly or use cpl.spawn"
        )
    if args:
        if not callable(fn):
            raise TypeError("top_level(fn, *args): fn must be callable when arguments are given")
        aw: Any = fn(*args)
    else:
        aw = fn
    coro = as_coroutine(aw)
    label = name or getattr(coro, "__name__", None) or "top-level"
    run_ = Run(label, instruments)
    root = Task(coro, label, kind="top-level", _register=False)
    root._run = run_
    run_.root = root
    for hook in run_.instruments.run_started:
        hook(root)
    _ACTIVE.add(root)
    try:
        root.start()
        try:
            while root.alive:
                fut = root._add_waiter()
                try:
                    await fut
                finally:
                    root._drop_waiter(fut)
        except asyncio.CancelledError:
            root.evaporate("the caller of top_level was cancelled")
            await wait_dead([root])
            raise
    finally:
        _ACTIVE.discard(root)
        log_cleanup_failures(root)  # otherwise seen only in the recorded tree
        if name is not None:
            (history or DEFAULT_HISTORY).record(name, root)
        for hook in run_.instruments.run_finished:
            hook(root)
    if root.failure is not None:
        failure = root.failure
        if isinstance(failure, _Retry | _Return):
            raise RuntimeError(
                "cpl.retry() / cpl.return_() was called outside any with_failure_handling"
            ) from None
        raise failure
    return root.result


def run(
    fn: Callable[..., Awaitable[Any]] | Awaitable[Any],
    *args: Any,
    name: str | None = None,
    clock: Any = None,
    instruments: Iterable[Instrument] = (),
    history: RunHistory | None = None,
    debug: bool | None = None,
) -> Any:
    """Run a plan in a new event loop (like ``asyncio.run``) as a top level.

    ``clock`` installs a clock policy on the loop (``cpl.testing.MockClock()`` for tests:
    virtual time that jumps when everything waits). Returns the plan's value or raises its
    failure; every task is dead when it returns.
    """
    if CURRENT_TASK.get() is not None:
        raise RuntimeError("cpl.run cannot be called from inside a cpl task; await the plan")

    def factory() -> asyncio.AbstractEventLoop:
        loop = asyncio.new_event_loop()
        if clock is not None:
            clock.install(loop)
        return loop

    with asyncio.Runner(debug=debug, loop_factory=factory) as runner:
        return runner.run(top_level(fn, *args, name=name, instruments=instruments, history=history))
