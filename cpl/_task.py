"""Tasks: the nodes of the task tree, each running on its own asyncio task.

Life cycle (see :class:`~cpl.Status`): a task is CREATED, RUNNING once its asyncio task
executes, may be SUSPENDED and woken, and ends SUCCEEDED (with a result), FAILED (with the
failure object, re-raised unchanged by every join) or EVAPORATED (cancelled; joins give
``None``).

Design notes, and where we differ from CRAM:

- A cpl task wraps an asyncio task that runs its body through :class:`_Driver` (the work
  of :meth:`Task._main`, without a coroutine frame of its own). Joiners never
  await that asyncio task: they wait on futures of their own, so cancelling a joiner never
  leaks into the joined task (asyncio would otherwise cancel the awaited task too).
- When a task's body has finished (returned, failed or been evaporated), the task
  evaporates every child still alive and **waits for them** before its own status changes,
  also when it failed (CRAM evaporates asynchronously on failure; we always wait, so that
  "every task is dead when ``run`` returns" holds).
- Order of cleanup: a form (``par``, ``pursue``, a joined plan call, ...) evaporates its
  children and waits for them *before* the exception unwinds further, so children's
  ``finally`` blocks run before the parent's. CRAM runs the parent's own cleanups first;
  structured concurrency on asyncio makes the inner-first order the natural one.
- Evaporation is asyncio cancellation. Waiting for the children to die during teardown
  survives further cancellations (it keeps waiting and re-raises afterwards), so cleanup
  cannot be cut short by a second evaporation. While it waits, an anyio cancel scope's
  repeated cancellations are held off by a shielded anyio scope, so the wait sleeps
  instead of spinning (:class:`~cpl._scheduling.DeferredCancellation`).
- A task whose body has ended is tearing down: evaporating it then is a no-op and it ends
  with its body's outcome once its children are dead.
- Evaporation is a *native* asyncio cancellation, like ``Task.cancel`` or
  ``asyncio.timeout``: it goes through ``anyio.CancelScope(shield=True)`` and abandons an
  ``anyio.to_thread.run_sync`` call (the thread runs on). Cleanup that must finish, or a
  thread that must be waited for, goes in ``cpl.shielded(...)``.
"""

from __future__ import annotations

import asyncio
import inspect
from collections.abc import Awaitable, Callable, Coroutine, Generator
from types import CoroutineType
from typing import TYPE_CHECKING, Any, NoReturn, Protocol

from ._failure_handling import signal_failure
from ._failures import Evaporated
from ._scheduling import CURRENT_TASK, DeferredCancellation, block_until
from ._status import LEGAL_TRANSITIONS, Status
from ._subtree import Subtree
from ._timeline import current_time

if TYPE_CHECKING:
    from ._fluents import Fluent

__all__ = ["Task", "current_task", "spawn", "with_task"]

_CREATED = Status.CREATED
_RUNNING = Status.RUNNING
_SUSPENDED = Status.SUSPENDED
_SUCCEEDED = Status.SUCCEEDED
_FAILED = Status.FAILED
_EVAPORATED = Status.EVAPORATED
_DEAD = frozenset({_SUCCEEDED, _FAILED, _EVAPORATED})
_BODY_DONE: Any = object()  # Task._aw once the body has ended


class Task:
    """A node of the task tree.

    ``cpl.Task(aw, name=...)`` creates a task that exists before it runs (CRAM's tags): it
    becomes a child of the current task at once, is shown as CREATED, and starts when a
    form (``par``, ``partial_order``, ...) receives it or when :meth:`start` is called. A
    task still CREATED when its parent finishes is evaporated without ever running.

    ``aw`` is a coroutine or a zero-argument async callable.
    """

    __slots__ = (
        "__weakref__",
        "_atask",
        "_aw",
        "_blocked_on",
        "_children",
        "_entry",
        "_extras",
        "_inline_parent",
        "_name_counts",
        "_run",
        "_state",
        "_supervisor",
        "_suspend_requested",
        "_waiting",
        "annotations",
        "arguments",
        "end_time",
        "evaporation",
        "failure",
        "kind",
        "name",
        "parent",
        "result",
        "start_time",
    )

    def __init__(
        self,
        aw: Awaitable[Any] | Callable[[], Awaitable[Any]] | None,
        name: str | None = None,
        *,
        kind: str = "task",
        arguments: dict[str, Any] | None = None,
        annotations: dict[str, Any] | None = None,
        parent: Task | None = None,
        subtree: Subtree | None = None,
        _register: bool = True,
    ) -> None:
        if (
            aw is not None
            and type(aw) is not CoroutineType
            and not inspect.isawaitable(aw)
            and not callable(aw)
        ):
            raise TypeError(
                f"a cpl task runs a coroutine or a zero-argument async callable, got "
                f"{type(aw).__name__}; did you mean to call the function first?"
            )
        self.name: str = name if name is not None else _name_of(aw)
        self.kind: str = kind
        # Invariant: the body (a coroutine or an async callable) until it is taken to run;
        # then None; _BODY_DONE once the body has returned, failed or been evaporated: the
        # outcome is then fixed and only the children's teardown remains (evaporate is a
        # no-op).
        self._aw: Any = aw
        self._atask: asyncio.Task[None] | None = None
        # Invariant: set while this task runs *inline*: its body runs in the asyncio task
        # of the parent that joins it (see run_inline), and this is that parent. Such
        # tasks share one asyncio task down a chain; a suspension at the innermost one's
        # checkpoint is where the whole chain stops.
        self._inline_parent: Task | None = None
        # Invariant: _state moves only along LEGAL_TRANSITIONS (checked in _set_state).
        self._state: Status = _CREATED
        # Invariant: None until one of the rarely used parts is needed (the status fluent,
        # partial-order constraints, suspension); a task without them carries none of
        # their four fields (see _TaskExtras).
        self._extras: _TaskExtras | None = None
        self._children: list[Task] | None = None  # creation order
        self._name_counts: dict[str, int] | None = None
        # the path entry: the name, or the call number n when the name repeats at this place
        # (the entry is then ``name#n``, built when asked: a string per task costs ~60 B)
        self._entry: str | int = self.name
        # a form's supervisor, told (``finished(task)``) once when this task ends; an object,
        # not a bound method, so that a form's branch carries no extra allocation
        self._supervisor: Any = None
        # Invariant: True from suspend() until the task is SUSPENDED or wake_up() withdraws
        # the request; block_until suspends the task at its next checkpoint while set.
        self._suspend_requested: bool = False
        # Invariant: the future the task awaits in block_until (its one checkpoint), else
        # None. A suspend request resolves it early (a spurious wake-up the caller re-checks).
        self._blocked_on: asyncio.Future[Any] | None = None
        self.result: Any = None
        self.failure: BaseException | None = None
        self.evaporation: Evaporated | None = None
        self.start_time: float | None = None
        self.end_time: float | None = None
        self.arguments: dict[str, Any] | None = arguments
        self.annotations: dict[str, Any] | None = annotations
        # What the task waits for, described lazily (see ``waiting_on``): a string, or the
        # Fluent / Task it waits for (formatting a message per wait costs a string each).
        self._waiting: Any = None
        self.parent: Task | None = None
        # Invariant: the Run (root and instruments) this task belongs to, the same object
        # for the whole tree: set on the root by top_level, inherited on adoption. None for
        # a task not (yet) in a run: it then reports to no instrument.
        self._run: Any = None
        if subtree is not None:  # before adoption: the spawn hooks (event log) read it
            if not isinstance(subtree, Subtree):
                raise TypeError(f"a task's subtree mark is a cpl.Subtree, got {subtree!r}")
            self._more().subtree = subtree
        if _register:
            owner = parent if parent is not None else CURRENT_TASK.get()
            if owner is not None:
                owner._adopt(self)

    # ------------------------------------------------------------------ tree structure
    def _adopt(self, child: Task) -> None:
        """Make ``child`` a child of this task, naming its path entry (``name#n`` when the
        name repeats at this place, CRAM's ``:call n``)."""
        child.parent = self
        child._run = self._run
        counts = self._name_counts
        if counts is None:
            counts = self._name_counts = {}
        n = counts.get(child.name, 0) + 1
        counts[child.name] = n
        child._entry = child.name if n == 1 else n
        if self._children is None:
            self._children = [child]
        else:
            self._children.append(child)
        run = self._run
        if run is not None and run.instruments.task_spawned:
            for hook in run.instruments.task_spawned:
                hook(child)

    def _move_under(self, new_parent: Task) -> None:
        """Re-parent a CREATED task (a pre-made tag handed to a form)."""
        old = self.parent
        if old is new_parent:
            return
        if old is not None and old._children is not None:
            old._children.remove(self)
        new_parent._adopt(self)

    @property
    def children(self) -> list[Task]:
        """The child tasks in creation order (a copy)."""
        return list(self._children) if self._children else []

    @property
    def path_entry(self) -> str:
        """This task's entry in its path: its name, or ``name#n`` for the n-th call at the
        same place."""
        entry = self._entry
        return entry if type(entry) is str else f"{self.name}#{entry}"

    def snapshot(self, *, max_nodes: int | None = None, collapse_finished: bool = False) -> Any:
        """An immutable :class:`~cpl.TaskNode` of this task and its subtree, now."""
        from ._tree import snapshot

        return snapshot(self, max_nodes=max_nodes, collapse_finished=collapse_finished)

    @property
    def path(self) -> tuple[str, ...]:
        """Path entries from the top level down to this task."""
        parts: list[str] = []
        node: Task | None = self
        while node is not None:
            entry = node._entry
            parts.append(entry if type(entry) is str else f"{node.name}#{entry}")
            node = node.parent
        parts.reverse()
        return tuple(parts)

    # ------------------------------------------------------------------------- status
    @property
    def state(self) -> Status:
        """The current status (without creating the status fluent)."""
        return self._state

    @property
    def status(self) -> Fluent[Status]:
        """The status as a :class:`~cpl.Fluent` (created on first access)."""
        extras = self._more()
        fl: Fluent[Status] | None = extras.status_fluent
        if fl is None:
            from ._fluents import Fluent

            fl = extras.status_fluent = Fluent(self._state, name=f"{self.name}.status")
        return fl

    def _more(self) -> _TaskExtras:
        """The task's rarely used parts, created on first use."""
        extras = self._extras
        if extras is None:
            extras = self._extras = _TaskExtras()
        return extras

    @property
    def subtree(self) -> Subtree | None:
        """What this task's subtree stands for in reasoning (:class:`cpl.Subtree`), fixed
        at creation; ``None`` for an ordinary task."""
        return None if self._extras is None else self._extras.subtree

    @property
    def _constraints(self) -> list[Task] | None:
        return None if self._extras is None else self._extras.constraints

    @property
    def _active_forms(self) -> list[Task] | None:
        return None if self._extras is None else self._extras.active_forms

    @property
    def _resume(self) -> asyncio.Future[None] | None:
        return None if self._extras is None else self._extras.resume

    @_resume.setter
    def _resume(self, fut: asyncio.Future[None] | None) -> None:
        if fut is not None or self._extras is not None:
            self._more().resume = fut

    @property
    def alive(self) -> bool:
        return self._state not in _DEAD

    @property
    def dead(self) -> bool:
        return self._state in _DEAD

    def _set_state(self, new: Status) -> None:
        old = self._state
        if old is new:
            return
        if new not in LEGAL_TRANSITIONS[old]:
            raise RuntimeError(f"illegal status transition {old.name} -> {new.name} of {self!r}")
        self._state = new
        extras = self._extras
        if extras is not None:
            if extras.status_fluent is not None:
                extras.status_fluent.value = new
            waiters = extras.waiters
            if waiters is not None:
                extras.waiters = None
                for fut in waiters:
                    if not fut.done():
                        fut.set_result(None)
        run = self._run
        if run is not None:
            hooks = run.instruments.task_status_changed
            if hooks:
                for hook in hooks:
                    hook(self, old, new)

    def _add_waiter(self) -> asyncio.Future[None]:
        fut: asyncio.Future[None] = asyncio.get_running_loop().create_future()
        extras = self._more()
        if extras.waiters is None:
            extras.waiters = [fut]
        else:
            extras.waiters.append(fut)
        return fut

    def _drop_waiter(self, fut: asyncio.Future[None]) -> None:
        waiters = self._extras.waiters if self._extras is not None else None
        if waiters is not None and not fut.done():
            try:
                waiters.remove(fut)
            except ValueError:
                pass

    # -------------------------------------------------------------------- annotations
    def annotate(self, key: str, value: Any) -> None:
        """Attach a free-form annotation shown in the task tree (e.g. the designator)."""
        if self.annotations is None:
            self.annotations = {}
        self.annotations[key] = value

    @property
    def waiting_on(self) -> str | None:
        """What the task waits for right now, in words (``None`` when it does not wait)."""
        w = self._waiting
        if w is None or type(w) is str:
            return w
        if isinstance(w, Task):
            return f"joining {w.name}"
        return f"waiting for {w.name}"  # a fluent

    @waiting_on.setter
    def waiting_on(self, what: str | None) -> None:
        self._waiting = what

    # ------------------------------------------------------------------- form nodes
    # A form node (kind par, pursue, ...) has no asyncio task of its own: the form's code,
    # running in the owner's task, drives its status through these three methods.
    def _begin_form(self) -> None:
        self.start_time = current_time()
        self._set_state(_RUNNING)

    def _end_form(self, outcome: Status, value: Any, failure: BaseException | None) -> None:
        self.end_time = current_time()
        if outcome is _SUCCEEDED:
            self.result = value
        else:
            self.failure = failure
        if self._state is _SUSPENDED and outcome is _SUCCEEDED:
            self._set_state(_RUNNING)
        self._set_state(outcome)

    def _push_form(self, node: Task) -> None:
        """``node``, a form running in this task's code, is active (suspension follows it)."""
        extras = self._more()
        if extras.active_forms is None:
            extras.active_forms = [node]
        else:
            extras.active_forms.append(node)

    def _pop_form(self, node: Task) -> None:
        forms = self._active_forms
        if forms is not None:
            forms.remove(node)

    # ----------------------------------------------------------------------- starting
    def start(self) -> Task:
        """Start a CREATED task (a no-op if it already started). Returns the task."""
        if self._state is not _CREATED or self._atask is not None:
            return self
        if self.parent is None and self.kind != "top-level":
            owner = CURRENT_TASK.get()
            if owner is None:
                raise RuntimeError(
                    f"task {self.name!r} has no parent: start it inside a cpl task "
                    "(cpl.run / cpl.top_level) or hand it to a form"
                )
            owner._adopt(self)
        self._atask = asyncio.get_running_loop().create_task(_Driver(self))
        return self

    async def _main(self) -> None:
        CURRENT_TASK.set(self)
        if self.evaporation is not None:  # evaporated before it got to run
            self._close_aw()
            self._finish(_EVAPORATED)
            return
        self.start_time = current_time()
        self._set_state(_RUNNING)
        outcome = _SUCCEEDED
        reraise: BaseException | None = None
        try:
            if self._constraints:
                await self._await_constraints()
            if self._suspend_requested:
                await self._suspend_here()
            self.result = await self._take_body()
        except GeneratorExit:
            # The coroutine is being closed without running (an abandoned loop is torn
            # down): no cleanup can await any more; just let it close.
            self._close_aw()
            raise
        except BaseException as exc:
            outcome, reraise = self._ended_by(exc)
        finally:
            self._close_aw()
        await self._after_body(outcome, reraise)

    def _ended_by(
        self, exc: BaseException, inline_parent: Task | None = None
    ) -> tuple[Status, BaseException | None]:
        """How a body that raised ``exc`` ends: the outcome, and what to re-raise after the
        finish; records the failure or the evaporation. The one classification of the
        three ways a body runs (:meth:`_main`, :class:`_Driver` on the task's own asyncio
        task; :meth:`_run_inline` in ``inline_parent``'s asyncio task, shared down a
        chain of inline tasks, whose cancel requests it must take back).

        - a ``CancelledError`` after :meth:`evaporate`: EVAPORATED. Inline, the
          evaporation's cancel request is consumed (``uncancel``) and the cancellation
          goes on only if the shared asyncio task was cancelled for someone else too;
        - a ``CancelledError`` while the asyncio task is being cancelled without an
          evaporation: EVAPORATED and re-raised, from outside cpl (own task) or for an
          ancestor (inline: its parent was evaporated);
        - any other exception, a foreign ``CancelledError`` (an awaited future was
          cancelled: not ours to swallow) included: FAILED with it; ``KeyboardInterrupt``
          and ``SystemExit`` are re-raised after the finish too.
        """
        if isinstance(exc, asyncio.CancelledError):
            host = self._atask
            if self.evaporation is not None:
                if inline_parent is None or host is None:
                    return _EVAPORATED, None
                host.uncancel()  # our own evaporation's cancel request, consumed here
                # the parent (or the asyncio task) was cancelled too: that goes on
                return _EVAPORATED, exc if host.cancelling() else None
            if host is not None and host.cancelling():
                if inline_parent is None:
                    # Someone cancelled our asyncio task directly: evaporation from outside.
                    self.evaporation = Evaporated("cancelled outside cpl", None)
                else:
                    # The shared asyncio task was cancelled for an ancestor (or from
                    # outside): this task dies with it.
                    self.evaporation = Evaporated("its parent was evaporated", inline_parent.path)
                return _EVAPORATED, exc
        self.failure = exc
        if isinstance(exc, (KeyboardInterrupt, SystemExit)):
            return _FAILED, exc
        return _FAILED, None

    async def _after_body(self, outcome: Status, reraise: BaseException | None) -> None:
        """The end of :meth:`_main` once the body has ended: tear the children down, finish
        with ``outcome``, re-raise ``reraise`` (a cancellation from outside cpl)."""
        reraise = await self._end_body(outcome, reraise)
        self._finish(outcome)
        if reraise is not None:
            _raise_unreferenced(reraise)

    async def _run_inline(self) -> Any:
        """Run this CREATED task's body in the calling asyncio task and join it: its value,
        its failure re-raised, or ``None`` if it was evaporated (what ``join`` gives).

        This is the fast path of ``with_task``, plan calls and awaited tags: the parent
        only waits for the child, so the child needs no asyncio task of its own (CRAM's
        ``with-task`` makes a thread). The task tree, statuses, instruments, evaporation,
        suspension and teardown are the same as for a task on its own asyncio task:

        - evaporating the child cancels the shared asyncio task; the child's handler below
          takes back its own cancellation (``uncancel``) and the parent goes on, unless a
          cancellation of the parent (or of the whole asyncio task) is pending too, which
          then propagates after the child has become EVAPORATED;
        - evaporating the parent arrives in the child's code first: the child's ``finally``
          blocks and its children's teardown run before the parent's, as with a joined task.
        """
        parent = CURRENT_TASK.get()
        host = asyncio.current_task()
        assert host is not None and parent is not None
        self._atask = host
        self._inline_parent = parent
        token = CURRENT_TASK.set(self)
        self.start_time = current_time()
        self._set_state(_RUNNING)
        outcome = _SUCCEEDED
        reraise: BaseException | None = None
        try:
            if self._suspend_requested:
                await self._suspend_here()
            self.result = await self._take_body()
        except GeneratorExit:
            self._close_aw()
            raise
        except BaseException as exc:
            outcome, reraise = self._ended_by(exc, parent)
        finally:
            self._close_aw()
        if self.evaporation is not None and outcome is not _EVAPORATED and host.cancelling():
            host.uncancel()  # the body swallowed its evaporation: take back our request
        elif (
            outcome is _FAILED
            and self.evaporation is None
            and host.cancelling()
            and _evaporating(parent)
        ):
            # An ancestor's evaporation unwound this task and its cleanup raised: the task
            # failed in its cleanup (recorded, and logged at the run's end, as for a task of
            # its own), and the ancestor's evaporation goes on instead of that failure.
            # (A cancellation from outside cpl, an anyio scope or asyncio.timeout, is not
            # an evaporation: there the cleanup's failure propagates, as it would from any
            # Python code, and the scope that cancelled sees it instead of a cancellation
            # it never asked for.)
            self.evaporation = Evaporated("its parent was evaporated", parent.path)
            # The cancellation the cleanup interrupted goes on, the same object: whoever
            # else cancelled the asyncio task too (an anyio scope tells its own by the
            # message) still recognises it.
            reraise = _interrupted_cancellation(self.failure) or asyncio.CancelledError()
        reraise = await self._end_body(outcome, reraise)
        CURRENT_TASK.reset(token)
        self._inline_parent = None
        self._finish(outcome)
        if reraise is not None:
            _raise_unreferenced(reraise)
        if parent._state is _SUSPENDED:
            # The parent was suspended while this child ran in its place: its code must
            # not go on before it is woken.
            await parent._wait_resumed()
        if outcome is _FAILED:
            assert self.failure is not None
            signal_failure(self.failure)
            _raise_unreferenced(self.failure)
        return self.result

    def _take_body(self) -> Awaitable[Any]:
        """The body's awaitable (calling a zero-argument async callable); ``TypeError`` if
        the callable returned something else."""
        aw = self._aw
        self._aw = None
        if type(aw) is CoroutineType or inspect.isawaitable(aw):
            return aw
        aw = aw()
        if not inspect.isawaitable(aw):
            raise TypeError(
                f"task {self.name!r}: the callable returned {type(aw).__name__}, "
                "not an awaitable; pass an async function"
            )
        return aw

    async def _end_body(self, outcome: Status, reraise: BaseException | None) -> Any:
        """The body has ended with ``outcome``: from here on the outcome is decided and
        evaporate() is a no-op (nothing is left to stop but the children, which this
        tears down). A cancellation of the asyncio task from outside cpl while the
        children die (wait_dead waits through it) is returned to be re-raised after the
        finish; otherwise ``reraise``."""
        if outcome is not _SUCCEEDED:
            self.result = None
        self._aw = _BODY_DONE
        if self._children:
            try:
                await self._teardown_children()
            except asyncio.CancelledError as exc:
                if reraise is None:
                    reraise = exc
        return reraise

    def _close_aw(self) -> None:
        aw = self._aw
        if aw is _BODY_DONE:
            return
        self._aw = None
        if inspect.iscoroutine(aw):
            aw.close()

    def _finish(self, outcome: Status) -> None:
        self.end_time = current_time()
        self._waiting = None
        if self._state is _SUSPENDED and outcome is _SUCCEEDED:
            self._set_state(_RUNNING)
        self._set_state(outcome)
        sup = self._supervisor
        if sup is not None:
            self._supervisor = None
            sup.finished(self)

    async def _teardown_children(self) -> None:
        """Evaporate the children still alive and wait until all are dead."""
        children = self._children or ()
        me = self.path
        for child in list(children):
            if child._state not in _DEAD:
                child.evaporate(f"parent {self.name!r} finished", by=me)
        await wait_dead([c for c in children if c._state not in _DEAD])

    async def _await_constraints(self) -> None:
        for pred in self._constraints or ():
            self.waiting_on = f"waiting for {pred.name} to finish (partial order)"
            while pred._state not in _DEAD:
                fut = pred._add_waiter()
                try:
                    await block_until(fut)
                finally:
                    pred._drop_waiter(fut)
        self.waiting_on = None

    # ---------------------------------------------------------------------- joining
    async def join(self) -> Any:
        """Wait until the task is dead; return its result, re-raise its failure (the same
        object), or return ``None`` if it was evaporated. A CREATED task is not started
        by joining: it is waited for. Joining the current task raises ``RuntimeError``.
        """
        me = CURRENT_TASK.get()
        if me is self:
            raise RuntimeError(f"task {self.name!r} cannot join itself")
        if me is not None:
            me._waiting = self
        try:
            while self._state not in _DEAD:
                fut = self._add_waiter()
                try:
                    await block_until(fut)
                finally:
                    self._drop_waiter(fut)
        finally:
            if me is not None:
                me._waiting = None
        if self._state is _FAILED:
            assert self.failure is not None
            signal_failure(self.failure)  # the failure enters the joining task here
            raise self.failure
        return self.result

    # ------------------------------------------------------------------- evaporation
    def evaporate(self, reason: str = "evaporated", *, by: tuple[str, ...] | None = None) -> None:
        """Ask the task to end (CRAM's evaporate). Synchronous: it returns at once; join to
        wait for the end. A dead task, or a second request, is a no-op. The task's
        ``finally`` blocks run; its children are evaporated and waited for. ``by`` names who
        asked (default: the path of the calling task).

        A task whose body has already ended and that is waiting for its children's cleanup
        is dying anyway: evaporating it then is a no-op, and it ends with its body's
        outcome once its children are dead (as CRAM, whose teardown, once begun, runs to
        the end)."""
        if self._state in _DEAD or self.evaporation is not None or self._aw is _BODY_DONE:
            return
        if by is None:
            caller = CURRENT_TASK.get()
            by = caller.path if caller is not None else None
        self.evaporation = Evaporated(reason, by)
        if self._atask is None:
            if isinstance(self, FormNode):
                return  # a form node ends with its form
            # Never started: it dies without running.
            self._close_aw()
            self._finish(_EVAPORATED)
            return
        if self._state is _CREATED:
            # Scheduled but not entered yet: cancelling now would kill the coroutine before
            # _main could record the end. _main sees the request on entry instead.
            return
        self._atask.cancel(reason)

    # -------------------------------------------------------------------- suspension
    def _subtree(self) -> Generator[Task, None, None]:
        stack = [self]
        while stack:
            node = stack.pop()
            yield node
            if node._children:
                stack.extend(node._children)

    async def suspend(self) -> None:
        """Suspend the task and its whole subtree; return once every live task of it is
        suspended. Suspension takes effect at cpl checkpoints (``sleep``, ``wait_for``,
        ``join``, form boundaries, ``perform``). A dead task returns at once; suspending a
        suspended task is a no-op (CRAM asserts)."""
        for node in self._subtree():
            if node._state not in _DEAD and not isinstance(node, FormNode):
                if node._state is not _SUSPENDED:
                    node._suspend_requested = True
                    blocked = node._blocked_on
                    if blocked is not None and not blocked.done():
                        blocked.set_result(None)
        me = CURRENT_TASK.get()
        for node in list(self._subtree()):
            if node is me or isinstance(node, FormNode):
                continue
            while node._state is not _SUSPENDED and node._state not in _DEAD:
                if not node._suspend_requested:
                    break  # woken meanwhile
                fut = node._add_waiter()
                try:
                    await block_until(fut)
                finally:
                    node._drop_waiter(fut)
        if me is not None and me in set(self._subtree()) and me._suspend_requested:
            await me._suspend_here()

    def wake_up(self) -> None:
        """Wake a suspended task and its subtree (a synchronous request). Waking a running
        task is a no-op; a pending suspension request is withdrawn."""
        for node in self._subtree():
            node._suspend_requested = False
            resume = node._resume
            if resume is not None and not resume.done():
                resume.set_result(None)

    async def _suspend_here(self) -> None:
        """Suspend at a checkpoint: on_suspension handlers (innermost first), then
        SUSPENDED until woken. Evaporation while suspended raises :class:`Evaporated`
        (the task goes SUSPENDED -> EVAPORATED)."""
        handlers = self._extras.suspension_handlers if self._extras is not None else None
        for handler in reversed(handlers or ()):
            res = handler()
            if inspect.isawaitable(res):
                await res
        # Invariant: the request flag stays set until the task is SUSPENDED, so the
        # suspender can tell "not there yet" from "withdrawn by wake_up".
        if not self._suspend_requested or self._state is not _RUNNING:
            self._suspend_requested = False
            return
        resume: asyncio.Future[None] = asyncio.get_running_loop().create_future()
        self._resume = resume
        self._set_state(_SUSPENDED)
        self._suspend_requested = False
        for form in self._active_forms or ():
            if form._state is _RUNNING:
                form._set_state(_SUSPENDED)
        # Inline ancestors whose code waits for this one in the same asyncio task reach no
        # checkpoint of their own: a pending request suspends them here, with this task.
        node = self._inline_parent
        while node is not None:
            if node._suspend_requested and node._state is _RUNNING:
                node._suspend_requested = False
                node._resume = asyncio.get_running_loop().create_future()
                node._set_state(_SUSPENDED)
                for form in node._active_forms or ():
                    if form._state is _RUNNING:
                        form._set_state(_SUSPENDED)
            node = node._inline_parent
        previous, self._waiting = self._waiting, "suspended"
        try:
            await resume
        except asyncio.CancelledError:
            if self.evaporation is not None:
                raise self.evaporation from None
            raise
        finally:
            self._resume = None
            self._waiting = previous
        self._set_state(_RUNNING)
        for form in self._active_forms or ():
            if form._state is _SUSPENDED:
                form._set_state(_RUNNING)
        node = self._inline_parent
        while node is not None:  # ancestors woken meanwhile run again with this task
            if node._state is _SUSPENDED and node._resume is not None and node._resume.done():
                node._resume = None
                node._resume_state()
            node = node._inline_parent

    def _resume_state(self) -> None:
        self._set_state(_RUNNING)
        for form in self._active_forms or ():
            if form._state is _SUSPENDED:
                form._set_state(_RUNNING)

    async def _wait_resumed(self) -> None:
        """Wait, in this (inline-suspended) task's code, until it is woken; then RUNNING.
        Evaporation while waiting raises :class:`Evaporated`."""
        resume = self._resume
        if resume is None:
            resume = self._resume = asyncio.get_running_loop().create_future()
        previous, self._waiting = self._waiting, "suspended"
        try:
            await resume
        except asyncio.CancelledError:
            if self.evaporation is not None:
                raise self.evaporation from None
            raise
        finally:
            self._resume = None
            self._waiting = previous
        if self._state is _SUSPENDED:
            self._resume_state()

    def __repr__(self) -> str:
        return f"<cpl.Task {'/'.join(self.path)} {self._state.name}>"


async def wait_dead(tasks: list[Task]) -> None:
    """Wait until every task in ``tasks`` is dead, surviving cancellation: a cancellation
    that arrives meanwhile is re-raised once all are dead (cleanup is never cut short; see
    :class:`DeferredCancellation` for anyio's repeated cancellations)."""
    deferred = DeferredCancellation()
    try:
        for t in tasks:
            while t._state not in _DEAD:
                fut = t._add_waiter()
                try:
                    await fut
                except asyncio.CancelledError as exc:
                    deferred.defer(exc)
                finally:
                    t._drop_waiter(fut)
    finally:
        deferred.close()


class _FormPolicy(Protocol):
    """What a form node reads from its form's policy (e.g. ``cpl.ParallelPolicy``)."""

    @property
    def kind(self) -> str: ...


class FormNode(Task):
    """The node of a form (``par``, ``pursue``, ``try_all``, ``par_loop``,
    ``partial_order``) in the task tree. It has no body and no asyncio task of its own:
    the form's code runs in the task that called the form and drives the node's status
    (``_begin_form`` / ``_end_form``), so the node is never started, evaporated on its own
    nor suspended (its branches are). Its kind is its policy's (``policy.kind``, e.g.
    ``"par"``); it is told apart from other tasks by its type, not by that name."""

    __slots__ = ()

    def __init__(self, policy: _FormPolicy, parent: Task) -> None:
        kind = policy.kind
        super().__init__(None, kind, kind=kind, parent=parent)


class _TaskExtras:
    """The parts of a task that few tasks use, kept apart so that a task without them is
    smaller (see ``Task._extras``)."""

    __slots__ = (
        "active_forms",
        "constraints",
        "resume",
        "status_fluent",
        "subtree",
        "suspension_handlers",
        "waiters",
    )

    def __init__(self) -> None:
        self.waiters: list[asyncio.Future[None]] | None = None  # woken on every change
        # Invariant: the form nodes (par, pursue, ...) whose code runs in this task right
        # now, innermost last; they follow this task into and out of SUSPENDED because
        # they have no asyncio task of their own. Pushed and popped by the form.
        self.active_forms: list[Task] | None = None
        self.status_fluent: Any = None  # created on first access of Task.status
        self.constraints: list[Task] | None = None  # partial order: start after these die
        # Invariant: set only while the task is SUSPENDED; resolving it wakes the task.
        self.resume: asyncio.Future[None] | None = None
        self.suspension_handlers: list[Callable[[], Any]] | None = None
        self.subtree: Subtree | None = None  # set once, at the task's creation


class _Driver:
    """What the asyncio task of a cpl task runs: :meth:`Task._main`'s work, done by hand.

    asyncio drives a task's coroutine through ``send``/``throw``/``close``; this object
    speaks that protocol and forwards to the body, so a running task holds no wrapper
    coroutine frame (~200 B less per live task, and one frame less per step). The
    bookkeeping is ``_main``'s, in the same order: the current task is set, the task is
    RUNNING, the body's end is classified as in ``_main``'s ``except`` clauses, the body is
    closed, and the task finishes.

    It hands over to a real coroutine and only forwards from then on (``_task`` is then
    None) when the task must await around its body: it was evaporated
    before it ran, has partial-order constraints or a pending suspension (``_main``), or
    its body ended with children still alive (``_after_body`` tears them down).
    """

    __slots__ = ("_coro", "_task")

    def __init__(self, task: Task) -> None:
        # Invariant: the task until the driver hands over; None from then on (forwarding).
        self._task: Task | None = task
        # Invariant: None before the first step; then the iterator of the body's awaitable,
        # or (once _task is None) the cpl coroutine that does its own bookkeeping.
        self._coro: Any = None

    def send(self, value: Any) -> Any:
        coro = self._coro
        if coro is None:
            coro = self._begin()
        task = self._task
        if task is None:
            return coro.send(value)
        try:
            return coro.send(value)
        except StopIteration as stop:  # the body returned: the common end, handled here
            task.result = stop.value
        except BaseException as exc:
            return self._body_ended(exc)
        children = task._children
        if children and any(c._state not in _DEAD for c in children):
            coro = self._coro = task._after_body(_SUCCEEDED, None)
            self._task = None
            return coro.send(None)
        task._aw = _BODY_DONE
        task._finish(_SUCCEEDED)
        raise StopIteration

    def throw(self, exc: Any, *args: Any) -> Any:
        coro = self._coro
        if coro is None:
            # Thrown in before the first step (the asyncio task was cancelled from outside
            # before it ran): the body never starts, and the task ends as if it had raised
            # ``exc`` at once (a cancellation from outside: EVAPORATED, then re-raised).
            task = self._task
            assert task is not None
            CURRENT_TASK.set(task)
            task.start_time = current_time()
            task._set_state(_RUNNING)
            task._close_aw()
            if args:  # the old (type, value, traceback) form
                exc = args[0] if isinstance(args[0], BaseException) else exc(*args[:1])
            return self._body_ended(exc)
        if self._task is None:
            return coro.throw(exc, *args)
        try:
            return coro.throw(exc, *args)
        except BaseException as failure:
            return self._body_ended(failure)

    def close(self) -> None:
        coro = self._coro
        try:
            if coro is not None:
                coro.close()
        finally:
            if self._task is not None:
                self._task._close_aw()

    def __await__(self) -> Any:  # the Coroutine protocol; asyncio only sends and throws
        return self

    def __next__(self) -> Any:
        return self.send(None)

    @property
    def __name__(self) -> str:  # what asyncio's repr of the task shows as its coroutine
        task = self._task
        if task is None:
            return str(getattr(self._coro, "__qualname__", "cpl task"))
        return f"cpl task {task.name!r}"

    @property
    def cr_frame(self) -> Any:  # for asyncio's Task.get_stack / print_stack
        return getattr(self._coro, "cr_frame", None)

    @property
    def cr_await(self) -> Any:
        return getattr(self._coro, "cr_await", None)

    def _begin(self) -> Any:
        """The first step's set-up: what to send into (the body, or ``_main`` when the task
        must await before its body; then the driver only forwards)."""
        task = self._task
        assert task is not None
        CURRENT_TASK.set(task)
        extras = task._extras
        if (
            task.evaporation is not None
            or task._suspend_requested
            or (extras is not None and extras.constraints)
        ):
            coro = self._coro = task._main()
            self._task = None
            return coro
        task.start_time = current_time()
        task._set_state(_RUNNING)
        aw = task._aw
        if type(aw) is CoroutineType:  # the common case: no call to _take_body
            task._aw = None
        else:
            try:
                aw = task._take_body()
                if type(aw) is not CoroutineType:
                    aw = aw.__await__()
            except BaseException as exc:
                aw = _raising(exc)  # the body fails at its first step, as in _main
        self._coro = aw
        return aw

    def _body_ended(self, exc: BaseException) -> Any:
        task = self._task
        assert task is not None
        reraise: BaseException | None = None
        if type(exc) is StopIteration:  # returned after a throw (send handles its own)
            outcome = _SUCCEEDED
            task.result = exc.value
        elif isinstance(exc, GeneratorExit):
            task._close_aw()
            raise exc
        else:
            outcome, reraise = task._ended_by(exc)
        exc = None  # type: ignore[assignment]  # no failure -> frame -> failure cycle
        if task._aw is not None:
            task._close_aw()
        children = task._children
        if children and any(c._state not in _DEAD for c in children):
            coro = self._coro = task._after_body(outcome, reraise)
            self._task = None
            return coro.send(None)
        # No child left to tear down: _after_body's work, without awaiting.
        if outcome is not _SUCCEEDED:
            task.result = None
        task._aw = _BODY_DONE
        task._finish(outcome)
        if reraise is not None:
            _raise_unreferenced(reraise)
        raise StopIteration


Coroutine.register(_Driver)


def _raising(exc: BaseException) -> Generator[Any, Any, NoReturn]:
    """An iterator whose first step raises ``exc`` (a body that could not be taken)."""
    raise exc
    yield  # a generator


def _raise_unreferenced(exc: BaseException) -> NoReturn:
    """Raise ``exc`` without leaving it in the raising frame's locals: failure ->
    traceback -> frame -> failure would be a cycle only a full collection frees."""
    try:
        raise exc
    finally:
        del exc


def current_task() -> Task | None:
    """The cpl task whose code is running, or ``None`` outside any cpl task."""
    return CURRENT_TASK.get()


def _require_task(what: str) -> Task:
    task = CURRENT_TASK.get()
    if task is None:
        raise RuntimeError(
            f"{what} must run inside a cpl task: wrap your plan in cpl.run(...) or "
            "await cpl.top_level(...)"
        )
    return task


def spawn(
    aw: Awaitable[Any] | Callable[[], Awaitable[Any]],
    name: str | None = None,
    *,
    kind: str = "task",
) -> Task:
    """Start ``aw`` as a child task of the current task and return it at once.

    The child is evaporated if it is still running when its parent finishes. Join it to
    get its value or failure.
    """
    parent = _require_task("cpl.spawn")
    return Task(aw, name, kind=kind, parent=parent).start()


async def with_task(
    aw: Awaitable[Any] | Callable[[], Awaitable[Any]],
    *,
    name: str | None = None,
    kind: str = "task",
    arguments: dict[str, Any] | None = None,
    annotations: dict[str, Any] | None = None,
) -> Any:
    """Run ``aw`` as a named child task and join it (CRAM's ``with-task``).

    Returns the value or re-raises the failure. If the caller is evaporated meanwhile, the
    child is evaporated and waited for before the evaporation propagates.
    """
    parent = _require_task("cpl.with_task")
    child = Task(aw, name, kind=kind, arguments=arguments, annotations=annotations, parent=parent)
    return await run_joined(child)


async def run_joined(child: Task) -> Any:
    """Start a fresh CREATED ``child`` and join it, running it inline in the caller's
    asyncio task when it can (see :meth:`Task._run_inline`), on its own asyncio task
    otherwise (a child with ordering constraints, or one MAX_INLINE_DEPTH levels down a chain
    of inline tasks)."""
    if child._constraints or child._atask is not None or child._state is not _CREATED:
        child.start()
        return await join_owned(child)
    if child.evaporation is not None:  # evaporated before it started: it never runs
        child._close_aw()
        child._finish(_EVAPORATED)
        return None
    if _inline_chain_is_long(CURRENT_TASK.get()):
        # Every MAX_INLINE_DEPTH levels the chain goes on in a fresh asyncio task: its
        # stack starts empty, so a chain of any depth stays below the recursion limit,
        # and evaporating it unwinds one bounded stretch at a time (each join_owned
        # evaporates the next stretch and waits), not in one recursion down the chain.
        child.start()
        return await join_owned(child)
    return await child._run_inline()


def _interrupted_cancellation(exc: BaseException | None) -> asyncio.CancelledError | None:
    """The CancelledError that ``exc`` (raised by cleanup code) interrupted, if any: the
    nearest one in its ``__context__`` chain."""
    seen = 0
    while exc is not None and seen < 100:  # bounded: a chain may be long, or a cycle
        exc = exc.__context__
        if isinstance(exc, asyncio.CancelledError):
            return exc
        seen += 1
    return None


def _evaporating(task: Task | None) -> bool:
    """Whether ``task`` or one of the inline tasks it runs in (the chain sharing its
    asyncio task) was asked to evaporate."""
    while task is not None:
        if task.evaporation is not None:
            return True
        task = task._inline_parent
    return False


#: How many tasks may run inline in one asyncio task (a chain of joined plan calls): each
#: level costs a handful of Python frames, on the way down and again when a cancellation
#: unwinds it, and the interpreter's recursion limit (1000 frames) is shared by the chain.
MAX_INLINE_DEPTH = 32


def _inline_chain_is_long(task: Task | None) -> bool:
    """Whether ``task`` is the MAX_INLINE_DEPTH-th (or deeper) of a chain of inline tasks
    sharing one asyncio task (a walk of at most MAX_INLINE_DEPTH steps)."""
    depth = 0
    while task is not None:
        task = task._inline_parent
        depth += 1
        if depth >= MAX_INLINE_DEPTH:
            return True
    return False


async def join_owned(child: Task) -> Any:
    """Join a child this code owns: on cancellation evaporate it and wait for it first."""
    try:
        return await child.join()
    except asyncio.CancelledError:
        if child._state not in _DEAD:
            child.evaporate("the joining task was evaporated")
            await wait_dead([child])
        raise


def _name_of(aw: Any) -> str:
    if aw is None:
        return "task"
    code = getattr(aw, "cr_code", None)
    if code is not None:
        return str(code.co_name)
    name = getattr(aw, "__name__", None)
    if isinstance(name, str):
        return name
    return type(aw).__name__


def as_coroutine(aw: Awaitable[Any] | Callable[[], Awaitable[Any]]) -> Coroutine[Any, Any, Any]:
    """Turn a coroutine, awaitable or zero-argument async callable into a coroutine."""
    if inspect.iscoroutine(aw):
        return aw
    if inspect.isawaitable(aw):
        return _await(aw)
    if callable(aw):
        res = aw()
        if inspect.iscoroutine(res):
            return res
        if inspect.isawaitable(res):
            return _await(res)
        raise TypeError(
            f"{_name_of(aw)!r} returned {type(res).__name__}, not an awaitable; forms take "
            "coroutines or zero-argument async functions"
        )
    raise TypeError(
        f"forms take coroutines or zero-argument async functions, got {type(aw).__name__}"
    )


async def _await(aw: Awaitable[Any]) -> Any:
    return await aw
