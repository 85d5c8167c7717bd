"""Failure-handling strategies (CRAM v0.8.1's ``failure-handling-strategies.lisp``).

Use them inside ``cpl.with_failure_handling`` handlers::

    robot_loc = SolutionCursor(a.location(reachable_for="pr2", location=obj_loc))
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

Python cannot rebind the caller's variable (CRAM's macros ``setf`` a place), so the solution in
use lives in a small mutable holder: :class:`SolutionCursor` for designators,
:class:`ListCursor` for lazy lists. Deliberate difference from CRAM: ``reset=`` really
replaces the given cursors' designators by fresh copies (CRAM's macro only resets a loop
variable, a bug noted in the reference).
"""

from __future__ import annotations

import logging
import sys
from collections.abc import Callable, Iterable
from typing import Any, NoReturn

import cpl

from ._designator import Designator, LocationDesignator, equate, lazy_list_class

__all__ = [
    "DEFAULT_ANGLE_THRESHOLD",
    "DEFAULT_DISTANCE_THRESHOLD",
    "ListCursor",
    "SolutionCursor",
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
        lazy = lazy_list_class()
        self.solutions: Any = solutions if isinstance(solutions, lazy) else lazy(solutions)

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
