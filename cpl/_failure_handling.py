"""CRAM's ``with-failure-handling`` and retry counters.

``await cpl.with_failure_handling(body, handlers)`` runs ``body()`` (a zero-argument async
callable, called again on every retry). When it raises, the handlers whose type matches
are called in order with the failure; a handler may

- call :func:`retry` (the body runs again from the start),
- call :func:`return_` ``(value)`` (the form returns ``value``),
- raise another exception (it propagates; the same form's handlers do not see it), or
- return normally: it *declines*, the next matching clause is tried, and when none is left
  the **same failure object** propagates.

When handlers run: two modes.

- **After unwinding** (the default): handlers run after the body's ``finally`` blocks have
  run and its child tasks are dead. A handler sees a world in which the failing code's
  cleanup has already happened. Right for most robot plans: a retry handler that moves
  the robot must not race the failing branch's cleanup (parking the arm, closing the
  gripper), and async handlers are allowed. This differs from CRAM.
- **Before unwinding** (``before_unwinding=True``, CRAM's ``handler-bind``): handlers run at
  the point where the failure is signalled, while the failing code's state is still there:
  at ``cpl.fail(...)`` in the form's own task, and where a child's failure enters it (a
  ``join``, a ``par``/``pursue``/``try_all`` that fails, ``try_in_order`` giving up). Then
  ``retry()``/``return_()`` unwind from there (cleanups run afterwards, as in CRAM); a
  declining handler lets the failure go on unwinding, and the form does not call it a
  second time. Handlers must be synchronous here (a signal point such as ``fail`` is not
  async): an async handler is a ``TypeError``. A failure raised with a plain ``raise`` in
  the form's own task has no signal point: it is handled after unwinding. Right when the
  handler must inspect or record the failing state (which tasks were alive, the failing
  branch's designator) before cleanup changes it. As in CRAM, handlers of a parent task
  never run in a child task: a child's failure reaches them at the join.

Inner handling comes first, as with CRAM's nested ``handler-bind``: a form inside the body
that handles a failure itself is innermost, so an outer before-unwinding handler does not
see it. ``try_in_order`` / ``try_each_in_order`` moving on to the next alternative, and an
inner ``with_failure_handling`` (either mode) whose clauses match, get the failure first;
the outer handler sees only what they give up on: ``try_in_order``'s
:class:`~cpl.CompositeFailure` once every alternative failed (once), or a failure the inner
form declined. Parallel forms (``try_all``, ``pursue``) run branches in tasks of their own,
whose failures never reach the parent's handlers until the form itself fails. Deliberate
difference from CRAM: an inner form whose handlers run *after* unwinding decides only
then; if it declines, the outer before-unwinding handler gets the failure at the next
signal point or after unwinding, not at the original signal point.

Exception types in clauses:

- A clause naming ``Exception`` also catches :class:`~cpl.PlanFailure` (a ``PlanFailure`` is
  an ``Exception`` here). CRAM's ``error`` clause does not catch plan failures (there a
  plan failure is a serious condition, not an error). For CRAM's reading, name
  :class:`cpl.Error`: it matches every ``Exception`` that is *not* a plan failure
  (programming errors, driver exceptions).
- CRAM wraps Lisp errors from child tasks in envelopes. Here an exception keeps its type
  across every join, so a clause naming ``KeyError`` catches a ``KeyError`` from a child
  task directly.

:class:`~cpl.Evaporated` and ``asyncio.CancelledError`` are never handled: naming them in a
clause is a ``TypeError``.
"""

from __future__ import annotations

import asyncio
import inspect
from collections.abc import Awaitable, Callable, Iterable, Mapping
from contextvars import ContextVar, Token
from typing import Any, NoReturn, TypeAlias

from ._failures import PlanFailure
from ._scheduling import CURRENT_TASK

__all__ = [
    "Error",
    "RetryCounter",
    "retry",
    "return_",
    "signal_failure",
    "with_failure_handling",
    "with_retry",
]

ExcTypes: TypeAlias = type[BaseException] | tuple[type[BaseException], ...]
Handler: TypeAlias = Callable[[Any], Any]
Handlers: TypeAlias = Mapping[Any, Handler] | Iterable[tuple[Any, Handler]]


class _ErrorMeta(type):
    def __instancecheck__(cls, obj: object) -> bool:
        return isinstance(obj, Exception) and not isinstance(obj, PlanFailure)

    def __subclasscheck__(cls, sub: type) -> bool:
        return issubclass(sub, Exception) and not issubclass(sub, PlanFailure)


class Error(Exception, metaclass=_ErrorMeta):
    """CRAM's ``error`` clause type: in a failure-handling clause it matches every
    ``Exception`` that is not a :class:`~cpl.PlanFailure`. (Use it as a clause type;
    Python's own ``except`` ignores the matching rule and would catch nothing.)"""


class _Retry(BaseException):
    """Control flow of :func:`retry` (a BaseException so ``except Exception`` skips it).
    ``scope`` is the form it belongs to when a before-unwinding handler raised it
    (``None``: the innermost form)."""

    def __init__(self, scope: _Scope | None = None) -> None:
        super().__init__()
        self.scope = scope


class _Return(BaseException):
    """Control flow of :func:`return_`."""

    def __init__(self, value: Any, scope: _Scope | None = None) -> None:
        super().__init__()
        self.value = value
        self.scope = scope


class _Scope:
    """One ``with_failure_handling(..., before_unwinding=True)`` form in progress."""

    __slots__ = ("attempt", "clauses", "owner")

    def __init__(self, clauses: list[tuple[tuple[type[BaseException], ...], Handler]]) -> None:
        self.clauses = clauses
        # Invariant: the cpl task running the form; its handlers run only in that task.
        self.owner = CURRENT_TASK.get()
        # Invariant: bumped on every run of the body, so a failure object raised again by a
        # later attempt is dispatched again.
        self.attempt = 0


class _Handled:
    """A form that handles failures of ``types`` itself (``try_in_order`` moving on to the
    next alternative, a ``with_failure_handling`` whose handlers run after unwinding),
    pushed only while before-unwinding forms are around it. Signalled failures of those
    types stop here: the outer before-unwinding handlers do not see them, because the
    inner form handles them first (CRAM's inner ``handler-bind`` wins). If the inner form
    declines after all, the failure unwinds out of it and is dispatched again at the next
    signal point or by the outer form after unwinding."""

    __slots__ = ("owner", "types")

    def __init__(self, types: tuple[type[BaseException], ...]) -> None:
        self.types = types
        # Invariant: the cpl task running the form (it handles only that task's failures).
        self.owner = CURRENT_TASK.get()


#: The before-unwinding forms around the running code, and the inner forms that handle
#: failures themselves (innermost last). A context variable: each asyncio task sees its
#: own stack, and every scope names its owner task.
_EARLY: ContextVar[tuple[_Scope | _Handled, ...]] = ContextVar("cpl_early_handlers", default=())


def handling(types: tuple[type[BaseException], ...]) -> Token[tuple[_Scope | _Handled, ...]] | None:
    """Mark the code that runs until :func:`handled` as handled by the calling form for
    failures of ``types`` (see :class:`_Handled`). ``None`` (and no cost) when no
    before-unwinding form is around: there is nothing to hold back."""
    scopes = _EARLY.get()
    if not scopes:
        return None
    return _EARLY.set((*scopes, _Handled(types)))


def handled(token: Token[tuple[_Scope | _Handled, ...]] | None) -> None:
    """End what :func:`handling` began (in the same task)."""
    if token is not None:
        _EARLY.reset(token)


_TRIED = "_cpl_early_handled"


def _mark(failure: BaseException, scope: _Scope) -> None:
    try:
        tried = failure.__dict__.setdefault(_TRIED, set())
    except AttributeError:  # an exception without __dict__: it is dispatched again later
        return
    tried.add((id(scope), scope.attempt))


def _was_tried(failure: BaseException, scope: _Scope) -> bool:
    tried: set[tuple[int, int]] | None = getattr(failure, "__dict__", {}).get(_TRIED)
    return tried is not None and (id(scope), scope.attempt) in tried


def signal_failure(failure: BaseException) -> None:
    """Run the before-unwinding handlers of the current task for ``failure``, innermost
    form first, at the point where it is signalled. Returns if all declined; a handler's
    ``retry()``/``return_()`` raises its control flow from here (bound to its form).
    Called by ``cpl.fail`` and by every join point; cheap when no such form is active."""
    scopes = _EARLY.get()
    if not scopes or not isinstance(failure, Exception):
        return
    me = CURRENT_TASK.get()
    for scope in reversed(scopes):
        if scope.owner is not me:
            continue
        if isinstance(scope, _Handled):
            if isinstance(failure, scope.types):
                return  # an inner form handles it first
            continue
        if _was_tried(failure, scope):
            continue
        _mark(failure, scope)
        for types, handler in scope.clauses:
            if not isinstance(failure, types):
                continue
            try:
                res = handler(failure)
            except _Retry as ctl:
                ctl.scope = ctl.scope or scope
                raise
            except _Return as ctl:
                ctl.scope = ctl.scope or scope
                raise
            if inspect.isawaitable(res):
                if inspect.iscoroutine(res):
                    res.close()
                raise TypeError(
                    f"handler {getattr(handler, '__name__', handler)!r} is async, but handlers "
                    "that run before unwinding must be synchronous (they run inside "
                    "cpl.fail and joins); make it a plain function or use the default "
                    "after-unwinding mode"
                )


def retry() -> NoReturn:
    """Run the body of the innermost ``with_failure_handling`` again. Call it from a
    handler or from the body itself; outside any such form it is a ``RuntimeError`` at the
    top level."""
    raise _Retry()


def return_(value: Any = None) -> NoReturn:
    """Leave the innermost ``with_failure_handling`` with ``value``."""
    raise _Return(value)


def _clauses(handlers: Handlers) -> list[tuple[tuple[type[BaseException], ...], Handler]]:
    items = handlers.items() if isinstance(handlers, Mapping) else handlers
    out: list[tuple[tuple[type[BaseException], ...], Handler]] = []
    for item in items:
        try:
            types, handler = item
        except (TypeError, ValueError):
            raise TypeError(
                f"a failure-handling clause is a (failure type, handler) pair, got {item!r}"
            ) from None
        tup = types if isinstance(types, tuple) else (types,)
        for t in tup:
            if not (isinstance(t, type) and issubclass(t, BaseException)):
                raise TypeError(f"a clause names exception types, got {t!r}")
            if issubclass(t, asyncio.CancelledError) or issubclass(asyncio.CancelledError, t):
                raise TypeError(
                    f"a clause for {t.__name__} would catch evaporation; evaporation is not "
                    "a failure: use try/finally for cleanup instead"
                )
            if not issubclass(t, Exception):
                raise TypeError(
                    f"{t.__name__} is not an Exception; only failures and errors can be handled"
                )
        if not callable(handler):
            raise TypeError(f"the handler for {types!r} is not callable: {handler!r}")
        out.append((tup, handler))
    return out


_RETRY = object()


async def _dispatch(
    clauses: list[tuple[tuple[type[BaseException], ...], Handler]], failure: BaseException
) -> Any:
    """Call the matching handlers in order; ``_RETRY``, a ``_Return``, or ``None`` when all
    declined."""
    for types, handler in clauses:
        if not isinstance(failure, types):
            continue
        try:
            res = handler(failure)
            if inspect.isawaitable(res):
                await res
        except _Retry:
            return _RETRY
        except _Return as ret:
            return ret
    return None


async def with_failure_handling(
    body: Callable[[], Awaitable[Any]],
    handlers: Handlers,
    *,
    before_unwinding: bool = False,
) -> Any:
    """Run ``body()`` with failure handlers (CRAM's ``with-failure-handling``).

    ``handlers`` is an ordered mapping or a sequence of ``(type or tuple of types, handler)``;
    a handler takes the failure and may be sync or async (sync only with
    ``before_unwinding=True``; see the module docstring for when to use which mode).
    Returns the body's value, or the value given to :func:`return_`. Works inside and
    outside a top level. Evaporation is never handled: it goes through unchanged.
    """
    if not callable(body) or inspect.iscoroutine(body):
        raise TypeError(
            "with_failure_handling needs the body as a zero-argument async callable (it is "
            "called again on every retry), not a coroutine object"
        )
    clauses = _clauses(handlers)
    scope: _Scope | None = None
    token: Token[tuple[_Scope | _Handled, ...]] | None = None
    if not before_unwinding:
        # Its handlers get the body's failures first (after unwinding): outer
        # before-unwinding handlers wait until these decline.
        token = handling(tuple(t for types, _handler in clauses for t in types))
    else:
        for _types, handler in clauses:
            if inspect.iscoroutinefunction(handler):
                raise TypeError(
                    f"handler {getattr(handler, '__name__', handler)!r} is async; handlers "
                    "that run before unwinding must be synchronous"
                )
        scope = _Scope(clauses)
        token = _EARLY.set((*_EARLY.get(), scope))
    try:
        while True:
            if scope is not None:
                scope.attempt += 1
            try:
                aw = body()
                if not inspect.isawaitable(aw):
                    raise TypeError(
                        f"the failure-handling body returned {type(aw).__name__}, not an "
                        "awaitable; pass an async function"
                    )
                return await aw
            except _Retry as ctl:
                if ctl.scope is not None and ctl.scope is not scope:
                    raise  # a retry of an outer form, decided before unwinding
                continue
            except _Return as ctl:
                if ctl.scope is not None and ctl.scope is not scope:
                    raise
                return ctl.value
            except Exception as failure:
                if scope is not None and _was_tried(failure, scope):
                    raise  # its handlers ran (and declined) before unwinding
                outcome = await _dispatch(clauses, failure)
                if outcome is _RETRY:
                    continue
                if isinstance(outcome, _Return):
                    return outcome.value
                raise failure
    finally:
        if token is not None:
            _EARLY.reset(token)


class RetryCounter:
    """A retry budget (CRAM's ``with-retry-counters`` / ``do-retry``).

    Create it *outside* the ``with_failure_handling`` it serves, so it survives retries::

        relocations = cpl.RetryCounter(10)
        ...
        def on_failure(f):
            if relocations.do_retry():
                cpl.retry()
    """

    __slots__ = ("initial", "name", "remaining")

    def __init__(self, retries: int, name: str | None = None) -> None:
        if not isinstance(retries, int) or retries < 0:
            raise ValueError(f"a retry counter starts at a whole number >= 0, got {retries!r}")
        self.initial = retries
        self.remaining = retries
        self.name = name

    def do_retry(self) -> bool:
        """True (and one retry used) while retries remain; False once exhausted."""
        if self.remaining > 0:
            self.remaining -= 1
            return True
        return False

    @property
    def used(self) -> int:
        """How many retries were used so far."""
        return self.initial - self.remaining

    def reset(self) -> None:
        """Start over with the initial budget (CRAM's ``reset-counter``)."""
        self.remaining = self.initial

    def __repr__(self) -> str:
        label = f" {self.name}" if self.name else ""
        return f"<RetryCounter{label} {self.remaining}/{self.initial}>"


async def with_retry(
    body: Callable[[], Awaitable[Any]],
    on: ExcTypes,
    counter: RetryCounter | int,
    *,
    before_retry: Callable[[Any], Any] | None = None,
    rethrow: Callable[[Any], BaseException] | BaseException | None = None,
) -> Any:
    """Sugar for the most common clause: retry ``body`` on failures of type ``on`` while
    ``counter`` allows; ``before_retry(failure)`` runs before each retry (it may be async);
    when retries are exhausted, raise ``rethrow`` (an exception, or a function of the
    failure returning one) or let the failure propagate.

    Reads like CRAM's one visible retry scope per level::

        await cpl.with_retry(fetch, on=ObjectUnreachable, counter=relocations,
                             before_retry=next_base_pose,
                             rethrow=lambda f: ObjectUnfetchable(object=obj))
    """
    budget = counter if isinstance(counter, RetryCounter) else RetryCounter(counter)

    async def handler(failure: Any) -> None:
        if budget.do_retry():
            if before_retry is not None:
                res = before_retry(failure)
                if inspect.isawaitable(res):
                    await res
            retry()
        if rethrow is not None:
            exc = rethrow if isinstance(rethrow, BaseException) else rethrow(failure)
            raise exc from failure

    return await with_failure_handling(body, [(on, handler)])
