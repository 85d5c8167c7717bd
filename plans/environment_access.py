"""Accessing and sealing a container: navigate to the drawer's handle and open or close it
(part of CRAM HEAD's ``fetch-and-deliver-plans.lisp``), with CRAM's nested failure
handling and retry counts. The arm motions themselves (``opening``/``closing``) are in
:mod:`plans.environment`.

=================  ==========================================  ============================
action             retries (HEAD)                              raises when exhausted
=================  ==========================================  ============================
accessing/sealing  10 relocations                              env.-manipulation-impossible
=================  ==========================================  ============================

Deliberate differences from CRAM HEAD: when the base stops short
(:class:`plans.navigation.BaseStoppedShort`) the drawer is tried from where it stopped
(kept in spirit); and when the arm's relocations run out, the robot's other empty hands
are tried (v0.8.1's arm retry), each with :data:`OTHER_ARM_RELOCATIONS` base poses.
"""

from __future__ import annotations

import logging
from collections.abc import Iterator
from typing import Any

import cpl
from executive import (
    ContainerStates,
    Designator,
    DesignatorError,
    DesignatorInputError,
    EnvironmentManipulationImpossible,
    EnvironmentUnreachable,
    GripperLowLevelFailure,
    Key,
    ListCursor,
    LocationDesignator,
    ManipulationLowLevelFailure,
    NavigationGoalInCollision,
    ObjectDesignator,
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
    tally,
    the_base,
    translating_designator_errors,
)
from ._designators import _given_arm, _location, robot_name
from .checks import check_environment_manipulation_collisions
from .environment import DEFAULT_DISTANCE, handle_link
from .navigation import BaseStoppedShort

__all__ = [
    "CLOSED_WITHIN",
    "ENVIRONMENT_RELOCATIONS",
    "ENVIRONMENT_RELOCATION_FAILURES",
    "FARTHER_AT_LEAST",
    "OTHER_ARM_RELOCATIONS",
    "SEAL_TIMEOUT",
    "free_arm",
    "manipulate_environment",
    "open_farther",
    "opening_of",
    "seal_if_open",
]

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
    pose. When the relocations run out, the arm scope tries the robot's other empty
    hands, each with :data:`OTHER_ARM_RELOCATIONS` base poses (v0.8.1's one arm retry;
    HEAD had none). Raises ``EnvironmentManipulationImpossible`` (also for designator
    errors) naming the arms tried.

    Deliberate difference from HEAD (v0.8.1 retries with the other arm too): the left
    arm's ten base poses in front of the sink drawer all failed to open it on seeds 16
    and 17 (the pulled handle ends on the robot's right, out of the left arm's reach, or
    the drawer front would be pulled into the robot), and the spoon in it was lost."""
    arms = ListCursor([arm, *_other_free_arms(arm)])
    tried: list[str] = []

    def impossible(_failure: BaseException | None = None) -> EnvironmentManipulationImpossible:
        verb = "open" if action_type == "accessing" else "close"  # "cannot open drawer-1"
        return EnvironmentManipulationImpossible(
            f"cannot {verb} {container.short()} (arms tried: {', '.join(tried)})"
        )

    async def body() -> None:
        link = handle_link(container)
        try:
            handle = current_environment().world.link_pose(link, "map")
        except LookupError as error:
            raise DesignatorError(f"{container.short()}: {error}", container) from error
        allowed = (link, str(container.get("urdf-name")))

        @retry_scope(
            EnvironmentManipulationImpossible,
            arms,
            CountedRetries(len(arm_names()) - 1, "environment-arms"),
            rethrow=impossible,
        )
        async def with_arm() -> None:
            hand: str = arms.current
            tried.append(hand)
            base_poses = SolutionCursor(
                a.location(reachable_for=robot_name(), location=a.location(pose=handle), arm=hand)
            )
            relocations = ENVIRONMENT_RELOCATIONS if hand == arm else OTHER_ARM_RELOCATIONS

            @retry_scope(
                ENVIRONMENT_RELOCATION_FAILURES,
                base_poses,
                CountedRetries(relocations, "relocations"),
                rethrow=impossible,
            )
            async def from_here() -> None:
                try:
                    await perform(an.action(type="navigating", location=base_poses.current))
                except BaseStoppedShort as failure:
                    # deliberate: as CRAM did for every navigation, try from where the
                    # base stopped (next to an open drawer the base often stops a little
                    # short); the checked trajectory below decides whether the handle is
                    # in reach
                    log.info("acting on %s from where the base stopped: %s", link, failure)
                verb = "opening" if action_type == "accessing" else "closing"
                action = an.action(type=verb, object=container, arm=hand, distance=distance)
                await perform(check_environment_manipulation_collisions(action, allowed))

            await translating_designator_errors(from_here, impossible)

        await with_arm()

    await translating_designator_errors(body, impossible)


def _other_free_arms(arm: str) -> list[str]:
    """The robot's arms other than ``arm`` whose hand holds nothing (world model)."""
    world = current_environment().world
    return [n for n in arm_names() if n != arm and world.object_in_hand(n) is None]


#: The relocation scope of ``accessing`` / ``sealing`` for the arm asked for (CRAM HEAD's).
ENVIRONMENT_RELOCATIONS = 10
#: The relocation scope for each other arm tried after it (deliberate addition).
OTHER_ARM_RELOCATIONS = 5

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
        _check_container(d, container)
        arm = _given_arm(d, "left")
        distance = float(d.get("distance", DEFAULT_DISTANCE))
        yield (
            manipulate_environment,
            {"action_type": action_type, "container": container, "arm": arm, "distance": distance},
        )

    ground.__name__ = ground.__qualname__ = action_type
    return ground


def _check_container(d: Designator, container: ObjectDesignator) -> None:
    """A container whose ``urdf-name`` the world model does not know as a container (a
    misspelt drawer) is a :class:`executive.DesignatorInputError` naming the known ones,
    before anything moves, not "environment manipulation impossible" after ten
    relocations. A world model that cannot tell (no :class:`executive.ContainerStates`)
    leaves it to the handle lookup, as before."""
    name = container.get("urdf-name")
    env = current_environment()
    if not isinstance(name, str) or not env.has_world:
        return
    world = env.world
    if not isinstance(world, ContainerStates):
        return
    try:
        world.container_state(name)
    except LookupError as exc:
        raise DesignatorInputError(
            f"{d.short()}: its location is (in ...) {name!r}, which is not a container of "
            f"this world ({exc})",
            d,
        ) from None


def _environment_doc(verb: str) -> RuleDoc:
    act, acting = ("open", "opening") if verb == "accessing" else ("close", "closing")
    return RuleDoc(
        f"{act.capitalize()} the drawer a location is in (plan manipulate-environment): "
        f"navigate to reach its handle, check the {acting} in the belief, perform it.",
        keys=(
            Key(
                "location",
                "location designator (in <drawer>)",
                "the drawer's inside, e.g. where the spoon is",
                required=True,
            ),
            Key("arm", "'left' | 'right'", "the arm", default="'left'"),
            Key("distance", "number (m)", "how far", default=str(DEFAULT_DISTANCE)),
        ),
        raises=(EnvironmentManipulationImpossible,),
        retries=(
            Retry(
                ENVIRONMENT_RELOCATIONS,
                ENVIRONMENT_RELOCATION_FAILURES,
                "the next base pose reaching the handle",
                counter="relocations",
            ),
            Retry(
                1,
                (EnvironmentManipulationImpossible,),
                f"another empty hand, with {OTHER_ARM_RELOCATIONS} base poses reaching the "
                "handle for it (per other arm)",
                counter="environment-arms",
            ),
        ),
        performs=("navigating", acting),
        note="Designator errors become EnvironmentManipulationImpossible. A base that "
        "stopped short acts from where it stopped. The arm given is tried first, then the "
        "robot's other empty hands.",
    )


for _verb in ("accessing", "sealing"):
    rule("action", _verb, doc=_environment_doc(_verb))(_environment_rule(_verb))


# ------------------------------------------------------------------------ cleanup sealing
#: An opening (m) below which a container counts as closed (the sealing would have
#: nothing to push).
CLOSED_WITHIN = 0.005
#: Simulated seconds a cleanup's sealing may take (10 relocations of navigating and
#: closing take far less); then it is cancelled and fails.
SEAL_TIMEOUT = 180.0


def opening_of(container: ObjectDesignator) -> float | None:
    """How far (m) the world model has ``container`` open from its closed limit; None when
    it cannot tell (not an :class:`executive.ContainerStates`, or a container it does not
    know as jointed)."""
    state = _container_state(container)
    return None if state is None else max(0.0, state[0] - state[1])


def _container_state(container: ObjectDesignator) -> tuple[float, float, float] | None:
    """``(position, lower, upper)`` of ``container``'s joint in the world model; None when
    it cannot tell (not an :class:`executive.ContainerStates`, or a container it does not
    know as jointed)."""
    world = current_environment().world
    name = container.get("urdf-name")
    if not isinstance(world, ContainerStates) or not isinstance(name, str):
        return None
    try:
        return world.container_state(name)
    except LookupError:
        return None


def free_arm(preferred: str = "left") -> str | None:
    """``preferred`` if the robot has that hand and it holds nothing (in the world model),
    else another empty hand, else None (a one-armed robot: its hand or None)."""
    world = current_environment().world
    arms = arm_names()
    for arm in (*(n for n in arms if n == preferred), *(n for n in arms if n != preferred)):
        if world.object_in_hand(arm) is None:
            return arm
    return None


async def seal_if_open(location: LocationDesignator, *, assume_open: bool = False) -> bool:
    """Close the container of ``location`` (``(in <container>)``) if it is open, with
    ``sealing``: the cleanup of whatever opened it. Returns whether it sealed.

    Where the world model knows the container's joint (:class:`executive.ContainerStates`)
    it is sealed when open by :data:`CLOSED_WITHIN` or more, by exactly its opening (also
    a drawer left half open); where it cannot tell, only when ``assume_open`` (the caller
    knows it opened it), by :data:`plans.environment.DEFAULT_DISTANCE`. The arm is the
    left one unless that hand holds an object (a cleanup after an interrupted transport
    may still hold it), then the other. Both hands full: ``EnvironmentManipulationImpossible``.
    Bounded: after :data:`SEAL_TIMEOUT` simulated seconds the sealing is cancelled and
    ``EnvironmentManipulationImpossible`` raised (a pending evaporation wins). Run it
    shielded (``cpl.shielded``) from a ``finally``."""
    container = location.get("in")
    if not isinstance(container, ObjectDesignator):
        raise DesignatorError(f"{location.short()}: sealing needs (in <container>)", location)
    opening = opening_of(container)
    if opening is None:
        if not assume_open:
            return False
        distance = DEFAULT_DISTANCE
    elif opening < CLOSED_WITHIN:
        return False
    else:
        distance = opening
    arm = free_arm()
    if arm is None:
        raise EnvironmentManipulationImpossible(
            f"cannot seal {container.short()}: both hands hold objects"
        )
    sealing = an.action(type="sealing", location=location, arm=arm, distance=distance)
    try:
        await cpl.shielded(perform(sealing), timeout=SEAL_TIMEOUT)
    except TimeoutError as timeout:
        raise EnvironmentManipulationImpossible(
            f"sealing {container.short()} did not finish within {SEAL_TIMEOUT} s"
        ) from timeout
    return True


# ------------------------------------------------------------------- opening farther
#: :func:`open_farther` opens a container only if it can go at least this much (m)
#: farther.
FARTHER_AT_LEAST = 0.05


async def open_farther(location: LocationDesignator) -> bool:
    """Open the container of ``location`` (``(in <container>)``) to the end of its travel,
    with ``accessing`` and a free arm; returns whether it did. For a search that found
    nothing in it: CRAM's accessing opens a drawer by 0.3 m, and what lies behind that
    (the back 0.28 m of the sink drawer) stays inside the cabinet, out of the camera's
    view. Deliberate addition (no CRAM plan opens farther).

    Nothing to do (False): the world model cannot tell the container's travel
    (:class:`executive.ContainerStates`), it is open to within :data:`FARTHER_AT_LEAST` of
    its end, or no hand is free. An ``accessing`` that fails
    (``EnvironmentManipulationImpossible``: its checks found no arm and base pose that
    open it) is logged and counted (``drawer-farther-failed``), and False returned; the
    caller's cleanup closes the container by however far the world model has it open."""
    container = location.get("in")
    if not isinstance(container, ObjectDesignator):
        raise DesignatorError(
            f"{location.short()}: opening farther needs (in <container>)", location
        )
    state = _container_state(container)
    if state is None:
        return False
    position, _lower, upper = state
    room = upper - position
    arm = free_arm()
    if room < FARTHER_AT_LEAST or arm is None:
        return False
    tally("drawer-farther")
    accessing = an.action(type="accessing", location=location, arm=arm, distance=room)
    try:
        await perform(accessing)
    except EnvironmentManipulationImpossible as failure:
        log.warning("could not open %s farther: %s", container.short(), failure)
        tally("drawer-farther-failed")
        return False
    return True


register_resources(manipulate_environment, the_base)
