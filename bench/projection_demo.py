"""Median wall time of one bowl transport and of the full five-object table-setting demo
in projection, over several seeds (issue 17's target: full demo median <= 0.3 s), beside
the median time of a raw PyBullet scene load (connect + kitchen and robot URDFs) in the
same run.

    python bench/projection_demo.py [--seeds 5] [--planning] [--profile]

``--planning``: with ``World.arm_motion_planning`` on (the arm paths planned by OMPL);
each line also shows the runs' arm-motion cache counts
(``World.motion_cache_counts``: OMPL plans and controller-path sweeps reused / computed).
The CPU (process) seconds are printed beside the wall time: the steadier figure where
other processes share the cores. ``bench/imagining.py`` compares two trees interleaved.
"""

from __future__ import annotations

import argparse
import cProfile
import logging
import pstats
import statistics
import time

import cpl
import plans
import projection
from cpl.testing import MockClock
from kitchens.iai import DESCRIPTION as KITCHEN


def run_demo(
    seed: int, objects: tuple[str, ...], planning: bool = False
) -> tuple[float, int, dict[str, int], float]:
    world = projection.World(seed=seed)
    world.arm_motion_planning = planning

    async def main() -> dict[str, plans.ObjectOutcome]:
        async with projection.with_projected_robot(world):
            return await plans.table_setting(objects)

    start, cpu = time.perf_counter(), time.process_time()
    projection.set_up_scene(world, objects, seed=seed, settle_steps=0)
    outcomes = cpl.run(main, clock=MockClock())
    elapsed, cpu = time.perf_counter() - start, time.process_time() - cpu
    counts = world.motion_cache_counts()
    world.close()
    return elapsed, sum(o.success for o in outcomes.values()), counts, cpu


def raw_scene_load() -> float:
    """Wall time of raw PyBullet loading the demo's scene (connect, the kitchen and robot
    URDFs, disconnect), none of our code: the same-run baseline."""
    import pybullet as pb

    from projection._world_base import ASSETS

    start = time.perf_counter()
    c = pb.connect(pb.DIRECT)
    for urdf in ("kitchen.urdf", "pr2.urdf"):
        pb.loadURDF(str(ASSETS / urdf), useFixedBase=True, physicsClientId=c)
    pb.disconnect(physicsClientId=c)
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--planning", action="store_true")
    parser.add_argument("--profile", action="store_true")
    args = parser.parse_args()
    logging.getLogger("executive.retry").setLevel(logging.ERROR)
    base = statistics.median(raw_scene_load() for _ in range(5))
    print(f"baseline: raw PyBullet scene load (connect + 2 URDFs), median {base:.3f} s")
    for label, objects in (("bowl transport", ("bowl",)), ("full demo", KITCHEN.demo_objects)):
        runs = [run_demo(seed, objects, args.planning) for seed in range(1, args.seeds + 1)]
        times = [t for t, _, _, _ in runs]
        counts = {k: sum(c[k] for _, _, c, _ in runs) for k in runs[0][2]}
        print(
            f"{label:15s} median {statistics.median(times):.3f} s  "
            f"min {min(times):.3f}  max {max(times):.3f}  "
            f"ratio {statistics.median(times) / base:5.1f}x scene load  "
            f"cpu median {statistics.median(c for *_, c in runs):.3f} s  "
            f"delivered {[n for _, n, _, _ in runs]} of {len(objects)}  "
            f"cache {counts}"
        )
    if args.profile:
        profiler = cProfile.Profile()
        profiler.runcall(run_demo, 1, KITCHEN.demo_objects, args.planning)
        pstats.Stats(profiler).sort_stats("cumulative").print_stats(25)


if __name__ == "__main__":
    main()
