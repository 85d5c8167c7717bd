"""Blocking drivers off the loop: BlockingProcessModule runs its work in a worker thread;
the loop stays responsive; evaporation reaches the driver; on_cancel runs.

Responsiveness is shown by order and counts, never by wall time: the driver blocks until a
task on the loop has seen the driver's progress, which can only happen if the loop runs
while the driver blocks (the on-loop control case shows it does not happen there).
Every run goes through ``cpl_run`` (a worker thread with a deadline), on the system clock:
a driver thread's time is wall time.
"""

from __future__ import annotations

import logging
import threading
from typing import Any

import anyio.from_thread
import pytest

import cpl
from executive import (
    BlockingProcessModule,
    CancelRequest,
    NavigationPoseUnreachable,
    PMStatus,
    Pose,
    ProcessModule,
    ProcessModuleGoalEvaporated,
    a,
    perform,
    with_process_modules,
)

SYSTEM = cpl.SystemClock


def going(x: float = 1.0) -> Any:
    return a.motion(type="going", pose=Pose((x, 0.0, 0.0)))


class Driver:
    """A blocking driver that reports progress and waits for a release or a stop."""

    def __init__(self, log: list[str], patience: float = 5.0) -> None:
        self.log = log
        self.release = threading.Event()
        self.patience = patience  # wall seconds to wait for the release (bounds a test)

    def run(self, progress: Any, stop: CancelRequest | None, steps: int = 3) -> str:
        self.log.append("driver started")
        for k in range(1, steps + 1):
            progress(k)
        released = (
            self.release.wait(self.patience) if stop is None else _wait_either(self.release, stop)
        )
        if stop is not None and stop.requested:
            self.log.append(f"driver saw cancel: {stop.reason}")
            return "stopped"
        self.log.append("driver released" if released else "driver not released")
        return "done"


def _wait_either(release: threading.Event, stop: CancelRequest) -> bool:
    for _ in range(500):  # at most 5 s: a test never hangs on a driver
        if release.wait(0.01) or stop.requested:
            return release.is_set()
    return False


class ThreadedNav(BlockingProcessModule):
    motion_types = frozenset({"going"})

    def __init__(self, driver: Driver, progress: cpl.Fluent[int], name: str = "nav") -> None:
        super().__init__(name)
        self.driver = driver
        self.progress = progress
        self.cancelled: list[str] = []

    def execute_blocking(self, motion: Any, cancel: CancelRequest) -> str:
        def report(k: int) -> None:
            anyio.from_thread.run_sync(setattr, self.progress, "value", k)

        result = self.driver.run(report, cancel)
        self.driver.log.append("driver returned")
        return result

    async def on_cancel(self, motion: Any) -> None:
        self.driver.log.append("on_cancel")
        await cpl.sleep(0.01)
        self.cancelled.append(motion.type)


class OnLoopNav(ProcessModule):
    """The same driver called on the loop (what a naive module does)."""

    motion_types = frozenset({"going"})

    def __init__(self, driver: Driver, progress: cpl.Fluent[int]) -> None:
        super().__init__("nav")
        self.driver = driver
        self.progress = progress

    async def execute(self, motion: Any) -> str:
        def report(k: int) -> None:
            self.progress.value = k  # on the loop thread already

        result = self.driver.run(report, None, steps=3)
        self.driver.log.append("driver returned")
        return result


def watcher_plan(driver: Driver, progress: cpl.Fluent[int], nav: ProcessModule) -> Any:
    """A fluent-watching task counts the driver's progress pulses and releases the driver
    once it has seen all three."""

    async def watch() -> int:
        seen = 0
        async for _ in cpl.whenever(cpl.pulsed(progress, handle_missed="always")):
            seen += 1
            driver.log.append(f"watcher saw pulse {seen}")
            if seen == 3:
                driver.log.append("watcher releases the driver")
                driver.release.set()
                return seen
        raise AssertionError("unreachable")

    async def main() -> Any:
        async with with_process_modules(nav):
            return await cpl.pursue(cpl.par(perform(going()), watch()), cpl.sleep(2.0))

    return main


def test_the_loop_runs_while_a_blocking_driver_works(cpl_run: Any) -> None:
    log: list[str] = []
    driver = Driver(log)
    progress = cpl.Fluent(0, name="progress")
    nav = ThreadedNav(driver, progress)
    assert nav.blocking is True

    assert cpl_run(watcher_plan(driver, progress, nav), clock=SYSTEM()) == ["done", 3]
    assert log == [
        "driver started",
        "watcher saw pulse 1",
        "watcher saw pulse 2",
        "watcher saw pulse 3",
        "watcher releases the driver",
        "driver released",
        "driver returned",
    ]
    assert nav.status.value is PMStatus.OFFLINE  # the block was left


def test_control_the_same_driver_on_the_loop_starves_the_watcher(cpl_run: Any) -> None:
    """The control case: called on the loop, the driver blocks everything; the watcher
    sees nothing until the driver gave up waiting (so the threaded test is meaningful)."""
    log: list[str] = []
    driver = Driver(log, patience=0.3)
    progress = cpl.Fluent(0, name="progress")
    nav = OnLoopNav(driver, progress)
    assert nav.blocking is False

    cpl_run(watcher_plan(driver, progress, nav), clock=SYSTEM())
    assert log[:3] == ["driver started", "driver not released", "driver returned"]


def evaporating_plan(nav: ThreadedNav, started: cpl.Fluent[int], outcome: list[Any]) -> Any:
    async def main() -> Any:
        async with with_process_modules(nav):

            async def drive() -> None:
                try:
                    outcome.append(await perform(going()))
                except ProcessModuleGoalEvaporated as f:
                    outcome.append(f)

            async def evaporate_goal_once_started() -> None:
                await cpl.wait_for(started)
                me = cpl.current_task()
                assert me is not None and me.parent is not None
                (goal,) = [t for t in cpl.walk(me.parent) if t.name == "nav"]
                goal.evaporate("operator pressed stop")

            await cpl.par(drive, evaporate_goal_once_started)
            return nav.status.value

    return main


def test_evaporation_reaches_the_driver_then_on_cancel_runs(cpl_run: Any) -> None:
    log: list[str] = []
    driver = Driver(log)
    progress = cpl.Fluent(0, name="progress")
    nav = ThreadedNav(driver, progress)
    outcome: list[Any] = []

    status = cpl_run(evaporating_plan(nav, progress, outcome), clock=SYSTEM())
    assert log == [
        "driver started",
        "driver saw cancel: operator pressed stop",
        "driver returned",  # the driver call ended before on_cancel started
        "on_cancel",
    ]
    assert nav.cancelled == ["going"]
    assert len(outcome) == 1 and isinstance(outcome[0], ProcessModuleGoalEvaporated)
    assert "operator pressed stop" in str(outcome[0])
    assert status is PMStatus.IDLE
    assert not driver.release.is_set()  # nobody released it: the cancel request did


def test_cancel_request_callbacks_run_on_the_loop_thread_at_the_request(cpl_run: Any) -> None:
    log: list[str] = []
    driver = Driver(log)
    progress = cpl.Fluent(0, name="progress")
    loop_thread: list[threading.Thread] = []

    class Hooked(ThreadedNav):
        def execute_blocking(self, motion: Any, cancel: CancelRequest) -> str:
            cancel.add_callback(
                lambda req: log.append(
                    f"hook: {req.reason} on "
                    + ("loop" if threading.current_thread() is loop_thread[0] else "other")
                )
            )
            return super().execute_blocking(motion, cancel)

    nav = Hooked(driver, progress)

    async def main() -> Any:
        loop_thread.append(threading.current_thread())
        return await evaporating_plan(nav, progress, [])()

    cpl_run(main, clock=SYSTEM())
    assert log[:2] == ["driver started", "hook: operator pressed stop on loop"]
    assert log[-1] == "on_cancel"

    late = CancelRequest()
    late._set("already")
    late.add_callback(lambda req: log.append(f"late hook: {req.reason}"))
    assert log[-1] == "late hook: already" and late.requested and late.wait(0)
    with pytest.raises(TypeError, match="add_callback"):
        late.add_callback("stop the base")  # type: ignore[arg-type]


def test_a_driver_that_ignores_the_request_is_abandoned_and_on_cancel_still_runs(
    cpl_run: Any, caplog: pytest.LogCaptureFixture
) -> None:
    log: list[str] = []
    progress = cpl.Fluent(0, name="progress")
    release = threading.Event()

    class Deaf(BlockingProcessModule):
        motion_types = frozenset({"going"})
        cancel_timeout = 0.2

        def execute_blocking(self, motion: Any, cancel: CancelRequest) -> str:
            anyio.from_thread.run_sync(setattr, progress, "value", 1)
            release.wait(10.0)  # ignores ``cancel``
            log.append("deaf driver returned")
            return "late"

        async def on_cancel(self, motion: Any) -> None:
            log.append("on_cancel")

    nav = Deaf("nav")
    outcome: list[Any] = []
    with caplog.at_level(logging.WARNING, logger="executive.process_modules"):
        cpl_run(evaporating_plan(nav, progress, outcome), clock=SYSTEM())  # type: ignore[arg-type]
    assert log == ["on_cancel"]
    assert isinstance(outcome[0], ProcessModuleGoalEvaporated)
    assert any("abandoned in its worker thread" in r.getMessage() for r in caplog.records)
    release.set()  # let the abandoned thread end


def test_driver_result_and_failure_cross_the_thread(cpl_run: Any) -> None:
    calls: list[str] = []

    class Nav(BlockingProcessModule):
        motion_types = frozenset({"going"})

        def execute_blocking(self, motion: Any, cancel: CancelRequest) -> Any:
            x = motion.reference().arguments["pose"].position[0]
            calls.append(threading.current_thread().name)
            if x < 0:
                raise NavigationPoseUnreachable(pose=motion.reference().arguments["pose"])
            return x * 2

    nav = Nav("nav")

    async def main() -> Any:
        async with with_process_modules(nav):
            ok = await perform(going(1.5))
            with pytest.raises(NavigationPoseUnreachable):
                await perform(going(-1.0))
            return ok, nav.status.value

    assert cpl_run(main, clock=SYSTEM()) == (3.0, PMStatus.FAILED)
    assert len(calls) == 2
    assert all(name != threading.main_thread().name for name in calls)


def test_a_goal_evaporated_while_queued_never_reaches_the_driver(cpl_run: Any) -> None:
    log: list[str] = []
    driver = Driver(log)
    progress = cpl.Fluent(0, name="progress")
    nav = ThreadedNav(driver, progress)

    async def main() -> Any:
        async with with_process_modules(nav):
            first = cpl.spawn(perform(going(1.0)), "first")
            second = cpl.spawn(perform(going(2.0)), "second")
            await cpl.wait_for(progress)  # the first goal's driver is running
            second.evaporate("not needed")
            await second.join()
            driver.release.set()
            return await first.join(), second.state

    assert cpl_run(main, clock=SYSTEM()) == ("done", cpl.Status.EVAPORATED)
    assert log.count("driver started") == 1


def test_example_08_runs_and_the_monitor_stops_the_blocking_driver() -> None:
    """examples/08_blocking_driver.py, as a user runs it (own process, time-out)."""
    import os
    import re
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(root), *sys.path])}
    proc = subprocess.run(
        [sys.executable, "-W", "error", str(root / "examples" / "08_blocking_driver.py")],
        capture_output=True,
        text=True,
        timeout=60,
        env=env,
    )
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert re.fullmatch(r"monitor: base at x=1\.\d, stop it", lines[0]), lines
    assert lines[1:3] == [
        "driver stopped short of x=5: True, braked: True",
        "loop ticks while the driver blocked: many",
    ]
    assert "~ navigation - evaporated" in proc.stdout


def test_the_live_view_keeps_drawing_while_a_blocking_driver_works(cpl_run: Any) -> None:
    """The live task-tree view redraws from the loop: it shows the running goal while the
    driver blocks in its thread (the driver is released only after three such frames)."""
    import io

    from rich.console import Console

    from cpl.display import LiveTaskTree

    log: list[str] = []
    driver = Driver(log)

    class CountingView(LiveTaskTree):
        def __init__(self, root: cpl.Task) -> None:
            console = Console(file=io.StringIO(), width=100)
            super().__init__(root, refresh_per_second=200, console=console, ascii=True)
            self.root = root
            self.frames_with_goal = 0

        def refresh(self, *, final: bool = False) -> None:
            super().refresh(final=final)
            if any(t.name == "nav" and t.state is cpl.Status.RUNNING for t in cpl.walk(self.root)):
                self.frames_with_goal += 1

    class Nav(ThreadedNav):
        def execute_blocking(self, motion: Any, cancel: CancelRequest) -> str:
            result = self.driver.run(lambda k: None, cancel, steps=0)
            self.driver.log.append("driver returned")
            return result

    nav = Nav(driver, cpl.Fluent(0, name="progress"))

    async def main() -> Any:
        root = cpl.current_task()
        assert root is not None
        view = CountingView(root)
        async with view, with_process_modules(nav):

            async def release_after_three_frames() -> None:
                while view.frames_with_goal < 3:
                    await cpl.sleep(0.005)
                log.append("the view drew the running goal 3 times")
                driver.release.set()

            return await cpl.par(perform(going()), release_after_three_frames())

    assert cpl_run(main, clock=SYSTEM()) == ["done", None]
    assert log == [
        "driver started",
        "the view drew the running goal 3 times",
        "driver released",
        "driver returned",
    ]
