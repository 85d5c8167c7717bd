"""Fluents: pulses, callbacks, nets, pulse fluents, wait_for, whenever and threads."""

from __future__ import annotations

import asyncio
import gc
import operator
import threading
import weakref
from collections.abc import Awaitable, Callable, Coroutine
from typing import Any, Literal, TypeVar

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cpl._clock import MockClock
from cpl._fluents import (
    Fluent,
    fl_and,
    fl_eq,
    fl_funcall,
    fl_not,
    fl_or,
    fl_value_changed,
    pulsed,
    wait_for,
    whenever,
)

R = TypeVar("R")


def run(fn: Callable[[], Awaitable[R]], *, clock: MockClock | None = None) -> R:
    """Run ``fn()`` on a fresh loop driven by a MockClock (autojump by default)."""
    loop = asyncio.new_event_loop()
    clock = clock if clock is not None else MockClock()
    clock.install(loop)
    try:
        return loop.run_until_complete(fn())
    finally:
        loop.run_until_complete(loop.shutdown_asyncgens())
        clock.uninstall(loop)
        loop.close()


def _waiting(fluent: Fluent[Any], timeout: float | None = None) -> Coroutine[Any, Any, Any]:
    """``wait_for(fluent, timeout)`` for ``create_task``: in its context mypy solves
    ``wait_for``'s ``T`` as ``X | None`` and rejects the (invariant) ``Fluent[X]``."""
    return wait_for(fluent, timeout)


class Recorder:
    def __init__(self) -> None:
        self.values: list[Any] = []

    def __call__(self, value: Any) -> None:
        self.values.append(value)


# --------------------------------------------------------------------------- base fluent


def test_equal_value_does_not_pulse() -> None:
    f = Fluent(1, name="f")
    rec = Recorder()
    f.on_update(rec)
    f.value = 1
    assert f.pulse_count == 0
    assert rec.values == []
    f.value = 2
    assert (f.value, f.pulse_count, rec.values) == (2, 1, [2])


def test_creation_does_not_pulse_and_defaults() -> None:
    f: Fluent[Any] = Fluent()
    assert f.value is None
    assert f.pulse_count == 0
    assert f.name == "fluent"
    assert repr(Fluent(3, name="x")) == "<Fluent x=3>"


def test_custom_test() -> None:
    f = Fluent(0.0, test=lambda old, new: abs(old - new) < 1.0)
    f.value = 0.5
    assert (f.value, f.pulse_count) == (0.0, 0)
    f.value = 2.0
    assert (f.value, f.pulse_count) == (2.0, 1)


def test_incomparable_values_count_as_change() -> None:
    class Weird:
        def __eq__(self, other: object) -> bool:
            raise TypeError("no")

        __hash__ = object.__hash__

    f = Fluent(Weird())
    f.value = Weird()
    assert f.pulse_count == 1


def test_pulse_without_change() -> None:
    f = Fluent(7)
    rec = Recorder()
    f.on_update(rec)
    f.pulse()
    f.pulse()
    assert (f.value, f.pulse_count, rec.values) == (7, 2, [7, 7])


def test_callbacks_sync_in_order_and_removal() -> None:
    f = Fluent(0)
    order: list[str] = []
    f.on_update(lambda v: order.append(f"a{v}"), key="a")
    remove_b = f.on_update(lambda v: order.append(f"b{v}"), key="b")
    f.on_update(lambda v: order.append(f"c{v}"), key="c")
    f.value = 1
    assert order == ["a1", "b1", "c1"]
    remove_b()
    assert f.remove_update_callback("c") is True
    assert f.remove_update_callback("c") is False
    assert Fluent(0).remove_update_callback("x") is False
    f.value = 2
    assert order == ["a1", "b1", "c1", "a2"]


def test_callback_removing_itself_during_pulse() -> None:
    f = Fluent(0)
    seen: list[int] = []

    def once(v: int) -> None:
        seen.append(v)
        f.remove_update_callback("once")

    f.on_update(once, key="once")
    f.on_update(seen.append, key="always")
    f.value = 1
    f.value = 2
    assert seen == [1, 1, 2]


def test_duplicate_callback_key_error() -> None:
    f = Fluent(0)
    f.on_update(print, key="k")
    with pytest.raises(ValueError, match="already has an update callback 'k'"):
        f.on_update(abs, key="k")
    f.on_update(print)
    with pytest.raises(ValueError, match="remove_update_callback"):
        f.on_update(print)


def test_identity_semantics_not_overloaded() -> None:
    assert Fluent.__eq__ is object.__eq__
    assert Fluent.__ne__ is object.__ne__
    assert Fluent.__hash__ is object.__hash__
    assert not hasattr(Fluent, "__bool__")
    a, b = Fluent(1), Fluent(1)
    assert a != b
    assert len({a, b, a}) == 2


# --------------------------------------------------------------------------- nets

BINARY = [
    (operator.lt, 2, 3),
    (operator.le, 3, 3),
    (operator.gt, 4, 3),
    (operator.ge, 2, 3),
    (operator.add, 2, 3),
    (operator.sub, 2, 3),
    (operator.mul, 2, 3),
    (operator.truediv, 2, 4),
]


@pytest.mark.parametrize(("op", "x", "y"), BINARY)
def test_operator_nets(op: Callable[[Any, Any], Any], x: int, y: int) -> None:
    a, b = Fluent(x), Fluent(y)
    both, left, right = op(a, b), op(a, y), op(x, b)
    for net in (both, left, right):
        assert isinstance(net, Fluent)
        assert net.value == op(x, y)
    a.value = x + 5
    b.value = y + 1
    assert both.value == op(x + 5, y + 1)
    assert left.value == op(x + 5, y)
    assert right.value == op(x, y + 1)


def test_operator_names() -> None:
    t = Fluent(20, name="temp")
    assert (t < 30).name == "(< temp 30)"
    assert (1 - t).name == "(- 1 temp)"


def test_functions_without_fluents_return_plain_values() -> None:
    assert fl_funcall(max, 1, 5, 3) == 5
    assert fl_and(1, 2) == 2
    assert fl_and(1, 0, 2) == 0
    assert fl_and() is True
    assert fl_or(0, "", 3, 4) == 3
    assert fl_or(0, "") == ""
    assert fl_or() is None
    assert fl_not(0) is True
    assert fl_eq(2, 2) is True


def test_list_of_fluents_is_not_an_input() -> None:
    a = Fluent(1)
    assert fl_funcall(len, [a, a]) == 2


def test_fl_eq_not_funcall() -> None:
    a, b = Fluent(1), Fluent(2)
    eq, notb = fl_eq(a, b), fl_not(b)
    assert eq.value is False
    assert notb.value is False
    b.value = 1
    assert eq.value is True
    b.value = 0
    assert notb.value is True
    summed = fl_funcall(lambda *xs: sum(xs), a, b, 10)
    a.value = 5
    assert summed.value == 15


def test_fl_and_or_return_values() -> None:
    a, b = Fluent(0), Fluent("x")
    both, either = fl_and(a, b), fl_or(a, b)
    assert both.value == 0
    assert either.value == "x"
    a.value = 3
    assert both.value == "x"
    assert either.value == 3


def test_cacheable_net_pulses_only_on_change() -> None:
    a = Fluent(1)
    positive = a > 0
    rec = Recorder()
    positive.on_update(rec)
    a.value = 2
    a.pulse()
    assert (positive.value, positive.pulse_count, rec.values) == (True, 0, [])
    a.value = -1
    assert (positive.value, positive.pulse_count, rec.values) == (False, 1, [False])


def test_cacheable_net_computes_once_per_input_pulse() -> None:
    calls: list[int] = []

    def square(x: int) -> int:
        calls.append(x)
        return x * x

    a = Fluent(2)
    net = fl_funcall(square, a)
    assert calls == [2]
    assert (net.value, net.value, net.peek_value()) == (4, 4, 4)
    assert calls == [2]
    a.value = 3
    assert calls == [2, 3]


def test_nested_cacheable_nets_propagate() -> None:
    a = Fluent(1)
    net = (a + 1) * 2
    assert net.value == 4
    a.value = 2
    assert (net.value, net.pulse_count) == (6, 1)


def test_net_over_the_same_input_twice_pulses_once() -> None:
    a = Fluent(1)
    p = pulsed(a)
    doubled = fl_and(p, p)
    a.pulse()
    assert doubled.pulse_count == 1


def test_non_cacheable_net_recomputes_and_pulses_on_every_input_pulse() -> None:
    a, gate = Fluent(0), Fluent(True)
    p = pulsed(a, "always")
    net = fl_and(gate, p)
    rec = Recorder()
    net.on_update(rec)
    a.value = 1
    a.pulse()
    assert net.pulse_count == 2
    assert len(rec.values) == 2
    assert net.peek_value() is True
    assert net.value is True
    assert net.value is True
    assert net.value is False
    gate.value = False
    assert net.pulse_count == 3


def test_nets_over_non_cacheable_nets_are_non_cacheable() -> None:
    a = Fluent(0)
    outer = fl_not(fl_not(pulsed(a)))
    a.pulse()
    a.pulse()
    assert outer.pulse_count == 2
    assert outer.value is True
    assert outer.value is False
    assert type(outer).__name__ == "_Net"
    assert type(fl_not(a > 0)).__name__ == "_CacheableNet"


def test_fl_and_short_circuits_reads() -> None:
    gate, src = Fluent(False), Fluent(0)
    p = pulsed(src)
    src.pulse()
    assert fl_and(gate, p).value is False
    assert p.peek_value() is True  # not consumed
    assert fl_or(Fluent(True), p).value is True
    assert p.peek_value() is True
    assert fl_or(gate, p).value is True
    assert p.peek_value() is False  # consumed by fl_or


def test_net_value_cannot_be_set() -> None:
    a = Fluent(1)
    for net in (a + 1, pulsed(a), fl_value_changed(a), fl_and(pulsed(a))):
        with pytest.raises(AttributeError, match="set one of the input fluents"):
            net.value = 3


def test_dead_net_is_not_called_and_callback_removed() -> None:
    calls: list[int] = []

    def watch(x: int) -> int:
        calls.append(x)
        return x

    a = Fluent(1)
    net = fl_funcall(watch, a)
    p = pulsed(a)
    ref, pref = weakref.ref(net), weakref.ref(p)
    assert a._callbacks is not None and len(a._callbacks) == 2
    del net, p
    gc.collect()
    assert ref() is None and pref() is None
    a.value = 2
    assert calls == [1]
    assert not a._callbacks


def test_net_keeps_inputs_alive() -> None:
    net = Fluent(1) + 1
    gc.collect()
    assert net.value == 2


def test_net_function_error_propagates_to_setter() -> None:
    a = Fluent(1)
    inv = 1 / a
    with pytest.raises(ZeroDivisionError):
        a.value = 0
    assert a.value == 0  # the input changed; the failing net kept its old value
    assert inv.value == 1
    assert "ZeroDivisionError" in repr(fl_funcall(operator.truediv, 1, pulsed(a, "never")))


def test_value_changed() -> None:
    f = Fluent(1)
    changed = fl_value_changed(f)
    assert changed.value is False
    f.value = 2
    assert changed.peek_value() is True
    assert changed.value is True
    assert changed.value is False
    f.pulse()
    assert changed.pulse_count == 2
    assert changed.value is False


def test_value_changed_with_key() -> None:
    f = Fluent((1, "a"))
    changed = fl_value_changed(f, key=operator.itemgetter(0))
    f.value = (1, "b")
    assert changed.value is False
    f.value = (2, "b")
    assert changed.value is True
    with pytest.raises(TypeError, match="needs a Fluent"):
        fl_value_changed(3)


# --------------------------------------------------------------------------- pulsed


def test_pulsed_once() -> None:
    f = Fluent(0)
    f.pulse()
    p = pulsed(f)  # "once" is the default
    assert p.peek_value() is True
    assert p.value is True  # pulses before creation count once
    assert p.value is False
    f.pulse()
    f.pulse()
    assert p.value is True
    assert p.value is False


def test_pulsed_never() -> None:
    f = Fluent(0)
    f.pulse()
    p = pulsed(f, "never")
    assert p.value is False
    f.value = 1
    f.pulse()
    assert p.value is True
    assert p.value is False


def test_pulsed_always_counts_from_source_creation() -> None:
    f = Fluent(0)
    f.pulse()
    f.pulse()
    p = pulsed(f, "always")
    f.pulse()
    assert [p.value for _ in range(4)] == [True, True, True, False]


def test_pulsed_misuse() -> None:
    with pytest.raises(ValueError, match="'once', 'always', 'never'"):
        pulsed(Fluent(0), "sometimes")  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="needs a Fluent"):
        pulsed(3)  # type: ignore[arg-type]


Mode = Literal["once", "always", "never"]


@given(
    mode=st.sampled_from(["once", "always", "never"]),
    before=st.integers(0, 3),
    ops=st.lists(st.sampled_from(["pulse", "set", "read", "peek"]), max_size=40),
)
def test_pulsed_consumption_rules(mode: Mode, before: int, ops: list[str]) -> None:
    """Reads follow the documented rules, stated in terms of pulses since the last read."""
    f = Fluent(0)
    for _ in range(before):
        f.pulse()
    p = pulsed(f, mode)
    pending = before if mode != "never" else 0  # pulses not yet accounted for
    true_reads = 0
    total = before
    for op in ops:
        if op == "pulse":
            f.pulse()
            pending += 1
            total += 1
        elif op == "set":
            f.value = f.value + 1
            pending += 1
            total += 1
        elif op == "peek":
            assert p.peek_value() is (pending > 0)
        else:
            got = p.value
            assert got is (pending > 0)
            if mode == "always":
                pending = max(0, pending - 1)
            else:
                pending = 0
            true_reads += got
    assert p.pulse_count == total - before
    if mode == "always":
        assert true_reads + pending == total


# --------------------------------------------------------------------------- wait_for


def test_wait_for_immediate_when_true() -> None:
    async def main() -> tuple[Any, float]:
        loop = asyncio.get_running_loop()
        t0 = loop.time()
        got = await wait_for(Fluent("ready"), timeout=5)
        return got, loop.time() - t0

    assert run(main) == ("ready", 0.0)


def test_wait_for_returns_value_when_set() -> None:
    f: Fluent[Any] = Fluent(None)

    async def main() -> Any:
        asyncio.get_running_loop().call_later(3, setattr, f, "value", 42)
        return await wait_for(f)

    assert run(main) == 42
    assert not f._waiters


def test_wait_for_timeout_returns_none() -> None:
    f = Fluent(0)

    async def main() -> tuple[Any, float]:
        loop = asyncio.get_running_loop()
        t0 = loop.time()
        got = await wait_for(f, timeout=1000)
        return got, loop.time() - t0

    got, elapsed = run(main)
    assert got is None
    assert elapsed >= 1000
    assert not f._waiters


def test_wait_for_zero_and_negative_timeout() -> None:
    async def main() -> tuple[Any, Any]:
        return await wait_for(Fluent(0), 0), await wait_for(Fluent(0), -1)

    assert run(main) == (None, None)


def test_wait_for_nan_timeout() -> None:
    async def main() -> Any:
        return await wait_for(Fluent(0), float("nan"))

    with pytest.raises(ValueError, match="NaN"):
        run(main)


def test_pulse_without_change_does_not_release() -> None:
    f = Fluent(False)

    async def main() -> tuple[Any, Any]:
        loop = asyncio.get_running_loop()
        for delay in (1, 2, 3):
            loop.call_later(delay, f.pulse)
        first = await wait_for(f, timeout=10)
        loop.call_later(1, f.pulse)
        loop.call_later(2, setattr, f, "value", "go")
        second = await wait_for(f, timeout=10)
        return first, second

    assert run(main) == (None, "go")
    assert f.pulse_count == 5


def test_wait_for_non_fluent() -> None:
    async def main() -> Any:
        return await wait_for(5)

    assert run(main) == 5

    async def falsy() -> Any:
        return await wait_for(0)

    with pytest.raises(ValueError, match="falsy non-fluent"):
        run(falsy)


def test_wait_for_cancelled_removes_waiter() -> None:
    f = Fluent(0)

    async def main() -> None:
        task = asyncio.create_task(_waiting(f))
        await asyncio.sleep(1)
        assert f._waiters is not None and len(f._waiters) == 1
        task.cancel()
        with pytest.raises(asyncio.CancelledError):
            await task

    run(main)
    assert not f._waiters


def test_wait_for_pulse_fluent_reads_once_per_check() -> None:
    f = Fluent(0)
    p = pulsed(f, "always")
    for _ in range(3):
        f.pulse()

    async def main() -> list[Any]:
        got: list[Any] = [await wait_for(p) for _ in range(3)]
        return [*got, await wait_for(p, timeout=1)]

    assert run(main) == [True, True, True, None]


def test_wait_for_net_of_pulse_fluent() -> None:
    f = Fluent(0)

    async def main() -> Any:
        loop = asyncio.get_running_loop()
        loop.call_later(2, f.pulse)
        return await wait_for(fl_and(Fluent(True), pulsed(f, "never")), timeout=5)

    assert run(main) is True


def test_latecomers_released_by_once() -> None:
    """CRAM wait-for-wakeups-on-pulse: a waiter created after the pulse is still released."""
    f = Fluent(0)

    async def waiter(delay: float) -> Any:
        await asyncio.sleep(delay)
        return await wait_for(pulsed(f), timeout=100)

    async def main() -> list[Any]:
        asyncio.get_running_loop().call_later(5, f.pulse)
        return list(await asyncio.gather(*(waiter(d) for d in (0, 1, 6, 10))))

    assert run(main) == [True, True, True, True]


@settings(max_examples=40, deadline=None)
@given(
    thresholds=st.lists(st.integers(0, 10), min_size=1, max_size=30),
    steps=st.lists(st.integers(-3, 5), max_size=20),
    yields=st.booleans(),
)
def test_no_lost_wakeups(thresholds: list[int], steps: list[int], yields: bool) -> None:
    """Every waiter whose condition ever holds at the end is released with its value."""
    f = Fluent(0)

    async def main() -> list[Any]:
        tasks = [asyncio.create_task(wait_for(f >= k)) for k in thresholds]
        await asyncio.sleep(0)
        for step in steps:
            f.value = f.value + step
            if yields:
                await asyncio.sleep(0)
        f.value = 10
        return list(await asyncio.gather(*tasks))

    assert run(main) == [True] * len(thresholds)
    assert not f._waiters


def test_many_waiters_one_change() -> None:
    f = Fluent(0)

    async def main() -> list[Any]:
        tasks = [asyncio.create_task(_waiting(f)) for _ in range(500)]
        await asyncio.sleep(0)
        f.value = 1
        return list(await asyncio.gather(*tasks))

    assert run(main) == [1] * 500


# --------------------------------------------------------------------------- threads


def test_set_from_thread_wakes_waiter_on_loop_thread() -> None:
    f = Fluent(0)
    callback_threads: list[int] = []
    f.on_update(lambda _v: callback_threads.append(threading.get_ident()))

    async def main() -> tuple[Any, Any]:
        loop_thread = threading.get_ident()
        waiting = asyncio.create_task(_waiting(f, timeout=60))
        await asyncio.sleep(0)
        t = threading.Thread(target=f.set_threadsafe, args=(7,))
        t.start()
        got = await waiting
        await asyncio.to_thread(t.join)
        assert callback_threads == [loop_thread]
        t2 = threading.Thread(target=setattr, args=(f, "value", 8))
        t2.start()
        got2 = await wait_for(f > 7, timeout=60)
        await asyncio.to_thread(t2.join)
        return got, got2

    loop = asyncio.new_event_loop()
    try:
        assert loop.run_until_complete(main()) == (7, True)
        loop.run_until_complete(loop.shutdown_default_executor())
    finally:
        loop.close()
    assert callback_threads == [callback_threads[0]] * 2


def test_pulse_from_thread_under_mock_clock() -> None:
    f = Fluent(0)

    async def main() -> Any:
        p = pulsed(f, "never")
        waiting = asyncio.create_task(_waiting(p))
        await asyncio.sleep(0)
        t = threading.Thread(target=f.pulse)
        t.start()
        got = await waiting
        t.join()
        return got

    assert run(main) is True
    assert f.pulse_count == 1


def test_set_after_loop_closed_applies_directly() -> None:
    async def make() -> Fluent[int]:
        f = Fluent(0)
        await wait_for(f, timeout=1)
        return f

    f = run(make)
    t = threading.Thread(target=f.set_threadsafe, args=(3,))
    t.start()
    t.join()
    assert (f.value, f.pulse_count) == (3, 1)
    f.value = 4  # now unbound: set directly from this thread too
    assert f.value == 4


# --------------------------------------------------------------------------- whenever


def test_whenever_5_always() -> None:
    """CRAM whenever.5: 1 change + 4 pulses with "always" run the body exactly 5 times."""
    f = Fluent(0)

    async def main() -> int:
        p = pulsed(f, "always")
        runs = 0

        async def setter() -> None:
            f.value = 1
            for _ in range(4):
                await asyncio.sleep(0.1)
                f.pulse()

        task = asyncio.create_task(setter())
        async for _ in whenever(p):
            runs += 1
            if runs == 5:
                break
        await task
        assert await wait_for(p, timeout=10) is None  # no sixth run
        assert not f._waiters and not p._waiters
        return runs

    assert run(main) == 5


def test_whenever_once_coalesces_but_sees_final_value() -> None:
    f = Fluent(0)

    async def main() -> list[int]:
        seen: list[int] = []

        async def setter() -> None:
            for i in range(1, 11):
                f.value = i
                if i % 3 == 0:
                    await asyncio.sleep(1)

        task = asyncio.create_task(setter())
        async for _ in whenever(pulsed(f)):
            seen.append(f.value)
            if f.value == 10:
                break
        await task
        return seen

    seen = run(main)
    assert seen[-1] == 10
    assert len(seen) < 10


def test_whenever_on_persistently_true_fluent_does_not_starve() -> None:
    f = Fluent(True)
    stop = Fluent(False)

    async def main() -> int:
        spins = 0

        async def stopper() -> None:
            await asyncio.sleep(0)
            await asyncio.sleep(0)
            stop.value = True

        task = asyncio.create_task(stopper())
        async for value in whenever(f):
            assert value is True
            spins += 1
            if stop.value:
                break
        await task
        return spins

    assert run(main) >= 2


def test_whenever_cancelled_while_waiting_cleans_up() -> None:
    f = Fluent(0)

    async def watch() -> None:
        async for _ in whenever(pulsed(f, "never")):
            pass

    async def main() -> None:
        task = asyncio.create_task(watch())
        await asyncio.sleep(1)
        f.pulse()
        await asyncio.sleep(1)
        task.cancel()
        with pytest.raises(asyncio.CancelledError):
            await task

    run(main)
    assert not f._waiters
    gc.collect()
    f.pulse()
    assert not f._callbacks
