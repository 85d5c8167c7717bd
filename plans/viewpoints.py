"""Choosing where to look from by projection (issue 14: projection beyond one transport).

The robot's belief does not know an object it has not perceived yet, so imagining a
search cannot predict *finding* it. But the plan knows *where it will look*: the search
location (e.g. on the sink counter, in the drawer) and the sample of it the search is at.
:func:`navigate_to_best_viewpoint` imagines looking at that region from a few candidate
base poses and drives to the one predicted to see most of it:

* **candidates**: :data:`POOL` solutions of the search's own ``visible-for`` location (the
  visibility costmap of the current sample, validated as usual, drawn with the belief
  world's generator), cut by bearing around the sample into ``runs`` regions
  (:func:`plans.reasoning.partition_by_bearing`); each region's first pose is a
  candidate, so the candidates look from different sides; they are imagined in draw
  order, so the plan's own first choice (the pool's first pose) is the first;
* **imagined look**: each candidate is an :func:`plans.imagining.imagine_best` alternative
  (subtree ``imagine-viewpoint-<i>``): in the imagination (the belief world, which knows
  every occluder perceived so far) the robot navigates there, parks its arms out of view,
  turns towards the sample, and then, one at a time, a stand-in of the sought object type
  is spawned at each of :data:`REGION_POINTS` sample points of the search region (the
  current sample and the next ones of the search location) and detected by name: real
  PyBullet ray tests in the camera's frustum. The alternative returns how many it saw;
* **choice**: a candidate whose imagined navigation failed loses; then most points seen;
  a tie goes to the earlier candidate, i.e. to the plan's own choice, so projection only
  overrides it where it predicts a better view. (Breaking ties by the route cost from
  where the robot stands, :func:`plans.reasoning.route_cost`, is ``look_from_best``'s
  ``by_cost``; on the 10-seed campaign it delivered fewer objects: issue-14 note.)
  The winner runs for real as ``chosen-viewpoint-<i>``: the robot
  navigates to it (the other candidates and the rest of the pool follow as the
  location's further solutions, so a collision there tries the next best).

It composes with the search's retries: a search failure at that sample moves to the next
sample, which chooses its viewpoint anew. Pass-through (navigate to the plain
``visible-for`` location, nothing drawn) when the environment is projecting, cannot
imagine, or its imagined world cannot spawn the stand-ins (not an
:class:`executive.ObjectSpawning`, e.g. an in-memory fake). Deliberate difference from CRAM,
which samples the visibility costmap for one point and never imagines a search.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from itertools import islice
from typing import Any

from executive import (
    Designator,
    DesignatorError,
    LocationDesignator,
    ObjectSpawning,
    Pose,
    a,
    an,
    current_environment,
    perform,
)
from executive.failures import PerceptionLowLevelFailure

from ._exploration import partition_by_bearing, to_pose
from .imagining import Imagined, imagine_best, imagining
from .reasoning import route_cost

__all__ = ["POOL", "REGION_POINTS", "STAND_IN", "look_from_best", "navigate_to_best_viewpoint"]

log = logging.getLogger("plans.viewpoints")

#: Solutions of the ``visible-for`` location drawn as the candidates' pool.
POOL = 9
#: Sample points of the search region each imagined look checks (current sample first).
REGION_POINTS = 4
#: Candidate viewpoints (pool regions) imagined.
RUNS = 3
#: The name prefix of the stand-ins spawned in imagination.
STAND_IN = "viewpoint-stand-in"


def _scene(world: Any) -> ObjectSpawning | None:
    """The imagined world, if it can host stand-ins (:class:`executive.ObjectSpawning`)."""
    return world if isinstance(world, ObjectSpawning) else None


def _region_points(sample: Designator, spot: Pose) -> list[Pose]:
    """The current sample and the next solutions of the search location (distinct by
    more than 5 cm), :data:`REGION_POINTS` in all."""
    points = [spot]
    try:
        for value in islice(iter(sample.solutions()), 1, 4 * REGION_POINTS):
            pose = to_pose(value)
            if all(pose.distance_to(p) > 0.05 for p in points):
                points.append(pose)
            if len(points) >= REGION_POINTS:
                break
    except (DesignatorError, ValueError) as error:
        log.info("search region: %s", error)
    return points


async def _points_seen(object_type: str, points: Sequence[Pose]) -> int:
    """In imagination: spawn a stand-in at each point in turn, detect it by name."""
    scene = _scene(current_environment().world)
    assert scene is not None  # checked before imagining
    seen = 0
    for k, point in enumerate(points):
        name = f"{STAND_IN}-{k}"
        try:
            scene.spawn_object(name, object_type, point)
        except Exception as error:  # an occupied point: not counted either way
            log.info("no stand-in at %s: %s", point, error)
            continue
        try:
            # the detecting motion itself (one look, no retries): is it seen from here?
            await perform(a.motion(type="detecting", object=an.object(type=object_type, name=name)))
            seen += 1
        except PerceptionLowLevelFailure:
            pass  # hidden from there
        finally:
            scene.remove_object(name)
    return seen


async def navigate_to_best_viewpoint(
    object_designator: Designator, sample: Designator, spot: Pose, view: LocationDesignator
) -> dict[str, Pose]:
    """Navigate to the viewpoint of ``view`` (the ``visible-for`` location of ``spot``, the
    search location ``sample``'s current solution) predicted to see most of the search
    region (see the module docstring). Returns the candidates imagined, by alternative
    name (empty: a pass-through navigated to ``view``)."""
    env = current_environment()
    imagination = env.imagination
    object_type = object_designator.get("type")
    if env.projecting or imagination is None or not isinstance(object_type, str):
        await perform(an.action(type="navigating", location=view))
        return {}
    async with imagination.projection():
        spawnable = _scene(current_environment().world) is not None
    if not spawnable:
        await perform(an.action(type="navigating", location=view))
        return {}
    try:
        pool = [to_pose(p) for p in islice(iter(view.solutions()), POOL)]
    except DesignatorError as error:
        log.info("no viewpoints for %s: %s", spot, error)
        pool = []
    firsts = [r[0] for r in partition_by_bearing(pool, spot.position[:2], RUNS) if r]
    # in draw order: the plan's own first choice (the pool's first pose) comes first and
    # wins every tie, so projection only overrides it where it predicts a better view
    candidates = sorted(firsts, key=lambda p: next(i for i, q in enumerate(pool) if q is p))
    if len(candidates) < 2:
        await perform(an.action(type="navigating", location=view))
        return {}
    points = _region_points(sample, spot)
    return await look_from_best(object_type, candidates, points, spot, pool, by_cost=False)


async def look_from_best(
    object_type: str,
    candidates: Sequence[Pose],
    points: Sequence[Pose],
    spot: Pose,
    fallback: Sequence[Pose] = (),
    *,
    by_cost: bool = False,
) -> dict[str, Pose]:
    """Imagine looking at ``points`` from each of ``candidates`` (the alternatives
    ``viewpoint-<i>``), then navigate for real to the one that saw most of them; on a tie
    the earlier candidate (with ``by_cost``: the cheaper route from where the robot
    stands, then the earlier); ``fallback``: further poses to try if navigating there
    fails. Returns the candidates by alternative name."""
    env = current_environment()
    start = env.world.robot_pose() if env.has_world else None
    names = {f"viewpoint-{i}": pose for i, pose in enumerate(candidates, start=1)}

    def alternative(pose: Pose) -> Any:
        async def look_from() -> int:
            rest = [pose, *[p for p in (*candidates, *fallback) if p is not pose]]
            where = a.location(among=tuple(rest))
            await perform(an.action(type="navigating", location=where))
            if imagining() is None:
                return 0  # the real robot: looking is the search's own business
            from .search import arms_out_of_view

            await arms_out_of_view()
            await perform(an.action(type="turning-towards", target=a.location(pose=spot)))
            return await _points_seen(object_type, points)

        return look_from

    def score(imagined: Imagined) -> tuple[Any, ...]:
        seen = imagined.value if isinstance(imagined.value, int) else -1
        cost = route_cost([start, names[imagined.name]]) if by_cost and start is not None else 0.0
        return (not imagined.succeeded, -seen, cost)  # then the earlier candidate

    await imagine_best({n: alternative(p) for n, p in names.items()}, score)
    return names
