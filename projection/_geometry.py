"""Small pose arithmetic on plain tuples for the PyBullet world (cheaper than
:class:`executive.Pose` in the inner loops of collision checks and IK)."""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence

__all__ = ["Quat", "Tf", "Vec", "angle", "finite", "quat_mul", "quat_yaw", "yaw_quat"]

Vec = tuple[float, float, float]
Quat = tuple[float, float, float, float]
Tf = tuple[Vec, Quat]


def finite(values: Iterable[float], what: str) -> tuple[float, ...]:
    out = tuple(map(float, values))
    if not all(map(math.isfinite, out)):
        raise ValueError(f"{what} must be finite, got {out!r}")
    return out


def yaw_quat(yaw: float) -> Quat:
    return (0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0))


def quat_yaw(q: Sequence[float]) -> float:
    x, y, z, w = q
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def quat_mul(a: Sequence[float], b: Sequence[float]) -> Quat:
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    )


def angle(q1: Sequence[float], q2: Sequence[float]) -> float:
    dot = abs(sum(a * b for a, b in zip(q1, q2)))
    return 2.0 * math.acos(min(1.0, dot))
