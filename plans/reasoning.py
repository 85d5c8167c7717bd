"""Projection reasoning (CRAM's ``cram_pr2_projection_reasoning``): imagine a plan a few
times, then run it for real with the parameters of the best imagined run.

:func:`with_projected_task_tree` runs ``body`` ``runs`` times in the current
environment's imagination (:class:`executive.Imagination`: a projection environment over
the belief world, restored from a snapshot before every run and after the last), each run
a named subtree ``projection-run-<i>`` of the task tree; then ``pick`` reads those live
subtrees and chooses the parameters, and ``body`` runs for real as ``real-run``.
:func:`pick_best_parameters_by_distance` is CRAM's choice: the successful run whose base
route (current pose -> pick base pose -> place base pose) is shortest.

Where we differ from CRAM: its macro is a no-op in simulation (the demo runs inside a
projection environment and disables the flag); ours is enabled by default and runs
wherever the environment has an imagination and is not itself projecting (a real robot's
environment). Imagined failures also include designator errors (CRAM: plan failures only).
Retries granted in imagination are not tallied in the caller's :func:`retry_ledger`.
"""

from __future__ import annotations

import logging
from collections.abc import Awaitable, Callable, Sequence
from dataclasses import dataclass
from itertools import pairwise
from typing import TypeVar

import cpl
from executive import (
    ActionDesignator,
    DesignatorError,
    LocationDesignator,
    Pose,
    a,
    current_environment,
    newest_effective,
    performed,
    previous_performed,
)

from ._common import retry_ledger

__all__ = [
    "ProjectedParameters",
    "pick_best_parameters_by_distance",
    "projected_parameters",
    "route_cost",
    "with_projected_task_tree",
]

log = logging.getLogger("plans.reasoning")

T = TypeVar("T")


@dataclass(frozen=True)
class ProjectedParameters:
    """What projection injects into fetch and deliver (CRAM's four variables): the
    ``fetching`` robot location and ``picking-up`` action, the ``delivering`` robot
    location and ``placing`` action; ``None`` = not injected (the plans choose)."""

    fetch_robot_location: LocationDesignator | None = None
    pick_up_action: ActionDesignator | None = None
    deliver_robot_location: LocationDesignator | None = None
    place_action: ActionDesignator | None = None


#: ``pick(runs, start_pose)``: the run subtrees (in order) and the robot's base pose before
#: imagining -> the parameters for the real run, or ``None`` (then nothing is injected).
Pick = Callable[[Sequence[cpl.Task], Pose | None], ProjectedParameters | None]


# ------------------------------------------------------------------------ extraction
def _navigation_location(action: ActionDesignator) -> LocationDesignator | None:
    """The newest effective location of a ``navigating`` action (the sample that passed
    the collision check)."""
    newest = newest_effective(action) or action
    location = newest.get("location")
    if isinstance(location, Pose):
        location = a.location(pose=location)
        location.reference()
    if not isinstance(location, LocationDesignator):
        return None
    return newest_effective(location)


def _step_and_navigation(
    run: cpl.Task, outer: str, inner: str
) -> tuple[ActionDesignator | None, LocationDesignator | None]:
    """The newest effective ``inner`` action of the last successful ``inner`` task under
    the last successful ``outer`` task of ``run``, and the location of the ``navigating``
    sibling before it."""
    outers = performed(run, outer)
    if not outers:
        return None, None
    inners = performed(outers[-1][0], inner)
    if not inners:
        return None, None
    task, action = inners[-1]
    navigation = previous_performed(task, "navigating")
    location = _navigation_location(navigation[1]) if navigation is not None else None
    return newest_effective(action), location


def projected_parameters(run: cpl.Task) -> ProjectedParameters:
    """CRAM's task-tree query for one run: the successful ``fetching`` and its successful
    ``picking-up``, the successful ``delivering`` and its successful ``placing``, and the
    ``navigating`` sibling before each; their newest effective designators. A field is
    ``None`` where the query finds nothing (e.g. the run failed before placing)."""
    pick_up, pick_location = _step_and_navigation(run, "fetching", "picking-up")
    place, place_location = _step_and_navigation(run, "delivering", "placing")
    return ProjectedParameters(pick_location, pick_up, place_location, place)


def route_cost(route: Sequence[Pose]) -> float:
    """The sum over consecutive poses of ``‖Δxyz‖ + |angle between the orientations|``
    (CRAM: both weights 1). Poses in different frames: ValueError."""
    return sum(p.distance_to(q) + p.angle_to(q) for p, q in pairwise(route))


def _run_cost(params: ProjectedParameters, start: Pose | None) -> float | None:
    if params.fetch_robot_location is None or params.deliver_robot_location is None:
        return None
    if params.pick_up_action is None or params.place_action is None:
        return None
    try:
        route = [params.fetch_robot_location.reference(), params.deliver_robot_location.reference()]
        return route_cost(route if start is None else [start, *route])
    except (DesignatorError, ValueError) as error:
        log.info("projected run without a usable route: %s", error)
        return None


def pick_best_parameters_by_distance(
    runs: Sequence[cpl.Task], start_pose: Pose | None
) -> ProjectedParameters | None:
    """CRAM's ``pick-best-parameters-by-distance``: extract each run's parameters
    (:func:`projected_parameters`), cost the route ``start_pose`` -> pick base pose ->
    place base pose (:func:`route_cost`; without a start pose, just the second leg), and
    return the cheapest complete run's parameters (the earliest on a tie). ``None`` when
    no run is complete (none picked and placed)."""
    best: tuple[float, ProjectedParameters] | None = None
    for run in runs:
        if run.state is not cpl.Status.SUCCEEDED:
            continue
        params = projected_parameters(run)
        cost = _run_cost(params, start_pose)
        log.info("projected run %s: cost %s", run.name, cost)
        if cost is not None and (best is None or cost < best[0]):
            best = (cost, params)
    return best[1] if best is not None else None


# ---------------------------------------------------------------------------- the macro
async def with_projected_task_tree(
    body: Callable[[ProjectedParameters], Awaitable[T]],
    runs: int = 3,
    pick: Pick = pick_best_parameters_by_distance,
    *,
    enabled: bool = True,
) -> T:
    """Imagine ``body`` ``runs`` times, then run it for real with the picked parameters
    (CRAM's ``with-projected-task-tree``).

    Pass-through (``body(ProjectedParameters())`` once, no subtrees) when ``enabled`` is
    false, the current environment is ``projecting``, or it has no ``imagination``.
    Otherwise: snapshot the belief world; in the imagination's projection environment, for
    each run restore the snapshot and run ``body(ProjectedParameters())`` as the subtree
    ``projection-run-<i>``; a plan failure or designator error ends that run only (its
    subtree is FAILED). The snapshot is restored after the last run, also when a run
    raises something else or the caller is evaporated (the projection environment is
    left first, which stops its goals; restoring does not await). Then ``pick(run tasks,
    robot pose before imagining)`` chooses the parameters (``None``: nothing injected) and
    ``body(params)`` runs as the subtree ``real-run`` (annotated ``"projected"`` with the
    parameters); its value or failure is the result."""
    env = current_environment()
    imagination = env.imagination
    if not enabled or env.projecting or imagination is None:
        return await body(ProjectedParameters())
    start = env.world.robot_pose() if env.has_world else None
    snapshot = imagination.snapshot()
    run_tasks: list[cpl.Task] = []

    async def imagine() -> T:
        me = cpl.current_task()
        assert me is not None
        run_tasks.append(me)
        return await body(ProjectedParameters())

    try:
        with retry_ledger():  # imagined retries are not the caller's
            async with imagination.projection():
                for i in range(1, runs + 1):
                    imagination.restore(snapshot)
                    try:
                        await cpl.tag(f"projection-run-{i}", imagine())
                    except (cpl.PlanFailure, DesignatorError) as failure:
                        log.info("projection run %d failed: %r", i, failure)
    finally:
        imagination.restore(snapshot)
    params = pick(run_tasks, start)

    async def real() -> T:
        me = cpl.current_task()
        if me is not None and params is not None:
            me.annotate("projected", params)
        return await body(params if params is not None else ProjectedParameters())

    result: T = await cpl.tag("real-run", real())
    return result
