"""Imagining per transport and the projected five-object demo, this tree against another
(e.g. the tree before arm motion planning was on), interleaved so that both see the same
load on a shared machine; wall and CPU (process) seconds: means (garbage collection
included) and medians, this tree's ratio to the other, and imagining's growth with the
run's length (per transport of a demo).

    python bench/imagining.py --against /tmp/orig-imagspeed [--seeds 1,2,3] [--rounds 2]

Each measurement runs in a fresh interpreter whose imports resolve to the tree measured
(``PYTHONPATH``, working directory), alternating the trees seed by seed:

- ``projected``: the five-object table-setting demo purely in projection (``World`` with
  its default ``arm_motion_planning``), scene set-up included, as
  ``bench/projection_demo.py`` times it;
- ``imagining``: ``aiocram demo --seed S --no-live --no-store``'s imagining per transport
  (the three imagined runs before each real transport; ``imagined_wall_s`` of the report),
  wall and CPU seconds. The CPU seconds are read by giving ``plans.reasoning`` a clock
  that returns the process time (its wall clock is recorded beside it), so the report's
  own field is not changed; the demo is otherwise the command's.

CPU seconds are the steadier figure where other processes share the cores (wall time
there includes waiting for a core); both are printed.
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent.parent


class _Clock:
    """A stand-in for the ``time`` module in ``plans.reasoning``: ``perf_counter``
    returns the process time, and each call's wall time is kept (``walls``)."""

    def __init__(self) -> None:
        self.walls: list[float] = []

    def perf_counter(self) -> float:
        self.walls.append(time.perf_counter())
        return time.process_time()

    def __getattr__(self, name: str) -> Any:
        return getattr(time, name)


def child_projected(seed: int) -> dict[str, Any]:
    import cpl
    import plans
    import projection
    from cpl.testing import MockClock
    from kitchens.iai import DESCRIPTION as KITCHEN

    world = projection.World(seed=seed)

    async def main() -> dict[str, plans.ObjectOutcome]:
        async with projection.with_projected_robot(world):
            return await plans.table_setting(KITCHEN.demo_objects)

    try:
        wall, cpu = time.perf_counter(), time.process_time()
        projection.set_up_scene(world, KITCHEN.demo_objects, seed=seed, settle_steps=0)
        outcomes = cpl.run(main, clock=MockClock())
        wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
        counts: dict[str, int] = getattr(world, "motion_cache_counts", dict)()
    finally:
        world.close()
    return {
        "wall": wall,
        "cpu": cpu,
        "delivered": sum(o.success for o in outcomes.values()),
        "planning": bool(getattr(world, "arm_motion_planning", False)),
        "cache": counts,
    }


def child_imagining(seed: int) -> dict[str, Any]:
    import plans.reasoning as reasoning
    from aiocram.demo import DemoConfig, run_demo

    clock = _Clock()
    reasoning.time = clock  # type: ignore[assignment,attr-defined]
    report = run_demo(DemoConfig(seed=seed, live=False))
    cpu = [float(report.imagined_wall_s.get(n, 0.0)) for n in report.config.objects]
    walls = [b - a for a, b in zip(clock.walls[::2], clock.walls[1::2], strict=False)]
    return {
        "cpu": cpu,
        "wall": walls,
        "delivered": report.delivered,
        "sim": report.sim_time_s,
        "demo_wall": report.wall_time_s,
    }


def measure(tree: Path, what: str, seed: int) -> dict[str, Any]:
    env = dict(os.environ, PYTHONPATH=str(tree))
    out = subprocess.run(
        [sys.executable, str(Path(__file__).resolve()), "--child", what, "--seed", str(seed)],
        cwd=tree,
        env=env,
        capture_output=True,
        text=True,
        timeout=1800,
        check=False,
    )
    if out.returncode != 0:
        raise RuntimeError(f"{what} seed {seed} in {tree} failed:\n{out.stderr[-2000:]}")
    return dict(json.loads(out.stdout.strip().splitlines()[-1]))


def _median(values: list[float]) -> str:
    return f"{statistics.median(values):6.3f}" if values else "     -"


def _mean(values: list[float]) -> str:
    return f"{statistics.fmean(values):6.3f}" if values else "     -"


def _ratio(ours: list[float], theirs: list[float], of: Any) -> str:
    if not ours or not theirs or of(theirs) <= 0.0:
        return "   -  "
    return f"{of(ours) / of(theirs):5.2f}x"


def summary(rows: dict[tuple[str, str], list[dict[str, Any]]], kinds: list[str]) -> list[str]:
    """The report's lines: per kind, each tree's mean (garbage collection included: the
    children run with the collector on, as the demo does) and median, wall and CPU, and
    this tree's ratio to the other measured in the same run; for imagining, how the
    figure grows with the run's length: the mean CPU seconds of the k-th transport of a
    demo (later transports imagine a fuller table)."""
    lines: list[str] = []
    for kind in kinds:
        figures: dict[str, dict[str, list[float]]] = {}
        for label in ("this", "other"):
            ms = rows.get((label, kind), [])
            if kind == "projected":
                figures[label] = {"wall": [m["wall"] for m in ms], "cpu": [m["cpu"] for m in ms]}
                extra = f"planning {ms[0]['planning'] if ms else '-'}, delivered " + str(
                    [m["delivered"] for m in ms]
                )
                what = "projected demo     "
            else:
                figures[label] = {
                    "wall": [w for m in ms for w in m["wall"]],
                    "cpu": [c for m in ms for c in m["cpu"]],
                }
                extra = f"delivered {[m['delivered'] for m in ms]}, simulated " + str(
                    [round(m["sim"], 1) for m in ms]
                )
                what = "imagining/transport"
            f = figures[label]
            lines.append(
                f"{what} {label:5s} mean wall {_mean(f['wall'])} s  cpu {_mean(f['cpu'])} s"
                f" | median wall {_median(f['wall'])} s  cpu {_median(f['cpu'])} s"
                f"  over {len(f['cpu'])} ({extra})"
            )
        this, other = figures["this"], figures["other"]
        lines.append(
            f"{what} ratio this/other: mean wall "
            f"{_ratio(this['wall'], other['wall'], statistics.fmean)}"
            f" cpu {_ratio(this['cpu'], other['cpu'], statistics.fmean)}"
            f" | median wall {_ratio(this['wall'], other['wall'], statistics.median)}"
            f" cpu {_ratio(this['cpu'], other['cpu'], statistics.median)}"
        )
        if kind == "imagining":
            for label in ("this", "other"):
                per: dict[int, list[float]] = {}
                for m in rows.get((label, kind), []):
                    for k, c in enumerate(m["cpu"], start=1):
                        per.setdefault(k, []).append(c)
                growth = "  ".join(
                    f"#{k} {statistics.fmean(v):.3f}" for k, v in sorted(per.items())
                )
                lines.append(f"imagining by transport ({label}, mean cpu s): {growth}")
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--against", type=Path, help="the other tree (its root directory)")
    parser.add_argument("--seeds", default="1,2,3")
    parser.add_argument("--rounds", type=int, default=1)
    parser.add_argument("--skip", choices=("projected", "imagining"), default=None)
    parser.add_argument("--child", choices=("projected", "imagining"), help=argparse.SUPPRESS)
    parser.add_argument("--seed", type=int, default=1, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child is not None:
        logging.disable(logging.WARNING)
        run = child_projected if args.child == "projected" else child_imagining
        print(json.dumps(run(args.seed)))
        return
    if args.against is None:
        parser.error("--against TREE is needed (the tree to compare this one with)")
    seeds = [int(s) for s in args.seeds.split(",")]
    trees = {"this": HERE, "other": args.against.resolve()}
    kinds = [k for k in ("projected", "imagining") if k != args.skip]
    rows: dict[tuple[str, str], list[dict[str, Any]]] = {}
    for r in range(args.rounds):
        for seed in seeds:
            for kind in kinds:
                order = list(trees.items()) if (r + seed) % 2 == 0 else list(trees.items())[::-1]
                for label, tree in order:
                    m = measure(tree, kind, seed)
                    rows.setdefault((label, kind), []).append(m)
                    print(f"round {r + 1} seed {seed} {kind:9s} {label:5s} {json.dumps(m)}")
    print(f"\nthis: {trees['this']}\nother: {trees['other']}")
    for line in summary(rows, kinds):
        print(line)


if __name__ == "__main__":
    main()
