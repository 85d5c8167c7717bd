"""Lazy lists: memoised, shareable sequences over an iterator (CRAM's ``lazy-list``).

A Python generator is single-consumer and forgets what it produced. A :class:`LazyList`
forces its source at most once per element and keeps every forced element, so any number
of consumers, iterators and :meth:`LazyList.rest` views share one expansion (CRAM mutates its
conses in place for the same effect).
"""

from __future__ import annotations

import contextvars
import itertools
from collections.abc import Callable, Iterable, Iterator
from typing import Any, Generic, TypeVar

__all__ = ["LazyList"]

T = TypeVar("T")
U = TypeVar("U")

_REPR_LIMIT = 10


class _Memo(Generic[T]):
    """The expansion shared by a lazy list and all its views.

    Invariant: ``items`` holds every element forced so far, in order. ``source`` is ``None``
    once the source ended (exhausted or raised); ``error`` is the exception that ended it,
    if any. ``advancing`` is true while ``next`` runs on the source.
    """

    __slots__ = ("advancing", "ctx", "error", "items", "source")

    def __init__(self, source: Iterator[T], ctx: contextvars.Context) -> None:
        self.items: list[T] = []
        self.source: Iterator[T] | None = source
        self.ctx = ctx
        self.error: BaseException | None = None
        self.advancing = False

    def fill(self, index: int) -> bool:
        """Force elements until ``index`` exists; ``False`` if the list ends before it.

        Re-raises the exception that ended the source when ``index`` lies at or past it.
        """
        items = self.items
        while len(items) <= index:
            source = self.source
            if source is None:
                if self.error is not None:
                    raise self.error
                return False
            if self.advancing:
                raise RuntimeError(
                    "LazyList forced from inside its own source: the generator needs an "
                    "element it is still computing. Build the element from local state "
                    "instead of reading the list being generated."
                )
            self.advancing = True
            try:
                item = self.ctx.run(next, source)
            except StopIteration:
                self.source = None
                return False
            except BaseException as exc:
                self.source = None
                self.error = exc
                raise
            finally:
                self.advancing = False
            items.append(item)
        return True


class LazyList(Generic[T]):
    """A memoised lazy sequence over ``iterable``, shareable by several consumers.

    Elements are computed on demand, each at most once, and kept: indexing, iterating,
    :meth:`first`, :meth:`rest` and :meth:`force` all read the same memo. The list may be
    infinite, which is why it has no ``len()`` and no truth value (use :meth:`is_empty`).

    **Dynamic environment.** The :mod:`contextvars` context of the creator is copied at
    construction, and every advance of the source runs inside it (CRAM's
    ``with-lazy-list-dynamic-environment``): a ``ContextVar`` set when the list was made is
    what the generator sees, whichever task or context forces the element later.

    **Deliberate difference from CRAM:** CRAM computes the first element eagerly at
    construction; here nothing is computed until an element is asked for, so building a
    lazy list of solutions never runs a (possibly costly or failing) search by itself.

    **Failure.** An exception raised by the source propagates to the consumer that forced
    the element. The list then ends there: earlier elements stay readable, and forcing that
    position (or any later one) again re-raises the same exception object.

    Not thread-safe; force it from one thread (the loop's). A source that forces its own
    list raises ``RuntimeError``.
    """

    __slots__ = ("_memo", "_start")

    def __init__(self, iterable: Iterable[T]) -> None:
        self._memo: _Memo[T] = _Memo(iter(iterable), contextvars.copy_context())
        self._start = 0

    @classmethod
    def _view(cls, memo: _Memo[T], start: int) -> LazyList[T]:
        view: LazyList[T] = cls.__new__(cls)
        view._memo = memo
        view._start = start
        return view

    @classmethod
    def chain(cls, *iterables: Iterable[T]) -> LazyList[T]:
        """A lazy list of the elements of each iterable in turn (CRAM's ``lazy-append``).

        Iterables are opened only when the previous one is exhausted.
        """
        return cls(itertools.chain.from_iterable(iterables))

    def _has(self, index: int) -> bool:
        return self._memo.fill(self._start + index)

    def first(self) -> T:
        """The first element (CRAM's ``lazy-car``), forcing it if needed.

        Raises ``IndexError`` when the list is empty, or the source's exception.
        """
        if not self._has(0):
            raise IndexError("first() of an empty LazyList; check is_empty() first")
        return self._memo.items[self._start]

    def rest(self) -> LazyList[T]:
        """The list without its first element (CRAM's ``lazy-cdr``): a view sharing the memo.

        Forces the first element; raises ``IndexError`` when the list is empty.
        """
        if not self._has(0):
            raise IndexError("rest() of an empty LazyList; check is_empty() first")
        return self._view(self._memo, self._start + 1)

    def is_empty(self) -> bool:
        """Whether the list has no element; forces the first element to find out."""
        return not self._has(0)

    def __getitem__(self, index: int) -> T:
        """The element at ``index`` (an ``int >= 0``), forcing up to it.

        Raises ``IndexError`` past the end. Negative indexes and slices are refused with
        ``TypeError``/``IndexError``: they would force a possibly infinite list; use
        :meth:`take` or :meth:`rest`.
        """
        if not isinstance(index, int) or isinstance(index, bool):
            raise TypeError(
                f"LazyList indices must be integers >= 0, not {type(index).__name__}; "
                "use take(n) or rest() instead of slicing"
            )
        if index < 0:
            raise IndexError(
                f"LazyList index {index} is negative; a lazy list may be infinite, so "
                "index from the front (force() it first to count from the end)"
            )
        if not self._has(index):
            raise IndexError(f"LazyList index {index} out of range")
        return self._memo.items[self._start + index]

    def __iter__(self) -> Iterator[T]:
        """Iterate from this view's start; each iterator keeps its own position."""
        memo = self._memo
        i = self._start
        while memo.fill(i):
            yield memo.items[i]
            i += 1

    def force(self) -> list[T]:
        """Force every element and return them as a new list. Never returns on an infinite list."""
        memo = self._memo
        i = len(memo.items)
        while memo.fill(i):
            i += 1
        return memo.items[self._start :]

    def take(self, n: int) -> LazyList[T]:
        """A lazy list of at most the first ``n`` elements (CRAM's ``lazy-take``).

        Forces nothing itself; ``take(n).force()`` forces at most ``n`` elements.
        """
        if n < 0:
            raise ValueError(f"take({n}): n must be >= 0")
        return LazyList(itertools.islice(self, n))

    def map(self, fn: Callable[[T], U]) -> LazyList[U]:
        """A lazy list of ``fn(x)`` for each element, each computed once, on demand.

        ``fn`` runs in the context captured by this call.
        """
        return LazyList(fn(x) for x in self)

    def filter(self, pred: Callable[[T], Any]) -> LazyList[T]:
        """A lazy list of the elements for which ``pred`` is truthy, tested on demand."""
        return LazyList(x for x in self if pred(x))

    def __repr__(self) -> str:
        memo = self._memo
        forced = memo.items[self._start :]
        parts = [repr(x) for x in forced[:_REPR_LIMIT]]
        if len(forced) > _REPR_LIMIT or memo.source is not None:
            parts.append("...")
        elif memo.error is not None:
            parts.append(f"<{type(memo.error).__name__}>")
        shown = ", ".join(parts)
        return f"LazyList([{shown}])"
