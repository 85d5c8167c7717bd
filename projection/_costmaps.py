"""Costmaps for location designators (CRAM's ``cram_location_costmap`` and the spatial
relations of ``cram_btr_spatial_relations_costmap``), with numpy.

A :class:`Costmap` is a grid (:class:`CostmapSpec`, by default CRAM's 300 x 300 cells at
0.04 m from (-6, -6)) that is the product of named factors in [0, 1] (0/1 regions and
Gaussians; a factor whose name is already present is dropped, as CRAM de-duplicates by
name). It is normalised into a distribution, and :meth:`Costmap.sample` draws a cell with a
caller-supplied :class:`numpy.random.Generator` (so a run is reproducible), puts the pose
at the cell's corner (CRAM's quirk 10: exactly the point the factors were evaluated at),
picks the height among the height generators' outputs (default 0) and yields one pose per
orientation of the first orientation generator (default identity).

Factors are evaluated only on cells that are still non-zero, so an expensive factor (the
ray-cast visibility factor) runs last and on few cells.

The builders below (:func:`add_reachable_for`, :func:`add_on_box`, ...) add the factors of
one designator key (reference section 3.3) to a costmap; they take plain geometry
(numbers, AABBs) or a :class:`~projection._world.World`. Deviations from CRAM are named in
their docstrings; the main ones: boxes are the links' *true* AABBs (CRAM centres them on the
link origin; in this kitchen both coincide because link origins are box centres), and the
demo's restricted area in front of the sink reaches y < 1.25 (see :data:`DEMO_AREAS`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Final

import numpy as np
import pybullet as pb

from executive._pose import Pose, yaw_quaternion
from kitchens import iai as kitchen
from projection import _urdf

__all__ = [
    "BOARD_THICKNESS",
    "CAMERA_HEIGHTS",
    "DEMO_AREAS",
    "IN_REACH_DISTANCE",
    "KITCHEN_LINKS",
    "PADDING",
    "REACH_MINIMAL_DISTANCE",
    "VISIBILITY_SIZE",
    "Costmap",
    "CostmapSpec",
    "Factor",
    "add_demo_area",
    "add_far_from",
    "add_free_space",
    "add_in_box",
    "add_near",
    "add_on_box",
    "add_range",
    "add_reachable_for",
    "add_reachable_in_drawer",
    "add_relation",
    "add_side",
    "add_slots",
    "add_visible_for",
    "closest_edge",
    "constant_height",
    "drawer_shoulder",
    "facing",
    "gaussian",
    "near_padding",
    "near_size",
    "pose_covariance",
    "slot_centres",
]

Array = np.ndarray
FactorFn = Callable[[Array, Array], Array]
HeightFn = Callable[[float, float], Sequence[float]]
OrientationFn = Callable[[float, float], Sequence[float]]
Box2 = tuple[tuple[float, float], tuple[float, float]]
Bounds = tuple[float, float, float, float]

# ------------------------------------------------------------------ CRAM's parameters
PADDING: Final = 0.3  #: costmap-padding: kitchen free space
IN_REACH_DISTANCE: Final = 0.7  #: costmap-in-reach-distance
REACH_MINIMAL_DISTANCE: Final = 0.2  #: costmap-reach-minimal-distance
VISIBILITY_SIZE: Final = 2.0  #: visibility-costmap-size (range of visible-for, window side)
ORIENTATION_SAMPLES: Final = 2  #: orientation-samples (2 -> exactly one yaw)
ORIENTATION_SAMPLE_STEP: Final = 0.1  #: orientation-sample-step
POSE_MINVAR: Final = 0.5  #: 2d-pose-covariance minvar of reachable-for / visible-for
#: The PR2-like robot's camera heights cast from (m); a world's robot has its own
#: (``World.camera_heights``)
CAMERA_HEIGHTS: Final = (1.27, 1.38, 1.49, 1.60)
BOARD_THICKNESS: Final = 0.035  #: ``in`` height above the container's bottom
#: The kitchen's links (their AABBs make the free-space factor).
KITCHEN_LINKS: Final = tuple(_urdf.KITCHEN_BOXES)
#: The demo's restricted area: (x_lo, x_hi, y_lo, y_hi), 1 where x_lo < x <= x_hi and
#: y_lo < y < y_hi. CRAM's rectangles are (0, 1.0, -1, 0.7) in front of the sink and
#: (-1, 0, -1, 2.5) in front of the island. Our sink counter spans y -0.65..1.25 (CRAM's
#: rectangle was cut at 0.7 for the IAI kitchen's furniture, which this kitchen does not
#: have): with y < 0.7 and the counter front at x = 1.12 (free space keeps the base at
#: x <= 0.82) a point on the counter's left front end, e.g. (1.3, 1.2), is more than the
#: 0.7 m reach from every allowed base pose. So the sink rectangle reaches y < 1.25.
#: The island rectangle fits our island (x -1.20..-0.55, y 0.20..2.40) unchanged.
DEMO_AREAS: Final = ((0.0, 1.0, -1.0, 1.25), (-1.0, 0.0, -1.0, 2.5))

#: Table-setting slot paddings (x+, x-, y+, y-) per surface link (default 0.03 all round).
SLOT_PADDINGS: Final[Mapping[str, tuple[float, float, float, float]]] = MappingProxyType(
    {
        kitchen.ISLAND_SURFACE: (0.03, 0.03, 0.8, 0.03),
        kitchen.SINK_SURFACE: (0.03, 0.03, 0.03, 0.03),
    }
)
#: Slot size (max, min) per object type (default (0.8, 0.5)).
SLOT_SIZES: Final[Mapping[str, tuple[float, float]]] = MappingProxyType(
    {"plate": (0.8, 0.5), "bowl": (0.6, 0.2)}
)
#: Slot position-deviation threshold per object type (default 0.1).
SLOT_THRESHOLDS: Final[Mapping[str, float]] = MappingProxyType({"plate": 0.08})
_NEAR_PADDINGS: Final = MappingProxyType({"bowl": 0.03, "cup": 0.1, "mug": 0.01, "plate": 0.005})
_SHAPES: Final = MappingProxyType(
    {"bowl": "circle", "plate": "circle", "mug": "complex", "pot": "complex"}
)


# --------------------------------------------------------------------------- the grid
@dataclass(frozen=True)
class CostmapSpec:
    """Grid geometry: ``width`` x ``height`` cells of ``resolution`` metres, cell (0, 0)'s
    corner at ``origin``. Rows are y, columns x. Non-positive sizes raise ValueError."""

    width: int = 300
    height: int = 300
    resolution: float = 0.04
    origin: tuple[float, float] = (-6.0, -6.0)

    def __post_init__(self) -> None:
        if self.width <= 0 or self.height <= 0 or not self.resolution > 0:
            raise ValueError(f"a costmap needs positive sizes, got {self!r}")

    def grid(self) -> tuple[Array, Array]:
        """Cell-corner coordinates ``(X, Y)``, each of shape ``(height, width)``."""
        xs = self.origin[0] + self.resolution * np.arange(self.width)
        ys = self.origin[1] + self.resolution * np.arange(self.height)
        return np.meshgrid(xs, ys)

    def cell(self, x: float, y: float) -> tuple[int, int] | None:
        """``(row, col)`` of the cell containing (x, y), or None outside the grid."""
        col = math.floor((x - self.origin[0]) / self.resolution + 1e-6)
        row = math.floor((y - self.origin[1]) / self.resolution + 1e-6)
        if 0 <= row < self.height and 0 <= col < self.width:
            return row, col
        return None


@dataclass(frozen=True)
class Factor:
    """A named factor: ``fn(x, y)`` -> values in [0, 1] for 1-D arrays of cell corners.
    Factors run in descending ``score`` (CRAM's order), ``expensive`` ones last."""

    name: str
    fn: FactorFn
    score: float = 0.0
    expensive: bool = False
    #: ``(x_lo, x_hi, y_lo, y_hi)``: a box outside which ``fn`` is 0 (None: unbounded).
    #: :meth:`Costmap.values` evaluates the factors only on the cells inside every
    #: factor's box (plus one cell), so a bound must never cut a cell ``fn`` keeps.
    bounds: Bounds | None = None


@dataclass
class Costmap:
    """Factors, height and orientation generators, and (once built) the normalised map.

    Build lazily: :meth:`values` multiplies the factors once; adding anything afterwards
    raises RuntimeError. An empty map (sum zero) has :attr:`empty_reason` naming the
    factor that removed the last cells; sampling it raises ValueError.
    """

    spec: CostmapSpec = field(default_factory=CostmapSpec)
    factors: list[Factor] = field(default_factory=list)
    heights: list[HeightFn] = field(default_factory=list)
    orientations: list[OrientationFn] = field(default_factory=list)
    empty_reason: str | None = None
    _values: Array | None = None
    #: the cumulative sum over the positive cells only (``_cells``, ascending): the
    #: same sums as over the whole grid (adding a zero is exact), ~20x fewer to take
    _cdf: Array | None = None
    _cells: Array | None = None
    _max: float = 0.0

    # ---------------------------------------------------------------- composition
    def _mutable(self) -> None:
        if self._values is not None:
            raise RuntimeError("this costmap is already built; build a new one")

    def names(self) -> list[str]:
        return [f.name for f in self.factors]

    def unique_name(self, base: str) -> str:
        """``base``, or ``base-2``, ``base-3``... if taken (CRAM's ``instance-of``)."""
        taken = set(self.names())
        if base not in taken:
            return base
        k = 2
        while f"{base}-{k}" in taken:
            k += 1
        return f"{base}-{k}"

    def add(
        self,
        name: str,
        fn: FactorFn,
        score: float = 0.0,
        *,
        expensive: bool = False,
        bounds: Bounds | None = None,
    ) -> bool:
        """Add a factor unless one of that name exists; True if added. ``bounds`` (x_lo,
        x_hi, y_lo, y_hi): where ``fn`` may be non-zero (see :attr:`Factor.bounds`)."""
        self._mutable()
        if name in self.names():
            return False
        self.factors.append(Factor(name, fn, score, expensive, bounds))
        return True

    def add_height(self, fn: HeightFn) -> None:
        """``fn(x, y)`` -> candidate heights; a sample's z is one of all outputs."""
        self._mutable()
        self.heights.append(fn)

    def add_orientation(self, fn: OrientationFn) -> None:
        """``fn(x, y)`` -> yaws. Only the first orientation generator is used (CRAM chains
        them and the later ones pass the list through)."""
        self._mutable()
        self.orientations.append(fn)

    # ---------------------------------------------------------------- evaluation
    def values(self) -> Array:
        """The unnormalised product, shape ``(height, width)`` (computed once)."""
        if self._values is not None:
            return self._values
        spec = self.spec
        # Evaluate only the window every bounded factor allows (cells outside it are 0 in
        # the product anyway): the same values, without a pass over all 90k cells per
        # factor. An empty result is recomputed over the whole grid so that
        # ``empty_reason`` names the same factor as a full evaluation would.
        window = self._window()
        m, empty_reason = self._product(window)
        if empty_reason is not None and window is not None:
            m, empty_reason = self._product(None)
        if self.empty_reason is None:
            self.empty_reason = empty_reason
        self._values = m.reshape(spec.height, spec.width)
        self._cells = np.flatnonzero(m)
        self._cdf = np.cumsum(m[self._cells])
        self._max = float(m.max()) if m.size else 0.0
        return self._values

    def _window(self) -> Array | None:
        """The flat indices (ascending) of the cells inside every factor's bounds, grown
        by one cell; None without bounded factors."""
        boxes = [
            f.bounds
            for f in self.factors
            if f.bounds is not None and all(math.isfinite(v) for v in f.bounds)
        ]
        if not boxes:
            return None
        s = self.spec
        x_lo = max(b[0] for b in boxes)
        x_hi = min(b[1] for b in boxes)
        y_lo = max(b[2] for b in boxes)
        y_hi = min(b[3] for b in boxes)
        c0 = max(math.floor((x_lo - s.origin[0]) / s.resolution) - 1, 0)
        c1 = min(math.ceil((x_hi - s.origin[0]) / s.resolution) + 1, s.width - 1)
        r0 = max(math.floor((y_lo - s.origin[1]) / s.resolution) - 1, 0)
        r1 = min(math.ceil((y_hi - s.origin[1]) / s.resolution) + 1, s.height - 1)
        if c0 > c1 or r0 > r1:
            return np.empty(0, dtype=np.intp)
        rows = np.arange(r0, r1 + 1, dtype=np.intp)
        cols = np.arange(c0, c1 + 1, dtype=np.intp)
        return (rows[:, None] * s.width + cols[None, :]).ravel()

    def _product(self, live: Array | None) -> tuple[Array, str | None]:
        """The factors' product over the cells ``live`` (None: all), 0 elsewhere, and why
        it is empty (None if it is not)."""
        s = self.spec
        n = s.width * s.height
        if live is None:
            live = np.arange(n)
            m = np.ones(n)
        else:
            m = np.zeros(n)
            m[live] = 1.0
        # cell-corner coordinates exactly as CostmapSpec.grid() computes them
        cols, rows = np.divmod(live, s.width)[::-1]
        xs = s.origin[0] + s.resolution * cols.astype(float)
        ys = s.origin[1] + s.resolution * rows.astype(float)
        order = sorted(self.factors, key=lambda f: (f.expensive, -f.score))
        done: list[str] = []
        reason: str | None = None
        for f in order:
            if live.size == 0:
                break
            v = np.asarray(f.fn(xs, ys), dtype=float)
            ml = m[live] * np.clip(v, 0.0, None)
            m[live] = ml
            keep = ml > 0.0
            if not keep.any() and reason is None:
                after = f" after {', '.join(done)}" if done else ""
                reason = f"factor {f.name!r} leaves no cell{after}"
            live, xs, ys = live[keep], xs[keep], ys[keep]
            done.append(f.name)
        if live.size == 0 and reason is None:
            reason = "no cell has a positive value"
        return m, reason

    @property
    def empty(self) -> bool:
        self.values()
        return self._max <= 0.0

    @property
    def max(self) -> float:
        self.values()
        return self._max

    def value(self, x: float, y: float) -> float:
        """The normalised value (value / max) of the cell containing (x, y); 0 outside the
        grid or for an empty map."""
        vals = self.values()
        cell = self.spec.cell(x, y)
        if cell is None or self._max <= 0.0:
            return 0.0
        return float(vals[cell] / self._max)

    def heights_at(self, x: float, y: float) -> list[float]:
        """Every height generator's output at (x, y); ``[0.0]`` without generators."""
        if not self.heights:
            return [0.0]
        out: list[float] = []
        for fn in self.heights:
            out.extend(float(z) for z in fn(x, y))
        return out or [0.0]

    # ---------------------------------------------------------------- sampling
    def sample_xy(self, rng: np.random.Generator) -> tuple[float, float]:
        """One cell corner drawn from the normalised map. Empty map -> ValueError."""
        self.values()
        cdf, cells = self._cdf, self._cells
        assert cdf is not None and cells is not None
        total = cdf[-1] if cdf.size else 0.0
        if not total > 0.0:
            raise ValueError(f"the costmap is empty: {self.empty_reason}")
        k = int(cdf.searchsorted(rng.random() * total, side="right"))
        # past the last positive cell: the grid's last cell, as a whole-grid cdf gives
        idx = int(cells[k]) if k < cells.size else self.spec.width * self.spec.height - 1
        row, col = divmod(idx, self.spec.width)
        s = self.spec
        return s.origin[0] + col * s.resolution, s.origin[1] + row * s.resolution

    def sample(self, rng: np.random.Generator) -> list[Pose]:
        """The poses of one drawn cell: one per orientation (identity without an
        orientation generator), z drawn among the heights. Empty map -> ValueError."""
        x, y = self.sample_xy(rng)
        hs = self.heights_at(x, y)
        z = hs[int(rng.integers(len(hs)))] if len(hs) > 1 else hs[0]
        if not self.orientations:
            return [Pose((x, y, z))]
        return [Pose((x, y, z), yaw_quaternion(yaw)) for yaw in self.orientations[0](x, y)]

    def poses(self, rng: np.random.Generator) -> Iterator[Pose]:
        """An infinite stream of sampled poses (nothing for an empty map)."""
        if self.empty:
            return
        while True:
            yield from self.sample(rng)


# ------------------------------------------------------------------ cost functions
def gaussian(mean: Sequence[float], cov: Array) -> FactorFn:
    """The normalised 2-D normal pdf (CRAM's ``make-gauss-cost-function``)."""
    mu = np.asarray(mean[:2], dtype=float)
    cov = np.asarray(cov, dtype=float)
    inv = np.linalg.inv(cov)
    norm = 1.0 / (2.0 * math.pi * math.sqrt(float(np.linalg.det(cov))))

    def f(x: Array, y: Array) -> Array:
        dx, dy = x - mu[0], y - mu[1]
        q = inv[0, 0] * dx * dx + (inv[0, 1] + inv[1, 0]) * dx * dy + inv[1, 1] * dy * dy
        return np.asarray(norm * np.exp(-0.5 * q), dtype=float)

    return f


def pose_covariance(
    points: Sequence[Sequence[float]], minvar: float
) -> tuple[tuple[float, float], Array]:
    """CRAM's ``2d-pose-covariance``: mean xy and Σ with Σxx = mean(max(dx², minvar)),
    Σyy likewise, Σxy = mean(dx·dy). No points -> ValueError."""
    if not points:
        raise ValueError("2d-pose-covariance needs at least one point")
    p = np.asarray([q[:2] for q in points], dtype=float)
    mu = p.mean(axis=0)
    d = p - mu
    sxx = float(np.mean(np.maximum(d[:, 0] ** 2, minvar)))
    syy = float(np.mean(np.maximum(d[:, 1] ** 2, minvar)))
    sxy = float(np.mean(d[:, 0] * d[:, 1]))
    return (float(mu[0]), float(mu[1])), np.array([[sxx, sxy], [sxy, syy]])


def _range_fn(cx: float, cy: float, r: float, invert: bool) -> FactorFn:
    def f(x: Array, y: Array) -> Array:
        inside = np.hypot(x - cx, y - cy) <= r
        return (~inside if invert else inside).astype(float)

    return f


def _disc(cx: float, cy: float, r: float, invert: bool = False) -> Bounds | None:
    """The bounds of :func:`_range_fn` (an inverted range is unbounded)."""
    return None if invert else (cx - r, cx + r, cy - r, cy + r)


def _box_fn(lo: Sequence[float], hi: Sequence[float]) -> FactorFn:
    def f(x: Array, y: Array) -> Array:
        return ((x > lo[0]) & (x < hi[0]) & (y > lo[1]) & (y < hi[1])).astype(float)

    return f


def constant_height(z: float) -> HeightFn:
    """A height generator that always gives ``z``."""

    def f(x: float, y: float) -> tuple[float]:
        return (z,)

    return f


def facing(
    px: float, py: float, samples: int = ORIENTATION_SAMPLES, step: float = ORIENTATION_SAMPLE_STEP
) -> OrientationFn:
    """CRAM's ``make-angle-to-point-generator``: the yaw towards (px, py) plus offsets
    +step, -step, +2 step... while the offset is below ``step * ceil(samples / 2)``; with
    samples = 2 exactly one yaw."""
    offsets = [0.0]
    k = 1
    while k * step < step * math.ceil(samples / 2) - 1e-12:
        offsets += [k * step, -k * step]
        k += 1

    def f(x: float, y: float) -> list[float]:
        base = math.atan2(py - y, px - x)
        return [base + o for o in offsets]

    return f


# --------------------------------------------------------------------- key builders
def add_free_space(cm: Costmap, boxes: Sequence[Box2], padding: float = PADDING) -> None:
    """Kitchen free space (score 4): 0 inside every box grown by ``padding``. Boxes are
    the links' true world AABBs (CRAM centres them on the link origin)."""
    arr = np.asarray(
        [(lo[0] - padding, lo[1] - padding, hi[0] + padding, hi[1] + padding) for lo, hi in boxes],
        dtype=float,
    ).reshape(-1, 4)

    def f(x: Array, y: Array) -> Array:
        out = np.ones_like(x)
        for x0, y0, x1, y1 in arr:
            out[(x > x0) & (x < x1) & (y > y0) & (y < y1)] = 0.0
        return out

    cm.add("kitchen-free-space", f, 4)


def add_demo_area(
    cm: Costmap, areas: Sequence[tuple[float, float, float, float]] = DEMO_AREAS
) -> None:
    """The demo's restricted area (score 5): 1 inside any rectangle (see
    :data:`DEMO_AREAS`)."""
    rects = tuple(areas)

    def f(x: Array, y: Array) -> Array:
        out = np.zeros_like(x)
        for x0, x1, y0, y1 in rects:
            out[(x > x0) & (x <= x1) & (y > y0) & (y < y1)] = 1.0
        return out

    bounds = (
        (
            min(r[0] for r in rects),
            max(r[1] for r in rects),
            min(r[2] for r in rects),
            max(r[3] for r in rects),
        )
        if rects
        else None
    )
    cm.add("demo-restricted-area", f, 5, bounds=bounds)


def add_reachable_for(
    cm: Costmap,
    points: Sequence[Sequence[float]],
    in_reach: float = IN_REACH_DISTANCE,
    minimal: float = REACH_MINIMAL_DISTANCE,
) -> tuple[float, float]:
    """``reachable-for``: a Gaussian (2d-pose-covariance, minvar 0.5, score 5) over the
    reach points, per point an ``in_reach`` include and a ``minimal`` exclude disc (the
    robot's arms' :class:`executive.Reach`; the PR2-like robot's 0.7 m and 0.2 m by
    default), orientation facing the mean, height 0. Returns the mean (the validator's
    reach point)."""
    mu, cov = pose_covariance(points, POSE_MINVAR)
    cm.add("pose-distribution", gaussian(mu, cov), 5)
    for p in points:
        cm.add(
            cm.unique_name("reach-range"),
            _range_fn(p[0], p[1], in_reach, False),
            7,
            bounds=_disc(p[0], p[1], in_reach),
        )
        cm.add(
            cm.unique_name("reach-minimal-range"),
            _range_fn(p[0], p[1], minimal, True),
            6,
        )
    cm.add_orientation(facing(*mu))
    cm.add_height(constant_height(0.0))
    return mu


#: The PR2-like robot's shoulders in ``base_footprint`` (x, |y|): torso x + shoulder y of
#: its URDF. A world's robot has its own (``World.shoulder_xy``).
SHOULDER_XY: Final = (_urdf.TORSO_XYZ[0], _urdf.SHOULDER_Y)
#: The PR2-like robot's shoulders by arm (the default of the drawer costmaps)
_PR2_SHOULDERS: Final = MappingProxyType(
    {"left": SHOULDER_XY, "right": (SHOULDER_XY[0], -SHOULDER_XY[1])}
)


def drawer_shoulder(
    x: float,
    y: float,
    yaw: float,
    arm: str,
    shoulders: Mapping[str, tuple[float, float]] = _PR2_SHOULDERS,
) -> tuple[float, float]:
    """The ``arm``'s shoulder point (map xy) of a base at (x, y, yaw); ``shoulders``: each
    arm's shoulder in ``base_footprint`` (default: the PR2-like robot's)."""
    sx, sy = shoulders[arm]
    c, s = math.cos(yaw), math.sin(yaw)
    return x + c * sx - s * sy, y + s * sx + c * sy


def add_reachable_in_drawer(
    cm: Costmap,
    point: Sequence[float],
    drawer_lo: Sequence[float],
    drawer_hi: Sequence[float],
    outward: tuple[float, float],
    arm: str | None,
    *,
    shoulders: Mapping[str, tuple[float, float]] = _PR2_SHOULDERS,
    in_reach: float = IN_REACH_DISTANCE,
    minimal: float = REACH_MINIMAL_DISTANCE,
) -> float:
    """``reachable-for`` a point inside an open drawer (after CRAM's ``pr2-em`` drawer
    costmaps, which choose the robot's side of the drawer by arm and orient the base
    along the drawer axis). Deviation: CRAM adds them only for ``(object <container>)``
    (the handle); here they replace the reach discs whenever the reach point lies in an
    open drawer, because from straight in front of the drawer the base (half width
    0.325 m) cannot come within 0.7 m of an object 0.2-0.3 m behind the drawer front.

    Factors: the usual Gaussian (minvar 0.5, score 5); ``drawer-side`` (score 6): beside
    the drawer strip, on the robot's right of it for the left arm (the drawer is on the
    robot's left), on its left for the right arm, either side without an arm;
    ``drawer-reach`` / ``drawer-reach-minimal`` (scores 7 / 6): the reach point within
    0.7 m (beyond 0.2 m) of that arm's *shoulder* (the base orientation is fixed, so the
    shoulder is a constant offset). Orientation: facing the cabinet along the drawer axis
    (``-outward``); height 0. ``shoulders``: the robot's arms (all of them) and their
    shoulders in ``base_footprint``; ``in_reach``/``minimal``: the arms' reach (defaults:
    the PR2-like robot's). Returns the base yaw."""
    ox, oy = outward
    yaw = math.atan2(-oy, -ox)
    fx, fy = math.cos(yaw), math.sin(yaw)
    lx, ly = -fy, fx  # the robot's left
    corners = [(a, b) for a in (drawer_lo[0], drawer_hi[0]) for b in (drawer_lo[1], drawer_hi[1])]
    left_lo = min(lx * a + ly * b for a, b in corners)
    left_hi = max(lx * a + ly * b for a, b in corners)
    px, py = float(point[0]), float(point[1])
    sides = tuple(shoulders) if arm is None else (arm,)
    mu, cov = pose_covariance([point], POSE_MINVAR)
    cm.add("pose-distribution", gaussian(mu, cov), 5)

    def side_mask(x: Array, y: Array, side: str) -> Array:
        along = lx * x + ly * y
        return along < left_lo if side == "left" else along > left_hi

    def beside(x: Array, y: Array) -> Array:
        out = np.zeros(x.shape, dtype=bool)
        for side in sides:
            out |= side_mask(x, y, side)
        return out.astype(float)

    def shoulder_distance(x: Array, y: Array) -> Array:
        best = np.full(x.shape, np.inf)
        for side in sides:
            sx, sy = drawer_shoulder(0.0, 0.0, yaw, side, shoulders)
            d = np.hypot(px - (x + sx), py - (y + sy))
            best = np.where(side_mask(x, y, side), np.minimum(best, d), best)
        return best

    def reach(x: Array, y: Array) -> Array:
        return (shoulder_distance(x, y) <= in_reach).astype(float)

    def beyond_minimal(x: Array, y: Array) -> Array:
        d = shoulder_distance(x, y)
        inside: Array = (d >= minimal) & np.isfinite(d)
        return inside.astype(float)

    cm.add("drawer-side", beside, 6)
    cm.add("drawer-reach", reach, 7)
    cm.add("drawer-reach-minimal", beyond_minimal, 6)
    cm.add_orientation(lambda _x, _y: [yaw])
    cm.add_height(constant_height(0.0))
    return yaw


def _clear_rays(
    client: int, starts: Array, ends: Array, exclude: frozenset[int], tolerance: float = 0.02
) -> Array:
    """For each ray, whether nothing but ``exclude`` bodies lies on it up to ``tolerance``
    before its end. Rays that hit an excluded body are cast on from just behind the hit."""
    n = len(starts)
    clear = np.zeros(n, dtype=bool)
    todo = np.arange(n)
    cur = starts.astype(float).copy()
    ends = np.asarray(ends, dtype=float)
    batch = pb.MAX_RAY_INTERSECTION_BATCH_SIZE
    excluded = np.fromiter(exclude, dtype=int, count=len(exclude))
    for _ in range(6):
        if todo.size == 0:
            break
        again: list[Array] = []
        for k in range(0, todo.size, batch):
            part = todo[k : k + batch]
            res = pb.rayTestBatch(cur[part].tolist(), ends[part].tolist(), physicsClientId=client)
            # vectorised per-ray verdicts (this loop is the visibility costmap's hot spot)
            columns = tuple(zip(*res))  # (body, link, fraction, position, normal) columns
            body = np.asarray(columns[0], dtype=int)
            frac = np.asarray(columns[2], dtype=float)
            seg = ends[part] - cur[part]
            length = np.sqrt((seg * seg).sum(axis=1))
            done = (body < 0) | ((1.0 - frac) * length <= tolerance)
            clear[part[done]] = True
            on = ~done & np.isin(body, excluded)
            if on.any():
                idx = part[on]
                hit = np.asarray(columns[3], dtype=float)[on]
                step = seg[on] / np.maximum(length[on], 1e-9)[:, None] * 1e-3
                cur[idx] = hit + step
                again.append(idx)
        todo = np.concatenate(again) if again else np.empty(0, dtype=int)
    return clear


def add_visible_for(
    cm: Costmap,
    client: int,
    target: Sequence[float],
    exclude: frozenset[int],
    heights: Sequence[float] = CAMERA_HEIGHTS,
) -> None:
    """``visible-for``: Gaussian around the target (minvar 0.5), range 2 m, orientation
    facing it, height 0, and the visibility factor (score 20, expensive): for each cell of
    the 2 x 2 m window around the target closer than 1 m (horizontally), the fraction of
    rays from the camera heights above the cell to the target that nothing but the
    ``exclude`` bodies blocks (PyBullet ``rayTestBatch``; CRAM renders depth images)."""
    tx, ty, tz = (float(v) for v in target[:3])
    mu, cov = pose_covariance([target], POSE_MINVAR)
    cm.add("pose-distribution", gaussian(mu, cov), 5)
    cm.add(
        "visibility-range",
        _range_fn(tx, ty, VISIBILITY_SIZE, False),
        7,
        bounds=_disc(tx, ty, VISIBILITY_SIZE),
    )
    hs = np.asarray(heights, dtype=float)
    half = VISIBILITY_SIZE / 2.0

    def f(x: Array, y: Array) -> Array:
        out = np.zeros_like(x)
        idx = np.nonzero(np.hypot(x - tx, y - ty) < half)[0]
        if idx.size == 0:
            return out
        k = hs.size
        starts = np.empty((idx.size * k, 3))
        starts[:, 0] = np.repeat(x[idx], k)
        starts[:, 1] = np.repeat(y[idx], k)
        starts[:, 2] = np.tile(hs, idx.size)
        ends = np.tile(np.asarray([tx, ty, tz]), (starts.shape[0], 1))
        clear = _clear_rays(client, starts, ends, exclude)
        out[idx] = clear.reshape(idx.size, k).mean(axis=1)
        return out

    cm.add("visibility", f, 20, expensive=True, bounds=_disc(tx, ty, half))
    cm.add_orientation(facing(tx, ty))
    cm.add_height(constant_height(0.0))


def add_on_box(
    cm: Costmap,
    label: str,
    lo: Sequence[float],
    hi: Sequence[float],
    object_height: float | None = None,
) -> None:
    """``on``: 1 strictly inside the surface's AABB (score 5); height its top, or top +
    ``object_height`` / 2 with ``for``."""
    cm.add(f"on-bounding-box-{label}", _box_fn(lo, hi), 5, bounds=(lo[0], hi[0], lo[1], hi[1]))
    top = float(hi[2]) + (object_height / 2.0 if object_height is not None else 0.0)
    cm.add_height(constant_height(top))


def add_in_box(cm: Costmap, label: str, lo: Sequence[float], hi: Sequence[float]) -> None:
    """``in``: 1 strictly inside the container's AABB (score 5); height its bottom +
    :data:`BOARD_THICKNESS`."""
    cm.add(f"in-bounding-box-{label}", _box_fn(lo, hi), 5, bounds=(lo[0], hi[0], lo[1], hi[1]))
    z = float(lo[2]) + BOARD_THICKNESS
    cm.add_height(constant_height(z))


_SIDES: Final = {"front": (0, False), "back": (0, True), "right": (1, False), "left": (1, True)}


def add_side(cm: Costmap, side: str, origin: Sequence[float]) -> None:
    """``side``: HEAD's world-axes half-plane through the link origin (score 5): front
    x < lx, back x > lx, right y < ly, left y > ly. Unknown side -> ValueError."""
    if side not in _SIDES:
        raise ValueError(f"unknown side {side!r}; known sides: {', '.join(_SIDES)}")
    axis, greater = _SIDES[side]
    c = float(origin[axis])

    def f(x: Array, y: Array) -> Array:
        v = x if axis == 0 else y
        return (v > c if greater else v < c).astype(float)

    cm.add(f"side-{side}", f, 5)


def add_range(cm: Costmap, origin: Sequence[float], r: float, invert: bool) -> None:
    """``range`` / ``range-invert``: keep distance <= r (>= r inverted) from the link
    origin's xy (score 2)."""
    base = "range-invert" if invert else "range"
    ox, oy = float(origin[0]), float(origin[1])
    cm.add(cm.unique_name(base), _range_fn(ox, oy, r, invert), 2, bounds=_disc(ox, oy, r, invert))


def slot_centres(
    lo: Sequence[float],
    hi: Sequence[float],
    paddings: Sequence[float],
    object_type: str,
    count: int,
    yaw: float = 0.0,
) -> list[tuple[float, float]]:
    """Table-setting slot centres in map xy (CRAM's ``make-slot-cost-function``) for a
    surface AABB, paddings (x+, x-, y+, y-), the object type and ``object-count``."""
    xp, xm, yp, ym = paddings
    smax, smin = SLOT_SIZES.get(object_type, (0.8, 0.5))
    dims = (hi[0] - lo[0] - (xp + xm), hi[1] - lo[1] - (yp + ym))
    centre = ((lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0)
    shift = ((xm - xp) / 2.0, (ym - yp) / 2.0)
    long_axis = 0 if dims[0] >= dims[1] else 1
    length, short = dims[long_axis], dims[1 - long_axis]
    if length <= 0 or short <= 0:
        return []
    n = min(int(count), 2 * math.floor(length / smin))
    if n <= 0:
        return []
    n_pref, n_other = math.ceil(n / 2), n // 2
    d = min(length / n_pref, smax)
    c = short / 2.0 - smin / 2.0
    local: list[tuple[float, float]] = []
    for k, across in ((n_pref, c), (n_other, -c)):
        for i in range(k):
            along = (k - 1) / 2.0 * d - i * d
            local.append((along, across) if long_axis == 0 else (across, along))
    cy, sy = math.cos(yaw), math.sin(yaw)
    ox = centre[0] + cy * shift[0] - sy * shift[1]
    oy = centre[1] + sy * shift[0] + cy * shift[1]
    return [(ox + cy * a - sy * b, oy + sy * a + cy * b) for a, b in local]


def add_slots(
    cm: Costmap,
    label: str,
    lo: Sequence[float],
    hi: Sequence[float],
    object_type: str,
    count: int,
    yaw: float = 0.0,
) -> list[tuple[float, float]]:
    """``context table-setting`` + ``on`` + ``for`` + ``object-count`` (score 6): 1 within
    the type's position-deviation threshold of a slot centre. Returns the centres."""
    centres = slot_centres(lo, hi, SLOT_PADDINGS.get(label, (0.03,) * 4), object_type, count, yaw)
    thr = SLOT_THRESHOLDS.get(object_type, 0.1)
    pts = np.asarray(centres, dtype=float).reshape(-1, 2)

    def f(x: Array, y: Array) -> Array:
        if pts.size == 0:
            return np.zeros_like(x)
        d = np.hypot(x[:, None] - pts[None, :, 0], y[:, None] - pts[None, :, 1]).min(axis=1)
        return np.asarray(d <= thr, dtype=float)

    bounds = (
        (
            float(pts[:, 0].min()) - thr,
            float(pts[:, 0].max()) + thr,
            float(pts[:, 1].min()) - thr,
            float(pts[:, 1].max()) + thr,
        )
        if pts.size
        else None
    )
    cm.add("table-setting-slots", f, 6, bounds=bounds)
    return centres


def near_size(object_type: str | None, size: Sequence[float]) -> float:
    """The reference size of ``near``/``far-from`` by shape: circle (bowl, plate) AABB x;
    complex (mug, pot) min(x, y), i.e. the body without its handle; rectangle min(x, y)."""
    shape = _SHAPES.get(object_type or "", "rectangle")
    if shape == "circle":
        return float(size[0])
    if shape == "oval":
        return float(max(size[0], size[1]))
    return float(min(size[0], size[1]))


def near_padding(object_type: str | None) -> float:
    """Padding by type: bowl 0.03, cup 0.1, mug 0.01, plate 0.005, default 0.01."""
    return _NEAR_PADDINGS.get(object_type or "", 0.01)


def add_near(
    cm: Costmap, centre: Sequence[float], s_ref: float, p_ref: float, s_for: float, p_for: float
) -> None:
    """``near``: exclude a disc of radius sR/2 + pR + pF + sF/2, include one of that + (sR +
    sF) / 2, and a Gaussian with σ = 1 around the reference (score 5)."""
    r_min = s_ref / 2 + p_ref + p_for + s_for / 2
    width = (s_ref + s_for) * 0.5 * 1.0
    cx, cy = float(centre[0]), float(centre[1])
    cm.add(cm.unique_name("near-exclude"), _range_fn(cx, cy, r_min, True), 5)
    cm.add(
        cm.unique_name("near-include"),
        _range_fn(cx, cy, r_min + width, False),
        5,
        bounds=_disc(cx, cy, r_min + width),
    )
    cm.add(cm.unique_name("near-gauss"), gaussian((cx, cy), np.eye(2)), 5)


def add_far_from(
    cm: Costmap, centre: Sequence[float], s_ref: float, p_ref: float, s_for: float, p_for: float
) -> None:
    """``far-from``: a ring from 1.5 sR + 3 pR + pF + sF/2 (if sR > sF; else sR/2 + pR + 3 pF
    + 1.5 sF) of width (sR + sF) / 2 * 5 (score 5)."""
    if s_ref > s_for:
        r_min = 1.5 * s_ref + 3 * p_ref + p_for + s_for / 2
    else:
        r_min = s_ref / 2 + p_ref + 3 * p_for + 1.5 * s_for
    width = (s_ref + s_for) * 0.5 * 5.0
    cx, cy = float(centre[0]), float(centre[1])
    cm.add(cm.unique_name("far-exclude"), _range_fn(cx, cy, r_min, True), 5)
    cm.add(
        cm.unique_name("far-include"),
        _range_fn(cx, cy, r_min + width, False),
        5,
        bounds=_disc(cx, cy, r_min + width),
    )


def closest_edge(
    lo: Sequence[float], hi: Sequence[float], point: Sequence[float], yaw: float = 0.0
) -> str:
    """The supporting body's edge closest to ``point`` in the body frame: ``front`` (-x),
    ``back`` (+x), ``right`` (-y) or ``left`` (+y); distances to the short edges are
    scaled by the aspect ratio so that long edges are preferred."""
    cx, cy = (lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0
    a, b = (hi[0] - lo[0]) / 2.0, (hi[1] - lo[1]) / 2.0
    c, s = math.cos(-yaw), math.sin(-yaw)
    dx, dy = point[0] - cx, point[1] - cy
    x, y = c * dx - s * dy, s * dx + c * dy
    x_edge = "back" if x >= 0 else "front"
    y_edge = "left" if y >= 0 else "right"
    dist_x = a - abs(x)  # to the edge perpendicular to x
    dist_y = b - abs(y)  # to the edge perpendicular to y
    if b > a:
        dist_y *= b / a
    elif a > b:
        dist_x *= a / b
    return x_edge if dist_x <= dist_y else y_edge


#: (edge, relation) -> (axis, greater) of the potential field, in the body frame.
_RELATIONS: Final = {
    "front": {
        "left-of": (1, True),
        "right-of": (1, False),
        "behind": (0, True),
        "in-front-of": (0, False),
    },
    "back": {
        "left-of": (1, False),
        "right-of": (1, True),
        "behind": (0, False),
        "in-front-of": (0, True),
    },
    "right": {
        "left-of": (0, False),
        "right-of": (0, True),
        "behind": (1, True),
        "in-front-of": (1, False),
    },
    "left": {
        "left-of": (0, True),
        "right-of": (0, False),
        "behind": (1, False),
        "in-front-of": (1, True),
    },
}
RELATIONS: Final = ("left-of", "right-of", "in-front-of", "behind")


def add_relation(
    cm: Costmap,
    relation: str,
    reference: Sequence[float],
    support: Box2 | None,
    edge: str,
    yaw: float = 0.0,
    margin: float = 0.0,
) -> None:
    """``left-of`` / ``right-of`` / ``in-front-of`` / ``behind``: the supporting body's
    AABB (score 9, when there is one) and the potential field (score 7) at the reference's
    xy in the body's frame: |p_axis| / |p| where the relation's predicate holds and that is
    > 0.2, else 0. Deviation: the support box is shrunk by ``margin`` on every side (the
    caller passes the ``for`` object's half footprint plus a clearance), so the placed
    object lies wholly on its support; CRAM's bare AABB let its centre reach the edge,
    half off the counter (v0.8.1 then relied on its stability check)."""
    if relation not in RELATIONS:
        raise ValueError(f"unknown relation {relation!r}; known: {', '.join(RELATIONS)}")
    if support is not None:
        lo = (support[0][0] + margin, support[0][1] + margin)
        hi = (support[1][0] - margin, support[1][1] - margin)
        cm.add("supporting-object", _box_fn(lo, hi), 9, bounds=(lo[0], hi[0], lo[1], hi[1]))
    axis, greater = _RELATIONS[edge][relation]
    ox, oy = float(reference[0]), float(reference[1])
    c, s = math.cos(yaw), math.sin(yaw)

    def f(x: Array, y: Array) -> Array:
        dx, dy = x - ox, y - oy
        px, py = c * dx + s * dy, -s * dx + c * dy
        pa = px if axis == 0 else py
        norm = np.hypot(px, py)
        with np.errstate(invalid="ignore", divide="ignore"):
            v = np.where(norm > 0, np.abs(pa) / np.where(norm > 0, norm, 1.0), 0.0)
        ok = (pa > 0) if greater else (pa < 0)
        return np.where(ok & (v > 0.2), v, 0.0)

    cm.add(cm.unique_name(f"potential-field-{relation}"), f, 7)
