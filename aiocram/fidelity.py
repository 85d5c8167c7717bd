"""The projection fidelity witness: how well the chosen imagined run predicted the real
one (issue 14), measured by the app that reports it, never by the plans.

* :func:`watch_bases` (with the default ``record``) is what a witness of the *true* world
  (the demo's truth observer) subscribes: at every grasp and release it annotates the
  enclosing real run of projection reasoning (the subtree marked :attr:`cpl.Subtree.REAL`)
  with the true robot's base pose, as :data:`TRUE_BASES`.
* :func:`fidelity_of` reads a finished real run (its annotations: the imagined runs'
  :class:`plans.reasoning.RunAssessment` records, the chosen one's name, the robot's start
  pose) and measures the :class:`Fidelity` (:func:`measure_fidelity`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import cpl
from executive import DesignatorError, Environment, LocationDesignator, Pose
from executive.events import ObjectAttached, ObjectDetached
from plans.reasoning import RunAssessment, projected_parameters, route_cost, run_outcome

__all__ = ["TRUE_BASES", "Fidelity", "fidelity_of", "measure_fidelity", "watch_bases"]

#: The annotation of a real run (marked :attr:`cpl.Subtree.REAL`) where a witness outside
#: the robot (e.g. the demo's truth observer, reading the *true* world through
#: :func:`watch_bases`) records the true base poses at pick and place:
#: ``{"pick": Pose, "place": Pose}``. The plans never write it themselves (the robot's
#: belief is no measurement).
TRUE_BASES = "true_bases"


def _annotate_real_run(kind: str, pose: Pose) -> None:
    """Note ``pose`` as the ``kind`` base of the real run around the current task
    (nothing outside one, or inside an imagined run)."""
    task = cpl.current_task()
    while task is not None:
        mark = task.subtree
        if mark is cpl.Subtree.IMAGINED:
            return
        if mark is cpl.Subtree.REAL:
            bases = dict((task.annotations or {}).get(TRUE_BASES) or {})
            bases[kind] = pose
            task.annotate(TRUE_BASES, bases)
            return
        task = task.parent


def watch_bases(
    env: Environment,
    robot_pose: Callable[[], Pose],
    record: Callable[[str, Pose], None] | None = None,
) -> Callable[[], None]:
    """Watch where the robot's base stands at pick and place: on every ``ObjectAttached``
    (``"pick"``) and ``ObjectDetached`` (``"place"``) event of ``env``, call
    ``record(kind, robot_pose())`` (so the last grasp and the last release win). By
    default ``record`` annotates the enclosing real run's :data:`TRUE_BASES` (a witness
    of the true world passes the true robot's pose). Returns the function that
    unsubscribes."""
    note = record if record is not None else _annotate_real_run

    def attached(_event: ObjectAttached) -> None:
        note("pick", robot_pose())

    def detached(_event: ObjectDetached) -> None:
        note("place", robot_pose())

    undo = [env.subscribe(ObjectAttached, attached), env.subscribe(ObjectDetached, detached)]

    def unsubscribe() -> None:
        for u in undo:
            u()

    return unsubscribe


@dataclass(frozen=True)
class Fidelity:
    """How well the chosen imagined run predicted the real one.

    ``predicted`` / ``real``: :func:`plans.reasoning.run_outcome` of each; ``agrees``:
    they are equal; ``pick_base_m`` / ``place_base_m``: distance (m) between the imagined
    and the real run's base goals (the newest effective ``navigating`` location before the
    successful pick / place; ``None`` where one run has none); ``route_m``: |real route
    cost - imagined route cost| (start -> pick base -> place base).

    ``true_pick_base_m`` / ``true_place_base_m`` (and ``..._deg``): how far (m, and
    degrees of heading) the real robot's *true* base stood at pick / place
    (:data:`TRUE_BASES`, recorded by a witness of the true world) from where the imagined
    robot stood then (:attr:`plans.reasoning.RunAssessment.bases`); ``None`` without
    both."""

    chosen: str
    predicted: str
    real: str
    pick_base_m: float | None
    place_base_m: float | None
    route_m: float | None
    true_pick_base_m: float | None = None
    true_place_base_m: float | None = None
    true_pick_base_deg: float | None = None
    true_place_base_deg: float | None = None

    @property
    def agrees(self) -> bool:
        return self.predicted == self.real

    def to_json(self) -> dict[str, Any]:
        return {
            "chosen": self.chosen,
            "predicted": self.predicted,
            "real": self.real,
            "agrees": self.agrees,
            "pick_base_m": self.pick_base_m,
            "place_base_m": self.place_base_m,
            "route_m": self.route_m,
            "true_pick_base_m": self.true_pick_base_m,
            "true_place_base_m": self.true_place_base_m,
            "true_pick_base_deg": self.true_pick_base_deg,
            "true_place_base_deg": self.true_place_base_deg,
        }


def _goal(location: LocationDesignator | None) -> Pose | None:
    if location is None:
        return None
    try:
        pose = location.reference()
    except DesignatorError:
        return None
    return pose if isinstance(pose, Pose) else None


def _apart(p: Pose | None, q: Pose | None) -> float | None:
    if p is None or q is None or p.frame != q.frame:
        return None
    return math.dist(p.position[:2], q.position[:2])


def _heading_apart(p: Pose | None, q: Pose | None) -> float | None:
    if p is None or q is None or p.frame != q.frame:
        return None
    d = p.yaw - q.yaw
    return math.degrees(abs(math.atan2(math.sin(d), math.cos(d))))


def measure_fidelity(
    chosen: RunAssessment, real: cpl.Task, start: Pose | None, failure: BaseException | None
) -> Fidelity:
    """Compare the chosen imagined run with the finished real run ``real`` (``start``: the
    robot's base pose before imagining; ``failure``: what ended the real run, if known)."""
    mine = projected_parameters(real)
    pick, place = _goal(mine.fetch_robot_location), _goal(mine.deliver_robot_location)
    route_m = None
    if pick is not None and place is not None and chosen.cost is not None and chosen.route:
        legs = [pick, place] if start is None else [start, pick, place]
        try:
            route_m = abs(route_cost(legs) - route_cost(chosen.route))
        except ValueError:
            route_m = None
    imagined_pick = _goal(chosen.params.fetch_robot_location)
    imagined_place = _goal(chosen.params.deliver_robot_location)
    true = (real.annotations or {}).get(TRUE_BASES) or {}
    return Fidelity(
        chosen.name,
        "succeeded" if chosen.failure is None else chosen.failure,
        run_outcome(real, failure),
        _apart(imagined_pick, pick),
        _apart(imagined_place, place),
        route_m,
        _apart(chosen.bases.get("pick"), true.get("pick")),
        _apart(chosen.bases.get("place"), true.get("place")),
        _heading_apart(chosen.bases.get("pick"), true.get("pick")),
        _heading_apart(chosen.bases.get("place"), true.get("place")),
    )


def fidelity_of(real: cpl.Task) -> Fidelity | None:
    """The :class:`Fidelity` of a finished real run of projection reasoning (a task marked
    :attr:`cpl.Subtree.REAL`); ``None`` while it runs, when it was evaporated (stopped,
    not predicted) or when no imagined run was chosen (a ``pick`` of the caller's, or no
    usable run)."""
    if real.subtree is not cpl.Subtree.REAL or not real.dead:
        return None
    if real.state is cpl.Status.EVAPORATED:
        return None
    notes = real.annotations or {}
    params = notes.get("projected")
    # the chosen run is the one whose very parameters the real run was given
    chosen = next((r for r in notes.get("imagined", ()) if r.params is params), None)
    if chosen is None or "chosen" not in notes:
        return None
    return measure_fidelity(chosen, real, notes.get("start"), real.failure)
