"""Tasks, top levels, spawn/join, evaporation and cleanup."""

from __future__ import annotations

import asyncio

import pytest

import cpl
from cpl.testing import MockClock


def test_run_returns_value_and_records_named_tree(mrun):
    async def main(x):
        await cpl.sleep(1)
        return x * 2

    assert mrun(main, 21, name="double") == 42
    tree = cpl.task_tree("double")
    assert tree is not None
    assert tree.name == "double"
    assert tree.status is cpl.Status.SUCCEEDED


def test_failure_identity_through_run(mrun):
    boom = cpl.PlanFailure("boom")

    async def inner():
        raise boom

    async def main():
        t = cpl.spawn(inner(), name="inner")
        await t.join()

    with pytest.raises(cpl.PlanFailure) as info:
        mrun(main)
    assert info.value is boom


def test_programming_error_propagates_unchanged(mrun):
    async def main():
        return await cpl.par(cpl.sleep(1), _raise(KeyError("k")))

    with pytest.raises(KeyError):
        mrun(main)


async def _raise(exc):
    raise exc


def test_nested_top_level_raises():
    async def main():
        await cpl.top_level(cpl.sleep, 0)

    with pytest.raises(RuntimeError, match="cannot be nested"):
        cpl.run(main, clock=MockClock())


def test_top_level_inside_existing_loop():
    async def plan():
        await cpl.sleep(0.001)
        return "ok"

    async def outside():
        return await cpl.top_level(plan)

    assert asyncio.run(outside()) == "ok"


def test_spawned_child_evaporated_when_parent_finishes(mrun):
    cleaned = []

    async def worker():
        try:
            await cpl.sleep(100)
        finally:
            cleaned.append("worker")

    async def main():
        t = cpl.spawn(worker(), name="worker")
        await cpl.sleep(1)
        return t

    t = mrun(main)
    assert t.state is cpl.Status.EVAPORATED
    assert t.evaporation is not None
    assert "finished" in t.evaporation.reason
    assert t.evaporation.by == ("test",)
    assert cleaned == ["worker"]


def test_join_values_failures_and_evaporated(mrun):
    async def ok():
        return 5

    async def slow():
        await cpl.sleep(10)

    async def main():
        a = cpl.spawn(ok(), name="a")
        b = cpl.spawn(slow(), name="b")
        assert await a.join() == 5
        b.evaporate("not needed")
        assert await b.join() is None
        assert b.evaporation is not None and b.evaporation.reason == "not needed"
        me = cpl.current_task()
        assert me is not None
        with pytest.raises(RuntimeError, match="cannot join itself"):
            await me.join()
        return True

    assert mrun(main)


def test_cleanup_runs_once_even_when_it_awaits(mrun):
    log = []

    async def worker():
        try:
            await cpl.sleep(100)
        finally:
            log.append("cleanup-start")
            await cpl.shielded(cpl.sleep(2))
            log.append("cleanup-end")

    async def main():
        t = cpl.spawn(worker(), name="w")
        await cpl.sleep(1)
        t.evaporate("stop")
        t.evaporate("again")  # a second request is a no-op
        await t.join()

    mrun(main)
    assert log == ["cleanup-start", "cleanup-end"]


def test_shielded_cleanup_survives_evaporation_of_caller(mrun):
    log = []

    async def park():
        await cpl.sleep(1)
        log.append("parked")

    async def worker():
        try:
            await cpl.sleep(100)
        finally:
            await cpl.shielded(park())

    async def main():
        await cpl.pursue(worker(), cpl.sleep(1))

    mrun(main)
    assert log == ["parked"]


def test_shielded_timeout_raises_timeout_error(mrun):
    async def forever():
        await asyncio.sleep(1000)

    async def main():
        with pytest.raises(TimeoutError):
            await cpl.shielded(forever(), timeout=1)
        return True

    assert mrun(main)


def test_evaporate_created_task_never_runs(mrun):
    ran = []

    async def body():
        ran.append(1)

    async def main():
        t = cpl.Task(body(), name="later")
        assert t.state is cpl.Status.CREATED
        t.evaporate("never mind")
        # mypy keeps the narrowing to CREATED across the call that changes the state
        assert t.state is cpl.Status.EVAPORATED  # type: ignore[comparison-overlap]
        assert await t.join() is None

    mrun(main)
    assert ran == []


def test_unstarted_task_evaporated_with_parent(mrun):
    async def body():
        return 1

    async def main():
        return cpl.Task(body(), name="never")

    t = mrun(main)
    assert t.state is cpl.Status.EVAPORATED


def test_foreign_cancelled_error_is_not_swallowed(mrun):
    async def main():
        fut = asyncio.get_running_loop().create_future()
        fut.cancel()
        await fut  # a CancelledError we did not ask for

    with pytest.raises(asyncio.CancelledError):
        mrun(main)


def test_caller_cancellation_evaporates_plan_and_waits():
    log = []

    async def plan():
        try:
            await cpl.sleep(100)
        finally:
            await cpl.shielded(cpl.sleep(1))
            log.append("cleaned")

    async def outside():
        t = asyncio.ensure_future(cpl.top_level(plan, name="cancelled"))
        await asyncio.sleep(0.01)
        t.cancel()
        with pytest.raises(asyncio.CancelledError):
            await t
        tree = cpl.task_tree("cancelled")
        return tree

    loop = asyncio.new_event_loop()
    MockClock().install(loop)
    try:
        tree = loop.run_until_complete(outside())
    finally:
        loop.close()
    assert log == ["cleaned"]
    assert tree.status is cpl.Status.EVAPORATED


def test_evaporated_exception_records_who(mrun):
    seen = []

    async def worker():
        try:
            await cpl.sleep(100)
        except cpl.Evaporated as e:
            seen.append((e.by, e.reason))
            raise

    async def main():
        t = cpl.spawn(worker(), name="w")
        await cpl.sleep(1)
        t.evaporate("because")
        await t.join()

    mrun(main)
    assert seen == [(("test",), "because")]


def test_spawn_outside_task_teaches():
    async def x():
        return 1

    coro = x()
    with pytest.raises(RuntimeError, match=r"cpl\.run"):
        cpl.spawn(coro)
    coro.close()


def test_task_rejects_non_awaitable():
    with pytest.raises(TypeError, match="coroutine"):
        cpl.Task(42)  # type: ignore[arg-type]


def test_status_fluent_tracks_state(mrun):
    async def main():
        t = cpl.spawn(cpl.sleep(1), name="s")
        fl = t.status
        seen: list[cpl.Status] = []
        fl.on_update(seen.append)
        await t.join()
        return seen

    assert mrun(main) == [cpl.Status.RUNNING, cpl.Status.SUCCEEDED]


def test_path_and_call_numbers(mrun):
    @cpl.plan
    async def step(n):
        me = cpl.current_task()
        assert me is not None
        return me.path

    async def main():
        a = await step(1)
        b = await step(2)
        return a, b

    a, b = mrun(main, name="paths")
    assert a == ("paths", "step")
    assert b == ("paths", "step#2")
    tree = cpl.task_tree("paths")
    assert tree is not None
    assert [c.arguments for c in tree.children] == [{"n": "1"}, {"n": "2"}]


def test_plan_bad_arguments_fail_at_call_site():
    @cpl.plan
    async def go(pose):
        return pose

    with pytest.raises(TypeError, match="plan 'go'"):
        go(1, 2)  # type: ignore[call-arg]


def test_plan_requires_async_function():
    with pytest.raises(TypeError, match="async"):
        cpl.plan(lambda: 1)  # type: ignore[arg-type, return-value]


def test_instrument_that_raises_is_removed(mrun, caplog):
    class Bad(cpl.Instrument):
        calls = 0

        def task_status_changed(self, task, old, new):
            Bad.calls += 1
            raise ValueError("instrument bug")

    async def main():
        await cpl.sleep(1)
        return "fine"

    assert cpl.run(main, clock=MockClock(), instruments=[Bad()]) == "fine"
    assert Bad.calls == 1
    assert "removed" in caplog.text


def test_plan_argument_binding_matches_signature_bind():
    import inspect

    async def f(a, b=2, c=3):
        return a

    async def g(a, *rest, key=None, **more):
        return a

    for fn, calls in (
        (f, [((1,), {}), ((1, 5), {}), ((1,), {"c": 9}), ((), {"a": 1, "b": 0})]),
        (g, [((1, 2, 3), {"key": 4}), ((1,), {"x": 5})]),
    ):
        p = cpl.plan(fn)
        for args, kwargs in calls:
            expected = inspect.signature(fn).bind(*args, **kwargs)
            expected.apply_defaults()
            assert p.bind(args, kwargs) == dict(expected.arguments)
    p = cpl.plan(f)
    for bad_args, bad_kwargs in (((), {}), ((1,), {"a": 1}), ((1,), {"zz": 1}), ((1, 2, 3, 4), {})):
        with pytest.raises(TypeError, match="plan 'f'"):
            p.bind(bad_args, bad_kwargs)
