"""Imagining per transport and the projected five-object demo, this tree against another
(e.g. the tree before arm motion planning was on), interleaved so that both see the same
load on a shared machine; wall and CPU (process) seconds, medians.

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
    for kind in kinds:
        for label in trees:
            ms = rows[(label, kind)]
            if kind == "projected":
                print(
                    f"projected demo  {label:5s} median wall {_median([m['wall'] for m in ms])} s"
                    f"  cpu {_median([m['cpu'] for m in ms])} s  over {len(ms)} runs"
                    f"  (planning {ms[0]['planning']}, delivered {[m['delivered'] for m in ms]})"
                )
            else:
                walls = [w for m in ms for w in m["wall"]]
                cpus = [c for m in ms for c in m["cpu"]]
                print(
                    f"imagining/transport {label:5s} median wall {_median(walls)} s"
                    f"  cpu {_median(cpus)} s  over {len(cpus)} transports"
                    f"  (delivered {[m['delivered'] for m in ms]},"
                    f" simulated {[round(m['sim'], 1) for m in ms]} s)"
                )


if __name__ == "__main__":
    main()
