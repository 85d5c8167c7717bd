"""Fetching a perceived object (part of CRAM HEAD's ``fetch-and-deliver-plans.lisp``), with
CRAM's nested failure handling and retry counts:

=================  ==========================================  ============================
action             retries (HEAD)                              raises when exhausted
=================  ==========================================  ============================
fetching           10 relocations, 1 regrasp, 60 pick checks   object-unfetchable
=================  ==========================================  ============================

Deliberate difference from CRAM: the base backs off (:func:`plans.navigation.back_off`)
before the arms are parked after the pick.

Deliberate addition (no CRAM plan does this): :func:`search_floor` looks for an object
that is no longer where it was believed (dropped, or knocked off a counter) on the floor
around that place; ``transport`` calls it, and ``fetch`` then picks it up from the floor
(the IK lowers the torso; top and side grasps as anywhere else). An object seen on the
floor that no base pose, arm and grasp can reach fails with
:class:`ObjectUnreachableOnFloor` (logged, and counted as ``floor-unreachable``).

Deliberate addition (beyond CRAM): an object on the floor at the foot of a counter (its
centre within :data:`plans.pushing.PUSH_NEAR` of a kitchen surface's footprint) is first
pushed away from that counter by the hand (:func:`plans.pushing.push_clear_of_counter`,
counted ``pushes``; a push the belief says cannot work is counted ``push-infeasible`` and
the fetch tries from where it lies), then fetched from where it was re-perceived.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterator
from typing import Any

import cpl
from executive import (
    Designator,
    GripperLowLevelFailure,
    Key,
    LocationDesignator,
    LookingHighLevelFailure,
    ManipulationLowLevelFailure,
    NavigationGoalInCollision,
    ObjectDesignator,
    ObjectNowhereToBeFound,
    ObjectUnfetchable,
    ObjectUnreachable,
    PerceptionLowLevelFailure,
    Pose,
    Retry,
    RuleDoc,
    SolutionCursor,
    Transform,
    a,
    an,
    current_environment,
    knowledge,
    perform,
    register_resources,
    retry_scope,
    rule,
)

from ._common import (
    CountedRetries,
    arm_names,
    object_label,
    tally,
    the_base,
    the_robot,
    translating_designator_errors,
)
from ._designators import _check_places, _given_arm, _object, default_of, learned_base, robot_name
from .checks import check_picking_up_collisions
from .navigation import back_off, park_clear
from .overhang import overhanging_grasps, push_until_overhanging
from .pushing import ObjectUnpushable, push_clear_of_counter
from .search import arms_out_of_view, search_for_object
from .toppled import (
    ObjectToppledUngraspable,
    check_graspable_as_it_lies,
    ungraspable_as_it_lies,
)

__all__ = [
    "FETCH_REGRASPS",
    "FETCH_RELOCATIONS",
    "FETCH_RELOCATION_FAILURES",
    "FLOOR_SEARCH_OFFSETS",
    "ObjectUnreachableOnFloor",
    "fetch",
    "floor_base_poses",
    "floor_height",
    "floor_pick_distances",
    "search_floor",
]

log = logging.getLogger(__name__)

# The retry budgets of ``fetching`` (CRAM HEAD's), each named once: the scopes below read
# them, and the tables of this module's and :mod:`plans`' docstrings are checked against
# them (tests/plans/test_retry_budgets.py). Its pick checks are
# :data:`plans.checks.PICK_CHECKS`.
#: The relocation scope: base poses tried.
FETCH_RELOCATIONS = 10
#: The regrasp scope: pick attempts again from the same base pose.
FETCH_REGRASPS = 1


def floor_height() -> float:
    """Below this height (m, map) an object lies on the floor: the current environment's
    kitchen's (:attr:`executive.KitchenDescription.floor_height`, one number for every
    layer)."""
    return current_environment().kitchen.floor_height


#: Where :func:`search_floor` looks, around the object's last believed position (m, map
#: x/y offsets; the spots are on the floor): there first, then 0.4 m around it.
FLOOR_SEARCH_OFFSETS = ((0.0, 0.0), (-0.4, 0.0), (0.0, -0.4), (0.0, 0.4), (0.4, 0.0))
#: The height (m) of a floor spot the robot looks at.
FLOOR_SPOT_Z = 0.05


class ObjectUnreachableOnFloor(ObjectUnfetchable):
    """An object lying on the floor that no base pose, arm and grasp could pick up (an
    ``object-unfetchable``). Deliberate addition: CRAM never fetched from the floor."""

    default_message = "Object on the floor out of reach."


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
    Backs off, parks the arms (:func:`plans.navigation.park_clear`: stepping away or
    one arm at a time where the park would sweep a neighbour) and returns the newest
    object designator."""

    def unfetchable(_failure: BaseException | None = None) -> ObjectUnfetchable:
        return ObjectUnfetchable(object=object_label(object_designator))

    async def body() -> ObjectDesignator:
        nonlocal object_designator
        # as the search perceived it: toppled with no grasp that fits, pushed over the
        # counter's edge first (or the typed failure, before moving)
        object_designator = await _graspable_as_it_lies(object_designator)
        name = object_designator.current().get("name")
        object_pose = a.location(of_item_object=name).reference()
        on_floor = object_pose.position[2] < floor_height()
        if on_floor and robot_location is None:
            # at the foot of a counter no grasp reaches it: pushed away first
            object_designator = await _pushed_clear(object_designator)
            object_pose = a.location(of_item_object=name).reference()
        if robot_location is not None:
            where = robot_location.current()
        elif on_floor:
            where = a.location(among=floor_base_poses(object_pose))
        else:
            where = a.location(
                reachable_for=robot_name(),
                location=a.location(pose=object_pose),
                arm=arm,
                **learned_base("picking-up", object_designator),
            )
        base_poses = SolutionCursor(where)

        @retry_scope(
            FETCH_RELOCATION_FAILURES,
            base_poses,
            CountedRetries(FETCH_RELOCATIONS, "relocations"),
            rethrow=unfetchable,
        )
        async def from_here() -> None:
            await perform(an.action(type="navigating", location=base_poses.current))
            if on_floor:  # the forearms in ``carry`` hide the floor next to the base
                await arms_out_of_view()
            await perform(an.action(type="turning-towards", target=a.location(pose=object_pose)))

            @retry_scope(
                GripperLowLevelFailure,
                None,
                CountedRetries(FETCH_REGRASPS, "regrasps"),
                before_retry=park_clear,
                rethrow=lambda _f: ObjectUnreachable(object=object_label(object_designator)),
            )
            async def pick() -> None:
                perceived = await perform(an.action(type="detecting", object=object_designator))
                _check_lying(perceived)
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
        await park_clear()
        return object_designator.current()

    try:
        result: ObjectDesignator = await translating_designator_errors(body, unfetchable)
    except ObjectUnfetchable as failure:
        height = _believed_height(object_designator)
        if isinstance(failure, ObjectToppledUngraspable):
            raise  # it says why already (logged and counted)
        if height is None or height >= floor_height():
            raise
        log.warning(
            "%s lies on the floor out of reach (%.2f m high)",
            object_label(object_designator),
            height,
        )
        tally("floor-unreachable")
        raise ObjectUnreachableOnFloor(object=object_label(object_designator)) from failure
    return result


#: The failures after which ``fetch`` goes to the next base pose.
FETCH_RELOCATION_FAILURES = (
    NavigationGoalInCollision,
    LookingHighLevelFailure,
    PerceptionLowLevelFailure,
    ObjectUnreachable,
    ManipulationLowLevelFailure,
)


#: Where the base stands to pick an object up from the floor, in the object's frame
#: turned to the base's yaw: this far behind it and this far to either side, so that the
#: arm on that side reaches down next to the base (the ``reachable-for`` costmap is made
#: for counter heights, from where the floor is out of reach). The distances behind it
#: are fractions of the robot's shortest arm reach
#: (:attr:`executive.Reach.in_reach_distance`), farther first: for the PR2-like robot
#: (0.7 m) 0.5 m, from where its arm, torso lowest, takes a tool pointing down to 0.04 m
#: above the floor, then 0.45 m (to about 0.02 m) and 0.4 m (the floor itself; measured
#: with the projection world's IK, the object 0.2 m to the side): a carton lying on its
#: broad face is grasped 0.02 m high, and the closer poses are in collision with a lying
#: carton whose long axis points at the base (the navigation check drops them).
FLOOR_PICK_REACH_FRACTIONS = (5.0 / 7.0, 4.5 / 7.0, 4.0 / 7.0)
FLOOR_PICK_SIDE = 0.2
#: Further sideways offsets tried after :data:`FLOOR_PICK_SIDE` (m): an object lying next
#: to a counter is reached with the base standing along the counter, farther to the side.
FLOOR_PICK_MORE_SIDES = (0.3,)
#: Base yaws (around the object) of the floor base poses.
FLOOR_PICK_YAWS = 16


def floor_pick_distances() -> tuple[float, ...]:
    """How far behind an object on the floor the base stands to pick it up (m), farther
    first: :data:`FLOOR_PICK_REACH_FRACTIONS` of the current robot's shortest arm reach."""
    reach = min(arm.reach.in_reach_distance for arm in the_robot().arms)
    return tuple(round(f * reach, 6) for f in FLOOR_PICK_REACH_FRACTIONS)


def floor_base_poses(object_pose: Pose) -> tuple[Pose, ...]:
    """Base poses from which an arm can reach an object on the floor at ``object_pose``
    (map): around it at :data:`FLOOR_PICK_YAWS` yaws, the object
    :data:`FLOOR_PICK_SIDE` to the left or right and each of :func:`floor_pick_distances`
    ahead; the spots nearest to the robot first, at each spot the farther distance first
    and then the closer one (an object lying low, out of the arm's reach from the first,
    is reached from the second without spending the relocations on every other spot;
    the navigation check drops those in collision). Deliberate addition: CRAM never
    fetched from the floor."""
    ox, oy = object_pose.position[0], object_pose.position[1]
    robot = current_environment().world.robot_pose().position
    distances = floor_pick_distances()
    spots = []
    for k in range(FLOOR_PICK_YAWS):
        yaw = 2 * math.pi * k / FLOOR_PICK_YAWS
        c, s = math.cos(yaw), math.sin(yaw)
        for lateral in (FLOOR_PICK_SIDE, *FLOOR_PICK_MORE_SIDES):
            for side in (lateral, -lateral):
                spot = [
                    Pose.from_xyz_yaw(ox - c * d + s * side, oy - s * d - c * side, 0.0, yaw)
                    for d in distances
                ]
                spots.append((lateral != FLOOR_PICK_SIDE, spot))
    # nearest to the robot by the spot's farthest pose (the order the rings had before)
    spots.sort(key=lambda spot: (spot[0], math.dist(spot[1][0].position[:2], robot[:2])))
    return tuple(p for _more, spot in spots for p in spot)


def _check_lying(perceived: Any) -> None:
    """A perceived object that lies toppled with no grasp that fits the gripper, neither
    from above nor by an end overhanging the counter's edge
    (:func:`plans.overhang.overhanging_grasps`):
    :class:`plans.toppled.ObjectToppledUngraspable` (logged, counted) before anything
    moves. Perceived without a type or a pose in the base frame: nothing is checked."""
    obj = perceived.current() if isinstance(perceived, ObjectDesignator) else perceived
    transform = obj.get("transform") if hasattr(obj, "get") else None
    otype = obj.get("type") if hasattr(obj, "get") else None
    if not isinstance(transform, Transform) or not isinstance(otype, str):
        return
    try:
        knowledge.object_knowledge(otype)
    except LookupError:
        return  # the picking-up grounding names the known types
    name = obj.get("name")
    if knowledge.is_lying(transform) and any(
        overhanging_grasps(name, otype, arm) for arm in arm_names()
    ):
        return
    check_graspable_as_it_lies(obj, otype, transform)


async def _graspable_as_it_lies(object_designator: ObjectDesignator) -> ObjectDesignator:
    """The perceived object, graspable as it lies: one toppled with no grasp that fits
    from above (:func:`plans.toppled.ungraspable_as_it_lies`) is pushed over the edge of
    the counter it lies on until an end sticks out for the overhang grasp
    (:func:`plans.overhang.push_until_overhanging`, re-perceived); where that cannot
    work, :class:`plans.toppled.ObjectToppledUngraspable` naming both whys (logged,
    counted), nothing moved."""
    obj = object_designator.current()
    transform, otype = obj.get("transform"), obj.get("type")
    if not isinstance(transform, Transform) or not isinstance(otype, str):
        return object_designator
    try:
        why = ungraspable_as_it_lies(otype, transform)
    except LookupError:
        return object_designator  # the picking-up grounding names the known types
    if why is None:
        return object_designator
    log.info("%s: %s; pushing it over the counter's edge", object_label(obj), why)
    return await push_until_overhanging(object_designator, why)


async def _pushed_clear(object_designator: ObjectDesignator) -> ObjectDesignator:
    """The object on the floor pushed clear of the counter it lies at the foot of
    (:func:`plans.pushing.push_clear_of_counter`), re-perceived; not at a counter, or no
    push works (logged and counted there): the designator as it was, and the fetch tries
    from where it lies."""
    try:
        return await push_clear_of_counter(object_designator)
    except ObjectUnpushable:
        return object_designator


def _believed_height(object_designator: ObjectDesignator) -> float | None:
    """The height (m, map) at which the world model believes the object is, or None when
    it is not known by name."""
    name = object_designator.current().get("name")
    if not isinstance(name, str):
        return None
    try:
        return float(current_environment().world.object_pose(name).position[2])
    except (LookupError, cpl.PlanFailure):
        return None


@cpl.plan(name="search-floor")
async def search_floor(object_designator: ObjectDesignator, failure: BaseException) -> Any:
    """Look for an object that was not where it was believed (``failure``: why the
    caller gave up on it there) on the floor around its last believed position: the
    spots of :data:`FLOOR_SEARCH_OFFSETS` in turn, each a ``searching`` with its own
    torso retry and no other sample (a ``floor-search`` retry per further spot). Returns
    the perceived designator. Not found anywhere, seen but not on the floor (below
    :func:`floor_height`), or the object is not known by name (a designator never
    perceived): ``failure`` is raised again. Deliberate addition: no
    CRAM plan searches the floor; a dropped or knocked-off object was lost for good."""
    name = object_designator.current().get("name")
    height = _believed_height(object_designator)
    if height is None:
        raise failure
    near = current_environment().world.object_pose(str(name))
    x, y = near.position[0], near.position[1]
    spots = [Pose((x + dx, y + dy, FLOOR_SPOT_Z)) for dx, dy in FLOOR_SEARCH_OFFSETS]
    more = CountedRetries(len(spots) - 1, "floor-search")
    for i, spot in enumerate(spots):
        if i and not more.do_retry():
            break
        try:
            found = await search_for_object(object_designator, a.location(pose=spot), retries=0)
        except ObjectNowhereToBeFound:
            continue
        height = _believed_height(found)
        if height is None or height >= floor_height():
            # seen, but not on the floor (still on its counter): nothing new to try
            log.info("%s seen from the floor search, but not on the floor", name)
            raise failure
        log.info("%s found on the floor near %r", name, spot)
        return found
    log.warning("%s not on the floor around (%.2f, %.2f) either", name, x, y)
    raise failure


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


@rule(
    "action",
    "fetching",
    doc=RuleDoc(
        "Pick up a perceived object (plan fetch): navigate to a base pose that reaches it, "
        "turn towards it, detect it again, choose a picking-up solution that works in the "
        "belief, pick it up, back off, park the arms (carry). Returns the newest object "
        "designator.",
        keys=(
            Key(
                "object",
                "object designator (perceived, with a name)",
                "what to fetch (searching returns it)",
                required=True,
            ),
            Key("arm", "'left' | 'right'", "the arm to pick with", default="right, then left"),
            Key(
                "robot-location",
                "location designator",
                "where the base may stand",
                default="reachable-for the object's pose now (on the floor: around it)",
            ),
            Key(
                "pick-up-action",
                "picking-up action designator",
                "its arm and grasp (projection reasoning injects it)",
                default="-",
            ),
        ),
        raises=(ObjectUnfetchable, ObjectUnreachableOnFloor, ObjectToppledUngraspable),
        retries=(
            Retry(
                10,
                FETCH_RELOCATION_FAILURES,
                "the robot location's next base pose",
                counter="relocations",
            ),
            Retry(
                1,
                (GripperLowLevelFailure,),
                "park the arms (backing off if needed), detect and pick again",
                counter="regrasps",
            ),
            Retry(
                default_of(check_picking_up_collisions, "retries"),
                (ObjectUnreachable,),
                "the next picking-up solution (arm, grasp, approach)",
                probes=True,
            ),
        ),
        performs=(
            "navigating",
            "turning-towards",
            "detecting",
            "picking-up",
            "going",
            "positioning-arm",
            "pushing-object",
        ),
        note="Designator errors become ObjectUnfetchable. An object believed on the floor "
        "(below 0.3 m) is fetched from base poses around it; out of reach there: "
        "ObjectUnreachableOnFloor (logged, counted). An object lying toppled with no grasp "
        "from above that fits the gripper is pushed over its counter's edge and grasped by "
        "the end that sticks out (plans.overhang, performs pushing-object); where no push "
        "can do that: ObjectToppledUngraspable (logged, counted), before anything moves.",
    ),
)
def _fetching(d: Designator) -> Iterator[Any]:
    _check_places(d, "robot-location")
    yield (
        fetch,
        {
            "object_designator": _object(d),
            "arm": _given_arm(d),
            "robot_location": d.get("robot-location"),
            "pick_up_action": d.get("pick-up-action"),
        },
    )


register_resources(fetch, the_base)
