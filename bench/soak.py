"""Soak benchmark: a robot's executive running all day in one top level (issue 28).

Run: ``python bench/soak.py [--performs N] [--retention all|recent|stream] [--quick]``

One ``cpl.run``, an environment with one fake process module, an action that grounds to a
plan performing one ``going`` motion, performed in a loop (three tasks per perform: the
plan's, the goal's, and the process module's). At each checkpoint (10 k, 50 k, 100 k,
300 k, 1 M performs, up to N) it prints:

- **mean µs / perform** over the performs since the previous checkpoint, garbage
  collection included (total wall time / count), and the same in CPU time of the thread
  (``time.thread_time``: what the run itself spent, without the time other processes of
  a shared machine held the core);
- **peak RSS growth** since the warm-up ended (``ru_maxrss``);
- **full collections** (gen-2) so far and the **longest pause** of one of them (each timed
  with ``gc.callbacks``);
- the **nodes** the recorded tree holds in full below the root.

The same run measures its asyncio baseline first: a bare coroutine loop of the same count
(an ``asyncio`` task spawned and awaited per iteration: the floor of one task), printed
as µs per iteration, and the ratio of each mean to it.

``--retention`` picks the task-tree retention policy (see ``cpl.Retention``): ``all``
(``cpl.KeepAll``, the behaviour before issue 28), ``recent`` (``cpl.KeepRecent(F,
records=10_000, freeze=True)``; with the default ``--full 0`` it is the long-running
default the README recommends) or ``stream`` (``cpl.StreamFinished`` to a temporary
file, ``F`` kept whole, ``freeze=True``). ``--quick`` runs 20 k performs (for CI).

The fake process module keeps no history of its goals (``history=1``), as a real one: a
module that kept every motion would grow the heap by itself. The longest pause is
printed with its CPU time (``time.thread_time``): on a shared machine the wall time of a
collection also counts the time other processes held the core.
"""

from __future__ import annotations

import argparse
import asyncio
import gc
import os
import sys
import tempfile
import time
from typing import Any

from _timing import FullCollections, rss_mb

import cpl
from executive import Pose, RuleSet, a, an, environment, perform
from executive.testing import FakeProcessModule

P = Pose((1.0, 2.0, 0.0))
CHECKPOINTS = (10_000, 50_000, 100_000, 300_000, 1_000_000)
QUICK_CHECKPOINTS = (2_000, 5_000, 10_000, 20_000)
WARMUP = 1_000
TARGET_RSS_MB = 50.0  # growth from 100 k to 1 M performs under the long-running default
TARGET_PAUSE_MS = 20.0  # longest full collection
TARGET_FLAT = 1.2  # mean at the last checkpoint / mean at the first


async def moving_plan() -> None:
    await perform(a.motion(type="going", pose=P))


def moving_rule(d: Any) -> Any:
    yield moving_plan, {}


async def _noop() -> None:
    return None


async def _baseline(n: int) -> float:
    """µs per iteration of a bare loop spawning and awaiting one asyncio task."""
    loop = asyncio.get_running_loop()
    t0 = time.perf_counter()
    for _ in range(n):
        await loop.create_task(_noop())
    return (time.perf_counter() - t0) / n * 1e6


def _policy(name: str, log_path: str, full: int) -> cpl.Retention:
    if name == "all":
        return cpl.KeepAll()
    if name == "recent":
        return cpl.KeepRecent(full, records=10_000, freeze=True)
    if name == "stream":
        return cpl.StreamFinished(log_path, full=full, freeze=True)
    raise SystemExit(f"soak: unknown --retention {name!r}; use all, recent or stream")


def soak(
    total: int, checkpoints: tuple[int, ...], retention: str, full: int = 0
) -> list[dict[str, float]]:
    marks = [c for c in checkpoints if c <= total]
    if not marks or marks[-1] != total:
        marks.append(total)
    rows: list[dict[str, float]] = []
    collections = FullCollections()
    rules = RuleSet()
    rules.register("action", "soak-moving", moving_rule)
    baseline: list[float] = []

    async def main() -> None:
        baseline.append(await _baseline(total))
        gc.collect()
        fake = FakeProcessModule("nav", history=1)  # keeps no goals, as a real module
        async with environment(rules=rules, process_modules=[fake]):
            root = cpl.current_task()
            assert root is not None
            for _ in range(WARMUP):
                await perform(an.action(type="soak-moving"))
            gc.collect()
            rss0 = rss_mb()
            gc.callbacks.append(collections)
            try:
                done = 0
                for mark in marks:
                    t0 = time.perf_counter()
                    c0 = time.thread_time()
                    for _ in range(mark - done):
                        await perform(an.action(type="soak-moving"))
                    elapsed = time.perf_counter() - t0
                    cpu = time.thread_time() - c0
                    rows.append(
                        {
                            "performs": mark,
                            "mean_us": elapsed / (mark - done) * 1e6,
                            "cpu_us": cpu / (mark - done) * 1e6,
                            "rss_mb": rss_mb() - rss0,
                            "full": collections.count,
                            "pause_ms": collections.longest * 1e3,
                            "pause_cpu_ms": collections.longest_cpu * 1e3,
                            "nodes": sum(1 for _ in cpl.walk(root)),
                        }
                    )
                    done = mark
                    print(_row(rows[-1], baseline[0]), flush=True)
            finally:
                gc.callbacks.remove(collections)

    with tempfile.TemporaryDirectory() as tmp:
        policy = _policy(retention, os.path.join(tmp, "soak.jsonl"), full)
        print(
            f"soak: {total} action performs in one top level, retention {policy!r}; "
            f"asyncio baseline measured first in the same run",
            flush=True,
        )
        print(
            "| performs so far | mean µs / perform (CPU µs) | x asyncio task | peak RSS growth "
            "| full collections | longest pause (its CPU time) | nodes in full |",
            flush=True,
        )
        print("|---:|---:|---:|---:|---:|---:|---:|", flush=True)
        cpl.run(main, name="soak", retention=policy)
    print(f"asyncio baseline: {baseline[0]:.2f} µs per iteration (task spawn + await)")
    _verdicts(rows)
    return rows


def _row(r: dict[str, float], base: float) -> str:
    return (
        f"| {int(r['performs']):,} | {r['mean_us']:.1f} ({r['cpu_us']:.1f} CPU) "
        f"| {r['mean_us'] / base:.1f} "
        f"| {r['rss_mb']:+.1f} MB | {int(r['full'])} | {r['pause_ms']:.1f} ms "
        f"({r['pause_cpu_ms']:.1f} ms CPU) "
        f"| {int(r['nodes']):,} |"
    )


def _verdicts(rows: list[dict[str, float]]) -> None:
    first, last = rows[0], rows[-1]
    ratio = last["mean_us"] / first["mean_us"]
    cpu_ratio = last["cpu_us"] / first["cpu_us"]
    print(
        f"target mean at {int(last['performs']):,} <= {TARGET_FLAT}x mean at "
        f"{int(first['performs']):,}: {ratio:.2f}x wall, {cpu_ratio:.2f}x CPU -> "
        f"{'OK' if ratio <= TARGET_FLAT else 'OVER'} (wall), "
        f"{'OK' if cpu_ratio <= TARGET_FLAT else 'OVER'} (CPU)"
    )
    pause = max(r["pause_ms"] for r in rows)
    pause_cpu = max(r["pause_cpu_ms"] for r in rows)
    print(
        f"target longest full collection <= {TARGET_PAUSE_MS:.0f} ms: {pause:.1f} ms wall, "
        f"{pause_cpu:.1f} ms CPU -> {'OK' if pause <= TARGET_PAUSE_MS else 'OVER'} (wall), "
        f"{'OK' if pause_cpu <= TARGET_PAUSE_MS else 'OVER'} (CPU)"
    )
    at_100k = [r for r in rows if r["performs"] == 100_000]
    if at_100k and last["performs"] > 100_000:
        growth = last["rss_mb"] - at_100k[0]["rss_mb"]
        print(
            f"target peak RSS growth 100,000 -> {int(last['performs']):,} <= "
            f"{TARGET_RSS_MB:.0f} MB: {growth:+.1f} MB -> "
            f"{'OK' if growth <= TARGET_RSS_MB else 'OVER'}"
        )


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--performs", type=int, default=1_000_000)
    parser.add_argument("--retention", default="recent", choices=("all", "recent", "stream"))
    parser.add_argument(
        "--full", type=int, default=0, help="finished performs kept whole (recent, stream)"
    )
    parser.add_argument("--quick", action="store_true", help="20 k performs (CI)")
    args = parser.parse_args(argv)
    if args.performs < 1:
        parser.error(f"--performs must be at least 1, got {args.performs}")
    if args.quick:
        soak(20_000, QUICK_CHECKPOINTS, args.retention, args.full)
    else:
        soak(args.performs, CHECKPOINTS, args.retention, args.full)


if __name__ == "__main__":
    main(sys.argv[1:])
