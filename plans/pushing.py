"""Pushing an object with the hand (issue 26): a plan-level action for the objects no grasp
reaches where they lie, which the hand can still push to where one does.

A push is a straight tool line: the gripper closed and pointing down, its fingers in
line with the push (the closed fingers' thin side leads, so the hand fits between an
object and a counter), lowered next to the object on the side away from the push, then
moved along the push direction, then drawn back and lifted. The line goes through the
object's believed place: the contact motion (the atomic ``pushing``, whose collision mode
allows contacts) lets the hand touch that object, and the plan's probe in the belief
(:meth:`executive.WorldProbes.probe_arm_trajectory` with ``allowed_contacts`` the pushed
object only) rejects a push whose hand or arm would touch anything else, or sweep through
a neighbour on its way. The object's own path (its footprint, moved along the push) must
stay clear of every other object the belief holds and of the kitchen's surfaces
(:func:`push_path_clear`). After the push the object is re-perceived where it should be
(the belief does not move it: the true world's contacts and friction do), and searched for
around there if it is not seen.

:func:`push_clear_of_counter` uses it for an object on the floor at the foot of a counter
(round 1's losses: no IK at the grasp height, the arm hits the cabinet, hidden from most
floor poses): pushed away from the counter, in the direction the belief's kitchen
geometry gives (the surfaces' footprints, :func:`nearest_counter`), far enough
(:data:`PUSH_CLEAR`) to be picked, then fetched as usual. :mod:`plans.overhang` pushes a
box lying flat on a counter over its edge (the hand comes down on the counter there, the
base stands in front of it: :data:`PUSH_COUNTER_BASE_DISTANCES`).

Deliberate addition (beyond CRAM): CRAM's ``pushing`` is an arm motion for closing
drawers; no CRAM plan pushes an object to make it graspable, and its fetch gave up on an
object no grasp reached.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

import cpl
from executive import (
    Designator,
    DesignatorInputError,
    HighLevelFailure,
    Key,
    ManipulationLowLevelFailure,
    NavigationGoalInCollision,
    NavigationLowLevelFailure,
    ObjectDesignator,
    ObjectInventory,
    ObjectNowhereToBeFound,
    PerceptionLowLevelFailure,
    Pose,
    RuleDoc,
    Transform,
    a,
    an,
    current_environment,
    knowledge,
    perform,
    register_resources,
    rule,
)

from ._common import (
    arm_description,
    arm_names,
    object_label,
    perform_ignoring,
    tally,
    the_base,
)
from .navigation import back_off
from .search import arms_out_of_view, search_for_object

__all__ = [
    "PUSH_CLEAR",
    "PUSH_NEAR",
    "ObjectUnpushable",
    "PushPlan",
    "nearest_counter",
    "plan_push",
    "push_clear_of_counter",
    "push_object",
    "push_path_clear",
    "push_plans",
]

log = logging.getLogger(__name__)

#: An object on the floor whose centre is closer than this (m, horizontally) to a
#: counter's footprint is pushed away from it before it is fetched.
PUSH_NEAR = 0.2
#: How far (m) from the counter's footprint its centre is pushed to.
PUSH_CLEAR = 0.3
#: The tool frame's height (m) above the object's lowest point during the push: low, so
#: that a tall carton slides rather than tips.
PUSH_HEIGHT = 0.04
#: The push line's waypoints are this far apart (m): see :func:`_in_steps`.
PUSH_STEP = 0.01
#: How much narrower (m) than the pushed object the fingertips are apart.
PUSH_FINGER_INSET = 0.02
#: How far (m) from the object's side the hand is lowered before it pushes.
PUSH_GAP = 0.03
#: How high (m) above the push line the hand comes down from and goes back up to.
PUSH_ABOVE = 0.15
#: How far (m) the hand draws back along the line before it lifts.
PUSH_DRAW_BACK = 0.04
#: Directions tried, as angles (rad) from the wanted one, in order: a push at an angle
#: still moves the object away, and lets the hand in where straight behind it is the
#: counter.
PUSH_ANGLES = tuple(math.radians(a) for a in (0.0, 30.0, -30.0, 50.0, -50.0, 65.0, -65.0))
#: Margin (m) the pushed object's path keeps from other objects and counters.
PUSH_MARGIN = 0.03
#: Arm probes a push spends per direction looking for a base pose and arm.
PUSH_PROBES = 24
#: How close (m) to a counter's footprint the hand's fingertips may come down.
PUSH_HAND_CLEARANCE = 0.02
#: Pushes (base pose, arm) a push tries to start before it gives up (the belief's
#: IK and the real arm's can differ).
PUSH_ATTEMPTS = 3
#: Other viewpoints tried when the object is not seen where the push left it.
PUSH_SEARCH_RETRIES = 4
#: See :func:`_beside`.
PUSH_ARM_ANGLE = math.radians(80)
#: Where the base stands for a push (m), around the push's start (the hand's lowest
#: reach, next to the counter): this far behind it, this far to the side, at these yaws.
PUSH_BASE_DISTANCES = (0.45, 0.4)
PUSH_BASE_SIDES = (0.2, -0.2, 0.3, -0.3)
PUSH_BASE_YAWS = 16
#: For a push on a counter the base stands in front of the counter, farther from the
#: hand (it comes down on the counter, behind the object): this far from the push's
#: start (m), turned so that the start is at these bearings (rad) from its heading (to
#: the side: the arm on that side reaches farther across the counter).
PUSH_COUNTER_BASE_DISTANCES = (0.55, 0.65, 0.75)
PUSH_COUNTER_BASE_BEARINGS = tuple(math.radians(a) for a in (0.0, 45.0, -45.0, 80.0, -80.0))
#: An object no taller than this (m) may be pushed towards the robot: it passes under the
#: forearm, which rises from a wrist held above the hand pointing down (:func:`_beside`).
PUSH_LOW_OBJECT = 0.1


class ObjectUnpushable(HighLevelFailure):
    """No push moves the object as wanted: no direction, arm and base pose whose hand
    touches nothing but the object in the belief, or an object whose path would run into
    another object or a counter (the message says which). Raised before anything moves.
    Field: ``object``. Deliberate addition: CRAM has no such push."""

    cram_name = "high-level-failure"
    default_message = "Object cannot be pushed as wanted."


@dataclass(frozen=True)
class PushPlan:
    """One push the belief says works: the base pose, the arm, the tool waypoints (map:
    above the start, the start, the end, drawn back, above), the direction (unit, map
    x/y), the distance (m) the object should move and where its centre should end."""

    base: Pose
    arm: str
    waypoints: tuple[Pose, ...]
    direction: tuple[float, float]
    distance: float
    expected: Pose  # invariant: the object's believed pose moved `distance` along `direction`
    opening: float  # the gripper's opening (m) during the push: see `_push_opening`


def _world() -> Any:
    return current_environment().world


def counter_footprints() -> tuple[tuple[str, tuple[float, float, float, float]], ...]:
    """The kitchen's surfaces (its description's start and table surfaces) as the belief
    has them: (link, (x_lo, y_lo, x_hi, y_hi)) of their bounding boxes in ``map``."""
    kitchen = current_environment().kitchen
    world = _world()
    out = []
    for link in dict.fromkeys((kitchen.start_surface, kitchen.table_surface)):
        (lx, ly, _lz), (hx, hy, _hz) = world.link_aabb(link)
        out.append((link, (float(lx), float(ly), float(hx), float(hy))))
    return tuple(out)


def nearest_counter(x: float, y: float) -> tuple[str, float, tuple[float, float]]:
    """The kitchen surface whose footprint is nearest to (x, y) (map): its link, the
    horizontal distance (m; 0 inside it) and the unit direction away from it (from its
    nearest point to (x, y); straight out of its nearest side when inside)."""
    best: tuple[str, float, tuple[float, float]] | None = None
    for link, (lx, ly, hx, hy) in counter_footprints():
        px, py = min(max(x, lx), hx), min(max(y, ly), hy)
        d = math.hypot(x - px, y - py)
        if d > 1e-9:
            away = ((x - px) / d, (y - py) / d)
        else:  # inside the footprint: out through the nearest side
            sides = {
                (-1.0, 0.0): x - lx,
                (1.0, 0.0): hx - x,
                (0.0, -1.0): y - ly,
                (0.0, 1.0): hy - y,
            }
            away = min(sides, key=lambda k: sides[k])
        if best is None or d < best[1]:
            best = (link, d, away)
    if best is None:
        raise LookupError("the kitchen has no surfaces")
    return best


def _rotated(v: tuple[float, float], angle: float) -> tuple[float, float]:
    c, s = math.cos(angle), math.sin(angle)
    return (c * v[0] - s * v[1], s * v[0] + c * v[1])


def _push_orientation(direction: tuple[float, float], arm: str) -> tuple[float, ...]:
    """The orientation (map) of ``arm``'s tool frame for a push along ``direction``: the
    standard gripper pointing down (its z, the approach), its fingers' closing axis (its
    x) along the push, so the closed fingers' thin side leads; combined with the arm's
    :attr:`executive.ArmDescription.standard_to_tool`."""
    dx, dy = direction
    m = np.eye(4)
    standard = np.array([[-dy, dx, 0.0], [dx, dy, 0.0], [0.0, 0.0, -1.0]]).T  # columns
    m[:3, :3] = standard @ np.array(arm_description(arm).standard_to_tool, dtype=float)
    return Transform.from_matrix(m).to_pose().orientation


def _push_opening(across: float, arm: str) -> float:
    """How far (m) ``arm``'s gripper is open during a push of an object ``across`` m wide
    (across the push): the two fingertips push it at two points (a closed hand's one
    point of contact lets it slide off sideways, measured: the milk carton escaped
    0.08 m to the side of a 0.18 m push), :data:`PUSH_FINGER_INSET` inside its width,
    so that it cannot pass between them."""
    widest = arm_description(arm).gripper.max_opening
    return max(0.0, min(widest, across - PUSH_FINGER_INSET))


def _half_extent(lo: Sequence[float], hi: Sequence[float], d: tuple[float, float]) -> float:
    """Half the extent (m) of the box ``lo``..``hi`` along the horizontal direction ``d``."""
    return 0.5 * ((hi[0] - lo[0]) * abs(d[0]) + (hi[1] - lo[1]) * abs(d[1]))


def push_path_clear(name: str, direction: tuple[float, float], distance: float) -> str | None:
    """Why the object ``name``'s footprint, moved ``distance`` along ``direction``, would
    run into another object the belief holds or over a kitchen surface's footprint
    (within :data:`PUSH_MARGIN`); None when the path is clear. Boxes are axis-aligned
    (the belief's bounding boxes), the path sampled every 2 cm. What the object lies
    against where it starts (within the margin) is not counted: the push moves it away
    from the counter at whose foot it lies (the direction is chosen so)."""
    world = _world()
    (lx, ly, lz), (hx, hy, hz) = world.object_aabb(name)
    others = []
    # a world model without an inventory (a test double): the counters only
    names = world.object_names() if isinstance(world, ObjectInventory) else ()
    for other in names:
        if other == name:
            continue
        try:
            (ox, oy, oz), (px, py, pz) = world.object_aabb(other)
        except LookupError:
            continue
        if pz < lz - 0.05 or oz > hz + 0.05:
            continue  # not at the pushed object's height (on a counter above the floor)
        others.append((other, ox, oy, px, py))
    if lz < current_environment().kitchen.floor_height:  # on the floor: counters are walls
        others += [(link, *box) for link, box in counter_footprints()]
    m = PUSH_MARGIN

    def meets(f: float, ox: float, oy: float, px: float, py: float) -> bool:
        ax, ay = lx + direction[0] * f, ly + direction[1] * f
        bx, by = hx + direction[0] * f, hy + direction[1] * f
        return bool(ax - m < px and ox < bx + m and ay - m < py and oy < by + m)

    # what it lies against already (the counter it is pushed away from) is not in the way
    others = [o for o in others if not meets(0.0, *o[1:])]
    steps = max(1, math.ceil(distance / 0.02))
    for k in range(1, steps + 1):
        f = distance * k / steps
        for other, ox, oy, px, py in others:
            if meets(f, ox, oy, px, py):
                return f"pushed {f:.2f} m it would run into {other}"
    return None


def _room_for_the_hand(at: tuple[float, float], across: tuple[float, float], half: float) -> bool:
    """Whether the hand can come down at ``at`` (map x/y), its fingertips ``half`` m to
    either side along ``across``: both tips and the middle outside every counter's
    footprint (by :data:`PUSH_HAND_CLEARANCE`)."""
    points = [(at[0] + k * half * across[0], at[1] + k * half * across[1]) for k in (-1, 0, 1)]
    c = PUSH_HAND_CLEARANCE
    return not any(
        lx - c < x < hx + c and ly - c < y < hy + c
        for _link, (lx, ly, hx, hy) in counter_footprints()
        for x, y in points
    )


def _face_behind(name: str, pose: Pose, d: tuple[float, float]) -> float:
    """How far (m) behind the object's centre, against ``d``, its face is: half its
    extent along ``d`` from its type's size as it lies (:mod:`executive.knowledge`);
    of a type without knowledge, half its bounding box's."""
    try:
        size = np.array(knowledge.object_knowledge(_world().object_type(name)).size)
    except LookupError:
        (lx, ly, _lz), (hx, hy, _hz) = _world().object_aabb(name)
        return _half_extent((lx, ly), (hx, hy), d)
    rotation = pose.matrix()[:3, :3]
    return float(0.5 * (np.abs(rotation.T @ np.array((d[0], d[1], 0.0))) @ size))


def _beside(base: Pose, end: tuple[float, float], d: tuple[float, float]) -> bool:
    """Whether the base stands beside or behind the push (as seen from where the hand's
    push ends, at least :data:`PUSH_ARM_ANGLE` from its direction): then the forearm,
    which slopes from the hand towards the robot, is not above the object's path.
    Measured: pushing a milk carton towards the robot, its top caught under the forearm
    and it was flung 1.3 m across the kitchen. Required for objects taller than
    :data:`PUSH_LOW_OBJECT` only."""
    vx, vy = base.position[0] - end[0], base.position[1] - end[1]
    norm = math.hypot(vx, vy)
    return norm > 1e-9 and (vx * d[0] + vy * d[1]) / norm <= math.cos(PUSH_ARM_ANGLE)


def _base_poses(mid: tuple[float, float], on_floor: bool = True) -> Iterator[Pose]:
    """Base poses around the push's start (see :data:`PUSH_BASE_DISTANCES`; on a counter
    :data:`PUSH_COUNTER_BASE_DISTANCES`), the nearest to the robot first."""
    robot = _world().robot_pose().position
    poses = []
    if not on_floor:
        for k in range(PUSH_BASE_YAWS):
            around = 2 * math.pi * k / PUSH_BASE_YAWS  # from the start to the base
            for d in PUSH_COUNTER_BASE_DISTANCES:
                x, y = mid[0] + d * math.cos(around), mid[1] + d * math.sin(around)
                for bearing in PUSH_COUNTER_BASE_BEARINGS:
                    poses.append(Pose.from_xyz_yaw(x, y, 0.0, around + math.pi - bearing))
        poses.sort(key=lambda p: math.dist(p.position[:2], robot[:2]))
        yield from poses
        return
    for k in range(PUSH_BASE_YAWS):
        yaw = 2 * math.pi * k / PUSH_BASE_YAWS
        c, s = math.cos(yaw), math.sin(yaw)
        for d in PUSH_BASE_DISTANCES:
            for side in PUSH_BASE_SIDES:
                x, y = mid[0] - c * d + s * side, mid[1] - s * d - c * side
                poses.append(Pose.from_xyz_yaw(x, y, 0.0, yaw))
    poses.sort(key=lambda p: math.dist(p.position[:2], robot[:2]))
    yield from poses


def push_plans(
    name: str,
    direction: tuple[float, float],
    distance: float,
    arm: str | None = None,
    angles: Sequence[float] = PUSH_ANGLES,
) -> Iterator[PushPlan]:
    """The pushes the belief says work, best first (see :func:`plan_push`); the first is
    found before anything is yielded, so a caller that takes none still gets
    :class:`ObjectUnpushable` from its first ``next``. ``angles``: the directions tried,
    as angles (rad) from ``direction`` (:data:`PUSH_ANGLES`; ``(0.0,)``: only along it)."""
    norm = math.hypot(*direction)
    if not math.isfinite(norm) or norm < 1e-9:
        raise DesignatorInputError(
            f"push direction must be a non-zero x/y vector, got {direction!r}"
        )
    if not (isinstance(distance, (int, float)) and math.isfinite(distance) and distance > 0):
        raise DesignatorInputError(f"push distance must be > 0 (m), got {distance!r}")
    if not angles or not all(
        isinstance(x, (int, float)) and abs(x) < math.pi / 2 - 0.1 for x in angles
    ):
        raise DesignatorInputError(
            f"push angles must be a non-empty sequence of angles (rad) within 80 degrees of "
            f"the direction, got {angles!r}"
        )
    return _push_plans(name, direction, distance, arm, tuple(float(x) for x in angles))


def plan_push(
    name: str,
    direction: tuple[float, float],
    distance: float,
    arm: str | None = None,
    angles: Sequence[float] = PUSH_ANGLES,
) -> PushPlan:
    """Find a push of the object ``name`` (known to the belief by name) ``distance`` m
    along ``direction`` (map x/y; normalised here) or within :data:`PUSH_ANGLES` of it
    (longer at an angle, so that it moves as far along ``direction``): the first
    direction whose object path is clear (:func:`push_path_clear`), with a base pose the
    robot stands free at and an arm whose push the belief's probe passes (reachable,
    touching only the object, sweeping no neighbour). Nothing moves. Raises
    :class:`ObjectUnpushable` naming why, after at most :data:`PUSH_PROBES` arm probes
    per direction (none where the hand would come down on a counter);
    :class:`executive.DesignatorInputError` for a zero direction or a distance that is
    not positive."""
    return next(push_plans(name, direction, distance, arm, angles))


def _push_plans(
    name: str,
    direction: tuple[float, float],
    distance: float,
    arm: str | None,
    angles: tuple[float, ...],
) -> Iterator[PushPlan]:
    norm = math.hypot(*direction)
    wanted = (direction[0] / norm, direction[1] / norm)
    world = _world()
    arms = (arm,) if arm is not None else arm_names()
    obj = world.object_pose(name)
    (lx, ly, lz), (hx, hy, hz) = world.object_aabb(name)
    cx, cy = obj.position[0], obj.position[1]
    # on a counter the hand comes down on it, beside the object; on the floor, outside
    # every counter's footprint
    on_floor = lz < current_environment().kitchen.floor_height
    low = hz - lz <= PUSH_LOW_OBJECT
    found = 0
    why: list[str] = []
    for angle in angles:
        d = _rotated(wanted, angle)
        along = distance / math.cos(angle)
        blocked = push_path_clear(name, d, along)
        if blocked is not None:
            why.append(f"{math.degrees(angle):+.0f} deg: {blocked}")
            continue
        back = _half_extent((lx, ly), (hx, hy), d) + PUSH_GAP
        # the hand meets the object's face, not its bounding box's: a turned object is
        # pushed the whole distance past where the hand first touches it
        short = _half_extent((lx, ly), (hx, hy), d) - _face_behind(name, obj, d)
        z = lz + PUSH_HEIGHT
        start = (cx - d[0] * back, cy - d[1] * back)
        travel = along + PUSH_GAP + short
        end = (start[0] + d[0] * travel, start[1] + d[1] * travel)
        drawn = (end[0] - d[0] * PUSH_DRAW_BACK, end[1] - d[1] * PUSH_DRAW_BACK)
        line = {
            hand: tuple(
                Pose(xyz, _push_orientation(d, hand))
                for xyz in (
                    (*start, z + PUSH_ABOVE),
                    (*start, z),
                    (*end, z),
                    (*drawn, z),
                    (*drawn, z + PUSH_ABOVE),
                )
            )
            for hand in arms
        }
        across = _half_extent((lx, ly), (hx, hy), (-d[1], d[0])) * 2
        opening = {hand: _push_opening(across, hand) for hand in arms}
        tips = max(opening.values()) / 2 + PUSH_HAND_CLEARANCE
        if on_floor and not _room_for_the_hand(start, (-d[1], d[0]), tips):
            why.append(f"{math.degrees(angle):+.0f} deg: no room for the hand behind it")
            continue
        probes = 0
        for base in _base_poses(start, on_floor):
            if probes >= PUSH_PROBES:
                break
            if not low and not _beside(base, end, d):
                continue
            if not world.probe_base_pose(base).ok:
                continue
            for hand in arms:
                probes += 1
                result = world.probe_arm_trajectory(
                    hand,
                    line[hand],
                    robot_pose=base,
                    gripper_opening=opening[hand],
                    allowed_contacts=(name,),
                )
                if result.ok:
                    expected = Pose(
                        (cx + d[0] * along, cy + d[1] * along, obj.position[2]), obj.orientation
                    )
                    found += 1
                    yield PushPlan(base, hand, line[hand], d, along, expected, opening[hand])
        why.append(f"{math.degrees(angle):+.0f} deg: no base pose and arm push it touching it only")
    raise ObjectUnpushable(f"no push of {name} {distance:.2f} m: " + "; ".join(why), object=name)


@cpl.plan(name="push-object")
async def push_object(
    object_designator: ObjectDesignator,
    direction: tuple[float, float],
    distance: float,
    arm: str | None = None,
    angles: Sequence[float] = PUSH_ANGLES,
) -> ObjectDesignator:
    """Push a perceived object ``distance`` m along ``direction`` (map) with one hand
    (:func:`plan_push` chooses the direction within ``angles`` of it (default
    :data:`PUSH_ANGLES`), the arm and the
    base pose in the belief first; :class:`ObjectUnpushable` before anything moves when
    none works): drive there, close the gripper, reach above the start (a free motion,
    planned), then the contact motion (``pushing``: down beside the object, along the
    push), draw back and lift (``retracting``). Then re-perceive the object where it
    should be (searching around there if it is not seen). Counted ``pushes``. Returns
    the newest object designator."""
    name = object_designator.current().get("name")
    if not isinstance(name, str):
        raise DesignatorInputError(
            f"push-object needs an object designator with a name, got {object_designator!r}"
        )
    plans = push_plans(name, direction, distance, arm, angles)
    push = next(plans)  # ObjectUnpushable before anything moves
    for attempt in range(PUSH_ATTEMPTS):
        if attempt:
            try:
                push = next(plans)
            except (StopIteration, ObjectUnpushable):
                break
        log.info(
            "pushing %s %.2f m along (%.2f, %.2f) with the %s arm",
            name,
            push.distance,
            *push.direction,
            push.arm,
        )
        above, start, end, drawn, up = push.waypoints
        side = f"{push.arm}_poses"
        try:
            await perform(an.action(type="navigating", location=a.location(pose=push.base)))
            await perform(
                an.action(type="setting-gripper", gripper=push.arm, position=push.opening)
            )
            await perform(an.action(type="reaching", **{side: (above,)}))
        except (
            NavigationLowLevelFailure,
            NavigationGoalInCollision,
            ManipulationLowLevelFailure,
        ) as f:
            # the hand is still above everything: nothing was pushed yet
            log.info("this push cannot start here (%s): the next one", f)
            tally("push-replans")
            continue
        tally("pushes")
        try:
            await perform(an.action(type="pushing", **{side: _in_steps(start, end)}))
            await perform(an.action(type="retracting", **{side: (drawn, up)}))
        except ManipulationLowLevelFailure as failure:
            # the object may have moved: counted, and re-perceived below, never ignored
            log.warning("the push of %s stopped part of the way: %s", name, failure)
            tally("push-interrupted")
            await perform_ignoring(
                an.action(type="retracting", **{side: (up,)}), ManipulationLowLevelFailure
            )
        return await _perceive_after(object_designator, push.expected)
    raise ObjectUnpushable(
        f"no push of {name} could start: {PUSH_ATTEMPTS} tried",
        object=object_label(object_designator),
    )


def _in_steps(start: Pose, end: Pose) -> tuple[Pose, ...]:
    """The push line from ``start`` to ``end`` as waypoints :data:`PUSH_STEP` apart (the
    start included): the hand moves in short motions, so that it pushes the object
    ahead of it rather than cutting through it between two control steps."""
    n = max(1, math.ceil(math.dist(start.position, end.position) / PUSH_STEP))
    return (start, *(_between(start, end, k / n) for k in range(1, n + 1)))


def _between(start: Pose, end: Pose, f: float) -> Pose:
    p = tuple(a + f * (b - a) for a, b in zip(start.position, end.position))
    return Pose(p, end.orientation, end.frame)


async def _perceive_after(object_designator: ObjectDesignator, expected: Pose) -> ObjectDesignator:
    """Detect the object where the push should have left it; not seen from here: search
    for it there from other viewpoints (:data:`PUSH_SEARCH_RETRIES`). The base backs off
    first: from where it pushed, the object is too close below the camera to be seen."""
    await back_off()
    await arms_out_of_view()
    spot = a.location(pose=expected)
    try:
        await perform(an.action(type="turning-towards", target=spot))
        found: ObjectDesignator = await perform(
            an.action(type="detecting", object=object_designator)
        )
        return found
    except PerceptionLowLevelFailure as failure:
        log.info(
            "%s not seen after the push (%s): searching around",
            object_label(object_designator),
            failure,
        )
    try:
        return await search_for_object(object_designator, spot, retries=PUSH_SEARCH_RETRIES)
    except ObjectNowhereToBeFound:
        log.warning("%s not found after the push", object_label(object_designator))
        raise


async def push_clear_of_counter(object_designator: ObjectDesignator) -> ObjectDesignator:
    """An object on the floor at the foot of a counter (its centre within
    :data:`PUSH_NEAR` of a surface's footprint, :func:`nearest_counter`): push it straight
    away from that counter (or at an angle, :data:`PUSH_ANGLES`) until its centre is
    :data:`PUSH_CLEAR` from it, and return the re-perceived designator. Farther already,
    or the world model knows no extent of the surfaces or the object: the designator,
    nothing moves. No push works: :class:`ObjectUnpushable` (logged,
    counted ``push-infeasible``), nothing moved."""
    name = str(object_designator.current().get("name"))
    x, y, _z = _world().object_pose(name).position
    try:
        link, gap, away = nearest_counter(x, y)
        _world().object_aabb(name)
    except LookupError as unknown:
        # a world model that knows no extent of the counters or the object: no push
        log.info("%s is not pushed: %s", name, unknown)
        return object_designator
    if gap >= PUSH_NEAR:
        return object_designator
    try:
        return await push_object(object_designator, away, PUSH_CLEAR - gap)
    except ObjectUnpushable as failure:
        log.warning("%s at the foot of %s cannot be pushed away: %s", name, link, failure)
        tally("push-infeasible")
        raise


@rule(
    "action",
    "pushing-object",
    doc=RuleDoc(
        "Push a perceived object along the floor or a counter with one hand (plan "
        "push-object): the push is checked in the belief first (reachable, the hand "
        "touching the object only, its path clear of neighbours), then the object is "
        "re-perceived. Returns the newest object designator.",
        keys=(
            Key(
                "object",
                "object designator (perceived, with a name)",
                "what to push",
                required=True,
            ),
            Key("direction", "(x, y) in map", "where to push it", required=True),
            Key("distance", "number (m) > 0", "how far", required=True),
            Key("arm", "'left' | 'right'", "the arm to push with", default="the first that works"),
            Key(
                "angles",
                "tuple of angles (rad)",
                "the directions tried, from the given one",
                default="PUSH_ANGLES (0, +-30, +-50, +-65 degrees)",
            ),
        ),
        raises=(ObjectUnpushable,),
        performs=(
            "navigating",
            "setting-gripper",
            "reaching",
            "pushing",
            "retracting",
            "detecting",
        ),
        note="Deliberate addition: CRAM's pushing is an arm motion only. The pushed object "
        "is the action's own: moving it is not a knock.",
    ),
)
def _pushing_object(d: Designator) -> Iterator[Any]:
    obj = d.get("object")
    if not isinstance(obj, ObjectDesignator):
        raise DesignatorInputError(f"{d.short()} needs an object designator", d)
    direction = d.get("direction")
    if not (isinstance(direction, tuple) and len(direction) == 2):
        raise DesignatorInputError(f"{d.short()}: direction is an (x, y) tuple in map", d)
    distance = d.get("distance")
    if isinstance(distance, bool) or not isinstance(distance, (int, float)):
        raise DesignatorInputError(f"{d.short()}: distance is a number of metres", d)
    angles = d.get("angles", PUSH_ANGLES)
    if not (
        isinstance(angles, tuple)
        and angles
        and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in angles)
    ):
        raise DesignatorInputError(f"{d.short()}: angles is a non-empty tuple of radians", d)
    yield (
        push_object,
        {
            "object_designator": obj,
            "direction": (float(direction[0]), float(direction[1])),
            "distance": float(distance),
            "arm": d.get("arm"),
            "angles": tuple(float(x) for x in angles),
        },
    )


register_resources(push_object, the_base)
