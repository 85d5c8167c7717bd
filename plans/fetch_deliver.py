"""Navigate, turn, search, fetch, deliver, transport, access and seal (CRAM HEAD's
``fetch-and-deliver-plans.lisp``), with CRAM's nested failure handling and retry counts:

=================  ==========================================  ============================
action             retries (HEAD)                              raises when exhausted
=================  ==========================================  ============================
navigating         30 collision-check samples                  navigation-goal-in-collision
turning-towards    1 (turn the base, look again)               looking-high-level-failure
searching          9 search locations                          object-nowhere-to-be-found
fetching           10 relocations, 1 regrasp, 30 pick checks   object-unfetchable
delivering         outer 2 targets, 5 relocations, 2 targets   object-undeliverable
accessing/sealing  10 relocations                              env.-manipulation-impossible
transporting       object-undeliverable -> drop at the sink    what search / fetch raise
=================  ==========================================  ============================

Every level has one retry scope: the counter and the designator cursor it advances are
named there; inner counters are created inside the outer body, so they start afresh on
every outer retry (CRAM's lexical counters). Counters are :class:`CountedRetries` whose
names ("relocations", "regrasps", "targets", "search", ...) the demo tallies.
Deliberate fix: ``deliver``'s outer retry reads the *advanced* target (HEAD read the old).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterator
from typing import Any

import cpl
from executive import (
    Designator,
    DesignatorError,
    EnvironmentManipulationImpossible,
    EnvironmentUnreachable,
    GripperLowLevelFailure,
    LocationDesignator,
    LookingHighLevelFailure,
    ManipulationLowLevelFailure,
    NavigationGoalInCollision,
    NavigationHighLevelFailure,
    NavigationLowLevelFailure,
    ObjectDesignator,
    ObjectNowhereToBeFound,
    ObjectUndeliverable,
    ObjectUnfetchable,
    ObjectUnreachable,
    PerceptionLowLevelFailure,
    Pose,
    PtuLowLevelFailure,
    SolutionCursor,
    a,
    an,
    current_environment,
    kitchen,
    knowledge,
    perform,
    retry_scope,
    rule,
)

from ._common import (
    CountedRetries,
    as_location,
    ignoring,
    object_label,
    perform_ignoring,
    to_base,
    to_map,
    translating_designator_errors,
    translating_failures,
)
from .atomic import park_arms
from .checks import (
    PlacingPoseUnstable,
    check_environment_manipulation_collisions,
    check_navigating_collisions,
    check_picking_up_collisions,
    check_placing_collisions,
    check_placing_pose_stability,
)
from .environment import DEFAULT_DISTANCE, handle_link
from .pick_place import release_held
from .reasoning import ProjectedParameters, with_projected_task_tree

__all__ = [
    "ROBOT",
    "deliver",
    "drop_at_sink",
    "fetch",
    "go_without_collisions",
    "manipulate_environment",
    "search_for_object",
    "transport",
    "turn_towards",
]

log = logging.getLogger(__name__)

#: The robot name in ``reachable-for`` / ``visible-for`` location designators.
ROBOT = "pr2"


def _location(d: Designator, key: str) -> LocationDesignator:
    value = d.get(key)
    if isinstance(value, (LocationDesignator, Pose)):
        return as_location(value)
    raise DesignatorError(f"{d.short()} needs a {key} (location designator or pose)", d)


def _check_places(d: Designator, *keys: str) -> None:
    """DesignatorError, raised by the action's rule (so before anything moves), when a
    location under ``keys`` names a surface (``(on ...)`` with a ``urdf-name``, also inside
    nested locations) that the environment's world does not have. Without this, an
    unknown surface failed only when the plan reached it, after the base and arms had
    moved (deliberate addition: CRAM checked nothing up front)."""
    world = getattr(current_environment(), "world", None)
    if world is None or not hasattr(world, "link_pose"):
        return
    stack: list[tuple[str, Any]] = [(key, d.get(key)) for key in keys]
    seen = 0
    while stack and seen < 50:
        key, value = stack.pop()
        seen += 1
        if not isinstance(value, LocationDesignator):
            continue
        # (in <container>) is left to the container's own rules: they reach it through its
        # handle link, which a world may know without knowing the container's body link
        for relation in ("on",):
            place = value.get(relation)
            if not isinstance(place, ObjectDesignator):
                continue
            link = place.get("urdf-name")
            if not isinstance(link, str):
                continue
            try:
                world.link_pose(link)
            except LookupError as exc:
                raise DesignatorError(
                    f"{d.short()}: its {key} is ({relation} ...) {link!r}, which this world "
                    f"does not have ({exc})",
                    d,
                ) from None
        stack.extend((key, v) for k, v in value.properties if isinstance(v, LocationDesignator))


def _object(d: Designator) -> ObjectDesignator:
    value = d.get("object")
    if not isinstance(value, ObjectDesignator):
        raise DesignatorError(f"{d.short()} needs an object designator", d)
    return value


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
    ``navigation-goal-in-collision``, never tried its next base pose."""
    await park_arms()
    checked = check_navigating_collisions(location)
    goal: Pose = to_map(checked.reference())

    @retry_scope(
        NavigationLowLevelFailure,
        None,
        CountedRetries(NAVIGATION_RETRIES, "navigation"),
        rethrow=lambda failure: BaseStoppedShort(f"did not get to {checked.short()}: {failure}"),
    )
    async def go() -> None:
        try:
            await perform(an.action(type="going", target=checked))
        except NavigationLowLevelFailure as failure:
            if not _close_enough(goal):
                raise
            log.info("the base stopped short but close enough to %r: %s", goal, failure)

    await go()


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


@rule("action", "navigating", keys=("location",))
def _navigating(d: Designator) -> Iterator[Any]:
    _check_places(d, "location")
    yield go_without_collisions, {"location": _location(d, "location")}


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


@rule("action", "turning-towards", keys=("target",))
def _turning_towards(d: Designator) -> Iterator[Any]:
    yield turn_towards, {"target": _location(d, "target")}


# ----------------------------------------------------------------------------- searching
#: Torso height (m) from which ``searching`` looks a second time (the upper limit: camera
#: at ~1.6 m).
SEARCH_TORSO_HEIGHT = 0.33

#: The failures after which ``searching`` tries the next sample of its location.
SEARCH_FAILURES = (NavigationGoalInCollision, LookingHighLevelFailure, PerceptionLowLevelFailure)


@cpl.plan(name="search-for-object")
async def search_for_object(
    object_designator: ObjectDesignator, location: LocationDesignator, retries: int = 9
) -> ObjectDesignator:
    """Go where ``location``'s current sample is visible, look at it and detect the
    object; a perception failure there is retried once from the raised torso (v0.8.1's
    torso retry: deliberate, HEAD has none); on ``navigation-goal-in-collision``,
    ``looking-high-level-failure`` or ``perception-low-level-failure`` try the next
    sample of ``location`` (9 retries).
    Raises ``ObjectNowhereToBeFound`` when samples or retries run out (and for designator
    errors). Returns the perceived designator."""
    spots = SolutionCursor(location)

    def nowhere(_failure: BaseException | None = None) -> ObjectNowhereToBeFound:
        return ObjectNowhereToBeFound(object=object_label(object_designator))

    @retry_scope(SEARCH_FAILURES, spots, CountedRetries(retries, "search"), rethrow=nowhere)
    async def look_there() -> ObjectDesignator:
        spot = spots.current.reference()
        view = a.location(visible_for=ROBOT, location=a.location(pose=spot))
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
    if any(world.object_in_hand(arm) for arm in knowledge.ARMS):
        return
    await park_arms("park")


async def _look_from_higher(spot: Pose) -> None:
    """Raise the torso to :data:`SEARCH_TORSO_HEIGHT` and turn towards ``spot`` again."""
    await perform(an.action(type="moving-torso", joint_angle=SEARCH_TORSO_HEIGHT))
    await perform(an.action(type="turning-towards", target=a.location(pose=spot)))


@rule("action", "searching", keys=("object", "location"))
def _searching(d: Designator) -> Iterator[Any]:
    _check_places(d, "location")
    yield search_for_object, {"object_designator": _object(d), "location": _location(d, "location")}


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
    the arms on ``gripper-low-level-failure``; exhausted -> ``object-unreachable``): detect,
    check the picking-up solutions (:func:`check_picking_up_collisions`, 30) and pick up.
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
                before_retry=park_arms,
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


# ---------------------------------------------------------------------------- delivering
def _injected_spot(
    place_action: Designator | None, robot_location: LocationDesignator | None
) -> Pose | None:
    """The map pose of an injected (projected) place action's target.

    CRAM reuses the projected placing target as it is, a pose in ``base_footprint``
    computed where the imagined robot stood. Deliberate difference: we anchor it in the
    map through that imagined base pose (the injected robot location), so that a real
    robot that stopped elsewhere still puts the object where projection meant it, and its
    own checks (IK, collisions, stability) judge it from where it really is."""
    if place_action is None:
        return None
    goal = place_action.current().get("target")
    if goal is None:
        return None
    pose = goal.reference() if isinstance(goal, LocationDesignator) else goal
    if not isinstance(pose, Pose):
        return None
    if pose.frame == "map":
        return pose
    if robot_location is None:
        return to_map(pose)
    base: Pose = robot_location.reference()
    if base.frame != "map":
        base = to_map(base)
    spot: Pose = base.to_transform("base_footprint") * pose
    return spot


@cpl.plan(name="deliver")
async def deliver(
    object_designator: ObjectDesignator,
    target: LocationDesignator,
    robot_location: LocationDesignator | None = None,
    place_action: Designator | None = None,
) -> None:
    """Deliver the held object to ``target``.

    Outer scope (2 retries over ``target``): on a designator error or
    ``object-undeliverable`` take the next target sample. Its body builds the robot
    location (``robot_location``'s newest effective member, or ``reachable-for`` the
    target pose) and runs the relocation scope (5 retries over the robot location; on
    ``navigation-goal-in-collision``, ``object-undeliverable`` or
    ``manipulation-low-level-failure``): navigate, then the target scope (2 retries over
    ``target``, the robot stays; on ``looking-high-level-failure``, ``object-unreachable``
    or an unstable placing pose): turn towards the target, check its stability (v0.8.1),
    build ``placing`` at the target in ``base_footprint``, check it
    (:func:`check_placing_collisions`) and perform it. Raises ``ObjectUndeliverable``."""
    targets = SolutionCursor(target)
    outer = CountedRetries(2, "deliver-targets")
    object_type = _held_type(object_designator)
    injected_spot = _injected_spot(place_action, robot_location)

    def undeliverable(_failure: BaseException | None = None) -> ObjectUndeliverable:
        return ObjectUndeliverable(object=object_label(object_designator))

    @retry_scope((DesignatorError, ObjectUndeliverable), targets, outer, rethrow=undeliverable)
    async def attempt() -> None:
        target_pose = to_map(targets.current.reference())
        given = robot_location.newest_effective() if robot_location is not None else None
        base_poses = SolutionCursor(
            given
            if given is not None
            else a.location(reachable_for=ROBOT, location=a.location(pose=target_pose))
        )

        @retry_scope(
            DELIVER_RELOCATION_FAILURES,
            base_poses,
            CountedRetries(5, "relocations"),
            rethrow=undeliverable,
        )
        async def from_here() -> None:
            await perform(an.action(type="navigating", location=base_poses.current))

            @retry_scope(
                DELIVER_TARGET_FAILURES,
                targets,
                CountedRetries(2, "targets"),
                rethrow=undeliverable,
            )
            async def place_at_target() -> None:
                spot = to_map(targets.current.reference())
                await perform(an.action(type="turning-towards", target=targets.current))
                check_placing_pose_stability(object_type, spot)
                goal = a.location(pose=to_base(spot))
                if injected_spot is not None:
                    goal = a.location(pose=to_base(injected_spot))
                # no explicit pose: a costmap sample, whose identity orientation means
                # nothing; the placing keeps the held yaw (see plans.pick_place)
                free_yaw = "pose" not in targets.current
                placing = an.action(
                    type="placing", object=object_designator, target=goal, free_yaw=free_yaw
                )
                await perform(check_placing_collisions(placing))

            await place_at_target()

        await from_here()

    # CRAM: designator-error -> object-undeliverable (also one raised while advancing a
    # target that has no solution at all, e.g. an empty costmap)
    await translating_designator_errors(attempt, undeliverable)
    await back_off()


#: The failures after which ``deliver`` goes to the next base pose.
DELIVER_RELOCATION_FAILURES = (
    NavigationGoalInCollision,
    ObjectUndeliverable,
    ManipulationLowLevelFailure,
)
#: The failures after which ``deliver`` tries the next target from where it stands.
DELIVER_TARGET_FAILURES = (LookingHighLevelFailure, ObjectUnreachable, PlacingPoseUnstable)


#: How far (m) the base backs off from a counter before the arms are parked.
BACK_OFF = 0.25


@cpl.plan(name="back-off")
async def back_off(distance: float = BACK_OFF) -> None:
    """Retreat before parking the arms next to a counter: drive the base ``distance``
    straight back if the belief's probe says the robot (with what it holds) stands free
    there; the going's failures are ignored (logged: the arms are parked wherever the
    base stopped). Deliberate addition: CRAM parked (``carry``) right where it had picked
    or placed, and the park swept the arm and the held object through the neighbours on
    the counter (the cereal box toppled off the sink counter, a delivered cup off the
    island)."""
    world = current_environment().world
    goal = to_map(Pose((-distance, 0.0, 0.0), frame="base_footprint"))
    probe = world.probe_base_pose(goal)
    if not probe.ok:
        log.info("no backing off: %s", probe.failure)
        return
    try:
        await perform(an.action(type="going", target=a.location(pose=goal)))
    except NavigationLowLevelFailure as failure:
        log.info("backing off stopped short: %s", failure)


def _held_type(obj: ObjectDesignator) -> str:
    otype = obj.current().type
    if isinstance(otype, str):
        return otype
    name = obj.current().get("name")
    return current_environment().world.object_type(name)


@rule("action", "delivering", keys=("object", "target", "robot-location", "place-action"))
def _delivering(d: Designator) -> Iterator[Any]:
    _check_places(d, "target", "robot-location")
    yield (
        deliver,
        {
            "object_designator": _object(d),
            "target": _location(d, "target"),
            "robot_location": d.get("robot-location"),
            "place_action": d.get("place-action"),
        },
    )


# -------------------------------------------------------------------------- transporting
#: CRAM's hard-coded drop-at-sink poses: the base in map, the object in base_footprint.
SINK_BASE_POSE = Pose((0.7, -0.2, 0.0))
SINK_DROP_POSE = Pose((0.7, 0.0, 1.2), frame="base_footprint")
#: The counter the object is put down on at the sink, and the gap (m) left below it.
SINK_SURFACE = kitchen.SINK_SURFACE
SINK_DROP_CLEARANCE = 0.01


def _sink_drop_pose(object_designator: ObjectDesignator) -> Pose:
    """Where ``drop-at-sink`` puts the object, in ``base_footprint`` at
    :data:`SINK_BASE_POSE`: CRAM's x and y, but (deliberate deviation) the height at which
    the held object's bottom is :data:`SINK_DROP_CLEARANCE` above the sink counter's top,
    from the world model's ``link_aabb`` and ``object_aabb`` (CRAM released it 1.2 m above
    the floor, 0.35 m above our counter: a bowl or cup bounced and rolled off the
    counter's front edge onto the floor). A world model that knows neither extent
    (``LookupError``): CRAM's pose."""
    world = current_environment().world
    name = object_designator.current().get("name")
    if not isinstance(name, str):
        return SINK_DROP_POSE
    try:
        top = world.link_aabb(SINK_SURFACE)[1][2]
        lo, hi = world.object_aabb(name)
    except LookupError:
        return SINK_DROP_POSE
    half = (hi[2] - lo[2]) / 2.0
    x, y, _z = SINK_DROP_POSE.position
    return Pose((x, y, top + half + SINK_DROP_CLEARANCE), frame="base_footprint")


async def drop_at_sink(object_designator: ObjectDesignator) -> None:
    """Go to CRAM's fixed pose at the sink and place the object there; every failure is
    ignored (CRAM's ``drop-at-sink``, quirk 9 kept: hard-coded base pose and x, y).
    Deliberate deviations: the object is put down *on* the sink counter rather than
    released 0.35 m above it (:func:`_sink_drop_pose`), keeping the yaw it is held with
    (``free-yaw``: the drop's orientation means nothing, and the held yaw needs no turn of
    the wrist); and a shielded cleanup releases the object if it is still in a hand (the
    placing failed, or the drop was evaporated): open the gripper and ``ObjectDetached``
    (:func:`plans.pick_place.release_held`), so no object stays attached after it."""

    async def drop() -> None:
        await perform(an.action(type="navigating", location=a.location(pose=SINK_BASE_POSE)))
        target = a.location(pose=_sink_drop_pose(object_designator))
        await perform(
            an.action(type="placing", object=object_designator, target=target, free_yaw=True)
        )

    try:
        await ignoring(drop, (cpl.PlanFailure, DesignatorError))
    finally:
        await cpl.shielded(release_held(object_designator))


@cpl.plan(name="transport")
async def transport(
    object_designator: ObjectDesignator,
    location: LocationDesignator,
    target: LocationDesignator,
    arm: str | None = None,
    projection_reasoning: bool = True,
    projection_runs: int = 3,
) -> ObjectDesignator | None:
    """Access the container (if ``location`` is ``in`` one), search, fetch and deliver the
    object; an ``object-undeliverable`` makes it drop the object at the sink. Search and
    fetch failures propagate. Fetch and deliver run inside
    :func:`~plans.reasoning.with_projected_task_tree` (``projection_runs`` imagined runs,
    the designator's ``projection-runs`` property, default 3; then the real one
    with the chosen base poses, arm, grasp and placing target) when
    ``projection_reasoning`` (the designator's ``projection-reasoning`` property, default
    true; CRAM's demo disables it) and the environment can imagine; otherwise it is a
    pass-through. Cleanup: the container is sealed in a ``finally`` that runs
    shielded, so it also runs when the transport is evaporated (the evaporation is
    re-raised afterwards). Returns the delivered object designator, or ``None`` when it was
    dropped at the sink."""
    container = location.get("in")
    accessible = container is None
    if not accessible:
        await perform(
            an.action(type="accessing", location=location, arm="left", distance=DEFAULT_DISTANCE)
        )
    try:
        found = await perform(
            an.action(type="searching", object=object_designator, location=location)
        )

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

        return await with_projected_task_tree(
            fetch_and_deliver,
            projection_runs,
            enabled=projection_reasoning,
            subject=found.current().get("name"),
        )
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
    keys=("object", "location", "target", "arm", "projection-reasoning", "projection-runs"),
)
def _transporting(d: Designator) -> Iterator[Any]:
    _check_places(d, "location", "target")
    yield (
        transport,
        {
            "object_designator": _object(d),
            "location": _location(d, "location"),
            "target": _location(d, "target"),
            "arm": d.get("arm"),
            "projection_reasoning": bool(d.get("projection-reasoning", True)),
            "projection_runs": int(d.get("projection-runs", 3)),
        },
    )


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
        arm = d.get("arm", "left")
        distance = float(d.get("distance", DEFAULT_DISTANCE))
        yield (
            manipulate_environment,
            {"action_type": action_type, "container": container, "arm": arm, "distance": distance},
        )

    ground.__name__ = ground.__qualname__ = action_type
    return ground


for _verb in ("accessing", "sealing"):
    rule("action", _verb, keys=("location", "arm", "distance"))(_environment_rule(_verb))
