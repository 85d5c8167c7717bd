""":class:`LearnedPriors`: what the experience store teaches about picking and placing,
per robot, action, object type and surface (issue 29, learning from experience).

Two things are learned from the ``parameters`` table (real runs only):

- which arm and grasp succeeded: per choice, the Laplace-smoothed success rate
  ``(succeeded + 1) / (tried + 2)``, so one lucky try does not outrank twenty good ones;
- where the base stood relative to the object when the action succeeded: the base pose
  in the object's frame ``(x, y, yaw)`` of every success (at most :data:`MAX_SAMPLES`),
  read as a Gaussian kernel density (:meth:`Prior.density`).

Saved and loaded as a versioned JSON file (:meth:`LearnedPriors.save`,
:meth:`LearnedPriors.load`); a file from a newer aiocram, a corrupt file or priors
learned for another robot raise a :class:`PriorsError` subclass before anything runs.

Deliberate difference from CRAM: CRAM keeps its costmaps and grasp orders fixed (the
learned-costmap experiments, e.g. Stulp's, were never part of the executive); here the
priors are an optional, default-off input that only reorders what resolution would
already yield: nothing is added or removed.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from sqlalchemy import func, select

from ._errors import StoreError
from ._schema import parameters, runs

__all__ = [
    "BANDWIDTH_XY",
    "BANDWIDTH_YAW",
    "MAX_SAMPLES",
    "PRIORS_VERSION",
    "ChoiceStats",
    "LearnedPriors",
    "Prior",
    "PriorsCorruptError",
    "PriorsError",
    "PriorsRobotError",
    "PriorsVersionError",
    "learn_priors",
]

#: The priors file format this aiocram writes and reads; a newer one is refused.
PRIORS_VERSION = 1
#: The successes kept per (action, object, surface): the density reads these.
MAX_SAMPLES = 400
#: Kernel widths of the density: metres in x, y; radians in yaw.
BANDWIDTH_XY = 0.1
BANDWIDTH_YAW = 0.5

_FORMAT = "aiocram-learned-priors"


class PriorsError(StoreError):
    """A learned-priors file cannot be used as given; its subclasses say why."""


class PriorsVersionError(PriorsError):
    """The file was written by a newer aiocram (its ``version`` is above ours)."""


class PriorsCorruptError(PriorsError):
    """The file is not JSON, or not a learned-priors file, or a field has the wrong type."""


class PriorsRobotError(PriorsError):
    """The priors were learned for another robot than the one about to run."""


@dataclass(frozen=True)
class ChoiceStats:
    """One arm and grasp for an action on an object on a surface."""

    arm: str
    grasp: str | None
    tried: int  # invariant: 0 <= succeeded <= tried
    succeeded: int

    @property
    def smoothed(self) -> float:
        """Laplace-smoothed success rate: (succeeded + 1) / (tried + 2)."""
        return (self.succeeded + 1) / (self.tried + 2)


@dataclass(frozen=True)
class Prior:
    """What was learned for one action on one object type on one surface."""

    action: str  # "picking-up" | "placing"
    object: str
    surface: str | None
    choices: tuple[ChoiceStats, ...]  # invariant: best smoothed rate first
    # the base pose (x, y, yaw) in the object's frame of each success
    samples: tuple[tuple[float, float, float], ...] = ()

    @property
    def tried(self) -> int:
        return sum(c.tried for c in self.choices)

    @property
    def succeeded(self) -> int:
        return sum(c.succeeded for c in self.choices)

    def rate(self, arm: str, grasp: str | None) -> float:
        """The smoothed success of ``arm``/``grasp``; an untried choice gets 1/2 (the
        Laplace prior), so it ranks between the proven and the failing ones."""
        for c in self.choices:
            if c.arm == arm and c.grasp == grasp:
                return c.smoothed
        return 0.5

    def density(self, x: float, y: float, yaw: float) -> float:
        """The kernel density of a base pose (x, y, yaw) in the object's frame, relative
        to its peak possible value: in [0, 1], 0 when there are no samples."""
        if not self.samples:
            return 0.0
        total = 0.0
        for sx, sy, syaw in self.samples:
            dyaw = math.remainder(yaw - syaw, math.tau)
            d2 = ((x - sx) ** 2 + (y - sy) ** 2) / BANDWIDTH_XY**2 + (dyaw / BANDWIDTH_YAW) ** 2
            total += math.exp(-0.5 * d2)
        return total / len(self.samples)


@dataclass(frozen=True)
class LearnedPriors:
    """Priors for one robot, by (action, object type, surface).

    :meth:`lookup` falls back from the surface to any surface of the object (the priors of
    all its surfaces pooled) when the surface was never seen."""

    robot: str
    priors: tuple[Prior, ...]
    runs: int = 0  # the real runs learned from
    source: str = ""  # the store they were learned from (shown, not used)
    _index: dict[tuple[str, str, str | None], Prior] = field(
        default_factory=dict, init=False, repr=False, compare=False
    )

    def __post_init__(self) -> None:
        for p in self.priors:
            self._index[(p.action, p.object, p.surface)] = p

    def lookup(self, action: str, obj: str, surface: str | None = None) -> Prior | None:
        if surface is not None and (action, obj, surface) in self._index:
            return self._index[(action, obj, surface)]
        pooled = [p for p in self.priors if p.action == action and p.object == obj]
        if not pooled:
            return None
        if len(pooled) == 1:
            return pooled[0]
        return _pool(action, obj, pooled)

    def order_choices(
        self, action: str, obj: str, choices: Sequence[tuple[str, str | None]]
    ) -> list[tuple[str, str | None]]:
        """``choices`` (arm, grasp) best learned success first; a stable sort, so equal
        and unknown choices keep the order they came in. Unchanged without a prior."""
        prior = self.lookup(action, obj)
        if prior is None:
            return list(choices)
        return sorted(choices, key=lambda c: -prior.rate(c[0], c[1]))

    def base_density(self, action: str, obj: str) -> Callable[[Any, Any, Any], Any] | None:
        """:meth:`Prior.density` over numpy arrays of base poses in the object's frame
        (:class:`executive.Preferences`); None when nothing (or no success) was learned."""
        prior = self.lookup(action, obj)
        if prior is None or not prior.samples:
            return None
        samples = np.asarray(prior.samples, dtype=float)

        def density(x: Any, y: Any, yaw: Any) -> Any:
            x, y, yaw = np.asarray(x, float), np.asarray(y, float), np.asarray(yaw, float)
            total = np.zeros(np.broadcast(x, y, yaw).shape)
            for sx, sy, syaw in samples:
                dyaw = np.remainder(yaw - syaw + math.pi, math.tau) - math.pi
                d2 = ((x - sx) ** 2 + (y - sy) ** 2) / BANDWIDTH_XY**2 + (dyaw / BANDWIDTH_YAW) ** 2
                total += np.exp(-0.5 * d2)
            return total / len(samples)

        return density

    def check_robot(self, robot: str) -> None:
        if robot != self.robot:
            raise PriorsRobotError(
                f"these priors were learned for robot {self.robot!r}, not {robot!r}: "
                f"learn them again from a store of {robot!r} runs (aiocram experience learn)"
            )

    # ------------------------------------------------------------------ files
    def to_json(self) -> dict[str, Any]:
        return {
            "format": _FORMAT,
            "version": PRIORS_VERSION,
            "robot": self.robot,
            "runs": self.runs,
            "source": self.source,
            "priors": [
                {
                    "action": p.action,
                    "object": p.object,
                    "surface": p.surface,
                    "choices": [[c.arm, c.grasp, c.tried, c.succeeded] for c in p.choices],
                    "samples": [list(s) for s in p.samples],
                }
                for p in self.priors
            ],
        }

    def save(self, path: str | os.PathLike[str]) -> Path:
        out = Path(path)
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(json.dumps(self.to_json(), indent=1) + "\n")
        return out

    @classmethod
    def from_json(cls, data: Any, where: str = "priors") -> LearnedPriors:
        if not isinstance(data, dict) or data.get("format") != _FORMAT:
            raise PriorsCorruptError(
                f'{where} is not a learned-priors file (no "format": {_FORMAT!r}); '
                "write one with aiocram experience learn --out FILE"
            )
        version = data.get("version")
        if not isinstance(version, int) or isinstance(version, bool):
            raise PriorsCorruptError(f'{where}: "version" must be an integer, got {version!r}')
        if version > PRIORS_VERSION:
            raise PriorsVersionError(
                f"{where} is version {version}, this aiocram reads up to {PRIORS_VERSION}: "
                "upgrade aiocram or learn the priors again with this one"
            )
        try:
            priors = tuple(
                Prior(
                    action=str(p["action"]),
                    object=str(p["object"]),
                    surface=None if p["surface"] is None else str(p["surface"]),
                    choices=tuple(
                        ChoiceStats(str(a), None if g is None else str(g), int(t), int(s))
                        for a, g, t, s in p["choices"]
                    ),
                    samples=tuple((float(x), float(y), float(yaw)) for x, y, yaw in p["samples"]),
                )
                for p in data["priors"]
            )
            robot = data["robot"]
            if not isinstance(robot, str) or not robot:
                raise TypeError(f"robot must be a name, got {robot!r}")
            for p in priors:
                for c in p.choices:
                    if not 0 <= c.succeeded <= c.tried:
                        raise ValueError(f"{c.arm}/{c.grasp}: {c.succeeded} of {c.tried} tries")
            return cls(robot, priors, int(data.get("runs", 0)), str(data.get("source", "")))
        except (KeyError, TypeError, ValueError) as exc:
            raise PriorsCorruptError(f"{where} is corrupt ({type(exc).__name__}: {exc})") from None

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> LearnedPriors:
        """Read a priors file; a missing, corrupt or newer file raises a
        :class:`PriorsError` naming it."""
        p = Path(path)
        try:
            text = p.read_text()
        except OSError as exc:
            raise PriorsError(f"cannot read the priors file {p}: {exc.strerror}") from None
        try:
            data = json.loads(text)
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise PriorsCorruptError(f"{p} is not JSON ({exc})") from None
        return cls.from_json(data, str(p))


def _pool(action: str, obj: str, priors: Iterable[Prior]) -> Prior:
    counts: dict[tuple[str, str | None], list[int]] = {}
    samples: list[tuple[float, float, float]] = []
    for p in priors:
        for c in p.choices:
            n = counts.setdefault((c.arm, c.grasp), [0, 0])
            n[0] += c.tried
            n[1] += c.succeeded
        samples.extend(p.samples)
    return Prior(action, obj, None, _ranked(counts), tuple(samples[:MAX_SAMPLES]))


def _ranked(counts: dict[tuple[str, str | None], list[int]]) -> tuple[ChoiceStats, ...]:
    stats = [ChoiceStats(a, g, t, s) for (a, g), (t, s) in counts.items()]
    return tuple(sorted(stats, key=lambda c: (-c.smoothed, -c.tried, c.arm, str(c.grasp))))


def base_in_object(rel_x: float, rel_y: float, rel_yaw: float) -> tuple[float, float, float]:
    """The base pose in the object's frame, from the object's pose in the base's frame
    (the inverse of a planar transform)."""
    c, s = math.cos(rel_yaw), math.sin(rel_yaw)
    return (-(c * rel_x + s * rel_y), -(-s * rel_x + c * rel_y), math.remainder(-rel_yaw, math.tau))


def learn_priors(store: Any, robot: str | None = None) -> LearnedPriors:
    """Learn priors from a :class:`Store`'s real runs of ``robot`` (default: the robot
    of most runs). Raises :class:`PriorsError` when the store has no pick or place of it."""
    robots = store._all(select(runs.c.robot).distinct())
    names = sorted(str(r) for (r,) in robots)
    if robot is None:
        if not names:
            raise PriorsError(f"{store!r} has no runs to learn from")
        if len(names) > 1:
            raise PriorsError(f"{store!r} holds runs of {', '.join(names)}: say which with --robot")
        robot = names[0]
    query = (
        select(
            parameters.c.action,
            parameters.c.object,
            parameters.c.surface,
            parameters.c.arm,
            parameters.c.grasp,
            parameters.c.status,
            parameters.c.rel_x,
            parameters.c.rel_y,
            parameters.c.rel_yaw,
        )
        .select_from(parameters)
        .join(runs, runs.c.id == parameters.c.run_id)
        .where(runs.c.robot == robot, parameters.c.imagined.is_(False))
        .order_by(parameters.c.run_id, parameters.c.node_idx)
    )
    groups: dict[tuple[str, str, str | None], dict[str, Any]] = {}
    for action, obj, surface, arm, grasp, status, rx, ry, ryaw in store._all(query):
        if obj is None or arm is None:
            continue
        g = groups.setdefault((str(action), str(obj), surface), {"counts": {}, "samples": []})
        n = g["counts"].setdefault((str(arm), grasp), [0, 0])
        n[0] += 1
        ok = status == "SUCCEEDED"
        n[1] += int(ok)
        if ok and None not in (rx, ry, ryaw) and len(g["samples"]) < MAX_SAMPLES:
            g["samples"].append(base_in_object(float(rx), float(ry), float(ryaw)))
    if not groups:
        raise PriorsError(f"{store!r} has no real pick or place of robot {robot!r} to learn from")
    (n_runs,) = store._all(select(func.count()).select_from(runs).where(runs.c.robot == robot))[0]
    priors = tuple(
        Prior(action, obj, surface, _ranked(g["counts"]), tuple(g["samples"]))
        for (action, obj, surface), g in sorted(groups.items(), key=lambda kv: str(kv[0]))
    )
    return LearnedPriors(robot, priors, int(n_runs), repr(store))
