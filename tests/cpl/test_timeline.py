"""Timelines: virtual time owned by a run inside the loop (projection's clock).

Every test runs on a MockClock (the loop's time jumps when it is idle), so a wait that
used the loop clock instead of the timeline would show up as loop time passing.
"""

from __future__ import annotations

import asyncio
from typing import Any

import pytest

import cpl
from cpl._timeline import BUSY_PATIENCE


def loop_time() -> float:
    return asyncio.get_running_loop().time()


def test_sleep_on_a_timeline_takes_timeline_time_not_loop_time(mrun: Any) -> None:
    async def main() -> tuple[float, float, float]:
        start = loop_time()
        with cpl.on_timeline(cpl.Timeline(start=100.0)) as timeline:
            await cpl.sleep(1000)
            assert cpl.current_time() == timeline.now()
            return timeline.now(), loop_time() - start, cpl.current_time()

    now, loop_elapsed, current = mrun(main)
    assert now == 1100.0 and current == 1100.0
    assert loop_elapsed == 0.0


def test_parallel_sleeps_overlap_and_wake_in_deadline_order(mrun: Any) -> None:
    woke: list[tuple[str, float]] = []

    async def sleeper(name: str, seconds: float) -> None:
        await cpl.sleep(seconds)
        woke.append((name, cpl.current_time()))

    async def main() -> float:
        with cpl.on_timeline(cpl.Timeline()):
            await cpl.par(sleeper("ten", 10), sleeper("five", 5), sleeper("seven", 7))
            return cpl.current_time()

    assert mrun(main) == 10.0
    assert woke == [("five", 5.0), ("seven", 7.0), ("ten", 10.0)]


def test_time_jumps_only_when_nothing_else_is_ready(mrun: Any) -> None:
    seen: list[float] = []

    async def worker() -> None:
        for _ in range(BUSY_PATIENCE // 2):  # busy, but not for long
            await asyncio.sleep(0)
            seen.append(cpl.current_time())

    async def main() -> None:
        with cpl.on_timeline(cpl.Timeline()):
            await cpl.par(cpl.sleep(1), worker())

    mrun(main)
    assert seen and set(seen) == {0.0}  # the sleeper's deadline waited for the worker


def test_a_busy_watcher_does_not_stop_time(mrun: Any) -> None:
    ticks = [0]

    async def watcher() -> None:
        while True:
            ticks[0] += 1
            await cpl.sleep(0)

    async def main() -> float:
        with cpl.on_timeline(cpl.Timeline()):
            await cpl.pursue(watcher(), cpl.sleep(3))
            return cpl.current_time()

    assert mrun(main) == 3.0
    assert ticks[0] >= BUSY_PATIENCE


def test_wait_for_timeout_counts_timeline_seconds(mrun: Any) -> None:
    async def main() -> tuple[Any, float, float]:
        start = loop_time()
        with cpl.on_timeline(cpl.Timeline()):
            value = await cpl.wait_for(cpl.Fluent(False), timeout=2.0)
            return value, cpl.current_time(), loop_time() - start

    assert mrun(main) == (None, 2.0, 0.0)


def test_timeout_policy_counts_timeline_seconds(mrun: Any) -> None:
    async def main() -> tuple[float, float]:
        start = loop_time()
        with cpl.on_timeline(cpl.Timeline()):
            with pytest.raises(cpl.PolicyTimeout):
                await cpl.with_policy(cpl.timeout_policy(5), cpl.sleep(60))
            return cpl.current_time(), loop_time() - start

    assert mrun(main) == (5.0, 0.0)


def test_shielded_timeout_counts_timeline_seconds(mrun: Any) -> None:
    async def main() -> tuple[float, float]:
        start = loop_time()
        with cpl.on_timeline(cpl.Timeline()):
            with pytest.raises(TimeoutError):
                await cpl.shielded(cpl.sleep(60), timeout=4)
            return cpl.current_time(), loop_time() - start

    assert mrun(main) == (4.0, 0.0)


def test_tasks_on_a_timeline_are_stamped_in_its_time(mrun: Any) -> None:
    async def step() -> None:
        await cpl.sleep(3)

    async def main() -> cpl.Task:
        with cpl.on_timeline(cpl.Timeline(start=50.0)):
            await cpl.sleep(2)
            task = cpl.spawn(step(), name="step")
            await task.join()
            return task

    task = mrun(main)
    assert (task.start_time, task.end_time) == (52.0, 55.0)


def test_two_timelines_in_one_loop_keep_their_own_time(mrun: Any) -> None:
    async def run(start: float, seconds: float) -> float:
        with cpl.on_timeline(cpl.Timeline(start=start)):
            await cpl.sleep(seconds)
            return cpl.current_time()

    async def main() -> Any:
        return await cpl.par(run(0.0, 10.0), run(1000.0, 1.0))

    assert mrun(main) == [10.0, 1001.0]


def test_a_timeline_takes_no_loop_time_on_a_real_time_clock() -> None:
    # the demo's loop may run in real time (ScaledClock(1)): an hour of imagined time must
    # pass at once; if it took loop time, the run's 10 s timeout would fail the test
    async def main() -> float:
        with cpl.on_timeline(cpl.Timeline()):
            await cpl.par(cpl.sleep(3600), cpl.wait_for(cpl.Fluent(False), timeout=1800))
            return cpl.current_time()

    assert cpl.run(main, clock=cpl.ScaledClock(1), timeout=10) == 3600.0


def test_outside_a_timeline_cpl_reads_the_loop_clock(mrun: Any) -> None:
    async def main() -> tuple[Any, float, float]:
        start = loop_time()
        await cpl.sleep(7)
        return cpl.current_timeline(), cpl.current_time(), loop_time() - start

    assert mrun(main)[0] is None and mrun(main)[2] == 7.0


def test_bad_timelines_are_refused() -> None:
    with pytest.raises(TypeError, match=r"cpl\.Timeline"):
        with cpl.on_timeline(1.0):  # type: ignore[arg-type]
            pass
    with pytest.raises(ValueError, match="finite"):
        cpl.Timeline(start=float("nan"))


def test_wait_quiescent_returns_after_every_ready_task_ran(mrun: Any) -> None:
    # a reaction that takes several task switches has happened when wait_quiescent returns
    reacted: list[bool] = []

    async def slow_reaction() -> None:
        for _ in range(5):
            await asyncio.sleep(0)
        reacted.append(True)

    async def main() -> list[bool]:
        task = cpl.spawn(slow_reaction(), name="reaction")
        await cpl.wait_quiescent()
        seen = list(reacted)
        await task.join()
        return seen

    assert mrun(main) == [True]


def test_wait_quiescent_runs_before_a_timeline_jumps(mrun: Any) -> None:
    async def main() -> tuple[float, float]:
        with cpl.on_timeline(cpl.Timeline()):
            sleeper = cpl.spawn(cpl.sleep(5), name="sleeper")
            await cpl.wait_quiescent()
            before = cpl.current_time()
            await sleeper.join()
            return before, cpl.current_time()

    assert mrun(main) == (0.0, 5.0)


def test_a_timeline_belongs_to_one_loop() -> None:
    timeline = cpl.Timeline()

    async def sleep_on_it() -> None:
        with cpl.on_timeline(timeline):
            await cpl.sleep(1)

    cpl.run(sleep_on_it)
    with pytest.raises(RuntimeError, match="another event loop"):
        cpl.run(sleep_on_it)
