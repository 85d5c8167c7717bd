"""A process module whose driver blocks, run off the loop (``executive.BlockingProcessModule``).

``SlowBaseDriver`` stands for a vendor SDK: ``drive(x, stop)`` returns only when the base
has arrived (it blocks its thread, stepping every 20 ms) and reports its odometry
through a callback. The process module runs it in a worker thread; the odometry reaches a
fluent on the loop through ``anyio.from_thread.run_sync``, so a monitor on the loop sees
the base move *while* the driver blocks, and wins a ``pursue``. The evaporation asks the
driver to stop (its ``CancelRequest``), waits for it to return, then runs ``on_cancel``
(apply the brakes). The same driver run on the loop would freeze the monitor until the
end of the drive.

Run: ``python examples/08_blocking_driver.py`` (about 1 s of wall time).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import anyio.from_thread

import cpl
import executive
from cpl.display import render_text
from executive import BlockingProcessModule, CancelRequest, Pose, a


class SlowBaseDriver:
    """A blocking driver: moves 0.1 m per 20 ms step of wall time."""

    def __init__(self) -> None:
        self.x = 0.0
        self.braked = False

    def drive(self, goal: float, stop: CancelRequest, odometry: Callable[[float], None]) -> str:
        while self.x < goal - 1e-9:
            if stop.wait(0.02):  # sleeps one step, wakes at once on a cancel request
                return f"stopped at x={self.x:.1f} ({stop.reason})"
            self.x = round(self.x + 0.1, 3)
            odometry(self.x)
        return f"arrived at x={self.x:.1f}"


class BaseModule(BlockingProcessModule):
    """The navigation module of a robot whose base driver blocks."""

    motion_types = frozenset({"going"})

    def __init__(self, driver: SlowBaseDriver, position: cpl.Fluent[float]) -> None:
        super().__init__("navigation")
        self.driver = driver
        self.position = position

    def execute_blocking(self, motion: executive.Designator, cancel: CancelRequest) -> Any:
        goal = motion.reference().arguments["pose"].position[0]

        def odometry(x: float) -> None:  # called in the driver's thread
            anyio.from_thread.run_sync(setattr, self.position, "value", x)

        return self.driver.drive(goal, cancel, odometry)

    async def on_cancel(self, motion: executive.Designator) -> None:
        await cpl.sleep(0.05)  # the brakes take a moment
        self.driver.braked = True


async def main() -> None:
    position = cpl.Fluent(0.0, name="base-x")
    driver = SlowBaseDriver()
    nav = BaseModule(driver, position)
    ticks = 0

    async def ticker() -> None:  # proves the loop is free while the driver blocks
        nonlocal ticks
        while True:
            await cpl.sleep(0.01)
            ticks += 1

    async def drive() -> str:
        return await executive.perform(a.motion(type="going", pose=Pose((5.0, 0.0, 0.0))))

    async def monitor() -> str:
        await cpl.wait_for(cpl.fl_funcall(lambda x: x >= 1.0, position))
        return f"monitor: base at x={position.value:.1f}, stop it"

    async with executive.with_process_modules(nav):
        outcome = await cpl.pursue(drive, monitor, ticker)
    print(outcome)
    print(f"driver stopped short of x=5: {driver.x < 5.0}, braked: {driver.braked}")
    print(f"loop ticks while the driver blocked: {'many' if ticks >= 5 else ticks}")


if __name__ == "__main__":
    cpl.run(main, name="blocking-driver")
    print(render_text(cpl.task_tree("blocking-driver"), ascii=True, show_times=False))
