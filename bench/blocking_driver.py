"""Benchmark: the event loop's latency while a blocking driver works (not a test).

Run: ``python bench/blocking_driver.py [--rounds N]``

A ticker task on the loop asks to wake every 1 ms (``cpl.sleep(0.001)``) and records how
late each wake-up is. It runs while one motion is performed by

- ``idle``: no driver (the baseline floor of this machine, measured in the same run);
- ``threaded``: a :class:`executive.BlockingProcessModule` whose driver blocks in
  ``time.sleep`` steps (an I/O-like driver that releases the GIL): the framework runs it in
  a worker thread;
- ``on-loop``: the same driver called from a plain ``ProcessModule.execute`` (what a naive
  module does): the loop is blocked for each step;
- ``threaded-cpu``: a driver that computes (holds the GIL) in a worker thread: the loop
  only gets the GIL at the interpreter's switch interval (``sys.getswitchinterval()``), so
  threads help much less here; shown for honesty.

Each driver call takes about 0.3 s of wall time in 20 steps. The configurations are run
interleaved, N times each (default 3), after one uncounted warm-up run of each (the first
``to_thread`` call of a process imports anyio's thread machinery and starts the first worker
thread: a one-off stall of 30-50 ms on this machine); the percentiles are over all wake-ups. Printed
as p50 / p99 / max lateness in ms and as ratios against ``idle`` and ``threaded``.
"""

from __future__ import annotations

import argparse
import sys
import time
from typing import Any

import cpl
from executive import (
    BlockingProcessModule,
    CancelRequest,
    Pose,
    ProcessModule,
    a,
    perform,
    with_process_modules,
)

STEPS = 20
STEP_S = 0.015
PERIOD_S = 0.001


def sleepy_driver() -> str:
    for _ in range(STEPS):
        time.sleep(STEP_S)  # blocks, releases the GIL (I/O, a vendor SDK waiting)
    return "arrived"


def busy_driver() -> str:
    for _ in range(STEPS):
        end = time.perf_counter() + STEP_S
        while time.perf_counter() < end:  # computes, holds the GIL
            pass
    return "arrived"


class Threaded(BlockingProcessModule):
    motion_types = frozenset({"going"})

    def __init__(self, driver: Any) -> None:
        super().__init__("nav")
        self.driver = driver

    def execute_blocking(self, motion: Any, cancel: CancelRequest) -> str:
        result: str = self.driver()
        return result


class OnLoop(ProcessModule):
    motion_types = frozenset({"going"})

    def __init__(self, driver: Any) -> None:
        super().__init__("nav")
        self.driver = driver

    async def execute(self, motion: Any) -> str:
        result: str = self.driver()
        return result


def measure(pm: ProcessModule | None) -> list[float]:
    """Lateness (s) of every 1 ms wake-up of a ticker while ``pm`` performs one motion."""
    lateness: list[float] = []

    done = False
    started = False

    async def ticker() -> None:
        nonlocal started
        while not done:  # the wake-up pending when the work ends is still measured
            started = True
            t0 = time.perf_counter()
            await cpl.sleep(PERIOD_S)
            lateness.append(time.perf_counter() - t0 - PERIOD_S)

    async def work() -> None:
        nonlocal done
        while not started:  # the ticker is asleep before the driver may block the loop
            await cpl.sleep(0)
        try:
            if pm is None:
                await cpl.sleep(STEPS * STEP_S)
                return
            async with with_process_modules(pm):
                await perform(a.motion(type="going", pose=Pose((1.0, 0.0, 0.0))))
        finally:
            done = True

    async def main() -> None:
        await cpl.par(work, ticker)

    cpl.run(main)
    return lateness


def pct(xs: list[float], q: float) -> float:
    xs = sorted(xs)
    return xs[min(len(xs) - 1, int(q * len(xs)))]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--rounds", type=int, default=3, help="runs of each configuration")
    rounds = parser.parse_args().rounds
    if rounds < 1:
        parser.error(f"--rounds must be at least 1, got {rounds}")
    configs = {
        "idle": lambda: None,
        "threaded": lambda: Threaded(sleepy_driver),
        "on-loop": lambda: OnLoop(sleepy_driver),
        "threaded-cpu": lambda: Threaded(busy_driver),
    }
    samples: dict[str, list[float]] = {k: [] for k in configs}
    for make in configs.values():  # warm-up, not counted: imports, the first worker thread
        measure(make())
    for _ in range(rounds):
        for name, make in configs.items():
            samples[name] += measure(make())
    print(
        f"loop latency of a 1 ms ticker while one driver call runs ({STEPS} x "
        f"{STEP_S * 1000:.0f} ms blocking steps), {rounds} rounds, python "
        f"{sys.version.split()[0]}, switch interval {sys.getswitchinterval() * 1000:.0f} ms"
    )
    print(f"{'config':<14} {'wake-ups':>8} {'p50 ms':>8} {'p99 ms':>8} {'max ms':>8}")
    stats: dict[str, tuple[float, float, float]] = {}
    for name, xs in samples.items():
        p50, p99, mx = pct(xs, 0.5) * 1e3, pct(xs, 0.99) * 1e3, max(xs) * 1e3
        stats[name] = (p50, p99, mx)
        print(f"{name:<14} {len(xs):>8} {p50:>8.3f} {p99:>8.3f} {mx:>8.3f}")
    idle, thr, onl = stats["idle"], stats["threaded"], stats["on-loop"]
    print(
        f"ratios: threaded/idle p50 {thr[0] / idle[0]:.2f}x p99 {thr[1] / idle[1]:.2f}x; "
        f"on-loop/threaded p50 {onl[0] / thr[0]:.1f}x p99 {onl[1] / thr[1]:.1f}x; "
        f"wake-ups threaded/on-loop {len(samples['threaded']) / len(samples['on-loop']):.1f}x"
    )


if __name__ == "__main__":
    main()
