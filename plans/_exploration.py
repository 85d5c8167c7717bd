"""How projection reasoning's imagined runs explore: each run its own alternative.

:class:`Exploration` tells imagined run ``i`` of ``runs`` which arm it takes and which
region of a location designator's solutions (a shared pool, cut by bearing with
:func:`partition_by_bearing`) it tries first; the ``(among ...)`` location generator gives
those poses, then the plan's own designator. Used by :mod:`plans.reasoning`.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from itertools import islice
from typing import Any

from executive import (
    Designator,
    DesignatorError,
    Environment,
    Key,
    LocationDesignator,
    Pose,
    RuleDoc,
    a,
    current_environment,
    register_location_generator,
)

__all__ = [
    "POOL_PER_RUN",
    "Exploration",
    "explored_arms",
    "learned_weight",
    "partition_by_bearing",
    "to_pose",
    "wrap",
]

from ._common import arms_left_to_right

log = logging.getLogger("plans.reasoning")


#: Samples drawn per imagined run into a shared pool (see :class:`Exploration`).
POOL_PER_RUN = 4


def explored_arms() -> tuple[str | None, ...]:
    """The arms imagined runs explore when the caller fixed none: ``None`` (the plan
    chooses), then each of the environment's robot's arms in CRAM's left, right order;
    run ``i`` (1-based) takes element ``(i - 1) % len``. The PR2-like robot: none, left,
    right; a one-armed robot: none, left."""
    return (None, *arms_left_to_right())


def _bearing(pose: Pose, around: Sequence[float]) -> float:
    return math.atan2(pose.position[1] - around[1], pose.position[0] - around[0])


def wrap(angle: float) -> float:
    """``angle`` (rad) wrapped into (-pi, pi]."""
    return math.atan2(math.sin(angle), math.cos(angle))


def partition_by_bearing(
    poses: Sequence[Pose], around: Sequence[float], parts: int
) -> list[tuple[Pose, ...]]:
    """Cut ``poses`` into ``parts`` contiguous regions by their bearing seen from
    ``around`` (x, y). Bearings are taken relative to the poses' circular mean, so a region
    never straddles the far side; each region keeps the draw order of its poses. Sizes
    differ by at most one; with fewer poses than parts the last regions are empty."""
    if parts < 1:
        raise ValueError(f"partition_by_bearing needs at least one part, got {parts}")
    if not poses:
        return [() for _ in range(parts)]
    bearings = [_bearing(p, around) for p in poses]
    mean = math.atan2(sum(map(math.sin, bearings)), sum(map(math.cos, bearings)))
    order = sorted(range(len(poses)), key=lambda i: wrap(bearings[i] - mean))
    size, extra = divmod(len(poses), parts)
    regions: list[tuple[Pose, ...]] = []
    start = 0
    for k in range(parts):
        end = start + size + (1 if k < extra else 0)
        members = sorted(order[start:end])  # draw order inside a region
        regions.append(tuple(poses[i] for i in members))
        start = end
    return regions


def learned_weight(action: str, obj_type: Any, target: Pose) -> Callable[[Pose], float] | None:
    """The environment's learned base density (:meth:`executive.Preferences.base_density`)
    for ``action`` on ``obj_type`` at ``target`` (map frame), as a function of a base pose
    facing it; None without preferences or with nothing learned for the type."""
    preferences = current_environment().preferences
    if preferences is None or not isinstance(obj_type, str):
        return None
    density = preferences.base_density(action, obj_type)
    if density is None:
        return None
    tx, ty = target.position[0], target.position[1]
    oyaw = target.yaw

    def weight(base: Pose) -> float:
        dx, dy = base.position[0] - tx, base.position[1] - ty
        c, s = math.cos(oyaw), math.sin(oyaw)
        yaw = wrap(base.yaw - oyaw)
        return float(density(c * dx + s * dy, -s * dx + c * dy, yaw))

    return weight


def _among_generator(d: Designator, env: Environment) -> Iterator[Pose] | None:
    """``(among (P1 P2 ...))``: exactly those poses, in order (an imagined run's region);
    with ``(then L)``, followed by the solutions of location designator ``L`` that are not
    among them (the plan's own designator once the region is used up)."""
    del env
    if "among" not in d:
        return None
    poses = d["among"]
    if not isinstance(poses, tuple) or not all(isinstance(p, Pose) for p in poses):
        raise DesignatorError(f"{d.short()}: (among ...) takes a tuple of executive.Pose", d)
    fallback = d.get("then")
    if fallback is None:
        return iter(poses)
    if not isinstance(fallback, LocationDesignator):
        raise DesignatorError(f"{d.short()}: (then ...) takes a location designator", d)
    return _region_then(poses, fallback)


def _region_then(poses: tuple[Pose, ...], fallback: LocationDesignator) -> Iterator[Pose]:
    yield from poses
    for p in fallback.current().solutions():
        if not any(p == q for q in poses):
            yield p


register_location_generator(
    _among_generator,
    10,
    doc=RuleDoc(
        "An imagined run's region of poses, then (optionally) the plan's own designator.",
        raises=(DesignatorError,),
        keys=(
            Key("among", "tuple of executive.Pose", "exactly these poses, in order", default="-"),
            Key(
                "then",
                "location designator",
                "after the poses, its solutions that are not among them",
                default="nothing after the poses",
            ),
        ),
    ),
)


@dataclass(eq=False)
class Exploration:
    """Which alternative imagined run ``run`` (1-based) of ``runs`` explores.

    How the alternatives are drawn (so that ``runs=3`` compares three different choices,
    not three draws from one distribution):

    * **base-pose regions and placing targets** (:meth:`region`): the first run that asks
      for a pool ``key`` draws ``POOL_PER_RUN * runs`` solutions of the plan's own location
      designator (the same costmap, validated as usual, drawn with the belief world's
      generator); the pool is kept in ``pools``, shared by all runs of one projection. It is
      cut by bearing around a centre (the object for a pick base pose, the pool's centroid
      for placing targets) into ``runs`` contiguous regions (:func:`partition_by_bearing`):
      run ``i`` gets region ``i`` as an ``(among ...)`` location, whose solutions are that
      region's poses in draw order, then (``(then ...)``) the plan's own designator's
      other solutions: the relocation retries start in the region and, once it is used
      up, go on as without reasoning (a region of 4 poses used to end a fetch that has 10
      relocations after the 4th failure, with ``ObjectUnfetchable``). A
      pool too small for a region (e.g. a fixed pose target) leaves later runs on the
      plan's own designator.
    * **arm**: ``explored_arms()[(run - 1) % n]`` = unconstrained / left / right (a
      one-armed robot: unconstrained / left), unless the caller fixed the arm.
    * the grasp follows from arm and base pose (the picking checks choose it).

    ``explored`` records what this run was given (for the task tree and the demo)."""

    run: int
    runs: int
    pools: dict[str, tuple[Pose, ...]] = field(default_factory=dict)  # shared by the runs
    explored: dict[str, Any] = field(default_factory=dict)  # this run's choices

    def __post_init__(self) -> None:
        if not 1 <= self.run <= self.runs:
            raise ValueError(f"Exploration run must be in 1..{self.runs}, got {self.run}")

    def arm(self, given: str | None) -> str | None:
        """The arm this run explores (``given`` when the caller fixed one)."""
        if given is not None:
            arm: str | None = given
        else:
            arms = explored_arms()
            arm = arms[(self.run - 1) % len(arms)]
        self.explored["arm"] = arm or "any"
        return arm

    def region(
        self,
        key: str,
        designator: LocationDesignator,
        around: Sequence[float] | None = None,
        weight: Callable[[Pose], float] | None = None,
    ) -> LocationDesignator:
        """This run's region of ``designator``'s solutions (see the class docstring);
        ``around`` = the (x, y) centre of the bearings, default the pool's centroid.
        ``weight`` (learned from experience, :func:`learned_weight`): the regions are
        handed out by their poses' mean weight, highest to run 1 (a stable order, so
        equal weights keep the bearing order); None: by bearing."""
        pool = self.pools.get(key)
        if pool is None:
            try:
                n = POOL_PER_RUN * self.runs
                pool = tuple(to_pose(p) for p in islice(iter(designator.solutions()), n))
            except DesignatorError as error:
                log.info("no pool for %s: %s", key, error)
                pool = ()
            self.pools[key] = pool
        if around is None and pool:
            around = (
                sum(p.position[0] for p in pool) / len(pool),
                sum(p.position[1] for p in pool) / len(pool),
            )
        regions = partition_by_bearing(pool, around or (0.0, 0.0), self.runs)
        order = list(range(self.runs))
        if weight is not None:
            means = [sum(map(weight, r)) / len(r) if r else -math.inf for r in regions]
            order.sort(key=lambda k: -means[k])
        index = order[self.run - 1]
        mine = regions[index]
        if not mine:
            self.explored[key] = "plan's own"
            return designator
        bearing = math.degrees(_bearing(mine[0], around or (0.0, 0.0)))
        self.explored[key] = f"region {index + 1}/{self.runs} ({bearing:+.0f}°)"
        return a.location(among=mine, then=designator)


def to_pose(value: Any) -> Pose:
    if not isinstance(value, Pose):
        raise DesignatorError(f"a location solution must be a Pose, got {value!r}")
    return value
