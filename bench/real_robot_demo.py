"""Projection-then-execute on the simulated real robot at maximum speed.

For each seed, the five-object table-setting demo runs on the simulated real robot (true
and belief worlds, timed motions on a mock clock that jumps, noisy perception, no injected
faults) with projection reasoning (3 imagined runs per transport) and without. The
baseline, measured in the same run on the same seeds, is the same demo purely in
projection (teleporting robot, no physics between motions).

With ``--robots pr2,panda`` the real-robot rows are measured for each robot (the baseline
stays the PR2-like robot's pure projection), and each robot's wall time is also given as a
ratio to the first robot's: issue 25's target is the Panda within 1.5x of the PR2.

    python bench/real_robot_demo.py [--seeds 3] [--robots pr2,panda]
"""

from __future__ import annotations

import argparse
import logging
import statistics
import time

import cpl
import plans
import projection
from aiocram.demo import DemoConfig, run_demo
from cpl.testing import MockClock


def projection_only(seed: int) -> tuple[float, int]:
    world = projection.World(seed=seed)

    async def main() -> dict[str, plans.ObjectOutcome]:
        async with projection.with_projected_robot(world):
            return await plans.table_setting()

    try:
        t0 = time.perf_counter()
        projection.set_up_scene(world, seed=seed, settle_steps=0)
        outcomes = cpl.run(main, clock=MockClock())
        return time.perf_counter() - t0, sum(o.success for o in outcomes.values())
    finally:
        world.close()


def real(seed: int, with_projection: bool, robot: str = "pr2") -> tuple[float, float, int, float]:
    config = DemoConfig(seed=seed, projection=with_projection, live=False, robot=robot)
    report = run_demo(config)
    distance = sum(report.distances.values())
    return report.wall_time_s, report.sim_time_s, report.delivered, distance


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument(
        "--robots", default="pr2", help="comma-separated robots of the robots package"
    )
    args = parser.parse_args()
    from aiocram.demo import robot_names

    robots = robot_names(args.robots)  # DemoConfigError naming --robots before any run
    logging.disable(logging.WARNING)  # the plans log every retry; only the figures matter
    seeds = range(1, args.seeds + 1)
    base = [projection_only(s) for s in seeds]
    b = statistics.median(t for t, _ in base)
    print(f"five-object demo, seeds {list(seeds)} (medians; wall seconds)")
    print(f"{'projection only (baseline)':<44} {b:8.2f} s   delivered {[d for _, d in base]}")
    first: dict[bool, float] = {}  # the first robot's median wall time, per mode
    for robot in robots:
        for mode, label in ((True, "projection reasoning"), (False, "no projection reasoning")):
            runs = [real(s, mode, robot) for s in seeds]
            w = statistics.median(r[0] for r in runs)
            sim = statistics.median(r[1] for r in runs)
            dist = statistics.median(r[3] for r in runs)
            first.setdefault(mode, w)
            name = "real robot" if len(robots) == 1 else robot
            versus = "" if len(robots) == 1 else f"   vs {robots[0]} {w / first[mode]:5.2f}x"
            print(
                f"{name + ', ' + label:<44} {w:8.2f} s   ratio {w / b:5.2f}x   simulated "
                f"{sim:6.1f} s ({sim / w:5.1f}x real time)   distance {dist:5.2f} m   "
                f"delivered {[r[2] for r in runs]}{versus}"
            )


if __name__ == "__main__":
    main()
