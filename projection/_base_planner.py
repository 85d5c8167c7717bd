"""The simulated real robot's base planner: the first collision-free of a few candidate
base paths (straight while turning; turn, then drive; drive, then turn; face the travel
direction; a dog-leg through the midpoint), else the straight one."""

from __future__ import annotations

import itertools
import math

from executive import Pose
from executive.failures import NavigationPoseUnreachable
from projection._trajectories import along_timed, wrap_angle
from projection._world import World

__all__ = ["BASE_PATH_STEP", "BasePose", "along_base", "base_path"]

BasePose = tuple[float, float, float]
#: Spacing (m, rad) of the collision probes along a candidate base path.
BASE_PATH_STEP = (0.05, 0.1)


def _base_candidates(a: BasePose, b: BasePose) -> list[list[BasePose]]:
    """Candidate base paths from ``a`` to ``b`` (x, y, yaw), most direct first."""
    (x0, y0, t0), (x1, y1, t1) = a, b
    heading = math.atan2(y1 - y0, x1 - x0) if math.hypot(x1 - x0, y1 - y0) > 1e-6 else t0
    xm = (x0 + x1) / 2.0
    return [
        [a, b],
        [a, (x0, y0, t1), b],
        [a, (x1, y1, t0), b],
        [a, (x0, y0, heading), (x1, y1, heading), b],
        [a, (xm, y0, t0), (xm, y1, t1), b],
        [a, (x0, y0, t1), (xm, y0, t1), (xm, y1, t1), b],
    ]


def _path_free(world: World, path: list[BasePose]) -> bool:
    """Whether the robot (with what it holds) stays collision-free along ``path``; the
    world is left exactly as it was."""
    snap = world.snapshot()
    try:
        for (x0, y0, t0), (x1, y1, t1) in itertools.pairwise(path):
            dyaw = wrap_angle(t1 - t0)
            n = max(
                1,
                math.ceil(math.hypot(x1 - x0, y1 - y0) / BASE_PATH_STEP[0]),
                math.ceil(abs(dyaw) / BASE_PATH_STEP[1]),
            )
            for k in range(1, n + 1):
                f = k / n
                try:
                    world.drive(
                        Pose.from_xyz_yaw(
                            x0 + f * (x1 - x0), y0 + f * (y1 - y0), 0.0, t0 + f * dyaw
                        )
                    )
                except NavigationPoseUnreachable:
                    return False
        return True
    finally:
        world.restore(snap)


def base_path(world: World, start: Pose, goal: Pose) -> list[BasePose]:
    """The base path the simulated robot's local planner follows: the first collision-free
    candidate of :func:`_base_candidates`, else the straight one (which then stops at the
    obstacle, as a blocked robot does)."""
    a = (start.position[0], start.position[1], start.yaw)
    b = (goal.position[0], goal.position[1], goal.yaw)
    candidates = _base_candidates(a, b)
    for path in candidates:
        if _path_free(world, path):
            return path
    return candidates[0]


def along_base(path: list[BasePose], legs: list[float], s: float) -> BasePose:
    """The base pose at fraction ``s`` of the path's duration (legs in seconds)."""

    def lerp(p: BasePose, q: BasePose, f: float) -> BasePose:
        return (
            p[0] + f * (q[0] - p[0]),
            p[1] + f * (q[1] - p[1]),
            p[2] + f * wrap_angle(q[2] - p[2]),
        )

    return along_timed(path, legs, s, lerp)
