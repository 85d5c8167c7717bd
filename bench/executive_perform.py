"""Benchmark: the cost of ``executive.perform`` (not a test; prints numbers).

Run: ``python bench/executive_perform.py [N]``

- motion: ``perform(a.motion(type="going", pose=P))`` through a FakeProcessModule (a fresh
  designator each time: construction + resolution + dispatch + one goal task);
- action: ``perform(an.action(type="bench-moving"))`` whose plain async plan performs one
  such motion (two tasks: the plan's and the goal's);
- baselines measured in the same run: a bare ``await`` of an async function doing the same
  dict lookups, an asyncio task spawn + await, one ``cpl.with_task`` of a no-op, and two
  nested ``cpl.with_task`` (the task floor of the action case);
- flatness: the mean cost of the last 100 of 10k motion performs against the first 100, in
  one long top level whose task tree keeps growing.

Each measurement runs in its own top level (``cpl.run``) so that one case's task tree does
not tax the next one's garbage collection.
"""

from __future__ import annotations

import asyncio
import gc
import statistics
import sys
import time
from collections.abc import Awaitable, Callable, Iterator
from typing import Any

import cpl
from executive import Pose, RuleSet, a, an, environment, perform
from executive.testing import FakeProcessModule

P = Pose((1.0, 2.0, 0.0))
TARGET_US = 50.0
TABLE = {("motion", "going"): 1}


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


def measure(fn: Callable[[], Awaitable[Any]], n: int) -> float:
    """Median over 5 rounds (each a fresh top level) of the mean µs per call over n calls."""

    async def main() -> float:
        rules = RuleSet()
        rules.register("action", "bench-moving", moving_rule)
        async with environment(rules=rules, process_modules=[FakeProcessModule("nav")]):
            for _ in range(100):  # warm-up
                await fn()
            t0 = time.perf_counter()
            for _ in range(n):
                await fn()
            return (time.perf_counter() - t0) / n * 1e6

    return statistics.median(cpl.run(main, name="bench") for _ in range(5))


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
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 2000
    flat_n = 10_000
    results = {name: measure(fn, n) for name, fn in CASES.items()}
    flatness(200)  # warm-up top level: one-time costs stay out of the first 100
    gc.collect()
    first, last = flatness(flat_n)
    base = results["asyncio task"]
    print(f"executive.perform benchmark (n={n}, median of 5 top levels, µs per call)")
    for name, us in results.items():
        print(
            f"  {name:<15} {us:8.2f} µs   x{us / base:5.1f} asyncio task"
            f"   x{us / results['bare await']:6.0f} bare await"
        )
    print(
        f"  executive overhead: motion {results['perform motion'] - results['cpl.with_task']:.1f}"
        f" µs over one cpl task, action "
        f"{results['perform action'] - results['2 nested tasks']:.1f} µs over two"
    )
    for name in ("perform motion", "perform action"):
        verdict = "OK" if results[name] <= TARGET_US else "OVER"
        print(f"  target {name}: <= {TARGET_US:.0f} µs -> {verdict}")
    print(
        f"flatness over {flat_n} motion performs in one top level: first 100 "
        f"{first:.2f} µs, last 100 {last:.2f} µs, ratio {last / first:.2f}"
    )


if __name__ == "__main__":
    run()
