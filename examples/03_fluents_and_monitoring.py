"""A monitor evaporates a running motion when a fluent turns true (CRAM's pursue idiom).

The robot drives towards a shelf while a (simulated) range sensor reports the distance
ahead. ``distance < 0.5`` is a derived fluent; a monitor branch waits for it and wins the
``pursue``, which evaporates the drive. The drive's ``finally`` brakes (a cleanup that
awaits, shielded). A live task tree is shown while it runs (simulated time at 5x).

Run: ``python examples/03_fluents_and_monitoring.py``.
"""

from __future__ import annotations

import asyncio

import cpl
from cpl.display import LiveTaskTree, render_text


def now() -> float:
    return round(asyncio.get_running_loop().time(), 2)


@cpl.plan
async def drive(distance: cpl.Fluent[float], speed: float) -> str:
    try:
        while True:
            await cpl.sleep(0.1)
            distance.value = round(distance.value - speed * 0.1, 3)
    finally:
        await cpl.shielded(brake())


async def brake() -> None:
    await cpl.sleep(0.2)
    print(f"t={now()}: braked")


@cpl.plan
async def monitor(too_close: cpl.Fluent[bool]) -> str:
    await cpl.wait_for(too_close)
    return f"obstacle closer than 0.5 m at t={now()}"


async def main() -> str:
    distance = cpl.Fluent(2.0, name="distance-ahead")
    too_close = distance < 0.5  # a fluent network, recomputed on every change
    root = cpl.current_task()
    assert root is not None
    async with LiveTaskTree(root, refresh_per_second=8):
        result = await cpl.pursue(drive(distance, speed=0.4), monitor(too_close))
    print(f"t={now()}: {result}; distance now {distance.value} m")
    return result


if __name__ == "__main__":
    cpl.run(main, name="monitoring", clock=cpl.ScaledClock(5.0))
    print(render_text(cpl.task_tree("monitoring"), ascii=False, width=110))
