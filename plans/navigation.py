"""Navigating, turning towards and backing off (part of CRAM HEAD's
``fetch-and-deliver-plans.lisp``), with CRAM's nested failure handling and retry counts:

=================  ==========================================  ============================
action             retries (HEAD)                              raises when exhausted
=================  ==========================================  ============================
navigating         30 collision-check samples                  navigation-goal-in-collision
turning-towards    1 (turn the base, look again)               looking-high-level-failure
=================  ==========================================  ============================

``back-off`` (a deliberate addition: CRAM has none) retreats the base before the arms are
parked next to a counter; ``fetch`` and ``deliver`` use it. Deliberate differences from
CRAM: ``go-without-collisions`` does not ignore the going's failures (it drives again,
then raises :class:`BaseStoppedShort`; when a collision on the way stopped it, it drives
again by a :func:`detour`), and a ptu failure of the look forward while turning towards
is ignored.

``navigating`` claims the base for its duration, ``turning-towards`` the head and the base
(it may turn the base) (:func:`executive.register_resources`).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterator, Mapping
from typing import Any

import cpl
from executive import (
    ArmSweepProbe,
    Designator,
    DesignatorError,
    DesignatorInputError,
    Key,
    LocationDesignator,
    LookingHighLevelFailure,
    NavigationGoalInCollision,
    NavigationHighLevelFailure,
    NavigationLowLevelFailure,
    NavigationPoseUnreachable,
    Pose,
    PtuLowLevelFailure,
    Resource,
    Retry,
    RuleDoc,
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
    arms_left_to_right,
    base_frame,
    perform_ignoring,
    tally,
    the_base,
    the_robot,
    to_base,
    to_map,
    translating_failures,
)
from ._designators import _check_places, _location, default_of
from .checks import check_navigating_collisions

__all__ = [
    "BACK_OFF",
    "DETOUR_BACK_OFFS",
    "NAVIGATION_RETRIES",
    "NAVIGATION_TOLERANCE",
    "PARK_BACK_OFFS",
    "BaseStoppedShort",
    "back_off",
    "detour",
    "detour_poses",
    "go_without_collisions",
    "park_clear",
    "turn_towards",
]

log = logging.getLogger(__name__)


# ---------------------------------------------------------------------------- navigating
@cpl.plan(name="go-without-collisions")
async def go_without_collisions(location: LocationDesignator) -> None:
    """Park the arms (carry), pick a collision-free sample of ``location`` (up to 30,
    :func:`check_navigating_collisions`), and go there; a navigation low-level failure
    (the base stopped short: a fault, or a collision on the way) drives again from where
    it stopped (:data:`NAVIGATION_RETRIES`), unless it stopped within
    :data:`NAVIGATION_TOLERANCE` of the goal (logged). Raises ``NavigationGoalInCollision``
    (also for designator errors, and when the goal was never reached).

    Deliberate difference from CRAM, which ignored the going's failures: the plan went on
    from wherever the base had stopped (e.g. short of the island, where every placing
    then failed IK), and the caller's relocation scope, which only retries on
    ``navigation-goal-in-collision``, never tried its next base pose. The park before
    driving is :func:`park_clear` (CRAM parked wherever the robot stood)."""
    await park_clear()
    checked = check_navigating_collisions(location)
    goal: Pose = to_map(checked.reference())

    blocked = False  # the last going stopped at a collision (not a fault)
    start = current_environment().world.robot_pose()  # free: the base stood there

    @retry_scope(
        NavigationLowLevelFailure,
        None,
        CountedRetries(NAVIGATION_RETRIES, "navigation"),
        rethrow=lambda failure: BaseStoppedShort(f"did not get to {checked.short()}: {failure}"),
        before_retry=lambda: detour(start, goal) if blocked else None,
    )
    async def go() -> None:
        nonlocal blocked
        try:
            await perform(an.action(type="going", target=checked))
        except NavigationLowLevelFailure as failure:
            if not _close_enough(goal):
                blocked = _blocked_by_collision(failure)
                raise
            log.info("the base stopped short but close enough to %r: %s", goal, failure)

    await go()


def _blocked_by_collision(failure: BaseException) -> bool:
    """Whether the going stopped because the base (or what it carries) would have
    collided (its cause is a :class:`executive.NavigationPoseUnreachable`), not because
    of a fault."""
    cause: BaseException | None = failure
    while cause is not None:
        if isinstance(cause, NavigationPoseUnreachable):
            return True
        cause = cause.__cause__
    return False


#: How far (m) behind a goal, along the goal's own heading, :func:`detour` looks for a
#: pre-stand, nearest first.
DETOUR_BACK_OFFS = (0.5, 0.8)


def detour_poses(goal: Pose) -> tuple[Pose, ...]:
    """The pre-stands of :func:`detour`: ``goal`` (map) moved back along its heading by
    each of :data:`DETOUR_BACK_OFFS`, with the goal's yaw."""
    x, y, _z = goal.position
    c, s = math.cos(goal.yaw), math.sin(goal.yaw)
    return tuple(Pose.from_xyz_yaw(x - c * d, y - s * d, 0.0, goal.yaw) for d in DETOUR_BACK_OFFS)


async def detour(start: Pose, goal: Pose) -> None:
    """Before driving again to a ``goal`` (map) that a collision on the way stopped the
    base short of: drive back to ``start`` (where this navigating began: free, the base
    stood there, and the way back is the way it came), then to a pre-stand behind the goal
    (:func:`detour_poses`, the first that is collision-free in the belief,
    ``probe_base_pose``), so that the last leg is a straight drive forwards onto the goal.

    Deliberate addition (CRAM's navigation had no path around obstacles, and
    ``go-without-collisions`` only drove again from where it stopped): a stand beside the
    kitchen island's corner (the milk's, south of the island) was reached by a straight
    or dog-leg path that clipped the corner; the base stopped there, wedged (every first
    step from there collided), and stayed on every try and every base pose (seeds 12 and
    17 without faults: the milk was dropped at the sink). A step of the detour that fails,
    or no free pre-stand, is logged and counted (``detour-failed``): the drive to the goal
    is tried anyway, and its own failure says what happened."""
    world = current_environment().world
    steps = [start]
    pre = next((via for via in detour_poses(goal) if world.probe_base_pose(via).ok), None)
    if pre is None:
        log.info("no collision-free pre-stand behind %r", goal)
        tally("detour-failed")
    else:
        steps.append(pre)
    for via in steps:
        try:
            await perform(an.action(type="going", target=a.location(pose=via)))
        except NavigationLowLevelFailure as failure:
            log.info("the detour to %r stopped short: %s", via, failure)
            tally("detour-failed")


class BaseStoppedShort(NavigationGoalInCollision):
    """``go-without-collisions`` did not get to its collision-free goal (the base stopped
    short, even after driving again). A ``navigation-goal-in-collision`` for every retry
    scope that relocates; ``accessing``/``sealing`` act from where the base stopped."""


#: How often ``go-without-collisions`` drives again after the base stopped short.
NAVIGATION_RETRIES = 1
#: How near (m, rad) a base that stopped short must be to its goal to count as there.
NAVIGATION_TOLERANCE = (0.05, 0.1)


def _close_enough(goal: Pose) -> bool:
    robot = current_environment().world.robot_pose()
    d, angle = NAVIGATION_TOLERANCE
    return robot.distance_to(goal) <= d and abs(_wrap(robot.yaw - goal.yaw)) <= angle


def _wrap(angle: float) -> float:
    return (angle + math.pi) % (2 * math.pi) - math.pi


@rule(
    "action",
    "navigating",
    doc=RuleDoc(
        "Drive to a collision-free pose of the location (plan go-without-collisions): park "
        "the arms (carry; backing off first if the park would sweep through something), "
        "probe the location's samples in the belief, drive to the first free one.",
        keys=(
            Key(
                "location",
                "location designator or executive.Pose",
                "where the base may stand (e.g. reachable-for / visible-for)",
                required=True,
            ),
        ),
        raises=(NavigationGoalInCollision,),
        retries=(
            Retry(
                default_of(check_navigating_collisions, "samples"),
                (NavigationGoalInCollision,),
                "the location's next sample",
                probes=True,
            ),
            Retry(
                NAVIGATION_RETRIES,
                (NavigationLowLevelFailure,),
                "drive again (within 5 cm / 0.1 rad counts); stopped by a collision: "
                "by a detour (back to the start, a pre-stand behind the goal)",
                counter="navigation",
            ),
        ),
        performs=("positioning-arm", "going"),
        note="A (on ...) surface the world does not have is a DesignatorError before "
        "anything moves. When the base stops short for good: BaseStoppedShort (a "
        "NavigationGoalInCollision).",
    ),
)
def _navigating(d: Designator) -> Iterator[Any]:
    _check_places(d, "location")
    yield go_without_collisions, {"location": _location(d, "location")}


register_resources(go_without_collisions, the_base)


# ----------------------------------------------------------------------- turning towards
def _turned_base(target: Pose) -> Pose:
    """The robot's pose rotated in place to face ``target``."""
    world = current_environment().world
    in_base = to_base(target)
    yaw = math.atan2(in_base.position[1], in_base.position[0])
    robot = world.robot_pose()
    return Pose.from_xyz_yaw(robot.position[0], robot.position[1], 0.0, robot.yaw + yaw)


@cpl.plan(name="turn-towards")
async def turn_towards(target: LocationDesignator) -> None:
    """Look at ``target``; on ``ptu-low-level-failure`` (1 retry) turn the base towards it
    (``navigating``), look forward and look again. Raises ``LookingHighLevelFailure`` when
    the retry is used up, and for designator errors and navigation high-level failures."""

    @retry_scope(
        PtuLowLevelFailure,
        None,
        CountedRetries(1, "turns"),
        before_retry=lambda: _turn_base_towards(target),
        rethrow=lambda _f: LookingHighLevelFailure(f"cannot look at {target.short()}"),
    )
    async def look() -> None:
        await perform(an.action(type="looking", target=target))

    await translating_failures(
        (DesignatorError, NavigationHighLevelFailure),
        look,
        lambda failure: LookingHighLevelFailure(str(failure)),
    )


async def _turn_base_towards(target: LocationDesignator) -> None:
    """Turn the base towards ``target`` and look forward (before looking again)."""
    base = _turned_base(target.current().reference())
    await perform(an.action(type="navigating", location=a.location(pose=base)))
    # deliberate: a ptu failure of this look forward is ignored (in CRAM it escaped the
    # handler as a low-level failure and ended the whole transport); the retry looks at
    # the target again anyway
    await perform_ignoring(an.action(type="looking", direction="forward"), PtuLowLevelFailure)


@rule(
    "action",
    "turning-towards",
    doc=RuleDoc(
        "Look at the target, turning the base towards it when the head cannot (plan turn-towards).",
        keys=(
            Key(
                "target",
                "location designator or executive.Pose",
                "the point to look at",
                required=True,
            ),
        ),
        raises=(LookingHighLevelFailure,),
        retries=(
            Retry(
                1,
                (PtuLowLevelFailure,),
                "turn the base towards the target (navigating), look forward, look again",
                counter="turns",
            ),
        ),
        performs=("looking", "navigating"),
        note="Designator errors and navigation failures also become LookingHighLevelFailure.",
    ),
)
def _turning_towards(d: Designator) -> Iterator[Any]:
    yield turn_towards, {"target": _location(d, "target")}


_HEAD_AND_BASE = (Resource.head(), Resource.base())
register_resources(turn_towards, lambda _args: _HEAD_AND_BASE)


# --------------------------------------------------------------------------- backing off
#: How far (m) the base backs off from a counter before the arms are parked.
BACK_OFF = 0.25


@cpl.plan(name="back-off")
async def back_off(distance: float = BACK_OFF, sideways: float = 0.0) -> bool:
    """Retreat before parking the arms next to a counter: drive the base ``distance``
    straight back if the belief's probe says the robot (with what it holds) stands free
    there; the going's failures are ignored (logged: the arms are parked wherever the
    base stopped). Deliberate addition: CRAM parked (``carry``) right where it had picked
    or placed, and the park swept the arm and the held object through the neighbours on
    the counter (the cereal box toppled off the sink counter, a delivered cup off the
    island). ``sideways``: also that far to the base's left (negative: right), the same
    orientation. Returns whether it drove (False: the belief says the robot cannot stand
    there)."""
    world = current_environment().world
    goal = to_map(Pose((-distance, sideways, 0.0), frame=base_frame()))
    probe = world.probe_base_pose(goal)
    if not probe.ok:
        log.info("no backing off: %s", probe.failure)
        return False
    try:
        await perform(an.action(type="going", target=a.location(pose=goal)))
    except NavigationLowLevelFailure as failure:
        log.info("backing off stopped short: %s", failure)
    return True


#: How often :func:`park_clear` backs off while the park from where the base stands
#: would sweep through an object or end inside the kitchen.
PARK_BACK_OFFS = 2
#: Where :func:`park_clear` steps to before a park that would sweep (m, the base frame:
#: back, left), the first the belief says the robot stands free at: straight back, back
#: and to either side (a counter or the island right behind the robot), a short step back.
PARK_STEPS = ((BACK_OFF, 0.0), (BACK_OFF, 0.2), (BACK_OFF, -0.2), (0.1, 0.0))


async def _step_away() -> bool:
    """Back off to the first of :data:`PARK_STEPS` the belief says is free; whether the
    base drove."""
    for back, left in PARK_STEPS:
        if await back_off(back, left):
            return True
    return False


async def park_clear(configuration: str | Mapping[str, str] = "carry") -> None:
    """Park the arms (:func:`plans.atomic.park_arms`) without sweeping them, or what they
    hold, through an object, as far as the belief can tell: the world model's
    ``probe_arm_configuration`` checks the path the arm controller will take (and fails
    where the arms would end inside the kitchen, e.g. the carry configuration next to a
    drawer the robot has just opened). A world model without that probe (a test double)
    is not asked. Where the park from here would sweep:

    1. the base steps away first (:func:`_step_away`: back, back and aside, a short step
       back; each probed), up to :data:`PARK_BACK_OFFS` times, re-probed after each;
    2. still blocked: the arms park **one at a time**, those whose own park is clear
       first (the other arm then stands still, and an arm that would sweep alongside
       it often does not alone: both arms from a counter where the robot could not
       back off swept the milk to the floor, seed 2); an arm whose own park still
       sweeps parks last anyway (logged, counted ``park-sweeps``): the robot has to
       carry.

    ``configuration`` names one configuration for every arm, or one per arm (arm name ->
    configuration, every arm of the robot: the final cleanup's holding arm to ``carry``,
    a free one to ``park``).

    Deliberate addition: CRAM parked wherever the robot stood (after a pick-up, a failed
    grip, before driving off), both arms at once, and from next to a counter the park
    swept the neighbours off it."""
    names = [arm.name for arm in the_robot().arms]
    if isinstance(configuration, str):
        per_arm = dict.fromkeys(names, configuration)
    else:
        per_arm = dict(configuration)
        if sorted(per_arm) != sorted(names):
            raise DesignatorInputError(
                f"park_clear: give a configuration for each arm of the robot {names}, "
                f"not for {sorted(per_arm)}"
            )

    async def park_all() -> None:
        await perform(
            an.action(
                type="positioning-arm",
                **{f"{arm}_configuration": per_arm[arm] for arm in arms_left_to_right()},
            )
        )

    world = current_environment().world
    if not isinstance(world, ArmSweepProbe):
        await park_all()
        return
    joints = {arm.name: arm.state(per_arm[arm.name]) for arm in the_robot().arms}
    result = world.probe_arm_configuration(left=joints.get("left"), right=joints.get("right"))
    for _ in range(PARK_BACK_OFFS):
        if result.ok:
            break
        log.info("stepping away before parking: %s", result.failure)
        if not await _step_away():
            break
        result = world.probe_arm_configuration(left=joints.get("left"), right=joints.get("right"))
    if result.ok or len(joints) == 1:
        if not result.ok:
            log.warning("parking although it sweeps: %s", result.failure)
            tally("park-sweeps")
        await park_all()
        return
    waiting = list(joints)
    while waiting:
        clear = [
            arm
            for arm in waiting
            if world.probe_arm_configuration(**{arm: joints[arm]}).ok  # type: ignore[arg-type]
        ]
        if clear:
            arm = clear[0]
        else:
            arm = waiting[0]
            log.warning("parking the %s arm although it sweeps (no clear park left)", arm)
            tally("park-sweeps")
        log.info("parking the %s arm alone", arm)
        await perform(an.action(type="positioning-arm", **{f"{arm}_configuration": per_arm[arm]}))
        waiting.remove(arm)
