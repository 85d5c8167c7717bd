"""The demo's typed report (:class:`DemoReport`) and its JSON record, the one the
robustness campaign aggregates (:mod:`aiocram.campaign`); a run that never reported
(crashed, its worker died) has a record of the same shape from :func:`crash_record`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from aiocram.knocks import KnockReport
from aiocram.truth import TruthReport

from ._config import DemoConfig, robot_description

if TYPE_CHECKING:  # plans is imported when a demo runs, not with this module
    from plans.demo import ObjectOutcome

__all__ = ["DemoReport", "crash_record"]


@dataclass
class DemoReport:
    """What happened: per-object outcomes as the plan reported them
    (:class:`plans.demo.ObjectOutcome`, by type), the truth measured on the true world
    (:class:`aiocram.truth.TruthReport`: delivered objects, phantoms, the invariants),
    what the app measured of each transport (metres driven, simulated seconds, wall
    seconds spent imagining) and the whole run's times."""

    config: DemoConfig
    outcomes: dict[str, ObjectOutcome]
    invariants: dict[str, bool]
    violations: dict[str, str]
    sim_time_s: float
    wall_time_s: float
    imagined_wall_s: dict[str, float] = field(default_factory=dict)
    real_sim_s: dict[str, float] = field(default_factory=dict)
    files: list[Path] = field(default_factory=list)
    #: True when Ctrl-C ended the run early (the outcomes are those of the objects done).
    interrupted: bool = False
    #: The run's root task (dead), for the final tree.
    root: Any = None
    #: Evaporated tasks whose cleanup raised (``cpl.cleanup_failures``; each is logged).
    cleanup_failures: int = 0
    #: What the true world says after the run (``None`` if it was never measured).
    truth: TruthReport | None = None
    foresight: list[dict[str, Any]] = field(default_factory=list)  # aiocram.foresight
    #: Wall seconds spent recording the run in the experience store (after the run).
    store_s: float = 0.0
    #: Metres the base drove while each object was transported (by type).
    distances: dict[str, float] = field(default_factory=dict)
    #: The objects real robot motions knocked, measured on the true world
    #: (:class:`aiocram.knocks.KnockWatcher`; ``None``: not watched).
    knocks: KnockReport | None = None
    #: Arm-motion answers reused and computed in the run, by world ("belief": the
    #: probes and the imagined runs; "true": the real robot's controller):
    #: ``projection.World.motion_cache_counts`` (issue 26).
    motion_cache: dict[str, dict[str, int]] = field(default_factory=dict)

    @property
    def robot(self) -> str:
        """The name of the robot that ran (its :class:`executive.RobotDescription`'s)."""
        return str(robot_description(self.config).name)

    @property
    def delivered(self) -> int:
        """Objects delivered, measured on the true world."""
        return 0 if self.truth is None else self.truth.delivered

    @property
    def claimed(self) -> int:
        """Objects the plan reported placed."""
        return sum(1 for o in self.outcomes.values() if o.success)

    def to_json(self) -> dict[str, Any]:
        objects = {}
        for name, o in self.outcomes.items():
            truth = None if self.truth is None else self.truth.objects.get(o.name)
            objects[name] = {
                **({} if truth is None else truth.to_json()),
                "claimed": o.success,
                "failure": None if o.failure is None else type(o.failure).__name__,
                "retries": dict(o.retries),
                "distance_driven": self.distances.get(name, 0.0),
                "real_sim_s": self.real_sim_s.get(name, 0.0),
                "imagined_wall_s": self.imagined_wall_s.get(name, 0.0),
            }
        return {
            "robot": self.robot,
            "seed": self.config.seed,
            "projection": self.config.projection,
            "objects": objects,
            "distance_driven": sum(self.distances.get(name, 0.0) for name in self.outcomes),
            "real_time_s": self.sim_time_s,
            "foresight": self.foresight,
            "invariants": dict(self.invariants),
            "violations": dict(self.violations),
            "cleanup_intervened": (
                [] if self.truth is None else list(self.truth.cleanup_intervened)
            ),
            # issue 26: "knocked" lists each knocked object once, "knocks" every knock
            **(KnockReport() if self.knocks is None else self.knocks).to_json(),
            "motion_cache": {w: dict(c) for w, c in self.motion_cache.items()},
        }


def crash_record(
    *,
    seed: int,
    fault_rate: float,
    projection: bool,
    objects: Sequence[str],
    error: str,
    robot: str,
) -> dict[str, Any]:
    """The record of a run that crashed or whose worker died: ``error`` says how; its
    ``planned`` objects count as not delivered in the campaign's summary."""
    return {
        "robot": robot,
        "seed": seed,
        "fault_rate": fault_rate,
        "projection": projection,
        "error": error,
        "objects": {},
        "planned": list(objects),
        "invariants": {},
    }
