"""The typed mark of a reasoning subtree (``cpl.Subtree``): on the live task, in its
snapshot, in the event log and back through ``tree_from_log`` (what ``aiocram show``
reads), independent of the subtree's name."""

from __future__ import annotations

import asyncio
from pathlib import Path

import pytest

import cpl
from cpl._eventlog import load_events


async def _plan() -> None:
    async def step() -> int:
        await cpl.sleep(0)
        return 1

    await cpl.tag("dream", step(), subtree=cpl.Subtree.IMAGINED)
    await cpl.tag("for-real", step(), subtree=cpl.Subtree.REAL)
    await cpl.tag("plain", step())


def test_the_mark_is_on_the_live_task_and_its_snapshot() -> None:
    async def main() -> None:
        async def top() -> None:
            await _plan()
            me = cpl.current_task()
            assert me is not None
            marks = {c.name: c.subtree for c in me.children}
            assert marks == {
                "dream": cpl.Subtree.IMAGINED,
                "for-real": cpl.Subtree.REAL,
                "plain": None,
            }
            tree = cpl.snapshot(me)
            assert {c.name: c.subtree for c in tree.children} == marks
            assert cpl.within(me.children[0], cpl.Subtree.IMAGINED)
            assert not cpl.within(me.children[1], cpl.Subtree.IMAGINED)

        async with asyncio.timeout(10):
            await cpl.top_level(top(), name="root")

    asyncio.run(main())


def test_the_mark_round_trips_through_the_event_log(tmp_path: Path) -> None:
    path = tmp_path / "log.jsonl"

    async def main() -> cpl.TaskNode:
        async def top() -> cpl.TaskNode:
            await _plan()
            me = cpl.current_task()
            assert me is not None
            return cpl.snapshot(me)

        async with asyncio.timeout(10):
            return await cpl.top_level(top(), name="root", instruments=[cpl.EventLog(path)])

    live = asyncio.run(main())
    events = load_events(path)
    started = {e["name"]: e for e in events if e["event"] == "task-started"}
    assert started["dream"]["subtree"] == "imagined"
    assert "subtree" not in started["plain"]  # an ordinary task's line is unchanged
    rebuilt = cpl.tree_from_log(path)
    assert {c.name: c.subtree for c in rebuilt.children} == {
        c.name: c.subtree for c in live.children
    }
    assert cpl.TaskNode.from_dict(rebuilt.to_dict()) == rebuilt
    assert rebuilt.find("dream").subtree is cpl.Subtree.IMAGINED  # type: ignore[union-attr]


def test_a_mark_that_is_not_a_subtree_is_refused_before_anything_runs() -> None:
    async def never() -> None:
        raise AssertionError("ran")

    coro = never()
    with pytest.raises(TypeError, match=r"cpl\.Subtree"):
        cpl.tag("x", coro, subtree="imagined")  # type: ignore[arg-type]
    coro.close()
    with pytest.raises(ValueError, match="'imagined'"):
        cpl.Subtree.parse("dreamt")
