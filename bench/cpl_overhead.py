"""cpl overhead against raw asyncio, measured in the same run (ratios, not absolutes).

- time per child of ``cpl.par`` / ``cpl.pursue`` / ``cpl.try_all`` over N trivial children
  against ``asyncio.TaskGroup`` with the same N;
- memory per live task: N children blocked at once (tracemalloc peak / N), cpl vs asyncio;
- ``wait_for`` wake-up latency (set -> all K waiters running) against ``asyncio.Event``.

Run: ``python bench/cpl_overhead.py [--sizes 1000 10000 100000] [--repeat 5] [--json PATH]``.
Targets (issue 2/3): par ratio <= 2 at N = 10k; 100k live tasks within 3 KB each.
"""

from __future__ import annotations

import argparse
import asyncio
import gc
import json
import statistics
import sys
import time
import tracemalloc
from collections.abc import Callable, Coroutine
from typing import Any

import cpl


async def _trivial() -> int:
    return 1


async def _taskgroup(n: int) -> None:
    async with asyncio.TaskGroup() as tg:
        for _ in range(n):
            tg.create_task(_trivial())


def _cpl_form(form: Callable[..., Coroutine[Any, Any, Any]]) -> Callable[[int], Any]:
    async def go(n: int) -> None:
        async def main() -> None:
            await form(*(_trivial() for _ in range(n)))

        await cpl.top_level(main)

    return go


def _time_per_child(fn: Callable[[int], Any], n: int, repeat: int) -> float:
    """Median seconds per child over ``repeat`` fresh loops."""
    samples = []
    for _ in range(repeat):
        loop = asyncio.new_event_loop()
        try:
            gc.collect()
            t0 = time.perf_counter()
            loop.run_until_complete(fn(n))
            samples.append((time.perf_counter() - t0) / n)
        finally:
            loop.close()
    return statistics.median(samples)


def _memory_per_live_task(n: int, use_cpl: bool) -> float:
    """Peak traced bytes per task while ``n`` children are blocked at once."""

    async def blocked(ev: asyncio.Event) -> None:
        await ev.wait()

    async def measure_asyncio() -> float:
        ev = asyncio.Event()
        gc.collect()
        tracemalloc.start()
        base = tracemalloc.get_traced_memory()[0]
        tasks = [asyncio.ensure_future(blocked(ev)) for _ in range(n)]
        await asyncio.sleep(0)
        used = tracemalloc.get_traced_memory()[0] - base
        tracemalloc.stop()
        ev.set()
        await asyncio.gather(*tasks)
        return used / n

    async def measure_cpl() -> float:
        ev = cpl.Fluent(False, name="go")
        result: list[float] = []

        async def waiter() -> None:
            await cpl.wait_for(ev)

        async def main() -> None:
            async def probe() -> None:
                await asyncio.sleep(0)
                await asyncio.sleep(0)
                result.append(tracemalloc.get_traced_memory()[0] - base)
                ev.value = True

            gc.collect()
            tracemalloc.start()
            nonlocal base
            base = tracemalloc.get_traced_memory()[0]
            await cpl.par(probe(), *(waiter() for _ in range(n)))
            tracemalloc.stop()

        base = 0
        await cpl.top_level(main)
        return result[0] / n

    loop = asyncio.new_event_loop()
    try:
        return loop.run_until_complete(measure_cpl() if use_cpl else measure_asyncio())
    finally:
        loop.close()


def _wakeup_latency(k: int, use_cpl: bool, repeat: int) -> float:
    """Median seconds from a set() to the last of ``k`` waiters running."""

    async def asyncio_case() -> float:
        ev = asyncio.Event()
        done = 0
        finished = asyncio.Event()

        async def waiter() -> None:
            nonlocal done
            await ev.wait()
            done += 1
            if done == k:
                finished.set()

        tasks = [asyncio.ensure_future(waiter()) for _ in range(k)]
        await asyncio.sleep(0)
        t0 = time.perf_counter()
        ev.set()
        await finished.wait()
        dt = time.perf_counter() - t0
        await asyncio.gather(*tasks)
        return dt

    async def cpl_case() -> float:
        fl = cpl.Fluent(False, name="signal")
        out: list[float] = []
        done = 0
        finished = asyncio.Event()

        async def waiter() -> None:
            nonlocal done
            await cpl.wait_for(fl)
            done += 1
            if done == k:
                finished.set()

        async def trigger() -> None:
            await asyncio.sleep(0)
            await asyncio.sleep(0)
            t0 = time.perf_counter()
            fl.value = True
            await finished.wait()
            out.append(time.perf_counter() - t0)

        async def main() -> None:
            await cpl.par(trigger(), *(waiter() for _ in range(k)))

        await cpl.top_level(main)
        return out[0]

    samples = []
    for _ in range(repeat):
        loop = asyncio.new_event_loop()
        try:
            samples.append(loop.run_until_complete(cpl_case() if use_cpl else asyncio_case()))
        finally:
            loop.close()
    return statistics.median(samples)


def _live_view_cost(n: int, repeat: int) -> tuple[float, float]:
    """Wall seconds of a run of ``n`` tasks that finish over ~1 s, without and with a
    LiveTaskTree watching (rendering to an in-memory terminal at 4 Hz)."""
    import io
    import random

    from rich.console import Console

    from cpl.display import LiveTaskTree

    async def plan(watch: bool) -> None:
        rng = random.Random(1)

        async def worker(delay: float) -> None:
            await cpl.sleep(delay)

        async def body() -> None:
            await cpl.par(*(worker(rng.uniform(0.0, 1.0)) for _ in range(n)))

        root = cpl.current_task()
        if watch:
            console = Console(file=io.StringIO(), force_terminal=True, width=120)
            async with LiveTaskTree(root, refresh_per_second=4, console=console):
                await body()
        else:
            await body()

    def once(watch: bool) -> float:
        loop = asyncio.new_event_loop()
        try:
            t0 = time.perf_counter()
            loop.run_until_complete(cpl.top_level(plan, watch))
            return time.perf_counter() - t0
        finally:
            loop.close()

    without = statistics.median(once(False) for _ in range(repeat))
    with_view = statistics.median(once(True) for _ in range(repeat))
    return without, with_view


def main(argv: list[str] | None = None) -> dict[str, Any]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[1000, 10000, 100000])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--waiters", type=int, nargs="+", default=[1, 100, 10000])
    parser.add_argument("--json", help="also write the figures to this JSON file")
    args = parser.parse_args(argv)
    results: dict[str, Any] = {"forms": [], "memory": [], "wakeup": []}

    print(f"cpl forms vs asyncio.TaskGroup (time per child, median of {args.repeat} runs)")
    print(f"{'N':>8} {'TaskGroup':>11} {'form':>8} {'cpl':>10} {'ratio':>7}")
    for n in args.sizes:
        rep = max(1, args.repeat if n <= 10000 else args.repeat // 2)
        base = _time_per_child(_taskgroup, n, rep)
        for name, form in (("par", cpl.par), ("pursue", cpl.pursue), ("try_all", cpl.try_all)):
            t = _time_per_child(_cpl_form(form), n, rep)
            ratio = t / base
            results["forms"].append(
                {
                    "n": n,
                    "form": name,
                    "taskgroup_us": base * 1e6,
                    "cpl_us": t * 1e6,
                    "ratio": ratio,
                }
            )
            print(f"{n:>8} {base * 1e6:>9.2f}us {name:>8} {t * 1e6:>8.2f}us {ratio:>6.2f}x")

    print("\nmemory per live (blocked) task")
    for n in args.sizes:
        a = _memory_per_live_task(n, use_cpl=False)
        c = _memory_per_live_task(n, use_cpl=True)
        results["memory"].append({"n": n, "asyncio_bytes": a, "cpl_bytes": c, "ratio": c / a})
        print(f"{n:>8} asyncio {a:>7.0f} B   cpl {c:>7.0f} B   ratio {c / a:.2f}x")

    print("\nwake-up latency: set -> all K waiters running (median)")
    for k in args.waiters:
        rep = args.repeat if k <= 100 else max(1, args.repeat // 2)
        a = _wakeup_latency(k, use_cpl=False, repeat=rep)
        c = _wakeup_latency(k, use_cpl=True, repeat=rep)
        results["wakeup"].append(
            {"k": k, "event_us": a * 1e6, "wait_for_us": c * 1e6, "ratio": c / a}
        )
        print(
            f"{k:>8} asyncio.Event {a * 1e6:>9.1f}us   cpl.wait_for {c * 1e6:>9.1f}us"
            f"   ratio {c / a:.2f}x"
        )
    print("\nlive task-tree view: a run of 10k tasks over ~1 s, watched at 4 Hz")
    without, with_view = _live_view_cost(10000, max(1, args.repeat // 2))
    results["live_view"] = {
        "n": 10000,
        "without_s": without,
        "with_s": with_view,
        "overhead": with_view / without - 1,
    }
    print(
        f"   without {without:.3f} s   with view {with_view:.3f} s   "
        f"overhead {100 * (with_view / without - 1):+.1f} %"
    )
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(results, fh, indent=2)
    return results


if __name__ == "__main__":
    sys.setrecursionlimit(10000)
    main()
