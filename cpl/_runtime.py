"""Running plans: ``run``, ``top_level``, and the trees of named top levels.

A *run* is one top-level task with everything below it. Instruments, and the live tasks
of the tree, belong to the run. The one process-wide store is :class:`RunHistory`, which
keeps the last run of each *named* top level (CRAM's ``*top-level-task-trees*``) so that
``cpl.task_tree(name)`` works after ``run`` returned; pass ``history=`` to use your own.
"""

from __future__ import annotations

import asyncio
import ctypes
import importlib
import inspect
import logging
import weakref
from asyncio import events
from collections import OrderedDict
from collections.abc import Awaitable, Callable, Iterable
from typing import TYPE_CHECKING, Any

from ._cleanup import log_cleanup_failures
from ._clock import Clock
from ._failure_handling import _Retry, _Return
from ._instruments import Instrument, InstrumentSet
from ._retention import KeepAll, Retention, _Retainer
from ._scheduling import CURRENT_TASK, DeferredCancellation
from ._task import Task, _Driver, as_coroutine

if TYPE_CHECKING:
    from ._tree import TaskNode

log = logging.getLogger("cpl")

__all__ = [
    "Run",
    "RunHistory",
    "RunTimeout",
    "current_roots",
    "run",
    "stray_asyncio_tasks",
    "task_tree",
    "top_level",
]


class Run:
    """One top-level run: its root task and its instruments."""

    __slots__ = ("__weakref__", "before", "instruments", "name", "retention", "root")

    def __init__(self, name: str, instruments: Iterable[Instrument]) -> None:
        self.name = name
        self.instruments = InstrumentSet(instruments)
        self.root: Task | None = None
        # Invariant: None when the run keeps its whole tree (cpl.KeepAll), else the
        # retainer of its retention policy, which is also the last of its instruments
        # (it sees a child finish after every other instrument did).
        self.retention: _Retainer | None = None
        # Invariant: the asyncio tasks of the loop that existed when the run started
        # (weakly held); every other asyncio task was created during the run.
        self.before: weakref.WeakSet[asyncio.Task[Any]] = weakref.WeakSet()


def stray_asyncio_tasks(root: Task) -> list[asyncio.Task[Any]]:
    """The plain asyncio tasks created during ``root``'s run that are still pending: not
    the asyncio task of any cpl task of the run, not the calling one, not one that existed
    before the run began. A plan that leaves such a task behind leaks it (cpl evaporates
    only cpl tasks). Call it on the run's loop."""
    run_ = root._run
    if run_ is None:
        raise ValueError(f"{root!r} is not the root of a run (start it with cpl.run / top_level)")
    ours = {t._atask for t in root._subtree() if t._atask is not None}
    me = asyncio.current_task()
    return [
        t
        for t in asyncio.all_tasks()
        if not t.done() and t is not me and t not in ours and t not in run_.before
    ]


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
    timeout: float | None = None,
    cleanup_timeout: float = 30.0,
    retention: Retention | None = None,
    _own_loop: bool = False,
) -> Any:
    """Run a plan as a top-level task inside a running event loop.

    Returns the plan's value or raises its failure (the same object), and returns only when
    every task it started is dead. Top levels do not nest (``RuntimeError``). If the caller
    is cancelled, the plan is evaporated and waited for, at most ``cleanup_timeout``
    seconds (tasks still alive then are logged and abandoned), then the cancellation
    propagates.

    ``timeout`` (seconds of the loop clock) bounds the run: when it passes, the plan is
    evaporated, its cleanup gets ``cleanup_timeout`` more seconds, and :class:`RunTimeout`
    is raised. It cannot hang: if the cleanup does not end in time either, ``RunTimeout``
    is raised anyway and names the tasks still alive (``stuck``); they are abandoned (a
    task that never awaits cannot be stopped by anyone on asyncio).

    Runs on asyncio only: under anyio use the asyncio backend (``anyio.run(main,
    backend="asyncio")``); awaiting it on trio raises ``RuntimeError`` (see
    ``docs/async_interop.md``).

    ``retention`` (a :class:`cpl.Retention`: :class:`cpl.KeepAll`, the default,
    :class:`cpl.KeepRecent` or :class:`cpl.StreamFinished`) says how much of the recorded
    tree stays in memory; a robot running all day in one top level should not keep it all
    (see ``cpl._retention``).

    (``_own_loop`` is for :func:`run`: the loop is fresh, so the asyncio tasks there
    before the run need not be listed for :func:`stray_asyncio_tasks`.)
    """
    _require_asyncio("cpl.top_level", fn)
    _check_timeouts(timeout, cleanup_timeout)
    _check_retention(retention, fn)
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
    if _own_loop:  # cpl.run's fresh loop: only this task was there before the run
        me = asyncio.current_task()
        assert me is not None
        run_.before.add(me)
    else:
        run_.before.update(asyncio.all_tasks())
    root = Task(coro, label, kind="top-level", _register=False)
    root._run = run_
    run_.root = root
    retainer = (retention or _KEEP_ALL)._start(root)
    if retainer is not None:
        run_.retention = retainer
        run_.instruments.add(retainer)
    for hook in run_.instruments.run_started:
        hook(root)
    _ACTIVE.add(root)
    loop = asyncio.get_running_loop()
    # Invariant: None until the root is evaporated (timeout or a cancelled caller); then
    # the loop time by which its cleanup must have ended. Set once: a second reason to
    # stop (the caller cancelled during the timeout's cleanup) does not extend it.
    cleanup_deadline: float | None = None
    try:
        root.start()
        try:
            if timeout is None:
                while root.alive:
                    fut = root._add_waiter()
                    try:
                        await fut
                    finally:
                        root._drop_waiter(fut)
            elif not await _wait_dead_until(root, loop.time() + timeout):
                root.evaporate(f"the run exceeded its timeout of {timeout:g} s", by=("timeout",))
                cleanup_deadline = loop.time() + cleanup_timeout
                if not await _wait_dead_until(root, cleanup_deadline):
                    raise RunTimeout(timeout, cleanup_timeout, root)
                raise RunTimeout(timeout, None, root)
        except asyncio.CancelledError:
            root.evaporate("the caller of top_level was cancelled")
            if cleanup_deadline is None:
                cleanup_deadline = loop.time() + cleanup_timeout
            if not await _wait_dead_shielded(root, cleanup_deadline):
                # The caller's cancellation goes on (it is theirs, not ours to turn into
                # a RunTimeout); the tasks that did not end are reported and abandoned.
                stuck = [t for t in root._subtree() if t.alive]
                log.error(
                    "top level %r: the caller was cancelled and the cleanup did not end "
                    "within cleanup_timeout=%g s; abandoned, still alive: %s",
                    label,
                    cleanup_timeout,
                    ", ".join("/".join(t.path) for t in stuck[:10]),
                )
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
    clock: Clock | None = None,
    instruments: Iterable[Instrument] = (),
    history: RunHistory | None = None,
    debug: bool | None = None,
    timeout: float | None = None,
    cleanup_timeout: float = 30.0,
    retention: Retention | None = None,
) -> Any:
    """Run a plan in a new event loop (like ``asyncio.run``) as a top level.

    ``clock`` installs a clock policy on the loop (``cpl.testing.MockClock()`` for tests:
    virtual time that jumps when everything waits). Returns the plan's value or raises its
    failure; every task is dead when it returns. ``timeout``/``cleanup_timeout`` as in
    :func:`top_level`; when tasks are stuck even after the cleanup time, the loop is closed
    without waiting for them (``asyncio.run`` would hang there) and :class:`RunTimeout`
    says which they are. ``retention`` as in :func:`top_level`.
    """
    if CURRENT_TASK.get() is not None:
        raise RuntimeError("cpl.run cannot be called from inside a cpl task; await the plan")
    if _running_loop() is not None:
        _close(fn)
        raise RuntimeError(
            "cpl.run starts its own event loop and cannot be called while one is running in "
            "this thread (an asyncio application, anyio.run, a pytest-asyncio test): use "
            "`await cpl.top_level(plan, ...)` there"
        )
    _check_timeouts(timeout, cleanup_timeout)
    _check_retention(retention, fn)

    def factory() -> asyncio.AbstractEventLoop:
        loop = asyncio.new_event_loop()
        if clock is not None:
            clock.install(loop)
        return loop

    runner = asyncio.Runner(debug=debug, loop_factory=factory)
    try:
        return runner.run(
            top_level(
                fn,
                *args,
                name=name,
                instruments=instruments,
                history=history,
                timeout=timeout,
                cleanup_timeout=cleanup_timeout,
                retention=retention,
                _own_loop=True,
            )
        )
    finally:
        _shut_down(runner, cleanup_timeout)


def _shut_down(runner: asyncio.Runner, cleanup_timeout: float) -> None:
    """Close ``runner`` without waiting unboundedly (``Runner.close`` cancels every task
    left and waits for all of them: one stuck cleanup would hang it).

    - cpl tasks still alive were already given their cleanup time by ``top_level``
      (``RunTimeout`` with ``stuck``, or a cancelled caller): they are abandoned at once;
    - plain asyncio tasks the plan left running are cancelled and get ``cleanup_timeout``
      seconds of the loop clock to end, then the rest is abandoned.
    """
    loop = runner.get_loop()
    if loop.is_closed():
        return
    left = [t for t in asyncio.all_tasks(loop) if not t.done()]
    stuck = [t for t in left if isinstance(t.get_coro(), _Driver)]
    others = [t for t in left if not isinstance(t.get_coro(), _Driver)]
    if others:
        for t in others:
            t.cancel("the run is over: a task the plan left running is cancelled")
        try:
            loop.run_until_complete(asyncio.wait(others, timeout=cleanup_timeout))
        finally:
            stuck += [t for t in others if not t.done()]
    if stuck:
        _abandon(loop, stuck)
    else:
        runner.close()


def _abandon(loop: asyncio.AbstractEventLoop, tasks: list[asyncio.Task[Any]]) -> None:
    """Give up on ``tasks`` (stuck beyond every bound) and close ``loop`` without waiting.

    Each coroutine is closed once, with ``loop`` set as the running loop (nothing runs
    it): its ``finally`` blocks run, and cleanup that awaits gets a pending future and
    suspends, which ends the close (``RuntimeError``: it ignored ``GeneratorExit``). Such a
    coroutine, one that refuses to close (it catches ``BaseException`` around its waits),
    is never driven again: it is logged and made immortal (its reference count is raised
    for good), since the garbage collector would otherwise close it a second time, with
    no loop to suspend on, where a plan that swallows every exception spins forever (in
    the collector, or at interpreter exit). A few hundred bytes per such task, for the
    life of the process, is the price of never hanging.
    """
    events._set_running_loop(loop)
    try:
        for atask in tasks:
            atask._log_destroy_pending = False  # type: ignore[attr-defined]
            coro = atask.get_coro()
            if coro is None or not hasattr(coro, "close"):
                continue
            chain = _await_chain(coro)
            try:
                coro.close()
            except RuntimeError as exc:  # it awaited in its cleanup, or ignored the close
                log.warning("abandoned task %r did not close cleanly: %s", atask.get_name(), exc)
            except BaseException as exc:  # its cleanup raised: the run is over, report it
                log.warning("abandoned task %r raised while closing: %r", atask.get_name(), exc)
            # Closing an outer coroutine whose inner one refused detaches the inner one,
            # still suspended: every suspended coroutine of the chain is kept.
            refused = [c for c in chain if _suspended(c)]
            if refused:
                log.error(
                    "abandoned task %r refused to close (%s catches BaseException around "
                    "its waits); it is made immortal, never run again",
                    atask.get_name(),
                    getattr(refused[-1], "__qualname__", refused[-1]),
                )
                for c in refused:
                    ctypes.pythonapi.Py_IncRef(ctypes.py_object(c))
    finally:
        events._set_running_loop(None)
    loop.close()


def _await_chain(coro: Any) -> list[Any]:
    """The coroutines and generators ``coro`` is suspended in, outermost first."""
    chain: list[Any] = []
    obj = coro
    while obj is not None and len(chain) < 100_000:  # bounded, whatever the objects claim
        if isinstance(obj, _Driver):  # a cpl task's driver: its body is what runs
            obj = obj._coro
            continue
        if inspect.iscoroutine(obj) or inspect.isgenerator(obj):
            chain.append(obj)
        inner = getattr(obj, "cr_await", None)
        obj = inner if inner is not None else getattr(obj, "gi_yieldfrom", None)
    return chain


def _suspended(obj: Any) -> bool:
    frame = obj.cr_frame if inspect.iscoroutine(obj) else obj.gi_frame
    return frame is not None


class RunTimeout(TimeoutError):
    """A run exceeded its ``timeout``. ``stuck`` lists the tasks that were still alive
    after ``cleanup_timeout`` more seconds (empty when the cleanup finished in time)."""

    def __init__(self, timeout: float, cleanup_timeout: float | None, root: Task) -> None:
        self.timeout = timeout
        self.stuck: list[Task] = [t for t in root._subtree() if t.alive]
        if self.stuck:
            names = ", ".join("/".join(t.path) for t in self.stuck[:10])
            msg = (
                f"the run exceeded its timeout of {timeout:g} s and its cleanup did not end "
                f"within {cleanup_timeout:g} s more; still alive: {names}"
            )
        else:
            msg = f"the run exceeded its timeout of {timeout:g} s; it was evaporated"
        super().__init__(msg)


_KEEP_ALL = KeepAll()


def _check_retention(retention: Any, fn: Any) -> None:
    if retention is not None and not isinstance(retention, Retention):
        _close(fn)
        raise TypeError(
            f"retention must be a cpl.Retention policy (cpl.KeepAll(), cpl.KeepRecent(n), "
            f"cpl.StreamFinished(path)), got {retention!r}"
        )


def _check_timeouts(timeout: float | None, cleanup_timeout: float) -> None:
    if timeout is not None and not (timeout >= 0 and timeout != float("inf")):
        raise ValueError(f"timeout must be a finite number of seconds >= 0, got {timeout!r}")
    if not (cleanup_timeout >= 0 and cleanup_timeout != float("inf")):
        raise ValueError(
            f"cleanup_timeout must be a finite number of seconds >= 0, got {cleanup_timeout!r}"
        )


async def _wait_dead_until(task: Task, deadline: float) -> bool:
    """Wait until ``task`` is dead or the loop clock reaches ``deadline``; whether it died."""
    loop = asyncio.get_running_loop()
    while task.alive:
        if loop.time() >= deadline:
            return False
        fut = task._add_waiter()
        timer = loop.call_at(deadline, _wake, fut)
        try:
            await fut
        finally:
            timer.cancel()
            task._drop_waiter(fut)
    return True


async def _wait_dead_shielded(task: Task, deadline: float) -> bool:
    """:func:`_wait_dead_until`, surviving cancellation: the caller was cancelled already
    and its cleanup is what we wait for, so a repeated cancellation (anyio re-delivers its
    scope's) does not cut the wait short; it is held off (:class:`DeferredCancellation`)
    and dropped, since the caller re-raises the first one anyway. Whether ``task`` died."""
    deferred = DeferredCancellation()
    try:
        while True:
            try:
                return await _wait_dead_until(task, deadline)
            except asyncio.CancelledError as exc:
                deferred.defer(exc)
    finally:
        deferred.release()


def _wake(fut: asyncio.Future[None]) -> None:
    if not fut.done():
        fut.set_result(None)


def _running_loop() -> asyncio.AbstractEventLoop | None:
    try:
        return asyncio.get_running_loop()
    except RuntimeError:
        return None


def _close(fn: Any) -> None:
    if inspect.iscoroutine(fn):
        fn.close()


def _require_asyncio(what: str, fn: Any) -> None:
    """Raise a clear error when awaited outside asyncio (trio, via anyio or not)."""
    if _running_loop() is not None:
        return
    _close(fn)
    library = "unknown"
    try:
        # sniffio is optional (trio and older anyio bring it): looked up, not imported.
        library = importlib.import_module("sniffio").current_async_library()
    except Exception:  # sniffio missing or no async library detected
        pass
    raise RuntimeError(
        f"{what} runs on asyncio only, but it was awaited without a running asyncio event "
        f"loop (async library: {library}). cpl tasks are asyncio tasks: under anyio use "
        "anyio.run(main, backend='asyncio'); the trio backend (and trio-asyncio) is not "
        "supported"
    )
