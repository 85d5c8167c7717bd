"""Timing helpers shared by the benchmark scripts (run them as ``python bench/X.py``)."""

from __future__ import annotations

import time
from collections.abc import Callable


def median_us(fn: Callable[[], object], reps: int, warmup: int = 20) -> float:
    """Median wall time of ``fn()`` in microseconds over ``reps`` calls, after a warm-up."""
    for _ in range(min(warmup, reps)):
        fn()
    samples = []
    for _ in range(reps):
        t0 = time.perf_counter_ns()
        fn()
        samples.append(time.perf_counter_ns() - t0)
    samples.sort()
    return samples[len(samples) // 2] / 1000.0


def row(name: str, ours: float, base_name: str, base: float, target: str) -> None:
    """Print one figure beside its same-run baseline, as a ratio."""
    print(
        f"{name:<34} {ours:>10.1f} µs | {base_name:<40} {base:>10.1f} µs | "
        f"ratio {ours / base:6.2f}x  ({target})"
    )
