"""The clock a real-robot plan runs on, and the check that the running loop has it.

The clock belongs to the event loop (``cpl.run(main, clock=...)``); the real robot only
asks the running loop's clock (:func:`cpl.current_clock`) for its rate."""

from __future__ import annotations

import math

import cpl

__all__ = ["check_clock", "real_robot_clock"]


def real_robot_clock(speed: float | None = None) -> cpl.Clock:
    """The clock to run a real-robot plan on (``cpl.run(main, clock=...)``): ``None`` or
    ``math.inf``: as fast as possible (``ScaledClock(None)``: time jumps whenever the loop
    is idle); otherwise simulated time runs ``speed`` times faster than the wall clock
    (``ScaledClock(speed)``; ``1.0`` = real time). Not > 0: ValueError."""
    if speed is None or speed == math.inf:
        return cpl.ScaledClock(None)
    return cpl.ScaledClock(speed)


def check_clock(speed: float) -> None:
    """Raise ValueError unless the running loop's clock runs at ``speed`` (see
    ``with_real_robot``). A clock whose time only moves when jumped (rate 0: a test's
    ``MockClock``) counts as as fast as possible."""
    rate = cpl.current_clock().rate
    if rate == 0.0:
        rate = math.inf
    if rate != speed:
        raise ValueError(
            f"with_real_robot(speed={speed}) but the loop runs at {rate}x wall time: run the "
            f"plan with cpl.run(..., clock=projection.real_robot_clock({speed}))"
        )
