"""Timing helpers shared by the benchmark scripts (run them as ``python bench/X.py``)."""

from __future__ import annotations

import resource
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


class FullCollections:
    """Counts gen-2 collections and keeps the longest one's duration (``gc.callbacks``)."""

    def __init__(self) -> None:
        self.count = 0
        self.longest = 0.0
        self.longest_cpu = 0.0  # the CPU time of the longest one (this thread's)
        self._start = 0.0
        self._start_cpu = 0.0

    def __call__(self, phase: str, info: dict[str, int]) -> None:
        if info["generation"] != 2:
            return
        if phase == "start":
            self._start = time.perf_counter()
            self._start_cpu = time.thread_time()
        else:
            self.count += 1
            pause = time.perf_counter() - self._start
            if pause > self.longest:
                self.longest = pause
                self.longest_cpu = time.thread_time() - self._start_cpu


def rss_mb() -> float:
    """Peak resident set size of this process so far, in MB."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
