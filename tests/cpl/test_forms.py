"""Semantics of seq, par, pursue, try_all, try_in_order, par_loop, tag, partial_order."""

from __future__ import annotations

from typing import Any

import pytest

import cpl


async def value_after(v, t, log=None):
    try:
        await cpl.sleep(t)
        return v
    finally:
        if log is not None:
            log.append(v)


async def fail_after(failure, t, log=None):
    try:
        await cpl.sleep(t)
        raise failure
    finally:
        if log is not None:
            log.append(failure)


def test_seq_returns_last_and_stops_at_failure(mrun):
    log: list[Any] = []

    async def main():
        assert await cpl.seq(value_after(1, 1), value_after(2, 1)) == 2
        assert await cpl.seq() is None
        with pytest.raises(cpl.PlanFailure):
            await cpl.seq(fail_after(cpl.PlanFailure("x"), 1), value_after(3, 1, log))
        return True

    assert mrun(main)
    assert log == []  # the step after the failure never ran (and was closed: no warning)


def test_seq_accepts_callables_and_works_outside_tasks():
    import asyncio

    async def one():
        return 1

    assert asyncio.run(cpl.seq(one, one())) == 1


def test_par_returns_all_values_in_order(mrun):
    async def main():
        return await cpl.par(value_after("a", 3), value_after("b", 1), value_after("c", 2))

    assert mrun(main) == ["a", "b", "c"]


def test_par_failure_evaporates_siblings_and_keeps_identity(mrun):
    boom = cpl.PlanFailure("boom")
    log: list[Any] = []

    async def main():
        try:
            await cpl.par(value_after("slow", 10, log), fail_after(boom, 1))
        except cpl.PlanFailure as f:
            return f

    assert mrun(main, name="parfail") is boom
    assert log == ["slow"]  # sibling cleanup ran
    tree = cpl.task_tree("parfail")
    assert tree is not None
    node = tree.find(lambda n: n.kind == "par")
    assert node is not None
    assert node.status is cpl.Status.FAILED
    assert [c.status for c in node.children] == [cpl.Status.EVAPORATED, cpl.Status.FAILED]


def test_par_branch_evaporated_from_outside_gives_none(mrun):
    async def main():
        victim = cpl.Task(value_after("v", 10), name="victim")

        async def killer():
            await cpl.sleep(1)
            victim.evaporate("killed")
            return "k"

        return await cpl.par(victim, killer())

    assert mrun(main) == [None, "k"]


def test_par_empty():
    async def main():
        return await cpl.par()

    assert cpl.run(main) == []


def test_pursue_first_finisher_wins(mrun):
    log: list[Any] = []

    async def main():
        return await cpl.pursue(value_after("slow", 5, log), value_after("fast", 1, log))

    assert mrun(main) == "fast"
    assert sorted(log) == ["fast", "slow"]


def test_pursue_failure_that_finishes_first_wins(mrun):
    boom = cpl.PlanFailure("first")

    async def main():
        await cpl.pursue(value_after("late", 5), fail_after(boom, 1))

    with pytest.raises(cpl.PlanFailure) as info:
        mrun(main)
    assert info.value is boom


def test_pursue_success_before_failure(mrun):
    async def main():
        return await cpl.pursue(fail_after(cpl.PlanFailure("late"), 5), value_after("ok", 1))

    assert mrun(main) == "ok"


def test_try_all_first_success_and_no_cancel_on_failure(mrun):
    log: list[Any] = []

    async def main():
        return await cpl.try_all(
            fail_after(cpl.PlanFailure("f1"), 1, log),
            value_after("ok", 3, log),
            value_after("late", 10, log),
        )

    assert mrun(main) == "ok"
    # the early failure did not cancel "ok"; "late" was evaporated after the success
    assert [str(x) for x in log] == ["f1", "ok", "late"]


def test_try_all_composite_only_when_all_failed(mrun):
    f1, f2 = cpl.PlanFailure("f1"), cpl.PlanFailure("f2")

    async def main():
        await cpl.try_all(fail_after(f1, 2), fail_after(f2, 1))

    with pytest.raises(cpl.CompositeFailure) as info:
        mrun(main)
    assert info.value.failures == (f1, f2)  # branch order


def test_try_all_programming_error_propagates_at_once(mrun):
    log: list[Any] = []

    async def main():
        await cpl.try_all(value_after("x", 10, log), fail_after(TypeError("bug"), 1))

    with pytest.raises(TypeError, match="bug"):
        mrun(main)
    assert log == ["x"]


def test_try_in_order(mrun):
    f1 = cpl.PlanFailure("one")
    calls = []

    async def attempt(name, ok):
        calls.append(name)
        if not ok:
            raise cpl.PlanFailure(name)
        return name

    async def main():
        assert (
            await cpl.try_in_order(fail_after(f1, 1), attempt("b", True), attempt("c", True)) == "b"
        )
        with pytest.raises(cpl.CompositeFailure) as info:
            await cpl.try_in_order(attempt("x", False), attempt("y", False))
        assert [str(f) for f in info.value.failures] == ["x", "y"]
        with pytest.raises(KeyError):
            await cpl.try_in_order(_raise(KeyError("k")), attempt("z", True))
        return True

    assert mrun(main)
    assert calls == ["b", "x", "y"]


async def _raise(exc):
    raise exc


def test_par_loop(mrun):
    async def double(x):
        await cpl.sleep(x)
        return 2 * x

    async def main():
        return await cpl.par_loop([3, 1, 2], double)

    assert mrun(main) == [6, 2, 4]


def test_tag_names_branches(mrun):
    async def main():
        await cpl.par(cpl.tag("left", value_after(1, 1)), cpl.tag("right", value_after(2, 1)))
        return await cpl.tag("solo", value_after(3, 1))

    assert mrun(main, name="tags") == 3
    tree = cpl.task_tree("tags")
    assert tree is not None
    names = [n.name for n in tree.walk()]
    assert {"left", "right", "solo", "par"} <= set(names)


def test_partial_order_starts_b_after_a(mrun):
    order = []

    async def step(name, t):
        order.append(("start", name))
        await cpl.sleep(t)
        order.append(("end", name))
        return name

    async def main():
        a = cpl.Task(step("a", 2), name="a")
        b = cpl.Task(step("b", 1), name="b")
        c = cpl.Task(step("c", 1), name="c")
        res = await cpl.partial_order([a, b, c], orderings=[(a, b)])
        return res, b

    res, b = mrun(main)
    assert res == ["a", "b", "c"]
    assert order.index(("end", "a")) < order.index(("start", "b"))
    assert order.index(("start", "c")) < order.index(("end", "a"))
    assert b.path[-2] == "partial-order"


def test_partial_order_failed_predecessor_releases_but_fails_form(mrun):
    async def main():
        a = cpl.Task(fail_after(cpl.PlanFailure("a"), 1), name="a")
        b = cpl.Task(value_after("b", 1), name="b")
        await cpl.partial_order([a, b], orderings=[(a, b)])

    with pytest.raises(cpl.PlanFailure, match="a"):
        mrun(main)


def test_partial_order_cycle_is_an_error(mrun):
    async def main():
        a = cpl.Task(value_after("a", 1), name="a")
        b = cpl.Task(value_after("b", 1), name="b")
        await cpl.partial_order([a, b], orderings=[(a, b), (b, a)])

    with pytest.raises(ValueError, match="cycle: a -> b -> a"):
        mrun(main)


def test_partial_order_unknown_step_is_an_error(mrun):
    async def main():
        a = cpl.Task(value_after("a", 1), name="a")
        b = cpl.Task(value_after("b", 1), name="b")
        await cpl.partial_order([a], orderings=[(a, b)])

    with pytest.raises(ValueError, match="not one of the steps"):
        mrun(main)


def test_forms_need_a_task():
    import asyncio

    async def main():
        return await cpl.par(value_after(1, 0))

    with pytest.raises(RuntimeError, match=r"cpl\.run"):
        asyncio.run(main())


def test_form_rejects_garbage(mrun):
    async def main():
        await cpl.par(value_after(1, 1), 42)  # type: ignore[arg-type]

    with pytest.raises(TypeError, match="forms take"):
        mrun(main)


def test_retry_rerun_gets_call_numbers(mrun):
    counter = cpl.RetryCounter(2)

    @cpl.plan
    async def attempt():
        raise cpl.PlanFailure("again")

    async def main():
        async def body():
            await attempt()

        def handler(f):
            if counter.do_retry():
                cpl.retry()

        await cpl.with_failure_handling(body, [(cpl.PlanFailure, handler)])

    with pytest.raises(cpl.PlanFailure):
        mrun(main, name="calls")
    tree = cpl.task_tree("calls")
    assert tree is not None
    assert [c.path[-1] for c in tree.children] == ["attempt", "attempt#2", "attempt#3"]
