"""Accessing and sealing a container: navigate to the drawer's handle and open or close it
(part of CRAM HEAD's ``fetch-and-deliver-plans.lisp``), with CRAM's nested failure
handling and retry counts. The arm motions themselves (``opening``/``closing``) are in
:mod:`plans.environment`.

=================  ==========================================  ============================
action             retries (HEAD)                              raises when exhausted
=================  ==========================================  ============================
accessing/sealing  10 relocations                              env.-manipulation-impossible
=================  ==========================================  ============================

Deliberate difference from CRAM (kept in spirit): when the base stops short
(:class:`plans.navigation.BaseStoppedShort`) the drawer is tried from where it stopped.
"""

from __future__ import annotations

import logging
from collections.abc import Iterator
from typing import Any

import cpl
from executive import (
    Designator,
    DesignatorError,
    EnvironmentManipulationImpossible,
    EnvironmentUnreachable,
    GripperLowLevelFailure,
    ManipulationLowLevelFailure,
    NavigationGoalInCollision,
    ObjectDesignator,
    SolutionCursor,
    a,
    an,
    current_environment,
    perform,
    retry_scope,
    rule,
)

from ._common import (
    CountedRetries,
    translating_designator_errors,
)
from ._designators import ROBOT, _given_arm, _location
from .checks import check_environment_manipulation_collisions
from .environment import DEFAULT_DISTANCE, handle_link
from .navigation import BaseStoppedShort

__all__ = ["ENVIRONMENT_RELOCATION_FAILURES", "manipulate_environment"]

log = logging.getLogger(__name__)


# ---------------------------------------------------------------------- accessing/sealing
@cpl.plan(name="manipulate-environment")
async def manipulate_environment(
    action_type: str, container: ObjectDesignator, arm: str, distance: float
) -> None:
    """Open (``accessing``) or close (``sealing``) a drawer: relocation scope (10 retries
    over ``reachable-for`` the handle, for ``arm``): navigate, build ``opening``/
    ``closing``, check it (:func:`check_environment_manipulation_collisions`, contacts with
    the drawer allowed) and perform it. On ``navigation-goal-in-collision``,
    ``environment-unreachable``, gripper or manipulation low-level failures: next base
    pose. Raises ``EnvironmentManipulationImpossible`` (also for designator errors)."""

    def impossible(_failure: BaseException | None = None) -> EnvironmentManipulationImpossible:
        return EnvironmentManipulationImpossible(f"cannot {action_type} {container.short()}")

    async def body() -> None:
        link = handle_link(container)
        try:
            handle = current_environment().world.link_pose(link, "map")
        except LookupError as error:
            raise DesignatorError(f"{container.short()}: {error}", container) from error
        base_poses = SolutionCursor(
            a.location(reachable_for=ROBOT, location=a.location(pose=handle), arm=arm)
        )
        allowed = (link, str(container.get("urdf-name")))

        @retry_scope(
            ENVIRONMENT_RELOCATION_FAILURES,
            base_poses,
            CountedRetries(10, "relocations"),
            rethrow=impossible,
        )
        async def from_here() -> None:
            try:
                await perform(an.action(type="navigating", location=base_poses.current))
            except BaseStoppedShort as failure:
                # deliberate: as CRAM did for every navigation, try from where the base
                # stopped (next to an open drawer the base often stops a little short);
                # the checked trajectory below decides whether the handle is in reach
                log.info("acting on %s from where the base stopped: %s", link, failure)
            verb = "opening" if action_type == "accessing" else "closing"
            action = an.action(type=verb, object=container, arm=arm, distance=distance)
            await perform(check_environment_manipulation_collisions(action, allowed))

        await from_here()

    await translating_designator_errors(body, impossible)


#: The failures after which ``accessing`` / ``sealing`` go to the next base pose.
ENVIRONMENT_RELOCATION_FAILURES = (
    NavigationGoalInCollision,
    EnvironmentUnreachable,
    GripperLowLevelFailure,
    ManipulationLowLevelFailure,
)


def _environment_rule(action_type: str) -> Any:
    def ground(d: Designator) -> Iterator[Any]:
        location = _location(d, "location")
        container = location.get("in")
        if not isinstance(container, ObjectDesignator):
            raise DesignatorError(f"{d.short()}: its location must be (in <container>)", d)
        arm = _given_arm(d, "left")
        distance = float(d.get("distance", DEFAULT_DISTANCE))
        yield (
            manipulate_environment,
            {"action_type": action_type, "container": container, "arm": arm, "distance": distance},
        )

    ground.__name__ = ground.__qualname__ = action_type
    return ground


for _verb in ("accessing", "sealing"):
    rule("action", _verb, keys=("location", "arm", "distance"))(_environment_rule(_verb))
