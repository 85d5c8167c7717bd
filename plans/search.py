"""Searching for an object (part of CRAM HEAD's ``fetch-and-deliver-plans.lisp``), with
CRAM's nested failure handling and retry counts:

=================  ==========================================  ============================
action             retries (HEAD)                              raises when exhausted
=================  ==========================================  ============================
searching          9 search locations                          object-nowhere-to-be-found
=================  ==========================================  ============================

Deliberate differences from HEAD: v0.8.1's torso retry (a perception failure is retried
once from the raised torso), and the arms are parked out of view before looking
(:func:`arms_out_of_view`; CRAM looked with them in ``carry``).
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import cpl
from executive import (
    Designator,
    Key,
    LocationDesignator,
    LookingHighLevelFailure,
    NavigationGoalInCollision,
    ObjectDesignator,
    ObjectNowhereToBeFound,
    PerceptionLowLevelFailure,
    Pose,
    Retry,
    RuleDoc,
    SolutionCursor,
    a,
    an,
    current_environment,
    perform,
    register_resources,
    retry_scope,
    rule,
)

from ._common import (
    CountedRetries,
    arm_names,
    object_label,
    the_base,
    the_robot,
    translating_designator_errors,
)
from ._designators import _check_places, _location, _object, default_of, robot_name
from .atomic import park_arms
from .viewpoints import navigate_to_best_viewpoint

__all__ = ["SEARCH_FAILURES", "arms_out_of_view", "search_for_object"]


# ----------------------------------------------------------------------------- searching

#: The failures after which ``searching`` tries the next sample of its location.
SEARCH_FAILURES = (NavigationGoalInCollision, LookingHighLevelFailure, PerceptionLowLevelFailure)


@cpl.plan(name="search-for-object")
async def search_for_object(
    object_designator: ObjectDesignator,
    location: LocationDesignator,
    retries: int = 9,
    viewpoint_reasoning: bool = False,
) -> ObjectDesignator:
    """Go where ``location``'s current sample is visible, look at it and detect the
    object; a perception failure there is retried once from the raised torso (v0.8.1's
    torso retry: deliberate, HEAD has none); on ``navigation-goal-in-collision``,
    ``looking-high-level-failure`` or ``perception-low-level-failure`` try the next
    sample of ``location`` (9 retries).
    Raises ``ObjectNowhereToBeFound`` when samples or retries run out (and for designator
    errors). Returns the perceived designator. ``viewpoint_reasoning``: choose the base pose
    to look from by projection (:func:`plans.viewpoints.navigate_to_best_viewpoint`;
    deliberate addition, CRAM samples one ``visible-for`` pose)."""
    spots = SolutionCursor(location)

    def nowhere(_failure: BaseException | None = None) -> ObjectNowhereToBeFound:
        return ObjectNowhereToBeFound(object=object_label(object_designator))

    @retry_scope(SEARCH_FAILURES, spots, CountedRetries(retries, "search"), rethrow=nowhere)
    async def look_there() -> ObjectDesignator:
        spot = spots.current.reference()
        view = a.location(visible_for=robot_name(), location=a.location(pose=spot))
        if viewpoint_reasoning:
            await navigate_to_best_viewpoint(object_designator, spots.current, spot, view)
        else:
            await perform(an.action(type="navigating", location=view))
        await arms_out_of_view()
        await perform(an.action(type="turning-towards", target=a.location(pose=spot)))

        # v0.8.1's torso retry: a taller object in front may hide the one sought from the
        # default camera height; raise the camera and look again.
        @retry_scope(
            PerceptionLowLevelFailure,
            None,
            CountedRetries(1, "search-torso"),
            before_retry=lambda: _look_from_higher(spot),
        )
        async def detect() -> ObjectDesignator:
            found: ObjectDesignator = await perform(
                an.action(type="detecting", object=object_designator)
            )
            return found

        return await detect()

    result: ObjectDesignator = await translating_designator_errors(look_there, nowhere)
    return result


async def arms_out_of_view() -> None:
    """Before looking for an object: both arms to ``park`` (at the sides) if they hold
    nothing. Deliberate difference from CRAM, which looked with the arms in ``carry``:
    from the counter the palm in ``carry`` hides objects in the drawer and low on the
    counter (the spoon's visibility was 0.33 in ``carry`` and 1.0 in ``park`` from the
    same base pose)."""
    world = current_environment().world
    if any(world.object_in_hand(arm) for arm in arm_names()):
        return
    await park_arms("park")


async def _look_from_higher(spot: Pose) -> None:
    """Raise the torso to its upper limit (the robot description's
    :attr:`executive.TorsoDescription.upper`; the PR2-like robot's camera is then at
    ~1.6 m) and turn towards ``spot`` again."""
    await perform(an.action(type="moving-torso", joint_angle=the_robot().torso.upper))
    await perform(an.action(type="turning-towards", target=a.location(pose=spot)))


@rule(
    "action",
    "searching",
    doc=RuleDoc(
        "Find the object at the location (plan search-for-object): for a sample of the "
        "location, navigate to where it is visible, park the arms out of view (if the hands "
        "are empty), turn towards it, detect. Returns the perceived object designator.",
        keys=(
            Key("object", "object designator", "what to find (type, name)", required=True),
            Key(
                "location",
                "location designator or executive.Pose",
                "where to look (e.g. on a surface); each retry takes its next sample",
                required=True,
            ),
            Key(
                "viewpoint-reasoning",
                "bool",
                "choose where to look from by imagining candidate viewpoints",
                default="False: one visible-for sample",
            ),
        ),
        raises=(ObjectNowhereToBeFound,),
        retries=(
            Retry(
                default_of(search_for_object, "retries"),
                SEARCH_FAILURES,
                "the location's next sample",
                counter="search",
            ),
            Retry(
                1,
                (PerceptionLowLevelFailure,),
                "raise the torso to its upper limit, turn towards, detect again",
                counter="search-torso",
            ),
        ),
        performs=("navigating", "positioning-arm", "turning-towards", "detecting", "moving-torso"),
        note="Each detecting makes its own 4 retries inside (same place, same view).",
    ),
)
def _searching(d: Designator) -> Iterator[Any]:
    _check_places(d, "location")
    yield (
        search_for_object,
        {
            "object_designator": _object(d),
            "location": _location(d, "location"),
            "viewpoint_reasoning": bool(d.get("viewpoint-reasoning", False)),
        },
    )


register_resources(search_for_object, the_base)
