"""Joined children (with_task, plan calls, awaited tags) run inline in the parent's
asyncio task; their semantics are those of a task of their own."""

from __future__ import annotations

import asyncio
from typing import Any

import pytest

import cpl


def test_a_joined_child_runs_in_the_parents_asyncio_task_and_is_a_tree_node(mrun: Any) -> None:
    async def child() -> Any:
        me = cpl.current_task()
        assert me is not None
        return asyncio.current_task(), me.name, me.parent.name if me.parent else None

    async def main() -> Any:
        host, name, parent = await cpl.with_task(child(), name="child")
        return host is asyncio.current_task(), name, parent

    assert mrun(main) == (True, "child", "test")


def test_evaporating_an_inline_child_leaves_the_parent_running(mrun: Any) -> None:
    log: list[str] = []

    async def child() -> None:
        try:
            await cpl.sleep(100)
        finally:
            await cpl.shielded(cpl.sleep(1))
            log.append("child cleanup")

    async def main() -> Any:
        me = cpl.current_task()
        assert me is not None

        async def killer() -> None:
            await cpl.sleep(2)
            (c,) = [t for t in me.children if t.name == "child"]
            c.evaporate("only the child")

        k = cpl.spawn(killer(), name="killer")
        value = await cpl.with_task(child(), name="child")
        await k.join()
        await cpl.sleep(1)  # the parent goes on: its own asyncio task was not cancelled
        log.append("parent continues")
        return value, asyncio.get_running_loop().time()

    assert mrun(main) == (None, 4.0)
    assert log == ["child cleanup", "parent continues"]


def test_evaporating_the_parent_runs_the_inline_childs_cleanup_first(mrun: Any) -> None:
    log: list[str] = []

    async def child() -> None:
        try:
            await cpl.sleep(100)
        finally:
            log.append("child cleanup")

    async def parent() -> None:
        try:
            await cpl.with_task(child(), name="child")
        finally:
            log.append("parent cleanup")

    async def main() -> Any:
        p = cpl.spawn(parent(), name="parent")
        await cpl.sleep(1)
        p.evaporate("stop")
        await p.join()
        (c,) = p.children
        return p.state, c.state

    assert mrun(main) == (cpl.Status.EVAPORATED, cpl.Status.EVAPORATED)
    assert log == ["child cleanup", "parent cleanup"]


def test_both_evaporated_at_once_the_parent_still_dies(mrun: Any) -> None:
    async def child() -> None:
        await cpl.sleep(100)

    async def parent() -> None:
        await cpl.with_task(child(), name="child")
        await cpl.sleep(100)  # must not be reached

    async def main() -> Any:
        p = cpl.spawn(parent(), name="parent")
        await cpl.sleep(1)
        (c,) = p.children
        c.evaporate("child")
        p.evaporate("parent")
        await p.join()
        return p.state, c.state, asyncio.get_running_loop().time()

    assert mrun(main) == (cpl.Status.EVAPORATED, cpl.Status.EVAPORATED, 1.0)


def test_suspending_an_inline_chain_suspends_every_task_of_it(mrun: Any) -> None:
    progress: list[float] = []

    async def inner() -> None:
        for _ in range(6):
            await cpl.sleep(1)
            progress.append(asyncio.get_running_loop().time())

    @cpl.plan
    async def middle() -> None:
        await cpl.with_task(inner(), name="inner")

    async def outer() -> None:
        await middle()

    async def main() -> Any:
        o = cpl.spawn(outer(), name="outer")
        await cpl.sleep(2.5)
        await o.suspend()
        states = [t.state for t in o._subtree()]
        n = len(progress)
        await cpl.sleep(10)
        frozen = len(progress) == n
        o.wake_up()
        await o.join()
        return states, frozen, progress[-1]

    states, frozen, end = mrun(main)
    assert set(states) == {cpl.Status.SUSPENDED}
    assert frozen
    # woken at 12.5 s; the interrupted sleep kept its deadline (3 s, passed): 3 more steps
    assert end == pytest.approx(15.5)


def test_waking_only_the_inner_task_lets_it_finish_but_not_its_suspended_parent(
    mrun: Any,
) -> None:
    log: list[str] = []

    async def inner() -> None:
        await cpl.sleep(2)
        log.append("inner done")

    async def outer() -> None:
        await cpl.with_task(inner(), name="inner")
        log.append("outer goes on")

    async def main() -> Any:
        o = cpl.spawn(outer(), name="outer")
        await cpl.sleep(1)
        await o.suspend()
        (i,) = o.children
        i.wake_up()
        await cpl.sleep(5)
        mid = (list(log), o.state)
        o.wake_up()
        await o.join()
        return mid, log

    mid, log_after = mrun(main)
    assert mid == (["inner done"], cpl.Status.SUSPENDED)
    assert log_after == ["inner done", "outer goes on"]


def test_a_cleanup_that_raises_does_not_replace_the_parents_evaporation(
    mrun: Any, caplog: pytest.LogCaptureFixture
) -> None:
    async def child() -> None:
        try:
            await cpl.sleep(100)
        finally:
            raise KeyError("cleanup broke")

    async def parent() -> None:
        await cpl.with_task(child(), name="child")

    async def main() -> Any:
        p = cpl.spawn(parent(), name="parent")
        await cpl.sleep(1)
        p.evaporate("stop")
        await p.join()
        (c,) = p.children
        return p.state, c.state, type(c.failure).__name__

    with caplog.at_level("ERROR", logger="cpl.cleanup"):
        assert mrun(main) == (cpl.Status.EVAPORATED, cpl.Status.FAILED, "KeyError")
    assert "cleanup broke" in caplog.text
