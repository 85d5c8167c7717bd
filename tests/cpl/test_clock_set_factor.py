"""ScaledClock.set_factor: the speed changes mid-run (``aiocram demo`` runs its Ctrl-C
cleanup at full speed this way). Hangs are guarded by run_guarded's wall deadline."""

from __future__ import annotations

import asyncio
import math
import threading

import pytest

import cpl
from cpl.testing import run_guarded


def test_a_sleep_at_real_time_ends_at_once_after_switching_to_full_speed() -> None:
    clock = cpl.ScaledClock(1.0)

    async def main() -> float:
        loop = asyncio.get_running_loop()
        start = loop.time()
        # from another thread, as a signal handler's call_soon_threadsafe would
        timer = threading.Timer(0.05, lambda: loop.call_soon_threadsafe(clock.set_factor, None))
        timer.start()
        try:
            await cpl.sleep(3600)  # an hour at real time: only the switch can end it
        finally:
            timer.cancel()
        return loop.time() - start

    elapsed = run_guarded(main, clock=clock, wall_timeout=30)
    assert elapsed >= 3600  # simulated time went on, it was not cut short
    assert clock.factor == math.inf and clock.rate == math.inf


def test_set_factor_keeps_time_and_checks_its_argument() -> None:
    clock = cpl.ScaledClock(None)

    async def main() -> tuple[float, float]:
        await cpl.sleep(10)
        before = cpl.current_clock().now()
        clock.set_factor(1000.0)
        after = cpl.current_clock().now()
        await cpl.sleep(1)
        return before, after

    before, after = run_guarded(main, clock=clock, wall_timeout=30)
    assert before >= 10 and after >= before
    assert clock.factor == 1000.0 and clock.rate == 1000.0
    for bad in (0, -1.0, math.nan):
        with pytest.raises(ValueError, match="factor must be > 0"):
            clock.set_factor(bad)
