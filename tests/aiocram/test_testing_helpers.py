"""aiocram.testing's helpers: the hang guards stop what they guard, the checker and the
tree assertions fail when they should."""

from __future__ import annotations

import asyncio
import threading
import time
from typing import Any

import pytest

import cpl
from aiocram.testing import as_tree, assert_attempts, assert_retried, find_nodes
from cpl.testing import (
    HangDetected,
    MockClock,
    TransitionChecker,
    call_guarded,
    run_app_guarded,
)


def guarded_threads() -> list[threading.Thread]:
    return [t for t in threading.enumerate() if t.name == "cpl-run-guarded" and t.is_alive()]


def test_run_guarded_returns_the_value_and_reraises_the_failure() -> None:
    async def ok(x: int) -> int:
        await asyncio.sleep(100)  # virtual time: instant
        return x * 2

    async def bad() -> None:
        raise KeyError("boom")

    assert run_app_guarded(ok, 21, clock=MockClock()) == 42
    with pytest.raises(KeyError, match="boom"):
        run_app_guarded(bad)


def test_run_guarded_stops_a_livelocked_loop_and_its_thread() -> None:
    """A loop that never goes idle (the issue-18 shape: a cancellation caught and waited
    on again forever) is stopped from outside; the guard returns, the thread ends."""
    before = len(guarded_threads())

    async def spin() -> None:
        while True:
            try:
                await asyncio.sleep(0)
            except asyncio.CancelledError:
                continue  # swallows every cancellation: asyncio.Runner would hang here

    async def plan() -> None:
        await cpl.top_level(cpl.par(cpl.tag("spinner", spin()), cpl.sleep(5)), name="spin")

    with pytest.raises(HangDetected) as info:
        run_app_guarded(plan, clock=MockClock(), wall_timeout=0.5)
    assert "did not end within 0.5 s" in str(info.value)
    assert "spinner" in info.value.tree  # the task tree at the deadline
    for _ in range(100):  # bounded: the stopped thread ends promptly
        if len(guarded_threads()) <= before:
            break
        time.sleep(0.02)
    assert len(guarded_threads()) <= before


def test_run_guarded_bounds_a_stuck_shutdown() -> None:
    """The main coroutine returns, but a leftover task ignores cancellation: the loop's
    shutdown (where asyncio.Runner hangs) is under the same deadline."""

    async def stubborn() -> None:
        while True:
            try:
                await asyncio.sleep(0.001)
            except asyncio.CancelledError:
                continue

    async def main() -> str:
        asyncio.get_running_loop().create_task(stubborn())
        return "returned"

    with pytest.raises(HangDetected):
        run_app_guarded(main, wall_timeout=0.5)


def test_run_guarded_rejects_bad_arguments() -> None:
    with pytest.raises(TypeError, match="async callable"):
        run_app_guarded("not callable")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="positive"):
        run_app_guarded(asyncio.sleep, 0, wall_timeout=0)


def test_call_guarded() -> None:
    assert call_guarded(sum, [1, 2, 3]) == 6
    release = threading.Event()
    with pytest.raises(HangDetected, match=r"did not return within 0\.2 s"):
        call_guarded(release.wait, 10.0, wall_timeout=0.2)
    release.set()


def test_checker_reports_alive_tasks_and_illegal_transitions() -> None:
    checker = TransitionChecker()

    async def main() -> None:
        cpl.spawn(cpl.sleep(1), "child")

    cpl.run(main, instruments=[checker], clock=MockClock())
    assert checker.problems() == []
    checker.assert_clean()
    assert {path for path, _, _ in checker.transitions} == {("main",), ("main", "child")}

    class Ghost:
        path = ("x", "ghost")
        alive = True
        state = cpl.Status.RUNNING
        waiting_on = "nothing"

    ghost: Any = Ghost()
    checker.tasks.append(ghost)
    checker.task_status_changed(ghost, cpl.Status.EVAPORATED, cpl.Status.RUNNING)
    assert checker.problems() == [
        "illegal status transition EVAPORATED -> RUNNING of task x/ghost",
        "task left alive: x/ghost (RUNNING, nothing)",
    ]
    with pytest.raises(AssertionError, match="cpl run checker"):
        checker.assert_clean()
    assert checker.forget_alive() == [ghost] and checker.alive() == []


def run_retries(name: str, failures: int) -> cpl.TaskNode:
    calls = 0

    async def step() -> str:
        nonlocal calls
        calls += 1
        if calls <= failures:
            raise cpl.PlanFailure(f"attempt {calls}")
        return "ok"

    async def main() -> Any:
        return await cpl.with_retry(lambda: cpl.tag("step", step()), on=cpl.PlanFailure, counter=5)

    cpl.run(main, name=name, clock=MockClock())
    tree = cpl.task_tree(name)
    assert tree is not None
    return tree


def test_tree_assertions_pass_and_fail_with_the_tree() -> None:
    tree = run_retries("retries-test", 2)
    assert [n.path[-1] for n in find_nodes(tree, "step")] == ["step", "step#2", "step#3"]
    attempts = assert_retried(tree, "step", 2)
    assert [a.status for a in attempts][-1] is cpl.Status.SUCCEEDED
    assert_retried("retries-test", "step", 2, under="retries-test")
    assert_attempts(tree, "step", [cpl.Status.FAILED, "failed", "SUCCEEDED"])
    with pytest.raises(AssertionError, match=r"found \[\['FAILED', 'FAILED', 'SUCCEEDED'\]\]"):
        assert_retried(tree, "step", 1)
    with pytest.raises(AssertionError, match="no call at all"):
        assert_retried(tree, "nothing", 0)
    with pytest.raises(AssertionError, match="no task called 'elsewhere'"):
        assert_retried(tree, "step", 2, under="elsewhere")
    with pytest.raises(LookupError, match="no top level named 'never-ran'"):
        as_tree("never-ran")
    with pytest.raises(ValueError, match="times"):
        assert_retried(tree, "step", -1)
    with pytest.raises(ValueError, match="unknown task status 'succeded'; use one of created"):
        assert_retried(tree, "step", 2, then="succeded")
