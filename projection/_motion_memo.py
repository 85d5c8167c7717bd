"""Memos of arm-motion answers kept per :class:`projection.World` (no module-level
state): :class:`SweepMemo` remembers what an arm motion's controller path sweeps
(:func:`projection._swept_motions.arm_motion_sweep`), bounded and least recently used
first out, with hit and miss counts for the bench and the campaign report."""

from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass
from typing import Any

__all__ = ["SWEEP_MEMO_SIZE", "Sweep", "SweepMemo"]

#: Sweeps a :class:`SweepMemo` keeps (least recently used dropped first).
SWEEP_MEMO_SIZE = 4096


@dataclass(frozen=True)
class Sweep:
    """One arm motion's path and what it sweeps.

    ``swept``: the free objects (not held) that the path sweeps through, other than those
    the robot touches where the motion starts or ends (the object reached for, the one
    just released), sorted; ``seconds``: the path's duration at the simulated real robot's
    joint speeds (:func:`projection._arm_planner.leg_seconds`, as the real arms module
    times it), None where the path was not computed (no free object in the arm's reach:
    nothing to sweep, the straight move's time is taken); ``waypoints``: the path's
    configurations (2 where it was not computed)."""

    swept: tuple[str, ...]
    seconds: float | None
    waypoints: int


class SweepMemo:
    """Sweeps already computed in one world, keyed by everything the path depends on:
    the command and its goals, the start and goal configurations (torso, every arm's
    joints, the grippers), the robot's base pose, what it holds, every free object's pose
    (rounded to 0.1 mm / 1e-4) and whether the controller plans with OMPL. Bounded
    (:data:`SWEEP_MEMO_SIZE`, least recently used dropped); ``hits``/``misses`` count
    the lookups."""

    def __init__(self, size: int = SWEEP_MEMO_SIZE) -> None:
        if isinstance(size, bool) or not isinstance(size, int) or size < 1:
            raise ValueError(f"a sweep memo holds at least 1 entry, got {size!r}")
        self.size = size
        # invariant: at most `size` entries, the least recently used first
        self._entries: OrderedDict[tuple[Any, ...], Sweep] = OrderedDict()
        self.hits = 0
        self.misses = 0
        #: (arm, held object types) -> the arm's span (m) from its shoulder (geometry)
        self.spans: dict[tuple[str, tuple[str, ...]], float] = {}

    def __len__(self) -> int:
        return len(self._entries)

    def get(self, key: tuple[Any, ...]) -> Sweep | None:
        sweep = self._entries.get(key)
        if sweep is None:
            self.misses += 1
            return None
        self.hits += 1
        self._entries.move_to_end(key)
        return sweep

    def put(self, key: tuple[Any, ...], sweep: Sweep) -> None:
        self._entries[key] = sweep
        self._entries.move_to_end(key)
        while len(self._entries) > self.size:
            self._entries.popitem(last=False)

    def clear(self) -> None:
        self._entries.clear()
