"""Failure-handling strategies (CRAM v0.8.1's ``failure-handling-strategies.lisp``).

Use them inside ``cpl.with_failure_handling`` handlers::

    robot = current_environment().robot  # the robot's name: never spelt in a plan
    robot_loc = SolutionCursor(a.location(reachable_for=robot.name, location=obj_loc))
    relocations = cpl.RetryCounter(10)

    async def body():
        await perform(an.action(type="navigating", location=robot_loc.current))
        ...

    await cpl.with_failure_handling(body, [
        (NavigationGoalInCollision,
         lambda f: retry_with_designator_solutions(
             robot_loc, relocations, rethrow=ObjectUnfetchable(object=obj))),
    ])

Each helper does CRAM's sequence: log the failure; if ``counter.do_retry()``: take the next
solution; if there is one, store it in the cursor (and run ``on_retry``) and ``cpl.retry()``;
otherwise log "No samples left". Then, if ``rethrow`` is given, raise it (an instance, or a
class instantiated without arguments), chained to the failure; otherwise return ``None``: the
handler declines and the original failure propagates.

:func:`retry_scope` is the one-line form of a whole scope (CRAM's
``with-failure-handling`` clause around ``retry-with-loc-designator-solutions``): the
failures, the cursor and the counter on the line above the body they guard::

    @retry_scope(NavigationGoalInCollision, robot_loc, cpl.RetryCounter(10),
                 rethrow=lambda f: ObjectUnfetchable(object=obj))
    async def from_here():
        await perform(an.action(type="navigating", location=robot_loc.current))
        ...

    await from_here()

Python cannot rebind the caller's variable (CRAM's macros ``setf`` a place), so the solution in
use lives in a small mutable holder: :class:`SolutionCursor` for designators,
:class:`ListCursor` for lazy lists. Deliberate difference from CRAM: ``reset=`` really
replaces the given cursors' designators by fresh copies (CRAM's macro only resets a loop
variable, a bug noted in the reference).

A :class:`executive.DesignatorInputError` (a malformed designator: an unknown name, key
or type) is never retried nor replaced by ``rethrow``, even when ``on`` covers it: the
helpers decline and it propagates as itself. Deliberate difference from CRAM, whose
handlers saw a misspelt name as one more failure and retried or translated it.
"""

from __future__ import annotations

import functools
import inspect
import logging
import sys
from collections.abc import Awaitable, Callable, Iterable
from typing import Any, NoReturn, TypeVar

import cpl

from ._designator import Designator, LocationDesignator, equate
from .failures import DesignatorInputError

__all__ = [
    "DEFAULT_ANGLE_THRESHOLD",
    "DEFAULT_DISTANCE_THRESHOLD",
    "ListCursor",
    "SolutionCursor",
    "retry_scope",
    "retry_with_designator_solutions",
    "retry_with_list_solutions",
]

log = logging.getLogger("executive.retry")

#: CRAM's ``*default-distance-threshold*`` (metres) for location retries.
DEFAULT_DISTANCE_THRESHOLD = 0.05
#: Angle (radians) under which two location solutions count as the same.
DEFAULT_ANGLE_THRESHOLD = 0.1


class SolutionCursor:
    """Holds the designator in use (``.current``) and advances it along its chain.

    ``advance()`` starts from the newest member of the chain (a projection check may have
    injected a choice with ``next_solution``), so the cursor never re-uses a solution the
    chain has moved past.
    """

    __slots__ = ("current",)

    def __init__(self, designator: Designator) -> None:
        if not isinstance(designator, Designator):
            raise TypeError(f"SolutionCursor needs a designator, got {designator!r}")
        self.current: Designator = designator

    def advance(
        self,
        distance_threshold: float | None = None,
        angle_threshold: float = DEFAULT_ANGLE_THRESHOLD,
    ) -> Designator | None:
        """Move to the next solution and return the new designator, or ``None`` (the cursor
        is then unchanged). For a location the next solution must differ by more than
        ``distance_threshold`` (default 0.05 m) or ``angle_threshold`` radians."""
        newest = self.current.current()
        if isinstance(newest, LocationDesignator):
            nxt: Designator | None = newest.next_different_solution(
                DEFAULT_DISTANCE_THRESHOLD if distance_threshold is None else distance_threshold,
                angle_threshold,
            )
        else:
            nxt = newest.next_solution()
        if nxt is not None:
            self.current = nxt
        return nxt

    def reset(self) -> Designator:
        """Replace ``current`` by a fresh, unresolved copy of the chain's first designator,
        equated to the chain (CRAM's ``desig:reset``). Returns it."""
        fresh = self.current.first().copy()
        equate(self.current, fresh)
        self.current = fresh
        return fresh

    def __repr__(self) -> str:
        return f"<SolutionCursor {self.current!r}>"


class ListCursor:
    """Holds a lazy list whose first element is the solution in use (CRAM's list place).

    ``current`` is that element (``None`` when the list is empty). As in CRAM, a ``None``
    element ends the iteration.
    """

    __slots__ = ("solutions",)

    def __init__(self, solutions: Iterable[Any]) -> None:
        self.solutions: cpl.LazyList[Any] = (
            solutions if isinstance(solutions, cpl.LazyList) else cpl.LazyList(solutions)
        )

    @property
    def current(self) -> Any:
        return None if self.solutions.is_empty() else self.solutions.first()

    def advance(self) -> Any:
        """Move to the next element and return it, or ``None`` if there is none (the cursor
        is then unchanged)."""
        if self.solutions.is_empty():
            return None
        rest = self.solutions.rest()
        if rest.is_empty():
            return None
        nxt = rest.first()
        if nxt is None:
            return None
        self.solutions = rest
        return nxt

    def __repr__(self) -> str:
        return f"<ListCursor {self.solutions!r}>"


def _raise(rethrow: BaseException | type[BaseException], failure: BaseException | None) -> NoReturn:
    exc = rethrow() if isinstance(rethrow, type) else rethrow
    if not isinstance(exc, BaseException):
        raise TypeError(f"rethrow must be an exception or exception class, got {rethrow!r}")
    raise exc from failure


def _describe(failure: BaseException | None) -> str:
    return f"{type(failure).__name__}: {failure}" if failure is not None else "failure"


def retry_with_designator_solutions(
    cursor: SolutionCursor,
    counter: Any,
    *,
    reset: Iterable[SolutionCursor] = (),
    rethrow: BaseException | type[BaseException] | None = None,
    distance_threshold: float | None = None,
    angle_threshold: float = DEFAULT_ANGLE_THRESHOLD,
    on_retry: Callable[[Designator], Any] | None = None,
    failure: BaseException | None = None,
) -> None:
    """Retry with the next solution of ``cursor``'s designator (CRAM's
    ``retry-with-designator-solutions``; for a location designator,
    ``retry-with-loc-designator-solutions`` with ``distance_threshold``, default 0.05 m).

    On retry the ``reset`` cursors are reset to fresh copies and ``on_retry(new)`` runs.
    ``failure`` (default: the exception being handled) is only used in the log and as the
    cause of ``rethrow``.
    """
    if not isinstance(cursor, SolutionCursor):
        raise TypeError(
            f"retry_with_designator_solutions needs a SolutionCursor, got {cursor!r}: wrap "
            "the designator (cursor = SolutionCursor(desig)) and read cursor.current in the "
            "body, since Python cannot rebind your variable"
        )
    failure = failure if failure is not None else sys.exc_info()[1]
    if isinstance(failure, DesignatorInputError):
        return None  # a malformed designator: no other solution cures it (see module doc)
    log.warning("%s (while using %s)", _describe(failure), cursor.current.short())
    if counter.do_retry():
        nxt = cursor.advance(distance_threshold, angle_threshold)
        if nxt is not None:
            log.info("Retrying with %r", nxt)
            for other in reset:
                other.reset()
            if on_retry is not None:
                on_retry(nxt)
            cpl.retry()
        log.warning("No samples left for %s", cursor.current.short())
    else:
        log.warning("No retries left for %s", cursor.current.short())
    if rethrow is not None:
        _raise(rethrow, failure)
    return None


def retry_with_list_solutions(
    cursor: ListCursor,
    counter: Any,
    *,
    rethrow: BaseException | type[BaseException] | None = None,
    on_retry: Callable[[Any], Any] | None = None,
    failure: BaseException | None = None,
) -> None:
    """Retry with the next element of ``cursor``'s lazy list (CRAM's
    ``retry-with-list-solutions``); see the module docstring for the sequence."""
    if not isinstance(cursor, ListCursor):
        raise TypeError(
            f"retry_with_list_solutions needs a ListCursor, got {cursor!r}: wrap the lazy "
            "list (cursor = ListCursor(solutions)) and read cursor.current in the body"
        )
    failure = failure if failure is not None else sys.exc_info()[1]
    if isinstance(failure, DesignatorInputError):
        return None  # a malformed designator: no other solution cures it (see module doc)
    log.warning("%s (while using solution %r)", _describe(failure), cursor.current)
    if counter.do_retry():
        nxt = cursor.advance()
        if nxt is not None:
            log.info("Retrying with %r", nxt)
            if on_retry is not None:
                on_retry(nxt)
            cpl.retry()
        log.warning("No samples left")
    else:
        log.warning("No retries left")
    if rethrow is not None:
        _raise(rethrow, failure)
    return None


T = TypeVar("T")
Rethrow = BaseException | type[BaseException] | Callable[[BaseException], BaseException]
Body = Callable[[], Awaitable[T]]


def retry_scope(
    on: type[BaseException] | tuple[type[BaseException], ...],
    cursor: SolutionCursor | ListCursor | None,
    counter: Any,
    *,
    rethrow: Rethrow | None = None,
    before_retry: Callable[[], Any] | None = None,
    on_retry: Callable[[Any], Any] | None = None,
    reset: Iterable[SolutionCursor] = (),
    distance_threshold: float | None = None,
    angle_threshold: float = DEFAULT_ANGLE_THRESHOLD,
) -> Callable[[Body[T]], Body[T]]:
    """A retry scope in one line: decorate a zero-argument async function (the scope's
    body) so that awaiting it runs it under ``cpl.with_failure_handling`` with one clause:
    on a failure of type ``on``,

    - with a :class:`SolutionCursor`: :func:`retry_with_designator_solutions` (the
      ``distance_threshold`` / ``angle_threshold`` of locations, ``reset`` cursors,
      ``on_retry(new designator)``);
    - with a :class:`ListCursor`: :func:`retry_with_list_solutions` (``on_retry(new
      element)``);
    - with ``cursor=None`` (a retry that changes no solution, CRAM's ``(when
      (do-retry counter) (recover) (retry))``): while ``counter`` allows, run
      ``before_retry()`` (sync or async: the recovery) and retry.

    When the retries or the solutions run out, raise ``rethrow`` chained to the failure
    (an exception instance or class, or a function of the failure returning one); without
    it the failure propagates. ``counter`` is anything with ``do_retry()`` (a
    :class:`cpl.RetryCounter`): create it where the scope is entered, as CRAM's
    ``with-retry-counters`` does. Bad arguments raise ``TypeError`` at decoration time.
    """
    types = on if isinstance(on, tuple) else (on,)
    if not types or not all(isinstance(t, type) and issubclass(t, Exception) for t in types):
        raise TypeError(f"retry_scope(on=...) names failure classes, got {on!r}")
    if cursor is not None and not isinstance(cursor, (SolutionCursor, ListCursor)):
        raise TypeError(
            f"retry_scope needs a SolutionCursor, a ListCursor or None as cursor, got {cursor!r}"
        )
    if not callable(getattr(counter, "do_retry", None)):
        raise TypeError(f"retry_scope needs a retry counter (cpl.RetryCounter), got {counter!r}")
    if cursor is not None and before_retry is not None:
        raise TypeError("before_retry is for scopes without a cursor; use on_retry=")
    if cursor is None and on_retry is not None:
        raise TypeError("on_retry takes the next solution: it needs a cursor; use before_retry=")
    if rethrow is not None and not (isinstance(rethrow, BaseException) or callable(rethrow)):
        raise TypeError(f"rethrow must be an exception, a class or a function, got {rethrow!r}")

    async def handler(failure: BaseException) -> None:
        if isinstance(failure, DesignatorInputError):
            return  # declined: a malformed designator is never retried nor rethrown
        exc = _rethrown(rethrow, failure)
        if isinstance(cursor, SolutionCursor):
            retry_with_designator_solutions(
                cursor,
                counter,
                reset=reset,
                rethrow=exc,
                distance_threshold=distance_threshold,
                angle_threshold=angle_threshold,
                on_retry=on_retry,
                failure=failure,
            )
        elif isinstance(cursor, ListCursor):
            retry_with_list_solutions(
                cursor, counter, rethrow=exc, on_retry=on_retry, failure=failure
            )
        else:
            if counter.do_retry():
                if before_retry is not None:
                    res = before_retry()
                    if inspect.isawaitable(res):
                        await res
                cpl.retry()
            if exc is not None:
                _raise(exc, failure)

    def decorate(body: Body[T]) -> Body[T]:
        if not callable(body):
            raise TypeError(f"retry_scope decorates an async function, got {body!r}")

        @functools.wraps(body)
        async def scope() -> T:
            result: T = await cpl.with_failure_handling(body, [(types, handler)])
            return result

        return scope

    return decorate


def _rethrown(
    rethrow: Rethrow | None, failure: BaseException
) -> BaseException | type[BaseException] | None:
    """``rethrow`` as :func:`_raise` takes it: a function of the failure is called now."""
    if rethrow is None or isinstance(rethrow, (BaseException, type)):
        return rethrow
    return rethrow(failure)
