"""LazyList: laziness, memoisation, sharing, context capture and failure behaviour."""

from __future__ import annotations

import contextvars
import itertools
from collections.abc import Iterator

import pytest
from hypothesis import given
from hypothesis import strategies as st

from cpl._lazy import LazyList


class Counted:
    """An iterable over ``items`` that counts how often it was advanced."""

    def __init__(self, items: list[int] | None = None) -> None:
        self.items = items
        self.advanced = 0

    def __iter__(self) -> Iterator[int]:
        source = itertools.count() if self.items is None else iter(self.items)
        for x in source:
            self.advanced += 1
            yield x


def test_construction_forces_nothing() -> None:
    src = Counted()
    LazyList(src)
    assert src.advanced == 0


def test_first_forces_one_element() -> None:
    src = Counted()
    ll = LazyList(src)
    assert ll.first() == 0
    assert ll.first() == 0
    assert src.advanced == 1


def test_getitem_forces_up_to_index_only() -> None:
    src = Counted()
    ll = LazyList(src)
    assert ll[4] == 4
    assert src.advanced == 5
    assert ll[2] == 2
    assert src.advanced == 5


def test_memoised_across_consumers_and_iterators() -> None:
    src = Counted([1, 2, 3])
    ll = LazyList(src)
    it1, it2 = iter(ll), iter(ll)
    assert next(it1) == 1
    assert next(it2) == 1
    assert list(it1) == [2, 3]
    assert list(it2) == [2, 3]
    assert list(ll) == [1, 2, 3]
    assert ll.force() == [1, 2, 3]
    assert src.advanced == 3


def test_rest_shares_the_memo() -> None:
    src = Counted()
    ll = LazyList(src)
    r = ll.rest()
    assert src.advanced == 1
    assert r.first() == 1
    assert r.rest().rest()[0] == 3
    assert src.advanced == 4
    assert ll[3] == 3
    assert src.advanced == 4
    assert r.take(3).force() == [1, 2, 3]


def test_empty_list() -> None:
    ll: LazyList[int] = LazyList([])
    assert ll.is_empty()
    with pytest.raises(IndexError, match="empty"):
        ll.first()
    with pytest.raises(IndexError, match="empty"):
        ll.rest()
    assert ll.force() == []
    assert list(ll) == []


def test_index_errors() -> None:
    ll = LazyList([1, 2])
    with pytest.raises(IndexError, match="out of range"):
        ll[2]
    with pytest.raises(IndexError, match="negative"):
        ll[-1]
    with pytest.raises(TypeError, match="take"):
        ll[0:1]  # type: ignore[index]
    with pytest.raises(TypeError):
        ll[True]


def test_no_len_no_bool() -> None:
    ll = LazyList([1])
    assert not hasattr(ll, "__len__")
    assert not hasattr(ll, "__bool__")


def test_infinite_with_take_map_filter() -> None:
    src = Counted()
    ll = LazyList(src)
    evens = ll.filter(lambda x: x % 2 == 0).map(lambda x: x * 10)
    assert src.advanced == 0
    assert evens.take(3).force() == [0, 20, 40]
    assert src.advanced == 5
    assert ll.take(0).force() == []
    with pytest.raises(ValueError, match=">= 0"):
        ll.take(-1)


def test_take_forces_at_most_n() -> None:
    src = Counted()
    assert LazyList(src).take(3).force() == [0, 1, 2]
    assert src.advanced == 3


def test_map_calls_fn_once_per_element() -> None:
    calls: list[int] = []

    def double(x: int) -> int:
        calls.append(x)
        return 2 * x

    m = LazyList([1, 2, 3]).map(double)
    assert calls == []
    assert m[1] == 4
    assert list(m) == [2, 4, 6]
    assert m.force() == [2, 4, 6]
    assert calls == [1, 2, 3]


def test_filter_evaluations() -> None:
    tested: list[int] = []

    def odd(x: int) -> bool:
        tested.append(x)
        return x % 2 == 1

    f = LazyList(range(10)).filter(odd)
    assert f.first() == 1
    assert tested == [0, 1]


def test_chain_is_lazy_across_iterables() -> None:
    a, b = Counted([1, 2]), Counted([3])
    ll = LazyList.chain(a, b, [])
    assert ll[1] == 2
    assert (a.advanced, b.advanced) == (2, 0)
    assert ll.force() == [1, 2, 3]
    assert LazyList.chain().is_empty()


def test_repr() -> None:
    ll = LazyList(itertools.count())
    assert repr(ll) == "LazyList([...])"
    ll[1]
    assert repr(ll) == "LazyList([0, 1, ...])"
    assert repr(ll.rest()) == "LazyList([1, ...])"
    done = LazyList([1, 2])
    done.force()
    assert repr(done) == "LazyList([1, 2])"
    big = LazyList(range(20))
    big.force()
    assert repr(big).endswith("9, ...])")


VAR: contextvars.ContextVar[str] = contextvars.ContextVar("VAR", default="unset")


def test_context_captured_at_creation() -> None:
    def gen() -> Iterator[str]:
        while True:
            yield VAR.get()

    def make() -> LazyList[str]:
        VAR.set("creator")
        return LazyList(gen())

    ll = contextvars.copy_context().run(make)
    assert VAR.get() == "unset"

    def consume() -> str:
        VAR.set("consumer")
        return ll[2]

    assert contextvars.copy_context().run(consume) == "creator"
    assert ll[3] == "creator"


def test_context_changes_inside_generator_persist_between_forcings() -> None:
    def gen() -> Iterator[int]:
        for i in range(3):
            VAR.set(f"gen{i}")
            yield i

    ll = LazyList(gen())
    ll[0]
    assert VAR.get() == "unset"
    ll[2]
    assert VAR.get() == "unset"


def test_source_exception_propagates_and_ends_the_list() -> None:
    err = RuntimeError("sensor down")

    def gen() -> Iterator[int]:
        yield 1
        raise err

    ll = LazyList(gen())
    assert ll.first() == 1
    with pytest.raises(RuntimeError, match="sensor down") as info:
        ll[1]
    assert info.value is err
    assert ll[0] == 1
    with pytest.raises(RuntimeError) as again:
        ll[1]
    assert again.value is err
    with pytest.raises(RuntimeError):
        ll.force()
    with pytest.raises(RuntimeError):
        list(ll)
    assert repr(ll) == "LazyList([1, <RuntimeError>])"


def test_self_forcing_source_is_refused() -> None:
    holder: list[LazyList[int]] = []

    def gen() -> Iterator[int]:
        yield holder[0][0] + 1

    ll = LazyList(gen())
    holder.append(ll)
    with pytest.raises(RuntimeError, match="own source"):
        ll.first()


@given(
    items=st.lists(st.integers(), max_size=30),
    reads=st.lists(st.tuples(st.integers(0, 3), st.integers(0, 40)), max_size=40),
)
def test_memoisation_property(items: list[int], reads: list[tuple[int, int]]) -> None:
    """Any mix of reads through any views forces each element at most once and agrees
    with the plain list."""
    src = Counted(items)
    ll = LazyList(src)
    views = [ll, ll.rest() if items else ll, ll, ll]
    offsets = [0, 1 if items else 0, 0, 0]
    highest = 0
    for which, index in reads:
        view, off = views[which], offsets[which]
        if off + index < len(items):
            assert view[index] == items[off + index]
            highest = max(highest, off + index + 1)
        else:
            with pytest.raises(IndexError):
                view[index]
            highest = len(items)
        assert src.advanced == highest
    assert ll.force() == items
    assert src.advanced == len(items)
