"""Costmap costs beside baselines measured in the same run.

``python bench/projection_costmaps.py [--reps N]``: medians (µs) of one more sample from a
cached costmap (``next_solution()`` on a resolved ``on`` designator: one draw + the
validators; target < 1 ms) against numpy's ``rng.choice`` over the 90 000 cells, and of
building a ``reachable-for`` costmap (target < 50 ms) against one raw ``rayTestBatch`` of
the same kitchen (2 500 rays).
"""

from __future__ import annotations

import argparse
import asyncio

import numpy as np
import pybullet as pb
from _timing import median_us, row

import executive
from executive import Pose, a, an
from projection import World
from projection._locations import LocationCostmaps


async def run(reps: int) -> None:
    with World(seed=0) as w:
        engine = LocationCostmaps(w)
        sink = an.object(type="counter-top", urdf_name="sink_area_surface", part_of="kitchen")
        async with executive.environment(rules=engine.rules):
            d = a.location(("side", "left"), ("side", "front"), on=sink, range=0.5)
            d.reference()
            cur = [d]

            def next_sample() -> None:
                cur[0] = cur[0].next_solution()

            ours = median_us(next_sample, reps)
            rng = np.random.default_rng(0)
            p = rng.random(90_000)
            p /= p.sum()
            base = median_us(lambda: rng.choice(90_000, p=p), reps)
            row("next_solution (cached costmap)", ours, "rng.choice(90000, p=P)", base, "< 1 ms")

            target = a.location(pose=Pose((1.4, 0.8, 0.9)))

            def build() -> None:
                engine.costmap(a.location(reachable_for="pr2", location=target)).values()

            ours = median_us(build, max(20, reps // 20))
            starts = [(0.04 * (i % 50) - 1, 0.04 * (i // 50) - 1, 1.4) for i in range(2500)]
            ends = [(1.4, 0.8, 0.9)] * 2500
            base = median_us(
                lambda: pb.rayTestBatch(starts, ends, physicsClientId=w.client),
                max(20, reps // 20),
            )
            row("build reachable-for costmap", ours, "rayTestBatch (2500 rays)", base, "< 50 ms")

            vis = a.location(pose=Pose((1.4, 0.4, 0.85)))
            ours = median_us(
                lambda: engine.costmap(a.location(visible_for="pr2", location=vis)).values(),
                max(10, reps // 50),
            )
            row("build visible-for costmap", ours, "rayTestBatch (2500 rays)", base, "info")


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--reps", type=int, default=1000)
    asyncio.run(run(parser.parse_args().reps))


if __name__ == "__main__":
    main()
