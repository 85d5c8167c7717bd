"""CRAM's ``with-failure-handling`` and retry counters.

``await cpl.with_failure_handling(body, handlers)`` runs ``body()`` (a zero-argument async
callable, called again on every retry). When it raises, the handlers whose type matches
are called in order with the failure; a handler may

- call :func:`retry` (the body runs again from the start),
- call :func:`return_` ``(value)`` (the form returns ``value``),
- raise another exception (it propagates; the same form's handlers do not see it), or
- return normally: it *declines*, the next matching clause is tried, and when none is left
  the **same failure object** propagates.

Deliberate differences from CRAM, forced by Python:

- CRAM's handlers run *before* unwinding (``handler-bind``); ours run after the body's
  ``finally`` blocks have run and its child tasks are dead. A handler therefore sees a
  world in which the failing code's cleanup has already happened.
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
from typing import Any, NoReturn, TypeAlias

__all__ = [
    "RetryCounter",
    "retry",
    "return_",
    "with_failure_handling",
    "with_retry",
]

ExcTypes: TypeAlias = type[BaseException] | tuple[type[BaseException], ...]
Handler: TypeAlias = Callable[[Any], Any]
Handlers: TypeAlias = Mapping[ExcTypes, Handler] | Iterable[tuple[ExcTypes, Handler]]


class _Retry(BaseException):
    """Control flow of :func:`retry` (a BaseException so ``except Exception`` skips it)."""


class _Return(BaseException):
    """Control flow of :func:`return_`."""

    def __init__(self, value: Any) -> None:
        super().__init__()
        self.value = value


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


async def with_failure_handling(body: Callable[[], Awaitable[Any]], handlers: Handlers) -> Any:
    """Run ``body()`` with failure handlers (CRAM's ``with-failure-handling``).

    ``handlers`` is an ordered mapping or a sequence of ``(type or tuple of types, handler)``;
    a handler takes the failure and may be sync or async. Returns the body's value, or the
    value given to :func:`return_`. Works inside and outside a top level.
    """
    if not callable(body) or inspect.iscoroutine(body):
        raise TypeError(
            "with_failure_handling needs the body as a zero-argument async callable (it is "
            "called again on every retry), not a coroutine object"
        )
    clauses = _clauses(handlers)
    while True:
        try:
            aw = body()
            if not inspect.isawaitable(aw):
                raise TypeError(
                    f"the failure-handling body returned {type(aw).__name__}, not an "
                    "awaitable; pass an async function"
                )
            return await aw
        except _Retry:
            continue
        except _Return as ret:
            return ret.value
        except Exception as failure:
            outcome = await _dispatch(clauses, failure)
            if outcome is _RETRY:
                continue
            if isinstance(outcome, _Return):
                return outcome.value
            raise failure


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
