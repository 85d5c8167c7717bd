"""Timed polylines: where a motion is at a fraction of its duration, shared by the base
and the arm controllers of the simulated real robot."""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from typing import TypeVar

T = TypeVar("T")

__all__ = ["along_timed", "nearest_turn_of", "wrap_angle"]


def wrap_angle(angle: float) -> float:
    """``angle`` in [-pi, pi)."""
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


def nearest_turn_of(angle: float, near: float) -> float:
    """``angle`` moved by whole turns to the value nearest ``near`` (a continuous joint
    reached from ``near`` the short way)."""
    return near + math.remainder(angle - near, 2.0 * math.pi)


def along_timed(path: list[T], legs: list[float], s: float, lerp: Callable[[T, T, float], T]) -> T:
    """The point at fraction ``s`` of a polyline's total duration, where ``legs[i]`` is
    the duration of the segment ``path[i] -> path[i + 1]``."""
    total = sum(legs)
    if total <= 0.0:
        return path[-1]
    d = s * total
    for (p, q), leg in zip(itertools.pairwise(path), legs):
        if d <= leg or q is path[-1]:
            return lerp(p, q, 1.0 if leg <= 0.0 else min(1.0, d / leg))
        d -= leg
    return path[-1]
