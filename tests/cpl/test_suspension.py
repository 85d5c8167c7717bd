"""Suspension of tasks and subtrees, on_suspension handlers, with_task_suspended."""

from __future__ import annotations

import asyncio

import cpl


def now():
    return asyncio.get_running_loop().time()


def test_suspend_subtree_and_sleep_keeps_deadline(mrun):
    ends = {}

    async def sleeper(name, t):
        await cpl.sleep(t)
        ends[name] = now()

    async def main():
        worker = cpl.spawn(
            cpl.par(cpl.tag("a", sleeper("a", 5)), cpl.tag("b", sleeper("b", 20))), name="worker"
        )
        await cpl.sleep(1)
        await worker.suspend()
        states = {t.name: t.state for t in _subtree(worker)}
        await cpl.sleep(10)  # a's deadline (t=5) passes while suspended
        assert "a" not in ends
        worker.wake_up()
        await worker.join()
        return states

    states = mrun(main)
    assert states["worker"] is cpl.Status.SUSPENDED
    assert states["a"] is cpl.Status.SUSPENDED and states["b"] is cpl.Status.SUSPENDED
    assert states["par"] is cpl.Status.SUSPENDED
    assert ends["a"] == 11  # woken at t=11, deadline 5 already passed: ends at once
    assert ends["b"] == 20  # original deadline kept


def _subtree(task):
    out = [task]
    for c in task.children:
        out.extend(_subtree(c))
    return out


def test_on_suspension_handlers_run_innermost_first_before_suspended(mrun):
    log = []

    async def worker():
        me = cpl.current_task()
        assert me is not None

        async def outer_handler():
            log.append(("outer", me.state))

        async with cpl.on_suspension(outer_handler):
            async with cpl.on_suspension(lambda: log.append(("inner", me.state))):
                await cpl.sleep(10)
        await cpl.sleep(10)  # handlers no longer active here

    async def main():
        w = cpl.spawn(worker(), name="w")
        await cpl.sleep(1)
        await w.suspend()
        w.wake_up()
        await cpl.sleep(15)
        await w.suspend()
        w.wake_up()
        await w.join()

    mrun(main)
    assert log == [("inner", cpl.Status.RUNNING), ("outer", cpl.Status.RUNNING)]


def test_with_task_suspended_wakes_on_exit_even_on_failure(mrun):
    async def main():
        w = cpl.spawn(cpl.sleep(5), name="w")
        await cpl.sleep(1)
        try:
            async with cpl.with_task_suspended(w):
                assert w.state is cpl.Status.SUSPENDED
                raise cpl.PlanFailure("inside")
        except cpl.PlanFailure:
            pass
        await cpl.sleep(0)  # wake_up is a request; the task resumes when it runs
        assert w.state is cpl.Status.RUNNING
        await w.join()
        return now()

    assert mrun(main) == 5


def test_suspending_dead_task_returns_at_once(mrun):
    async def main():
        w = cpl.spawn(cpl.sleep(1), name="w")
        await w.join()
        async with cpl.with_task_suspended(w):
            pass
        await w.suspend()
        w.wake_up()  # no-op
        return w.state

    assert mrun(main) is cpl.Status.SUCCEEDED


def test_suspended_task_can_be_evaporated(mrun):
    cleaned = []

    async def worker():
        try:
            await cpl.sleep(10)
        finally:
            cleaned.append(True)

    async def main():
        w = cpl.spawn(worker(), name="w")
        await cpl.sleep(1)
        await w.suspend()
        w.evaporate("while suspended")
        await w.join()
        return w

    w = mrun(main)
    assert w.state is cpl.Status.EVAPORATED and cleaned == [True]


def test_task_suspended_before_start_suspends_when_started(mrun):
    ran = []

    async def body():
        ran.append(now())

    async def main():
        t = cpl.Task(body(), name="t")
        t._suspend_requested = True  # as with_task_suspended on an unstarted tag would do
        t.start()
        await cpl.sleep(3)
        assert ran == [] and t.state is cpl.Status.SUSPENDED
        t.wake_up()
        await t.join()

    mrun(main)
    assert ran == [3]


def test_waking_a_running_task_is_a_noop(mrun):
    async def main():
        w = cpl.spawn(cpl.sleep(2), name="w")
        await cpl.sleep(1)
        w.wake_up()
        await w.join()
        return now()

    assert mrun(main) == 2


def test_child_suspends_its_own_parent():
    """A task may suspend an ancestor: it waits for the rest of the subtree, then suspends
    itself too; a waker outside the tree resumes everything."""
    from cpl.testing import MockClock

    log = []

    async def child():
        await cpl.sleep(1)
        me = cpl.current_task()
        assert me is not None
        parent = me.parent
        assert parent is not None

        async def wake():
            await asyncio.sleep(4)  # plain asyncio: not part of the suspended tree
            parent.wake_up()

        waker = asyncio.ensure_future(wake())
        await parent.suspend()
        log.append(("resumed", now()))
        await waker

    async def main():
        c = cpl.spawn(child(), name="c")
        await cpl.sleep(10)
        await c.join()

    loop = asyncio.new_event_loop()
    MockClock().install(loop)
    try:
        loop.run_until_complete(cpl.top_level(main))
    finally:
        loop.close()
    assert log == [("resumed", 5)]
