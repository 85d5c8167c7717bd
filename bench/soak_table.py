"""Soak benchmark of a projected robot: the table-setting demo in a loop, in one top level,
for an hour of simulated time (issue 28's second soak).

Run: ``python bench/soak_table.py [--hours 1.0] [--retention all|recent] [--quick]``

One ``cpl.run`` on a mock clock (projected time), one projection world and robot: the
world is put back to its empty kitchen (``World.restore`` of a snapshot taken before the
first demo), then ``plans.table_setting`` (five objects, seed = the round) runs, again and
again, until the loop clock has passed ``--hours`` of simulated time. After each round it
prints the simulated time, the wall time of the round, the peak RSS growth since the end
of the first round, the full (gen-2) collections so far and the longest one's pause (wall
and CPU, ``gc.callbacks``), and the tasks the recorded tree holds in full. The baseline
of the same run is the first round itself (imports and the world's first use included in
nothing after it): the flatness figure is the last round's wall time over the median of
the first three. ``--retention recent`` is the long-running default
(``cpl.KeepRecent(0, records=10_000, freeze=True)``), ``all`` keeps every task.
``--quick`` runs 0.05 h (CI).
"""

from __future__ import annotations

import argparse
import gc
import logging
import statistics
import sys
import time

from _timing import FullCollections, rss_mb

import cpl
import plans
import projection
from cpl.testing import MockClock
from kitchens.iai import DESCRIPTION as KITCHEN


def soak(hours: float, retention: str) -> None:
    policy: cpl.Retention = (
        cpl.KeepAll() if retention == "all" else cpl.KeepRecent(0, records=10_000, freeze=True)
    )
    world = projection.World(seed=1)
    empty = world.snapshot()
    collections = FullCollections()
    rounds: list[float] = []
    print(
        f"soak_table: table-setting demo (5 objects) in a loop for {hours:g} h of simulated "
        f"time in one top level, retention {policy!r}",
        flush=True,
    )
    print(
        "| round | simulated time | wall s / round | delivered | peak RSS growth "
        "| full collections | longest pause (its CPU time) | tasks in full |",
        flush=True,
    )
    print("|---:|---:|---:|---:|---:|---:|---:|---:|", flush=True)

    async def main() -> None:
        root = cpl.current_task()
        assert root is not None
        loop_time = cpl.current_time
        rss0 = 0.0
        n = 0
        async with projection.with_projected_robot(world):
            start = loop_time()
            while loop_time() - start < hours * 3600.0:
                n += 1
                world.restore(empty)
                t0 = time.perf_counter()
                projection.set_up_scene(world, KITCHEN.demo_objects, seed=n, settle_steps=0)
                outcomes = await plans.table_setting(
                    KITCHEN.demo_objects, projection_reasoning=True
                )
                rounds.append(time.perf_counter() - t0)
                if n == 1:
                    gc.collect()
                    rss0 = rss_mb()
                    gc.callbacks.append(collections)
                print(
                    f"| {n} | {(loop_time() - start) / 60:.1f} min | {rounds[-1]:.2f} "
                    f"| {sum(o.success for o in outcomes.values())} of 5 "
                    f"| {rss_mb() - rss0:+.1f} MB | {collections.count} "
                    f"| {collections.longest * 1e3:.1f} ms "
                    f"({collections.longest_cpu * 1e3:.1f} ms CPU) "
                    f"| {sum(1 for _ in cpl.walk(root)):,} |",
                    flush=True,
                )

    try:
        cpl.run(main, name="soak-table", clock=MockClock(), retention=policy)
    finally:
        if collections in gc.callbacks:
            gc.callbacks.remove(collections)
        world.close()
    first = statistics.median(rounds[:3])
    print(
        f"flatness: last round {rounds[-1]:.2f} s / median of the first three {first:.2f} s "
        f"= {rounds[-1] / first:.2f}x; longest full collection "
        f"{collections.longest * 1e3:.1f} ms ({collections.longest_cpu * 1e3:.1f} ms CPU)"
    )


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--hours", type=float, default=1.0)
    parser.add_argument("--retention", default="recent", choices=("all", "recent"))
    parser.add_argument("--quick", action="store_true", help="0.05 h of simulated time (CI)")
    args = parser.parse_args(argv)
    if not args.hours > 0:
        parser.error(f"--hours must be positive, got {args.hours}")
    logging.getLogger("executive.retry").setLevel(logging.ERROR)
    soak(0.05 if args.quick else args.hours, args.retention)


if __name__ == "__main__":
    main(sys.argv[1:])
