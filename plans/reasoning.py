"""Projection reasoning (CRAM's ``cram_pr2_projection_reasoning``): imagine a plan a few
times, then run it for real with the parameters of the best imagined run.

:func:`with_projected_task_tree` runs ``body`` ``runs`` times in the current
environment's imagination (:class:`executive.Imagination`: a projection environment over
the belief world, restored from a snapshot before every run and after the last), each run
a subtree ``projection-run-<i>`` of the task tree marked :attr:`cpl.Subtree.IMAGINED`;
then ``pick`` reads those live subtrees and chooses the parameters, and ``body`` runs for
real as ``real-run`` (marked :attr:`cpl.Subtree.REAL`). It is a front-end over the
imagination engine (:func:`plans.imagine`); how the runs explore is
:class:`Exploration` (``plans._exploration``), how they are judged a :class:`Ranking`.
How well the chosen run predicted the real one is measured by its reader, the app
(``aiocram.fidelity``).
:func:`pick_best_parameters_by_distance` is CRAM's choice: the successful run whose base
route (current pose -> pick base pose -> place base pose) is shortest.

Where we differ from CRAM: its macro is a no-op in simulation (the demo runs inside a
projection environment and disables the flag); ours is enabled by default and runs
wherever the environment has an imagination and is not itself projecting (a real robot's
environment). Imagined failures also include designator errors (CRAM: plan failures only).
Retries granted in imagination are not tallied in the caller's :func:`retry_ledger`.
"""

from __future__ import annotations

import asyncio
import logging
import math
import time
from collections.abc import Awaitable, Callable, Iterator, Mapping, Sequence
from contextlib import aclosing
from dataclasses import dataclass, field
from itertools import pairwise
from typing import Any, TypeVar

import cpl
from executive import (
    ActionDesignator,
    DesignatorError,
    LocationDesignator,
    ObjectDesignator,
    ObjectInventory,
    Pose,
    a,
    current_environment,
    newest_effective,
    performed,
    previous_performed,
)
from executive.events import ObjectAttached, ObjectDetached

from ._designators import learned_base, robot_name
from ._exploration import (
    POOL_PER_RUN,
    Exploration,
    learned_weight,
    partition_by_bearing,
)
from ._imagination import can_imagine, imagine, run_for_real

__all__ = [
    "DEFAULT_RANKING",
    "POOL_PER_RUN",
    "Exploration",
    "FetchAndDeliver",
    "ProjectedParameters",
    "Ranking",
    "RunAssessment",
    "assess_run",
    "partition_by_bearing",
    "pick_best_parameters_by_distance",
    "pick_by_prediction",
    "projected_parameters",
    "route_cost",
    "run_outcome",
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
    #: in an imagined run: which alternative this run explores (see :class:`Exploration`);
    #: ``None`` in the real run and in a pass-through.
    exploration: Exploration | None = None
    #: in an imagined run that explores a fetch and delivery (:class:`FetchAndDeliver`):
    #: the arm to fetch with (``None``: the plan's own) and the placing target (``None``:
    #: the plan's own); ``None`` in the real run, which follows ``pick_up_action``.
    arm: str | None = None
    target: LocationDesignator | None = None


# --------------------------------------------------------------------------- exploring
@dataclass(frozen=True)
class FetchAndDeliver:
    """What the imagined runs of a fetch and delivery explore (given to
    :func:`with_projected_task_tree` by ``transport``, whose body never knows whether it
    runs imagined or real): run ``i`` fetches ``object`` with :meth:`Exploration.arm`
    from its region of the base poses from which the object is reachable
    (``"pick base"``, bearings around the object) and places it at its region of
    ``target``'s solutions (``"placing target"``); ``arm``: the caller's fixed arm.

    Deliberate difference from CRAM: there the four variables are the only parameters
    and every imagined run draws from the same designator chains."""

    object: ObjectDesignator
    target: LocationDesignator
    arm: str | None = None

    def alternative(self, exploration: Exploration) -> ProjectedParameters:
        """The parameters of ``exploration``'s run (drawn in the imagined world)."""
        arm = exploration.arm(self.arm)
        spot = a.location(of_item_object=self.object.current().get("name")).reference()
        reachable = a.location(
            reachable_for=robot_name(),
            location=a.location(pose=spot),
            arm=self.arm,
            **learned_base("picking-up", self.object),
        )
        # learned priors (if the environment has any): the likeliest region imagined first
        weight = learned_weight("picking-up", self.object.current().get("type"), spot)
        return ProjectedParameters(
            fetch_robot_location=exploration.region(
                "pick base", reachable, spot.position[:2], weight
            ),
            exploration=exploration,
            arm=arm,
            target=exploration.region("placing target", self.target),
        )


# ------------------------------------------------------------------------- assessing
@dataclass(frozen=True)
class Ranking:
    """How imagined runs are judged and ranked (:func:`assess_run`,
    :meth:`RunAssessment.rank`): pass one to :func:`with_projected_task_tree` (default
    :data:`DEFAULT_RANKING`). A negative number: ValueError naming the field."""

    #: retries (all kinds, in one imagined run) above which a run counts as needing many
    many_retries: int = 3
    #: the route-cost equivalent of one retry (m + rad): what the time of a retry costs
    #: (3.0 measured no better on the 10-seed campaign: 88 %, 17.05 m, 364 s at 0 % faults)
    retry_cost: float = 1.0
    #: the weight of the way back (m, place base -> the start pose) in a run's cost: the
    #: next transport searches where this one started (the objects come from the counters
    #: the robot looked at), so a place base on that side saves the next drive.
    #: 0 = CRAM's open route (start -> pick base -> place base), the default: with 1.0 the
    #: 10-seed campaign drove more (17.45 m vs 16.96 m at 0 % faults; issue-14 note)
    return_weight: float = 0.0
    #: a neighbour moved more than this (m) or tilted more than ``tilt`` (rad) was knocked
    knock_distance: float = 0.03
    tilt: float = 0.35
    #: below this height (m) the transported object lies on the floor
    floor_z: float = 0.3

    def __post_init__(self) -> None:
        for name in ("many_retries", "retry_cost", "return_weight", "knock_distance", "tilt"):
            value = getattr(self, name)
            if not isinstance(value, int | float) or value < 0:
                raise ValueError(f"Ranking.{name} is a number >= 0, got {value!r}")
        if not isinstance(self.floor_z, int | float):
            raise ValueError(f"Ranking.floor_z is a height in metres, got {self.floor_z!r}")


#: The ranking projection reasoning uses unless told otherwise.
DEFAULT_RANKING = Ranking()


def _tilt(pose: Pose) -> float:
    x, y, _z, _w = pose.orientation
    return math.acos(max(-1.0, min(1.0, 1.0 - 2.0 * (x * x + y * y))))


@dataclass(frozen=True)
class RunAssessment:
    """What the imagined world predicts for one run (read before it is restored).

    ``failure``: the failure class name that ended the run (``None``: it succeeded);
    ``knocked``: neighbours it moved (> ``ranking.knock_distance``) or tilted
    (> ``ranking.tilt``);
    ``unstable``: the transported object ends tilted or on the floor; ``retries``: the
    retries granted in the run; ``route``: start -> pick base pose -> place base pose;
    ``cost``: route cost + ``ranking.return_weight`` x the distance from the place base
    back to the start + ``ranking.retry_cost`` per retry (``None`` without a complete
    route); ``ranking``: the :class:`Ranking` it was judged by."""

    name: str
    failure: str | None
    knocked: tuple[str, ...]
    unstable: bool
    retries: int
    route: tuple[Pose, ...]
    cost: float | None
    params: ProjectedParameters
    explored: Mapping[str, Any]
    #: where the imagined robot's base stood when it grasped (``"pick"``: the last
    #: ``ObjectAttached``) and released (``"place"``: the last ``ObjectDetached``) in the
    #: imagined world (see :func:`watch_bases`); empty when it never did
    bases: Mapping[str, Pose] = field(default_factory=dict)
    ranking: Ranking = field(default=DEFAULT_RANKING, repr=False)

    @property
    def clean(self) -> bool:
        """Succeeded, knocked nothing, left a stable object, needed few retries."""
        return (
            self.failure is None
            and not self.knocked
            and not self.unstable
            and self.retries <= self.ranking.many_retries
        )

    def rank(self) -> tuple[Any, ...]:
        """Smaller is better: predicted success first, then cost."""
        return (
            self.failure is not None,
            bool(self.knocked),
            self.unstable,
            self.retries > self.ranking.many_retries,
            self.cost is None,
            self.cost if self.cost is not None else math.inf,
        )

    def verdict(self) -> str:
        """One line: the prediction and the cost."""
        if self.failure is not None:
            what = f"fails ({self.failure})"
        elif self.knocked:
            what = "knocks " + ", ".join(self.knocked)
        elif self.unstable:
            what = "unstable object"
        elif self.retries > self.ranking.many_retries:
            # the retries are the verdict: said once ("15 retries, cost 18.91")
            return f"{self.retries} retries, cost {self._cost_text()}"
        else:
            what = "clean"
        retries = "1 retry" if self.retries == 1 else f"{self.retries} retries"
        return f"{what}, cost {self._cost_text()}, {retries}"

    def _cost_text(self) -> str:
        return "-" if self.cost is None else f"{self.cost:.2f}"


def _object_poses(world: Any, names: Sequence[str]) -> dict[str, Pose]:
    poses: dict[str, Pose] = {}
    for name in names:
        try:
            poses[name] = world.object_pose(name)
        except Exception:
            continue
    return poses


def _scene_names(world: Any) -> list[str]:
    """The object names of the imagined world, where it can list them
    (:class:`executive.ObjectInventory`); otherwise none (no run is judged by what it
    moved)."""
    if isinstance(world, ObjectInventory):
        return list(world.object_names())
    return []


def assess_run(
    name: str,
    outcome: str,
    params: ProjectedParameters,
    start: Pose | None,
    before: Mapping[str, Pose],
    after: Mapping[str, Pose],
    subject: str | None,
    retries: int,
    explored: Mapping[str, Any] | None = None,
    bases: Mapping[str, Pose] | None = None,
    ranking: Ranking = DEFAULT_RANKING,
) -> RunAssessment:
    """Assess one imagined run from its ``outcome`` (:func:`run_outcome`) and the object
    poses ``before`` it and ``after`` it, by ``ranking``."""
    failure = None if outcome == "succeeded" else outcome
    knocked = tuple(
        sorted(
            n
            for n, p in before.items()
            if n != subject
            and n in after
            and (
                math.dist(p.position, after[n].position) > ranking.knock_distance
                or abs(_tilt(after[n]) - _tilt(p)) > ranking.tilt
            )
        )
    )
    unstable = False
    if subject is not None and subject in after and failure is None:
        end = after[subject]
        begin = before.get(subject)
        tilted = _tilt(end) - (_tilt(begin) if begin is not None else 0.0) > ranking.tilt
        unstable = tilted or end.position[2] < ranking.floor_z
    route: tuple[Pose, ...] = ()
    cost = None
    if params.fetch_robot_location is not None and params.deliver_robot_location is not None:
        try:
            legs = [
                params.fetch_robot_location.reference(),
                params.deliver_robot_location.reference(),
            ]
            route = tuple(legs if start is None else [start, *legs])
            back = route[-1].distance_to(start) if start is not None else 0.0
            cost = route_cost(route) + ranking.return_weight * back + ranking.retry_cost * retries
        except (DesignatorError, ValueError) as error:
            log.info("projected run without a usable route: %s", error)
    return RunAssessment(
        name,
        failure,
        knocked,
        unstable,
        retries,
        route,
        cost,
        params,
        dict(explored or {}),
        dict(bases or {}),
        ranking,
    )


def pick_by_prediction(assessments: Sequence[RunAssessment]) -> RunAssessment | None:
    """The best run by :meth:`RunAssessment.rank` among those that succeeded with a
    complete route (the earliest on a tie); ``None`` when none did."""
    usable = [r for r in assessments if r.failure is None and r.cost is not None]
    return min(usable, key=RunAssessment.rank) if usable else None


def why(
    winner: RunAssessment, others: Sequence[RunAssessment], ranking: Ranking = DEFAULT_RANKING
) -> str:
    """Why ``winner`` beat ``others`` (judged by ``ranking``), in words."""
    losers = [r for r in others if r is not winner]
    reasons = []
    for r in losers:
        if r.failure is not None:
            reasons.append(f"{r.name} fails")
        elif r.knocked:
            reasons.append(f"{r.name} knocks {', '.join(r.knocked)}")
        elif r.unstable:
            reasons.append(f"{r.name} leaves it unstable")
        elif r.retries > ranking.many_retries:
            reasons.append(f"{r.name} needs {r.retries} retries")
        elif r.cost is not None and winner.cost is not None:
            reasons.append(f"{r.name} costs {r.cost - winner.cost:+.2f} more")
    return "; ".join(reasons) or "the only usable run"


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


# ---------------------------------------------------------------------------- outcome
def run_outcome(run: cpl.Task, failure: BaseException | None = None) -> str:
    """``"succeeded"`` or the failure class name: the failure that ended ``run``, else that
    of a failed ``delivering`` inside it (a transport that dropped its object at the sink
    still returns), else ``"succeeded"``; ``"interrupted"`` when the run was evaporated
    or cancelled (e.g. Ctrl-C) rather than failed."""
    failure = failure if failure is not None else run.failure
    if isinstance(failure, asyncio.CancelledError) or run.state is cpl.Status.EVAPORATED:
        return "interrupted"
    if failure is not None:
        return type(failure).__name__
    failed = performed(run, "delivering", state=cpl.Status.FAILED)
    if failed and failed[-1][0].failure is not None:
        return type(failed[-1][0].failure).__name__
    return "succeeded"


# ---------------------------------------------------------------------------- the macro
async def with_projected_task_tree(
    body: Callable[[ProjectedParameters], Awaitable[T]],
    runs: int = 3,
    pick: Pick | None = None,
    *,
    enabled: bool = True,
    subject: str | None = None,
    ranking: Ranking = DEFAULT_RANKING,
    explore: FetchAndDeliver | None = None,
) -> T:
    """Imagine ``body`` ``runs`` times, then run it for real with the picked parameters
    (CRAM's ``with-projected-task-tree``), on the imagination engine
    (:func:`plans.imagine`).

    Pass-through (``body(ProjectedParameters())`` once, no subtrees) when ``enabled`` is
    false, the current environment is ``projecting``, or it has no ``imagination``.
    Otherwise: snapshot the belief world; in the imagination's projection environment, for
    each run ``i`` restore the snapshot and run ``body(params)`` as the subtree
    ``projection-run-<i>`` (marked :attr:`cpl.Subtree.IMAGINED`), where ``params`` is
    ``explore.alternative(Exploration(i, runs, pools))`` (the run's own arm, pick base
    region and placing target region, drawn in the imagined world; see
    :class:`FetchAndDeliver`) or, without ``explore``,
    ``ProjectedParameters(exploration=Exploration(i, runs, pools))`` for a body that draws
    its own alternative; a plan failure or designator error ends that run only (its
    subtree is FAILED). Before the world is restored each run is assessed
    (:func:`assess_run` with ``ranking``: outcome, neighbours moved, ``subject`` unstable,
    retries, route cost) and the assessment annotated on its subtree as ``"assessment"``.
    The snapshot is restored after the last run, also when a run raises something else or
    the caller is evaporated (the projection environment is left first, which stops its
    goals; restoring does not await).

    Choice: with ``pick`` (CRAM's interface, e.g. :func:`pick_best_parameters_by_distance`)
    ``pick(run tasks, robot pose before imagining)``; by default :func:`pick_by_prediction`
    (predicted success first, then cost). ``None``: nothing injected. Then ``body(params)``
    runs as the subtree ``real-run`` (marked :attr:`cpl.Subtree.REAL`), annotated
    ``"imagined"`` (the assessments), ``"imagined_wall_s"``, ``"projected"`` (the
    parameters), ``"chosen"`` / ``"why"`` and ``"start"`` (the robot's base pose before
    imagining); its value or failure is the result. Deliberate difference from CRAM:
    CRAM's imagined runs all draw from one designator chain and it picks by distance
    only."""
    imagination = can_imagine(enabled)
    if imagination is None:
        return await body(ProjectedParameters())
    env = current_environment()
    start = env.world.robot_pose() if env.has_world else None
    run_tasks: list[cpl.Task] = []
    assessments: list[RunAssessment] = []
    pools: dict[str, tuple[Pose, ...]] = {}
    watched: dict[str, _Watched] = {}
    t0 = time.perf_counter()

    def alternatives() -> Iterator[tuple[str, Callable[[], Awaitable[T]]]]:
        for i in range(1, runs + 1):
            name = f"projection-run-{i}"
            exploration = Exploration(i, runs, pools)
            yield name, _watching(body, exploration, explore, watched.setdefault(name, _Watched()))

    async with aclosing(imagine(imagination, alternatives())) as imagined:
        async for run in imagined:
            if run.task is None:
                continue
            seen = watched[run.name]
            run_tasks.append(run.task)
            assert seen.given is not None and seen.given.exploration is not None
            assessment = assess_run(
                run.task.name,
                run_outcome(run.task, run.failure),
                projected_parameters(run.task),
                start,
                seen.before,
                _object_poses(run.env.world, seen.names),
                subject,
                run.retries,
                seen.given.exploration.explored,
                seen.bases,
                ranking,
            )
            run.task.annotate("assessment", assessment)
            assessments.append(assessment)
    imagined_wall = time.perf_counter() - t0
    chosen: RunAssessment | None = None
    if pick is not None:
        params = pick(run_tasks, start)
    else:
        chosen = pick_by_prediction(assessments)
        params = chosen.params if chosen is not None else None
    notes: dict[str, Any] = {"imagined": tuple(assessments), "imagined_wall_s": imagined_wall}
    if params is not None:
        notes["projected"] = params
    if chosen is not None:
        notes["chosen"] = chosen.name
        notes["why"] = why(chosen, assessments, ranking)
    if start is not None:
        notes["start"] = start
    real_params = params if params is not None else ProjectedParameters()
    return await run_for_real("real-run", cpl.Subtree.REAL, lambda: body(real_params), notes)


@dataclass
class _Watched:
    """What one imagined run's own code saw (after the engine restored the belief)."""

    given: ProjectedParameters | None = None
    names: list[str] = field(default_factory=list)  # the imagined world's objects
    before: dict[str, Pose] = field(default_factory=dict)  # their poses as the run began
    bases: dict[str, Pose] = field(default_factory=dict)  # the imagined robot at pick/place


def _watching(
    body: Callable[[ProjectedParameters], Awaitable[T]],
    exploration: Exploration,
    explore: FetchAndDeliver | None,
    seen: _Watched,
) -> Callable[[], Awaitable[T]]:
    """``body`` as the imagined run that explores ``exploration``: it notes in ``seen`` the
    parameters it was given, the object poses it began with and where the imagined
    robot's base stood at every grasp and release."""

    async def run() -> T:
        dream = current_environment()
        world = dream.world
        seen.names = _scene_names(world)
        seen.before = _object_poses(world, seen.names)
        given = seen.given = (
            explore.alternative(exploration)
            if explore is not None
            else ProjectedParameters(exploration=exploration)
        )

        def attached(_event: ObjectAttached) -> None:
            seen.bases["pick"] = world.robot_pose()

        def detached(_event: ObjectDetached) -> None:
            seen.bases["place"] = world.robot_pose()

        undo = [
            dream.subscribe(ObjectAttached, attached),
            dream.subscribe(ObjectDetached, detached),
        ]
        try:
            return await body(given)
        finally:
            for u in undo:
                u()

    return run
