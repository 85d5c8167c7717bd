"""The real robot's fault profile: which typed low-level failures it injects at which
rates, how noisy its perception is, and the command-line syntax for it
(:meth:`FaultProfile.parse`)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, fields
from typing import Any, ClassVar

__all__ = ["FaultProfile"]


@dataclass(frozen=True)
class FaultProfile:
    """Which low-level failures the real robot injects, and how well it sees.

    Rates are probabilities per motion: ``navigation`` (``going`` stops part of the way:
    :class:`executive.NavigationGoalNotReached`), ``ptu`` (``looking`` stops part of the
    way: :class:`executive.PtuGoalNotReached`), ``perception`` (a detection fails:
    :class:`executive.PerceptionObjectNotFound`), ``grasp_slip`` (a grip that closed on an
    object loses it: :class:`executive.GripperClosedCompletely`, nothing held), ``drop``
    (after a successful grip, the object falls out during the next arm motion of that arm,
    which then raises :class:`executive.GripperClosedCompletely`), ``ik`` (``moving-tcp``
    finds no IK solution: :class:`executive.ManipulationPoseUnreachable`).
    ``detection_noise`` = (position std in m, applied to x and y; yaw std in rad);
    ``miss_rate``: probability that a visible object is not seen. ``seed`` seeds every
    draw (None: fresh entropy). Values outside [0, 1] or negative noise: ValueError.
    """

    navigation: float = 0.0
    ptu: float = 0.0
    perception: float = 0.0
    grasp_slip: float = 0.0
    drop: float = 0.0
    ik: float = 0.0
    detection_noise: tuple[float, float] = (0.01, 0.03)
    miss_rate: float = 0.0
    seed: int | None = 0

    #: The failure kinds (the fields that :meth:`uniform` sets).
    KINDS: ClassVar[tuple[str, ...]] = (
        "navigation",
        "ptu",
        "perception",
        "grasp_slip",
        "drop",
        "ik",
    )

    def __post_init__(self) -> None:
        for key in (*self.KINDS, "miss_rate"):
            value = getattr(self, key)
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise TypeError(f"FaultProfile.{key} must be a number in [0, 1], got {value!r}")
            if not 0.0 <= value <= 1.0:
                raise ValueError(f"FaultProfile.{key} must be in [0, 1], got {value!r}")
        noise = tuple(self.detection_noise)
        if len(noise) != 2 or not all(
            isinstance(v, (int, float)) and math.isfinite(v) and v >= 0 for v in noise
        ):
            raise ValueError(
                "FaultProfile.detection_noise is (position std m, yaw std rad), both >= 0, "
                f"got {self.detection_noise!r}"
            )
        object.__setattr__(self, "detection_noise", (float(noise[0]), float(noise[1])))
        if self.seed is not None and (
            isinstance(self.seed, bool) or not isinstance(self.seed, int)
        ):
            raise TypeError(f"FaultProfile.seed must be an int or None, got {self.seed!r}")

    @classmethod
    def uniform(cls, rate: float, **others: Any) -> FaultProfile:
        """Every failure kind (:attr:`KINDS`) at ``rate``; ``others`` set the remaining
        fields (``detection_noise``, ``miss_rate``, ``seed``)."""
        rates: dict[str, Any] = dict.fromkeys(cls.KINDS, rate)
        return cls(**rates, **others)

    @classmethod
    def none(cls, seed: int | None = 0) -> FaultProfile:
        """A perfect robot: no failures, no misses, no detection noise."""
        return cls(detection_noise=(0.0, 0.0), seed=seed)

    @classmethod
    def parse(cls, text: str) -> FaultProfile:
        """From a command-line string: ``"0.1"`` (uniform), or comma-separated
        ``key=value`` items (keys: the kinds, ``miss_rate``, ``seed``,
        ``detection_noise=POS:YAW``), optionally led by a bare uniform rate:
        ``"0.05,grasp_slip=0.2,seed=3"``. Malformed text, or a key given twice: ValueError
        naming the keys."""
        known = {f.name for f in fields(cls)}
        values: dict[str, Any] = {}
        items = [item.strip() for item in text.split(",") if item.strip()]
        if not items:
            raise ValueError("an empty fault profile; give a rate like '0.1' or 'ik=0.2'")
        given: set[str] = set()  # the keys given as key=value, each at most once
        for k, item in enumerate(items):
            key, sep, raw = item.partition("=")
            key = key.strip().replace("-", "_")
            if sep and key in given:
                raise ValueError(f"{key} given more than once in {text!r}; give each key once")
            given.add(key)
            try:
                if not sep:
                    if k != 0:
                        raise ValueError(item)
                    values.update({kind: float(key) for kind in cls.KINDS})
                elif key not in known:
                    raise ValueError(item)
                elif key == "seed":
                    values[key] = None if raw.strip().lower() == "none" else int(raw)
                elif key == "detection_noise":
                    pos, _, yaw = raw.partition(":")
                    values[key] = (float(pos), float(yaw or 0.0))
                else:
                    values[key] = float(raw)
            except ValueError:
                raise ValueError(
                    f"bad fault profile item {item!r} in {text!r}: use a rate or key=value "
                    f"with keys {', '.join(sorted(known))}"
                ) from None
        return cls(**values)

    @property
    def rates(self) -> Mapping[str, float]:
        """Failure kind -> rate."""
        return {kind: getattr(self, kind) for kind in self.KINDS}
