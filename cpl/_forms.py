"""The plan language's forms: seq, par, pursue, try_all, try_in_order, par_loop,
partial_order and tag.

Each form takes coroutines, zero-argument async callables, ``cpl.tag(...)`` branches,
``@cpl.plan`` calls or pre-made (CREATED) :class:`~cpl.Task` objects.

The parallel forms put one *form node* into the task tree (kind ``par``, ``pursue``, ...)
whose children are the branch tasks; unlike CRAM there is no intermediate asyncio task.
A supervisor is told synchronously of each branch's end and decides (CRAM's watcher), so a
form with N branches costs O(N). When a form has decided, it evaporates the branches still
alive and waits for them to die before it returns or raises (synchronous evaporation,
also on failure: CRAM evaporates asynchronously on failure).

Outcome rules (CRAM's, with the deliberate choices named):

- ``par``: the list of all values in branch order (``None`` for a branch evaporated from
  outside). The first failure to happen evaporates the siblings and propagates as the same
  object. (CRAM returns the first branch's value only.)
- ``pursue``: the value of the first branch to finish, or its failure if it failed first. A
  branch evaporated from outside is ignored (CRAM would trip an assertion); if all branches
  are evaporated the result is ``None``.
- ``try_all``: the value of the first branch to succeed; individual failures do not cancel
  the siblings; :class:`~cpl.CompositeFailure` (failures in branch order) only when all
  failed. A programming error (not a :class:`~cpl.PlanFailure`) propagates at once.
- ``try_in_order``: runs in the current task, one after the other, until one succeeds;
  only plan failures are caught; :class:`~cpl.CompositeFailure` in source order otherwise.
"""

from __future__ import annotations

import asyncio
import inspect
from abc import ABC, abstractmethod
from collections.abc import Awaitable, Callable, Generator, Iterable, Sequence
from types import CoroutineType
from typing import Any

from ._failure_handling import handled, handling, signal_failure
from ._failures import CompositeFailure, PlanFailure
from ._scheduling import DeferredCancellation, block_until
from ._status import Status
from ._subtree import Subtree
from ._task import FormNode, Task, _require_task, as_coroutine, join_owned, run_joined

__all__ = [
    "AllSucceed",
    "FirstEnds",
    "FirstSucceeds",
    "ParallelPolicy",
    "par",
    "par_loop",
    "partial_order",
    "pursue",
    "seq",
    "tag",
    "try_all",
    "try_each_in_order",
    "try_in_order",
]

_DEAD = frozenset({Status.SUCCEEDED, Status.FAILED, Status.EVAPORATED})

Branch = Awaitable[Any] | Callable[[], Awaitable[Any]] | Task
#: The failures on which try_in_order / try_each_in_order move on to the next alternative.
_MOVES_ON = (PlanFailure,)


class Tagged:
    """A branch with a name in the task tree (``cpl.tag(name, aw)``). Awaiting it runs ``aw``
    as a child task of that name and joins it; a form runs it as the branch task itself."""

    __slots__ = ("aw", "name", "subtree")

    def __init__(
        self,
        name: str,
        aw: Awaitable[Any] | Callable[[], Awaitable[Any]],
        subtree: Subtree | None = None,
    ) -> None:
        if not isinstance(name, str) or not name:
            raise TypeError(f"a tag name is a non-empty string, got {name!r}")
        if subtree is not None and not isinstance(subtree, Subtree):
            raise TypeError(
                f"cpl.tag({name!r}, ...): subtree is a cpl.Subtree (IMAGINED, REAL, CHOSEN) "
                f"or None, got {subtree!r}"
            )
        self.name = name
        self.aw = aw
        self.subtree = subtree  # what the branch stands for in reasoning (None: nothing)

    def make_task(self, parent: Task) -> Task:
        return Task(self.aw, self.name, kind="tag", parent=parent, subtree=self.subtree)

    def close(self) -> None:
        _close(self.aw)

    def __await__(self) -> Generator[Any, None, Any]:
        parent = _require_task(f"cpl.tag({self.name!r})")
        child = self.make_task(parent)
        return run_joined(child).__await__()


def tag(
    name: str, aw: Awaitable[Any] | Callable[[], Awaitable[Any]], *, subtree: Subtree | None = None
) -> Tagged:
    """Name a branch in the task tree. ``await cpl.tag("w1", work())`` runs ``work()`` as a
    child task ``w1`` and joins it; forms accept tagged branches as named branches.
    ``subtree`` marks what the branch stands for in reasoning (:class:`cpl.Subtree`: an
    imagined run, the real run, the chosen alternative): readers of the tree go by it,
    never by the name."""
    return Tagged(name, aw, subtree)


def _close(aw: Any) -> None:
    """Close a coroutine that will never run (no 'never awaited' warning)."""
    if inspect.iscoroutine(aw):
        aw.close()
    elif isinstance(aw, Task):
        if aw.state is Status.CREATED:
            aw.evaporate("its form ended before it started")
    else:
        close = getattr(aw, "close", None)
        if callable(close) and hasattr(aw, "make_task"):
            close()


def _branch_task(branch: Branch, parent: Task, default_name: str) -> Task:
    if type(branch) is CoroutineType:  # the common case, first
        return Task(branch, branch.cr_code.co_name, kind="branch", parent=parent)
    if isinstance(branch, Task):
        if branch.state is not Status.CREATED or branch._atask is not None:
            raise RuntimeError(
                f"task {branch.name!r} already started; forms take tasks that have not run "
                "yet (cpl.Task(aw, name=...)) or coroutines"
            )
        branch._move_under(parent)
        return branch
    make = getattr(branch, "make_task", None)
    if make is not None:
        task: Task = make(parent)
        return task
    if not inspect.isawaitable(branch) and not callable(branch):
        raise TypeError(
            f"forms take coroutines, zero-argument async functions, cpl.tag(...) or "
            f"cpl.Task objects; got {type(branch).__name__}"
        )
    name = getattr(branch, "cr_code", None)
    nm = name.co_name if name is not None else getattr(branch, "__name__", default_name)
    return Task(branch, nm, kind="branch", parent=parent)


# ------------------------------------------------------------------------------ seq
async def seq(*aws: Branch) -> Any:
    """Run the steps one after the other in the current task; the value of the last
    (``None`` for no steps). The first failure propagates; steps not reached are closed."""
    value: Any = None
    items = list(aws)
    try:
        while items:
            step = items.pop(0)
            if isinstance(step, Task):
                step.start()
                value = await join_owned(step)
            elif isinstance(step, Tagged):
                value = await step
            else:
                value = await as_coroutine(step)
    finally:
        for rest in items:
            _close(rest)
    return value


async def try_in_order(*aws: Branch) -> Any:
    """Try the steps one after the other in the current task until one succeeds; return its
    value. Only :class:`~cpl.PlanFailure` moves on to the next step (programming errors
    propagate). All failed: :class:`~cpl.CompositeFailure` with the failures in order."""
    failures: list[BaseException] = []
    items = list(aws)
    token = handling(_MOVES_ON)  # its own handling is innermost
    try:
        while items:
            step = items.pop(0)
            try:
                if isinstance(step, Task):
                    step.start()
                    return await join_owned(step)
                if isinstance(step, Tagged):
                    return await step
                return await as_coroutine(step)
            except PlanFailure as failure:
                failures.append(failure)
    finally:
        handled(token)
        for rest in items:
            _close(rest)
    if not failures:
        return None
    composite = CompositeFailure(failures)
    signal_failure(composite)
    raise composite


async def try_each_in_order(values: Iterable[Any], fn: Callable[[Any], Awaitable[Any]]) -> Any:
    """Call ``fn(value)`` for each value in turn, in the current task, until one succeeds;
    return its result (CRAM's ``try-each-in-order``). Only :class:`~cpl.PlanFailure` moves
    on to the next value; all failed: :class:`~cpl.CompositeFailure` with the failures in
    order; no values: ``None``. ``values`` may be lazy (a generator, a ``cpl.LazyList``):
    it is consumed only as far as needed.
    """
    failures: list[BaseException] = []
    token = handling(_MOVES_ON)  # its own handling is innermost
    try:
        for value in values:
            try:
                return await fn(value)
            except PlanFailure as failure:
                failures.append(failure)
    finally:
        handled(token)
    if not failures:
        return None
    composite = CompositeFailure(failures)
    signal_failure(composite)
    raise composite


# ------------------------------------------------------------------ parallel forms
class ParallelPolicy(ABC):
    """How a parallel form decides from its branches' ends (CRAM's watcher body), as a
    small object in the manner of py_trees' ``ParallelPolicy``.

    :meth:`decide` is called synchronously once per branch end, until it returns ``True``
    (decided); ``sup.alive`` already counts that branch out. It records the outcome with
    ``sup.succeed(value)`` or ``sup.fail(failure)``. When it never decides and no branch is
    left, the form's value is ``None``.
    """

    __slots__ = ("kind", "loser_reason")

    def __init__(self, kind: str, loser_reason: str) -> None:
        self.kind = kind  # the form node's kind in the task tree
        self.loser_reason = loser_reason  # why the branches still alive are evaporated

    @abstractmethod
    def decide(self, sup: _Supervisor, task: Task) -> bool:
        """Record the outcome if ``task``'s end decides the form; whether it did."""


class AllSucceed(ParallelPolicy):
    """``par``, ``par_loop``, ``partial_order``: the first failure decides; otherwise, once
    no branch is alive, the list of all values (``None`` for an evaporated branch)."""

    __slots__ = ()

    def decide(self, sup: _Supervisor, task: Task) -> bool:
        if task.state is Status.FAILED:
            return sup.fail(task.failure)
        if sup.alive == 0:
            return sup.succeed(
                [b.result if b.state is Status.SUCCEEDED else None for b in sup.branches]
            )
        return False


class FirstEnds(ParallelPolicy):
    """``pursue``: the first branch to succeed or fail decides; evaporated branches are
    ignored (all evaporated: ``None``)."""

    __slots__ = ()

    def decide(self, sup: _Supervisor, task: Task) -> bool:
        if task.state is Status.SUCCEEDED:
            return sup.succeed(task.result)
        if task.state is Status.FAILED:
            return sup.fail(task.failure)
        return sup.alive == 0 and sup.succeed(None)


class FirstSucceeds(ParallelPolicy):
    """``try_all``: the first success decides; plan failures are collected and, once all
    branches failed, raised as :class:`~cpl.CompositeFailure`; any other exception decides
    at once."""

    __slots__ = ()

    def decide(self, sup: _Supervisor, task: Task) -> bool:
        if task.state is Status.SUCCEEDED:
            return sup.succeed(task.result)
        if task.state is Status.FAILED and not isinstance(task.failure, PlanFailure):
            return sup.fail(task.failure)
        if sup.alive == 0:
            failures = [b.failure for b in sup.branches if b.state is Status.FAILED]
            if failures:
                return sup.fail(CompositeFailure([f for f in failures if f is not None]))
            return sup.succeed(None)
        return False


_PAR = AllSucceed("par", "a sibling branch of par failed")
_PAR_LOOP = AllSucceed("par-loop", "a sibling in par_loop failed")
_PARTIAL_ORDER = AllSucceed("partial-order", "a sibling step of partial_order failed")
_PURSUE = FirstEnds("pursue", "pursue: another branch finished first")
_TRY_ALL = FirstSucceeds("try-all", "try_all: another branch succeeded")


class _Supervisor:
    """Applies a :class:`ParallelPolicy` to a form's branches as they end; told
    synchronously from each branch's finish, O(1) per branch."""

    __slots__ = ("alive", "branches", "decided", "failure", "policy", "value", "waiter")

    def __init__(self, policy: ParallelPolicy, branches: list[Task]) -> None:
        self.policy = policy
        self.branches = branches
        self.alive = len(branches)  # branches not dead yet
        # Invariant: once decided is True, value/failure hold the form's outcome and no
        # further branch end changes them.
        self.decided = False
        self.value: Any = None
        self.failure: BaseException | None = None
        # Invariant: the future the form awaits, or None while it does not wait.
        self.waiter: asyncio.Future[None] | None = None

    def succeed(self, value: Any) -> bool:
        self.decided, self.value = True, value
        return True

    def fail(self, failure: BaseException | None) -> bool:
        self.decided, self.failure = True, failure
        return True

    def finished(self, task: Task) -> None:
        self.alive -= 1
        if not self.decided:
            self.policy.decide(self, task)
        if (self.decided or self.alive == 0) and self.waiter is not None:
            if not self.waiter.done():
                self.waiter.set_result(None)


async def _parallel(policy: ParallelPolicy, branches: Sequence[Branch]) -> Any:
    kind = policy.kind
    try:
        owner = _require_task(f"cpl.{kind.replace('-', '_')}")
    except RuntimeError:
        for b in branches:
            _close(b)
        raise
    node = FormNode(policy, owner)
    node._begin_form()
    tasks: list[Task] = []
    try:
        for i, b in enumerate(branches):
            tasks.append(_branch_task(b, node, f"{kind}-{i + 1}"))
    except BaseException as exc:
        for t in tasks:
            t.evaporate(f"{kind} was given an invalid branch")
        for b in branches[len(tasks) :]:
            _close(b)
        node._end_form(Status.FAILED, None, exc)
        raise
    sup = _Supervisor(policy, tasks)
    for t in tasks:
        t._supervisor = sup
    owner._push_form(node)
    loop = asyncio.get_running_loop()
    outcome = Status.SUCCEEDED
    try:
        for t in tasks:
            if t.state is Status.CREATED and t._atask is None:
                t.start()
            elif t.state in _DEAD:  # evaporated before the form started it
                sup.finished(t)
        owner.waiting_on = f"{kind} of {len(tasks)} branches"
        while not sup.decided and sup.alive > 0:
            fut = loop.create_future()
            sup.waiter = fut
            await block_until(fut)
            sup.waiter = None
    except GeneratorExit:
        raise  # closed without running (an abandoned loop): nothing can be awaited
    except BaseException:
        outcome = Status.EVAPORATED
        await _end_branches(tasks, sup, f"{kind} was evaporated")
        raise
    else:
        if sup.alive:
            try:
                await _end_branches(tasks, sup, policy.loser_reason)
            except BaseException:
                # Cancelled while the losers died: the form did not complete.
                outcome = Status.EVAPORATED
                raise
        if sup.failure is not None:
            outcome = Status.FAILED
            signal_failure(sup.failure)
            raise sup.failure
        return sup.value
    finally:
        owner.waiting_on = None
        owner._pop_form(node)
        node._end_form(outcome, sup.value, sup.failure)


async def _end_branches(tasks: list[Task], sup: _Supervisor, reason: str) -> None:
    """Evaporate the branches still alive (on behalf of the form node) and wait until all
    are dead; a cancellation that arrives meanwhile is re-raised afterwards."""
    by = tasks[0].parent.path if tasks and tasks[0].parent is not None else None
    for t in tasks:
        if t.state not in _DEAD:
            t.evaporate(reason, by=by)
    loop = asyncio.get_running_loop()
    deferred = DeferredCancellation()
    try:
        while sup.alive > 0:
            fut = loop.create_future()
            sup.waiter = fut
            try:
                await fut
            except asyncio.CancelledError as exc:
                deferred.defer(exc)
            finally:
                sup.waiter = None
    finally:
        deferred.close()


async def par(*aws: Branch) -> list[Any]:
    """Run the branches concurrently; return the list of their values (branch order).

    The first failure evaporates the siblings and propagates as the same object. A branch
    evaporated from outside contributes ``None``. ``par()`` with no branches returns ``[]``.
    """
    if not aws:
        return []
    result: list[Any] = await _parallel(_PAR, aws)
    return result


async def pursue(*aws: Branch) -> Any:
    """Run the branches concurrently; the first to finish decides: its value, or its
    failure if it failed. The others are evaporated (and waited for)."""
    if not aws:
        return None
    return await _parallel(_PURSUE, aws)


async def try_all(*aws: Branch) -> Any:
    """Run the branches concurrently; return the value of the first to succeed and evaporate
    the rest. Individual plan failures do not cancel the siblings; when all failed, raise
    :class:`~cpl.CompositeFailure`. A programming error propagates at once."""
    if not aws:
        return None
    return await _parallel(_TRY_ALL, aws)


async def par_loop(iterable: Iterable[Any], fn: Callable[[Any], Awaitable[Any]]) -> list[Any]:
    """Run ``fn(item)`` for every item concurrently (CRAM's ``par-loop``); the list of values
    in item order. Failure semantics as :func:`par`."""
    branches = [fn(item) for item in iterable]
    if not branches:
        return []
    result: list[Any] = await _parallel(_PAR_LOOP, branches)
    return result


async def partial_order(
    steps: Sequence[Task | Tagged | Awaitable[Any]],
    orderings: Iterable[tuple[Task, Task]] = (),
) -> list[Any]:
    """Run ``steps`` concurrently, but start ``b`` only after ``a`` is dead for each
    ``(a, b)`` in ``orderings`` (a failed ``a`` releases ``b`` too, as in CRAM; the failure
    still fails the whole form, like :func:`par`). Steps named in orderings must be
    :class:`~cpl.Task` objects created with ``cpl.Task(aw, name=...)`` and listed in
    ``steps``. A cycle raises ``ValueError`` naming it (CRAM deadlocks).
    """
    step_list = list(steps)
    pairs = list(orderings)
    tasks = [s for s in step_list if isinstance(s, Task)]
    members = set(map(id, tasks))
    try:
        for pair in pairs:
            if not (isinstance(pair, tuple) and len(pair) == 2):
                raise TypeError(f"an ordering is a pair (a, b) of tasks, got {pair!r}")
            a, b = pair
            for t in (a, b):
                if not isinstance(t, Task) or id(t) not in members:
                    raise ValueError(
                        f"ordering {pair!r} names {t!r}, which is not one of the steps; "
                        "create steps with cpl.Task(aw, name=...) and list them in steps"
                    )
        _check_acyclic(tasks, pairs)
    except BaseException:
        for s in step_list:
            _close(s)
        raise
    for a, b in pairs:
        extras = b._more()
        if extras.constraints is None:
            extras.constraints = [a]
        else:
            extras.constraints.append(a)
    result: list[Any] = await _parallel(_PARTIAL_ORDER, step_list)
    return result


def _check_acyclic(tasks: list[Task], pairs: list[tuple[Task, Task]]) -> None:
    after: dict[int, list[Task]] = {id(t): [] for t in tasks}
    for a, b in pairs:
        after[id(a)].append(b)
    color: dict[int, int] = {}
    for start in tasks:
        if color.get(id(start)):
            continue
        stack: list[tuple[Task, int]] = [(start, 0)]
        trail: list[Task] = []
        while stack:
            node, i = stack.pop()
            if i == 0:
                color[id(node)] = 1
                trail.append(node)
            succ = after[id(node)]
            if i < len(succ):
                stack.append((node, i + 1))
                nxt = succ[i]
                c = color.get(id(nxt), 0)
                if c == 1:
                    cycle = [*trail[trail.index(nxt) :], nxt]
                    raise ValueError(
                        "partial_order orderings form a cycle: "
                        + " -> ".join(t.name for t in cycle)
                        + "; the steps would wait for each other forever"
                    )
                if c == 0:
                    stack.append((nxt, 0))
            else:
                color[id(node)] = 2
                trail.pop()
