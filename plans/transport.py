"""Transporting an object: access its container, search, fetch and deliver it (part of CRAM
HEAD's ``fetch-and-deliver-plans.lisp``), with CRAM's nested failure handling:

=================  ==========================================  ============================
action             retries (HEAD)                              raises when exhausted
=================  ==========================================  ============================
transporting       object-undeliverable -> drop at the sink    what search / fetch raise
=================  ==========================================  ============================

The levels it composes live in :mod:`plans.environment_access` (accessing/sealing),
:mod:`plans.search`, :mod:`plans.fetch` and :mod:`plans.deliver` (also the drop at the
sink); fetch and deliver run inside :func:`plans.reasoning.with_projected_task_tree`.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import cpl
from executive import (
    Designator,
    LocationDesignator,
    ObjectDesignator,
    ObjectNowhereToBeFound,
    ObjectUndeliverable,
    ObjectUnfetchable,
    a,
    an,
    perform,
    rule,
)

from ._designators import ROBOT, _check_places, _given_arm, _location, _object
from .deliver import drop_at_sink
from .environment import DEFAULT_DISTANCE
from .fetch import ObjectUnreachableOnFloor, search_floor
from .reasoning import ProjectedParameters, with_projected_task_tree

__all__ = ["transport"]


@cpl.plan(name="transport")
async def transport(
    object_designator: ObjectDesignator,
    location: LocationDesignator,
    target: LocationDesignator,
    arm: str | None = None,
    projection_reasoning: bool = True,
    projection_runs: int = 3,
    viewpoint_reasoning: bool = False,
) -> ObjectDesignator | None:
    """Access the container (if ``location`` is ``in`` one), search, fetch and deliver the
    object; an ``object-undeliverable`` makes it drop the object at the sink. An object
    not found at ``location`` or not fetchable there is looked for on the floor around
    where it was believed (:func:`plans.fetch.search_floor`; deliberate addition, no
    CRAM plan does this), then fetched (from the floor) and delivered without projection;
    otherwise search and fetch failures propagate. Fetch and deliver run inside
    :func:`~plans.reasoning.with_projected_task_tree` (``projection_runs`` imagined runs,
    the designator's ``projection-runs`` property, default 3; then the real one
    with the chosen base poses, arm, grasp and placing target) when
    ``projection_reasoning`` (the designator's ``projection-reasoning`` property, default
    true; CRAM's demo disables it) and the environment can imagine; otherwise it is a
    pass-through. Cleanup: the container is sealed in a ``finally`` that runs
    shielded, so it also runs when the transport is evaporated (the evaporation is
    re-raised afterwards). Returns the delivered object designator, or ``None`` when it was
    dropped at the sink. ``viewpoint_reasoning`` (the ``viewpoint-reasoning`` property,
    default false): the search chooses where to look from by projection
    (:mod:`plans.viewpoints`)."""
    container = location.get("in")
    accessible = container is None
    if not accessible:
        await perform(
            an.action(type="accessing", location=location, arm="left", distance=DEFAULT_DISTANCE)
        )
    try:
        try:
            found = await perform(
                an.action(
                    type="searching",
                    object=object_designator,
                    location=location,
                    viewpoint_reasoning=viewpoint_reasoning,
                )
            )
        except ObjectNowhereToBeFound as failure:
            found = await search_floor(object_designator, failure)

        async def fetch_and_deliver(given: ProjectedParameters) -> ObjectDesignator | None:
            fetch_arm, fetch_location, to = arm, given.fetch_robot_location, target
            explore = given.exploration
            if explore is not None:  # an imagined run: draw this run's own alternative
                fetch_arm = explore.arm(arm)
                spot = a.location(of_item_object=found.current().get("name")).reference()
                fetch_location = explore.region(
                    "pick base",
                    a.location(reachable_for=ROBOT, location=a.location(pose=spot), arm=arm),
                    spot.position[:2],
                )
                to = explore.region("placing target", target)
            fetched: ObjectDesignator = await perform(
                an.action(
                    type="fetching",
                    object=found,
                    arm=fetch_arm,
                    robot_location=fetch_location,
                    pick_up_action=given.pick_up_action,
                )
            )

            async def deliver_it() -> bool:
                await perform(
                    an.action(
                        type="delivering",
                        object=fetched,
                        target=to,
                        robot_location=given.deliver_robot_location,
                        place_action=given.place_action,
                    )
                )
                return True

            delivered = await cpl.with_failure_handling(
                deliver_it, [(ObjectUndeliverable, lambda _f: _drop_and_return(fetched))]
            )
            return fetched if delivered else None

        try:
            return await with_projected_task_tree(
                fetch_and_deliver,
                projection_runs,
                enabled=projection_reasoning,
                subject=found.current().get("name"),
            )
        except ObjectUnfetchable as failure:
            if isinstance(failure, ObjectUnreachableOnFloor):
                raise
            # no longer where it was fetched from (dropped, or knocked off): the floor
            found = await search_floor(found, failure)
            return await with_projected_task_tree(fetch_and_deliver, projection_runs, enabled=False)
    finally:
        if not accessible:
            sealing = an.action(
                type="sealing", location=location, arm="left", distance=DEFAULT_DISTANCE
            )
            await cpl.shielded(perform(sealing))


async def _drop_and_return(obj: ObjectDesignator) -> None:
    await drop_at_sink(obj)
    cpl.return_(False)


@rule(
    "action",
    "transporting",
    keys=(
        "object",
        "location",
        "target",
        "arm",
        "projection-reasoning",
        "projection-runs",
        "viewpoint-reasoning",
    ),
)
def _transporting(d: Designator) -> Iterator[Any]:
    _check_places(d, "location", "target")
    yield (
        transport,
        {
            "object_designator": _object(d),
            "location": _location(d, "location"),
            "target": _location(d, "target"),
            "arm": _given_arm(d),
            "projection_reasoning": bool(d.get("projection-reasoning", True)),
            "projection_runs": int(d.get("projection-runs", 3)),
            "viewpoint_reasoning": bool(d.get("viewpoint-reasoning", False)),
        },
    )
