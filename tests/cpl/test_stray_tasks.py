"""``cpl.lowlevel.stray_asyncio_tasks``: the plain asyncio tasks a run created and left
pending (what the demo's ``no_task_leaked`` invariant checks besides cpl tasks)."""

from __future__ import annotations

import asyncio
from typing import Any

import pytest

import cpl
from cpl.lowlevel import stray_asyncio_tasks
from cpl.testing import MockClock, run_app_guarded


async def _forever() -> None:
    await asyncio.sleep(1000.0)


def test_sees_a_pending_asyncio_task_and_nothing_of_cpl() -> None:
    seen: list[list[str]] = []

    async def plan() -> None:
        cpl.spawn(cpl.sleep(1000.0), name="cpl-child")  # a cpl task: not stray
        await cpl.with_task(cpl.sleep(0.1), name="joined")
        seen.append([t.get_name() for t in stray_asyncio_tasks(_root())])
        loop = asyncio.get_running_loop()
        done = loop.create_task(asyncio.sleep(0), name="finished")
        left = loop.create_task(_forever(), name="left-running")
        await cpl.sleep(0.1)
        assert done.done() and not left.done()
        seen.append([t.get_name() for t in stray_asyncio_tasks(_root())])
        left.cancel()

    cpl.run(plan, clock=MockClock())
    assert seen == [[], ["left-running"]]


def test_tasks_from_before_the_run_are_not_the_runs() -> None:
    seen: list[list[str]] = []

    async def plan() -> None:
        seen.append([t.get_name() for t in stray_asyncio_tasks(_root())])

    async def app() -> None:
        earlier = asyncio.get_running_loop().create_task(_forever(), name="the-app's")
        await cpl.top_level(plan)
        earlier.cancel()

    run_app_guarded(app, clock=MockClock(), wall_timeout=20)
    assert seen == [[]]


def test_a_task_that_is_not_a_runs_root_is_refused() -> None:
    async def main() -> Any:
        with pytest.raises(ValueError, match="not the root of a run"):
            stray_asyncio_tasks(cpl.Task(None, name="loose", _register=False))

    asyncio.run(main())


def _root() -> cpl.Task:
    task = cpl.current_task()
    assert task is not None
    while task.parent is not None:
        task = task.parent
    return task
