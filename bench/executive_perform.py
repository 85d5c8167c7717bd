"""Benchmark: the cost of ``executive.perform`` (not a test; prints numbers).

Run: ``python bench/executive_perform.py [N]`` (N calls per round, default 10 000)

- motion: ``perform(a.motion(type="going", pose=P))`` through a FakeProcessModule (a fresh
  designator each time: construction + resolution + dispatch + one goal task);
- action: ``perform(an.action(type="bench-moving"))`` whose plain async plan performs one
  such motion (two tasks: the plan's and the goal's);
- baselines measured in the same run: a bare ``await`` of an async function doing the same
  dict lookups, an asyncio task spawn + await, one ``cpl.with_task`` of a no-op, and two
  nested ``cpl.with_task`` (the task floor of the action case);
- action retiring: the action case in top levels with the long-running retention policy
  (``cpl.KeepRecent(0, records=10_000, freeze=True)``: each finished action retired at
  once, as a robot's executive running all day would; see ``bench/soak.py``);
- flatness: the mean cost of the last 100 of 10k motion performs against the first 100, in
  one long top level whose task tree keeps growing.

Each measurement runs in its own top level (``cpl.run``) so that one case's task tree does
not tax the next one's garbage collection. Per case it prints the **median** call (what a
call costs when no collection lands in it) and the **mean** over the N calls with the
cyclic garbage collector enabled (what N calls cost in total, collections included), and
the number and total time of the **gen-2 (full) collections** that ran during the timed
calls (summed over the 5 rounds).
"""

from __future__ import annotations

import asyncio
import gc
import statistics
import sys
import time
from collections.abc import Awaitable, Callable, Iterator
from dataclasses import dataclass
from typing import Any

import cpl
from executive import Pose, RuleSet, a, an, environment, perform
from executive.testing import FakeProcessModule

P = Pose((1.0, 2.0, 0.0))
TARGET_US = 25.0  # issue 17: mean of an action performing one motion, GC included
TARGET_MOTION_US = 12.0  # issue 17: a motion
TABLE = {("motion", "going"): 1}
LONG_RUNNING = "action retiring"  # perform action under KeepRecent(0, records=10_000)


async def moved() -> None:
    await perform(a.motion(type="going", pose=P))


async def moving_plan() -> None:
    await perform(a.motion(type="going", pose=P))


def moving_rule(d: Any) -> Iterator[Any]:
    yield moving_plan, {}


async def acted() -> None:
    await perform(an.action(type="bench-moving"))


async def bare() -> int:  # the dict lookups of a rule lookup, no task
    return TABLE[("motion", "going")] + TABLE.get(("motion", "x"), 0)


async def nothing() -> None:
    return None


async def asyncio_task() -> None:
    await asyncio.get_running_loop().create_task(nothing())


async def cpl_task() -> None:
    await cpl.with_task(nothing(), name="noop")


async def _inner() -> None:
    await cpl.with_task(nothing(), name="noop")


async def cpl_nested() -> None:
    await cpl.with_task(_inner(), name="outer")


CASES: dict[str, Callable[[], Awaitable[Any]]] = {
    "bare await": bare,
    "asyncio task": asyncio_task,
    "cpl.with_task": cpl_task,
    "2 nested tasks": cpl_nested,
    "perform motion": moved,
    "perform action": acted,
}


@dataclass
class Figure:
    """One case: medians over the rounds of the per-round median and mean (µs per call),
    and the gen-2 collections (count, total ms) during the timed calls of all rounds."""

    median: float
    mean: float
    full_collections: int
    full_ms: float


class _FullCollections:
    """Counts gen-2 collections (and their time) while active, via ``gc.callbacks``."""

    def __init__(self) -> None:
        self.count = 0
        self.seconds = 0.0
        self._start = 0.0
        self.active = False

    def __call__(self, phase: str, info: dict[str, int]) -> None:
        if not self.active or info["generation"] != 2:
            return
        if phase == "start":
            self._start = time.perf_counter()
        else:
            self.count += 1
            self.seconds += time.perf_counter() - self._start


def measure(
    fn: Callable[[], Awaitable[Any]],
    n: int,
    rounds: int = 5,
    retention: cpl.Retention | None = None,
) -> Figure:
    """Over ``rounds`` rounds (each a fresh top level) of n calls: the median call and the
    mean per call (garbage collection included), and the full collections seen."""
    full = _FullCollections()
    gc.callbacks.append(full)

    async def main() -> tuple[float, float]:
        rules = RuleSet()
        rules.register("action", "bench-moving", moving_rule)
        async with environment(rules=rules, process_modules=[FakeProcessModule("nav")]):
            for _ in range(100):  # warm-up
                await fn()
            samples = [0] * n
            clock = time.perf_counter_ns
            full.active = True
            t0 = clock()
            for i in range(n):
                t = clock()
                await fn()
                samples[i] = clock() - t
            total = clock() - t0
            full.active = False
            samples.sort()
            return samples[n // 2] / 1e3, total / n / 1e3

    try:
        runs = [cpl.run(main, name="bench", retention=retention) for _ in range(rounds)]
    finally:
        gc.callbacks.remove(full)
    return Figure(
        statistics.median(m for m, _ in runs),
        statistics.median(m for _, m in runs),
        full.count,
        full.seconds * 1e3,
    )


def flatness(total: int) -> tuple[float, float]:
    async def main() -> tuple[float, float]:
        async with environment(process_modules=[FakeProcessModule("nav")]):
            times = []
            for _ in range(total):
                t0 = time.perf_counter()
                await moved()
                times.append(time.perf_counter() - t0)
        return statistics.mean(times[:100]) * 1e6, statistics.mean(times[-100:]) * 1e6

    return cpl.run(main, name="bench-flatness")  # type: ignore[no-any-return]


def run() -> None:
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 10_000
    flat_n = 10_000
    figures = {name: measure(fn, n) for name, fn in CASES.items()}
    # the same action performs in a top level with the long-running retention policy
    # (each finished action retired at once: the tree, and the collector's work, stay
    # flat), as a robot's executive that runs all day would use (see bench/soak.py)
    figures[LONG_RUNNING] = measure(
        acted, n, retention=cpl.KeepRecent(0, records=10_000, freeze=True)
    )
    results = {name: f.mean for name, f in figures.items()}
    flatness(200)  # warm-up top level: one-time costs stay out of the first 100
    gc.collect()
    first, last = flatness(flat_n)
    base = figures["asyncio task"]
    print(
        f"executive.perform benchmark (n={n} calls per top level, medians of 5 top levels, "
        "µs per call; mean = total / n with garbage collection included; gen-2 = full "
        "collections during the timed calls of all 5 rounds)"
    )
    for name, f in figures.items():
        print(
            f"  {name:<15} median {f.median:8.2f} µs  mean {f.mean:8.2f} µs"
            f"  (mean x{f.mean / base.mean:5.1f} asyncio task,"
            f" x{f.mean / figures['bare await'].mean:6.0f} bare await)"
            f"  gen-2: {f.full_collections} ({f.full_ms:.1f} ms)"
        )
    print(
        f"  executive overhead (means): motion "
        f"{results['perform motion'] - results['cpl.with_task']:.1f}"
        f" µs over one cpl task, action "
        f"{results['perform action'] - results['2 nested tasks']:.1f} µs over two"
    )
    for name, target in (
        ("perform motion", TARGET_MOTION_US),
        ("perform action", TARGET_US),
        (LONG_RUNNING, TARGET_US),
    ):
        verdict = "OK" if results[name] <= target else "OVER"
        print(f"  target {name}: mean <= {target:.0f} µs -> {verdict}")
    print(
        f"flatness over {flat_n} motion performs in one top level: first 100 "
        f"{first:.2f} µs, last 100 {last:.2f} µs, ratio {last / first:.2f}"
    )


if __name__ == "__main__":
    run()
