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
    EnvironmentManipulationImpossible,
    Key,
    LocationDesignator,
    ObjectDesignator,
    ObjectNowhereToBeFound,
    ObjectUndeliverable,
    ObjectUnfetchable,
    RuleDoc,
    an,
    perform,
    register_resources,
    rule,
)

from ._common import the_base
from ._designators import _check_places, _given_arm, _location, _object
from .deliver import drop_at_sink
from .environment import DEFAULT_DISTANCE
from .environment_access import open_farther, seal_if_open
from .fetch import ObjectUnreachableOnFloor, search_floor
from .reasoning import FetchAndDeliver, ProjectedParameters, with_projected_task_tree
from .toppled import ObjectToppledUngraspable

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
    not found in the container it opened is looked for again once the container is open
    to the end of its travel (:func:`plans.environment_access.open_farther`; deliberate
    addition: CRAM opens by 0.3 m, and the back of the drawer stays inside the cabinet).
    An object not found at ``location`` or not fetchable there is looked for on the floor around
    where it was believed (:func:`plans.fetch.search_floor`; deliberate addition, no
    CRAM plan does this), then fetched (from the floor) and delivered without projection;
    otherwise search and fetch failures propagate. Fetch and deliver run inside
    :func:`~plans.reasoning.with_projected_task_tree` (``projection_runs`` imagined runs,
    the designator's ``projection-runs`` property, default 3; then the real one
    with the chosen base poses, arm, grasp and placing target), as in CRAM's Lisp: their
    body only takes the parameters it is given; what the imagined runs explore is
    declared to the macro (:class:`~plans.reasoning.FetchAndDeliver`), which draws each
    run's alternative, when
    ``projection_reasoning`` (the designator's ``projection-reasoning`` property, default
    true; CRAM's demo disables it) and the environment can imagine; otherwise it is a
    pass-through. Cleanup: the container is sealed in a ``finally`` that runs
    shielded, so it also runs when the transport is evaporated (the evaporation is
    re-raised afterwards); the ``accessing`` itself is inside it, so a transport
    evaporated (Ctrl-C) or failed while the drawer was being opened closes it too, by
    however far the world model has it open (:func:`plans.environment_access.seal_if_open`,
    bounded in time; a world model that cannot tell is sealed only after ``accessing``
    returned). Deliberate difference from CRAM, whose ``unwind-protect`` began after the
    ``accessing``. Returns the delivered object designator, or ``None`` when it was
    dropped at the sink. ``viewpoint_reasoning`` (the ``viewpoint-reasoning`` property,
    default false): the search chooses where to look from by projection
    (:mod:`plans.viewpoints`)."""
    container = location.get("in")
    accessed = False  # accessing returned: the container is open as far as we know
    try:
        if container is not None:
            await perform(
                an.action(
                    type="accessing", location=location, arm="left", distance=DEFAULT_DISTANCE
                )
            )
            accessed = True
        searching = an.action(
            type="searching",
            object=object_designator,
            location=location,
            viewpoint_reasoning=viewpoint_reasoning,
        )
        try:
            found = await perform(searching)
        except ObjectNowhereToBeFound as not_found:
            missing: ObjectNowhereToBeFound = not_found
            found = None
            if accessed and await open_farther(location):
                try:  # what lay behind the first opening is in view now
                    found = await perform(searching)
                except ObjectNowhereToBeFound as again:
                    missing = again
            if found is None:
                found = await search_floor(object_designator, missing)

        async def fetch_and_deliver(given: ProjectedParameters) -> ObjectDesignator | None:
            # CRAM's body of with-projected-task-tree: the parameters are what projection
            # chose (or explores in an imagined run); the body does not know which
            fetched: ObjectDesignator = await perform(
                an.action(
                    type="fetching",
                    object=found,
                    arm=given.arm if given.arm is not None else arm,
                    robot_location=given.fetch_robot_location,
                    pick_up_action=given.pick_up_action,
                )
            )

            async def deliver_it() -> bool:
                await perform(
                    an.action(
                        type="delivering",
                        object=fetched,
                        target=given.target if given.target is not None else target,
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
                explore=FetchAndDeliver(found, target, arm),
            )
        except ObjectUnfetchable as failure:
            if isinstance(failure, (ObjectUnreachableOnFloor, ObjectToppledUngraspable)):
                raise  # seen where it is, and why it cannot be picked is known
            # no longer where it was fetched from (dropped, or knocked off): the floor
            found = await search_floor(found, failure)
            return await with_projected_task_tree(fetch_and_deliver, projection_runs, enabled=False)
    finally:
        if container is not None:
            await cpl.shielded(seal_if_open(location, assume_open=accessed))


async def _drop_and_return(obj: ObjectDesignator) -> None:
    await drop_at_sink(obj)
    cpl.return_(False)


@rule(
    "action",
    "transporting",
    doc=RuleDoc(
        "Bring the object from location to target (plan transport): open its drawer if "
        "location is (in ...), search, fetch and deliver (imagined first, when the "
        "environment can imagine), close the drawer. Returns the delivered object "
        "designator, or None when it was dropped at the sink.",
        keys=(
            Key("object", "object designator", "what to bring (type, name)", required=True),
            Key(
                "location",
                "location designator",
                "where to search for it; (in <drawer>): the drawer is opened first",
                required=True,
            ),
            Key("target", "location designator", "where to deliver it", required=True),
            Key("arm", "'left' | 'right'", "the arm to fetch with", default="right, then left"),
            Key(
                "projection-reasoning",
                "bool",
                "imagine fetch and deliver first, run the best",
                default="True",
            ),
            Key("projection-runs", "int", "how many imagined runs", default="3"),
            Key(
                "viewpoint-reasoning",
                "bool",
                "the search imagines where to look from",
                default="False",
            ),
        ),
        raises=(
            ObjectNowhereToBeFound,
            ObjectUnfetchable,
            ObjectUnreachableOnFloor,
            EnvironmentManipulationImpossible,
        ),
        performs=(
            "accessing",
            "searching",
            "fetching",
            "delivering",
            "sealing",
            "navigating",
            "placing",
        ),
        note="ObjectUndeliverable: the object is dropped at the sink (placed on the sink "
        "counter) and None returned. Not found in the drawer it opened: the drawer is "
        "opened to the end of its travel and searched again. Not found, or not "
        "fetchable: searched on the floor "
        "around where it was believed, then fetched and delivered without projection. The "
        "drawer is closed in a shielded finally (also when the transport is evaporated).",
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


register_resources(transport, the_base)
