"""Fetching a perceived object (part of CRAM HEAD's ``fetch-and-deliver-plans.lisp``), with
CRAM's nested failure handling and retry counts:

=================  ==========================================  ============================
action             retries (HEAD)                              raises when exhausted
=================  ==========================================  ============================
fetching           10 relocations, 1 regrasp, 60 pick checks   object-unfetchable
=================  ==========================================  ============================

Deliberate difference from CRAM: the base backs off (:func:`plans.navigation.back_off`)
before the arms are parked after the pick.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import cpl
from executive import (
    Designator,
    GripperLowLevelFailure,
    LocationDesignator,
    LookingHighLevelFailure,
    ManipulationLowLevelFailure,
    NavigationGoalInCollision,
    ObjectDesignator,
    ObjectUnfetchable,
    ObjectUnreachable,
    PerceptionLowLevelFailure,
    SolutionCursor,
    a,
    an,
    perform,
    retry_scope,
    rule,
)

from ._common import (
    CountedRetries,
    object_label,
    translating_designator_errors,
)
from ._designators import ROBOT, _check_places, _object
from .atomic import park_arms
from .checks import check_picking_up_collisions
from .navigation import back_off, park_clear

__all__ = ["FETCH_RELOCATION_FAILURES", "fetch"]


# ------------------------------------------------------------------------------ fetching
@cpl.plan(name="fetch")
async def fetch(
    object_designator: ObjectDesignator,
    arm: str | None = None,
    robot_location: LocationDesignator | None = None,
    pick_up_action: Designator | None = None,
) -> ObjectDesignator:
    """Fetch a perceived object.

    Relocation scope (10 retries over ``robot_location``, default ``reachable-for`` the
    object's current map pose): on ``navigation-goal-in-collision``,
    ``looking-high-level-failure``, ``perception-low-level-failure``,
    ``object-unreachable`` or ``manipulation-low-level-failure`` go to the next base pose.
    Its body: navigate, turn towards the object, then the regrasp scope (1 retry, parks
    the arms on ``gripper-low-level-failure``, backing off first if the belief says the
    park would sweep through a neighbour (:func:`plans.navigation.park_clear`); exhausted
    -> ``object-unreachable``): detect, check the picking-up solutions
    (:func:`check_picking_up_collisions`, 60) and pick up.
    Raises ``ObjectUnfetchable`` when relocations run out (and for designator errors).
    Parks the arms and returns the newest object designator."""

    def unfetchable(_failure: BaseException | None = None) -> ObjectUnfetchable:
        return ObjectUnfetchable(object=object_label(object_designator))

    async def body() -> ObjectDesignator:
        name = object_designator.current().get("name")
        object_pose = a.location(of_item_object=name).reference()
        base_poses = SolutionCursor(
            robot_location.current()
            if robot_location is not None
            else a.location(reachable_for=ROBOT, location=a.location(pose=object_pose), arm=arm)
        )

        @retry_scope(
            FETCH_RELOCATION_FAILURES,
            base_poses,
            CountedRetries(10, "relocations"),
            rethrow=unfetchable,
        )
        async def from_here() -> None:
            await perform(an.action(type="navigating", location=base_poses.current))
            await perform(an.action(type="turning-towards", target=a.location(pose=object_pose)))

            @retry_scope(
                GripperLowLevelFailure,
                None,
                CountedRetries(1, "regrasps"),
                before_retry=park_clear,
                rethrow=lambda _f: ObjectUnreachable(object=object_label(object_designator)),
            )
            async def pick() -> None:
                perceived = await perform(an.action(type="detecting", object=object_designator))
                given_arm, given_grasp = _arm_and_grasp(pick_up_action)
                picking = an.action(
                    type="picking-up",
                    object=perceived,
                    arm=given_arm if pick_up_action is not None else arm,
                    grasp=given_grasp,
                )
                await perform(check_picking_up_collisions(picking))

            await pick()

        await from_here()
        await back_off()
        await park_arms()
        return object_designator.current()

    result: ObjectDesignator = await translating_designator_errors(body, unfetchable)
    return result


#: The failures after which ``fetch`` goes to the next base pose.
FETCH_RELOCATION_FAILURES = (
    NavigationGoalInCollision,
    LookingHighLevelFailure,
    PerceptionLowLevelFailure,
    ObjectUnreachable,
    ManipulationLowLevelFailure,
)


def _arm_and_grasp(pick_up_action: Designator | None) -> tuple[Any, Any]:
    """The arm and grasp of a given ``picking-up`` (its newest member): its properties,
    else those of its grounding when it was referenced (a projected pick names them only
    there). ``(None, None)`` without one."""
    if pick_up_action is None:
        return None, None
    given = pick_up_action.current()
    arm, grasp = given.get("arm"), given.get("grasp")
    grounded = given.newest_effective()
    if grounded is not None and (arm is None or grasp is None):
        arguments = grounded.reference().arguments
        if isinstance(arguments, dict):
            arm = arm if arm is not None else arguments.get("arm")
            grasp = grasp if grasp is not None else arguments.get("grasp")
    return arm, grasp


@rule("action", "fetching", keys=("object", "arm", "robot-location", "pick-up-action"))
def _fetching(d: Designator) -> Iterator[Any]:
    _check_places(d, "robot-location")
    yield (
        fetch,
        {
            "object_designator": _object(d),
            "arm": d.get("arm"),
            "robot_location": d.get("robot-location"),
            "pick_up_action": d.get("pick-up-action"),
        },
    )
