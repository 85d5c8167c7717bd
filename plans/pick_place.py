"""Pick and place (CRAM's ``pick-place-plans.lisp`` and ``pick-place-designators.lisp``).

``picking-up (object O) (arm A)? (grasp G)?``: solutions arm-major (right, then left) and
grasp-minor (the type's grasps in :mod:`executive.knowledge` order; an environment's
``preferences``, e.g. learned priors, reorder the (arm, grasp) pairs); the object must have
been perceived (its newest designator carries a ``transform`` base -> object, or a
``pose``). Waypoints: :func:`executive.knowledge.grasp_poses` (pregrasp, 2nd pregrasp,
grasp, lift, 2nd lift), in the robot's base frame.

The arms, their tool frames, the link a held object hangs from and the standard-gripper ->
tool rotation each grasp combines with are the environment's robot's
(:attr:`executive.Environment.robot`): "right, then left" is the PR2-like robot's order;
a one-armed robot has only its ``left`` arm to try. The gripper opens to the type's
opening (object knowledge), but no wider than the arm's gripper opens
(:attr:`executive.GripperDescription.max_opening`). Deliberate difference from CRAM, whose
opening is the type's whatever the robot: a Panda's 0.08 m gripper cannot open to the
0.10 m of a cup, and ``setting-gripper`` refuses an opening out of range.

A lying (toppled) object is picked the way it lies: only the grasps from above that fit
the arm's gripper are solutions (:mod:`plans.toppled`; deliberate addition).

``placing (object O)? (arm A)? (target L)?``: the arms holding something (or the given
arm); the target's every solution (else the object's current pose); the five waypoints at
the target, reversed. Deliberate fix of CRAM HEAD's quirk (it always used the type's
*first* grasp): the gripper-in-object transform is measured from the world model (the
object in hand relative to the tool frame), so the object lands where the target says,
whatever grasp picked it; the grounding names the grasp that transform is closest to.

Target orientation, a deliberate difference from CRAM: the costmap placing locations
carry no orientation (identity in map), and with the gripper-in-object transform kept from
the pick an identity target means, e.g., that a cup side-grasped while the robot faced +x
(the sink) must be approached from the far side of the island (the robot faces -x there):
unreachable. So a ``placing`` with ``(free-yaw t)`` (``deliver`` sets it when its target
location designator has no explicit ``pose``) orients the object upright with the yaw it
has in ``base_footprint`` as held (map yaw = base yaw now + held yaw in base), then that
yaw turned by pi/2, -pi/2 and pi (and by +-pi/4, +-3pi/4 for round types); an explicit
target orientation is kept as given, followed by its yaw + pi variant (the same footprint
for the box-shaped objects with fixed poses, e.g. the cereal). These variants are further
solutions of the grounding, target-major; :func:`plans.checks.check_placing_collisions`
probes them in order. Each target's variants come reached straight (from the lift pose
above the target, where the arm carries the object), then all again from
:data:`PLACE_APPROACH_HEIGHT` above that: deliberate addition (CRAM reached straight), the hand
comes in over the objects placed before and descends, where the straight reach would
sweep the held object or the arm through one (seed 3's spoon reached through the cup,
the cereal through the spoon).

Both claim the arm and the gripper they use for their whole duration
(:func:`executive.register_resources`): a concurrent goal on that hand from outside the
action fails with :class:`executive.ResourceConflict` before anything moves (two
``picking-up`` with one arm would otherwise interleave in the arm module's queue).
"""

from __future__ import annotations

import asyncio
import itertools
import logging
import math
from collections.abc import Iterator, Sequence
from typing import Any

import numpy as np

import cpl
from executive import (
    Designator,
    DesignatorError,
    GripperClosedCompletely,
    GripperLowLevelFailure,
    Key,
    LocationDesignator,
    ManipulationLowLevelFailure,
    ObjectDesignator,
    Pose,
    RuleDoc,
    Transform,
    an,
    current_environment,
    emit,
    knowledge,
    perform,
    register_resources,
    rule,
    yaw_quaternion,
)
from executive.events import ObjectAttached, ObjectDetached, object_name

from ._common import (
    arm_description,
    arm_names,
    base_frame,
    hand_link_of,
    hand_of,
    object_label,
    perform_ignoring,
    to_base,
    tool_frame_of,
)
from ._designators import _given_arm
from .overhang import overhanging_grasps
from .toppled import lying_grasps

_log = logging.getLogger(__name__)

__all__ = [
    "RELEASE_CLEARANCE",
    "object_lost",
    "pick_up",
    "place",
    "placing_waypoints",
    "release_held",
    "release_opening",
    "retreat",
    "verify_grasp",
]


def _sides(arm: str, poses: Sequence[Pose]) -> dict[str, tuple[Pose, ...]]:
    return {
        "left_poses": tuple(poses) if arm == "left" else (),
        "right_poses": tuple(poses) if arm == "right" else (),
    }


def _arm_action(action_type: str, arm: str, poses: Sequence[Pose]) -> Designator:
    return an.action(type=action_type, **_sides(arm, poses))


# ---------------------------------------------------------------------------- picking up
@cpl.plan(name="pick-up")
async def pick_up(
    object_designator: ObjectDesignator,
    arm: str,
    grasp: str,
    opening: float,
    effort: float,
    reach_poses: Sequence[Pose],
    grasp_poses: Sequence[Pose],
    lift_poses: Sequence[Pose],
) -> ObjectDesignator:
    """Pick the object up.

    1. in ``par``: ``setting-gripper`` to the opening, and ``reaching`` (its manipulation
       failure propagates); 2. ``grasping`` (failures ignored); 3. ``gripping`` (gripper
       failures propagate after its own regrip); the grasp is verified
       (:func:`verify_grasp`); a failed grip first backs out (:func:`retreat`);
       4. ``ObjectAttached`` (to the wrist link); 5. ``lifting`` (manipulation failures
       ignored, but not a gripper failure: the object fell out);
       the grasp is verified again. Evaporation before step 4 leaves nothing attached,
       and the hand backs out the way it came (:func:`retreat`, shielded, at most
       :data:`RETREAT_TIMEOUT` s; deliberate addition: CRAM left the hand where it was,
       and the cleanup's park from there swept the object off its counter).
    Returns the object designator.

    Deliberate difference from CRAM: CRAM's ``lift`` ignored every manipulation failure,
    and a ``gripper-closed-completely`` while lifting (the object fell out) with it, so
    the belief kept the object in the hand and the plan went on to "place" nothing. Here
    a lost object raises :class:`~executive.GripperClosedCompletely` from
    :func:`object_lost`, which first tells the world model with ``ObjectDetached``, so
    the fetch's regrasp scope looks for it again."""

    async def grip() -> None:
        await perform(an.action(type="gripping", gripper=arm, effort=effort))
        verify_grasp(object_designator, arm, "gripping", attached=False)

    async def back_out(failure: BaseException) -> None:
        await retreat(arm, reach_poses, opening, grasp_poses)
        raise failure

    try:
        await cpl.par(
            cpl.tag(
                "open", perform(an.action(type="setting-gripper", gripper=arm, position=opening))
            ),
            cpl.tag("reach", perform(_arm_action("reaching", arm, reach_poses))),
        )
        await perform_ignoring(
            _arm_action("grasping", arm, grasp_poses), ManipulationLowLevelFailure
        )
        await cpl.with_failure_handling(grip, [(GripperLowLevelFailure, back_out)])
    except asyncio.CancelledError:
        # evaporated (Ctrl-C) with the hand on its way to, or around, an object it does
        # not hold: back out the way it came (shielded) before anyone parks the arm: a
        # park straight from the grasp swept the milk off the counter (seed 1)
        await cpl.shielded(retreat(arm, reach_poses, opening, grasp_poses), timeout=RETREAT_TIMEOUT)
        raise
    emit(ObjectAttached(object_designator, arm, hand_link_of(arm)))

    async def lift() -> None:
        await perform(_arm_action("lifting", arm, lift_poses))

    async def fell_out(failure: BaseException) -> None:
        object_lost(object_designator, arm, "lifting", failure)

    await cpl.with_failure_handling(
        lift,
        [
            (GripperLowLevelFailure, fell_out),
            (ManipulationLowLevelFailure, lambda _f: cpl.return_(None)),
        ],
    )
    verify_grasp(object_designator, arm, "lifting")
    return object_designator


#: Simulated seconds the back-out of an evaporated pick-up may take (a few normally).
RETREAT_TIMEOUT = 30.0


#: How far (m) the tool may be from the straight line through a reach's waypoints and
#: still be on it (:func:`passed_waypoints`): the controller tracks tool lines to
#: millimetres; farther, the hand is still on its free way to the first waypoint.
ON_REACH = 0.03


def passed_waypoints(tool: Sequence[float], path: Sequence[Pose]) -> int:
    """How many waypoints of ``path`` (a reach's waypoints, then its grasp pose; all in
    the frame ``tool`` is given in) the hand at ``tool`` has passed: ``i + 1`` when the
    tool is nearest the straight segment from waypoint ``i`` to ``i + 1`` and within
    :data:`ON_REACH` of it; 0 when it is farther from every segment (still on its free
    way to the first waypoint). A path of one waypoint: 1 within :data:`ON_REACH` of it."""
    h = np.asarray(tool, dtype=float)
    points = [np.asarray(p.position, dtype=float) for p in path]
    # one waypoint: a segment of length 0
    segments = list(itertools.pairwise(points)) or [(q, q) for q in points]
    best, nearest = math.inf, 0
    for i, (a, b) in enumerate(segments):
        ab = b - a
        length = float(ab @ ab)
        t = 0.0 if length < 1e-12 else min(1.0, max(0.0, float((h - a) @ ab) / length))
        distance = float(np.linalg.norm(h - (a + t * ab)))
        if distance < best - 1e-9:
            best, nearest = distance, i
    return nearest + 1 if best <= ON_REACH else 0


@cpl.plan(name="retreat")
async def retreat(
    arm: str, reach_poses: Sequence[Pose], opening: float, grasp_poses: Sequence[Pose] = ()
) -> None:
    """After a failed grip or an evaporated reach, back out the way the hand came: open
    the gripper to the pick's ``opening`` and move the tool back through the reach
    waypoints it has passed (:func:`passed_waypoints` on the reach's waypoints and then
    ``grasp_poses``), in reverse (failures of both ignored: it is a best effort before
    the caller's own recovery). A hand still on its free way to the first waypoint has
    nothing to back out of and stays (sending it to the waypoints would take it closer
    to the object: the Ctrl-C sweep's bowl, toppled by a "retreat" that went to the
    pregrasp first). Deliberate addition: CRAM's regrasp parked the arms straight from
    the grasp pose, and a park from there sweeps the hand through the object and its
    neighbours."""
    await perform_ignoring(
        an.action(type="setting-gripper", gripper=arm, position=opening), GripperLowLevelFailure
    )
    path = (*reach_poses, *grasp_poses)
    if not path:
        return
    frame = path[0].frame
    tool = current_environment().world.link_pose(tool_frame_of(arm), frame).position
    passed = min(passed_waypoints(tool, path), len(reach_poses))
    if passed == 0:
        _log.info("the %s hand had not reached its first reach waypoint: nothing to back out", arm)
        return
    await perform_ignoring(
        _arm_action("retracting", arm, tuple(reversed(reach_poses[:passed]))),
        ManipulationLowLevelFailure,
    )


#: The gripper openings (m) at which the fingers hold an object of each type: measured by
#: closing the gripper at every grasp of the type in projection (a test re-measures them),
#: with a margin of about 5 mm. An opening outside the range after gripping means the
#: fingers closed on something else (the counter, a neighbour, the object's corner), or
#: on nothing; after lifting, that the object fell out.
GRIP_WIDTHS: dict[str, tuple[float, float]] = {
    "cup": (0.07, 0.1),
    "bowl": (0.012, 0.03),
    "milk": (0.05, 0.1),
    "breakfast-cereal": (0.062, 0.08),
    "cereal": (0.062, 0.08),
    "spoon": (0.022, 0.037),
}
#: For a type without a :data:`GRIP_WIDTHS` entry: any opening above this holds it.
MIN_HELD_OPENING = 0.004


def verify_grasp(object_designator: Any, arm: str, after: str, *, attached: bool = True) -> None:
    """Check that ``arm`` holds the object, from the gripper opening the world model
    reports (the robot's finger joints) against the type's :data:`GRIP_WIDTHS`. Outside
    them the object is not (or no longer) held: :func:`object_lost` (``attached``: whether
    ``ObjectAttached`` was emitted already; if not, the failure is only raised, nothing is
    detached). A world model that does not know the opening (None) cannot tell; then
    nothing is checked (logged). Deliberate addition: CRAM trusted a grip that did not
    close completely."""
    measured = current_environment().world.gripper_opening(arm)
    if measured is None:
        _log.debug("grasp after %s not verified: the world model has no gripper opening", after)
        return
    opening = float(measured)
    otype = object_designator_type(object_designator)
    low, high = GRIP_WIDTHS.get(otype, (MIN_HELD_OPENING, math.inf))
    if low <= opening <= high:
        return
    what = "closed on nothing" if opening < MIN_HELD_OPENING else "does not hold the " + otype
    failure = GripperClosedCompletely(
        f"after {after} the {arm} gripper {what} (opening {opening:.3f} m,"
        f" a {otype} is held at {low:.3f}-{high:.3f} m)",
        action=after,
        arm=arm,
    )
    if not attached:
        raise failure
    object_lost(object_designator, arm, after, failure)


def object_designator_type(object_designator: Any) -> str:
    """The type of the object an object designator (or its newest member) names."""
    obj = (
        object_designator.current()
        if isinstance(object_designator, ObjectDesignator)
        else object_designator
    )
    otype = obj.get("type") if hasattr(obj, "get") else None
    if isinstance(otype, str):
        return otype
    return current_environment().world.object_type(object_name(obj))


def object_lost(object_designator: Any, arm: str, during: str, failure: BaseException) -> None:
    """The object is no longer in ``arm``: tell the world model (``ObjectDetached``: the
    belief lets it fall where the hand is, to be perceived again) and raise
    :class:`~executive.GripperClosedCompletely` (from ``failure``)."""
    emit(ObjectDetached(object_designator, arm, hand_link_of(arm)))
    raise GripperClosedCompletely(
        f"{object_name(object_designator)} was lost from the {arm} gripper while {during}",
        action=during,
        arm=arm,
        object=object_label(object_designator),
    ) from failure


def _object_transform(obj: ObjectDesignator, d: Designator) -> Transform:
    transform = obj.get("transform")
    if isinstance(transform, Transform):
        return transform
    pose = obj.get("pose")
    if isinstance(pose, Pose):
        return to_base(pose).to_transform(str(obj.get("name", "")))
    raise DesignatorError(
        f"{d.short()}: the object {obj.short()} was not perceived (no pose); perform "
        "detecting first",
        d,
    )


#: How high (m) above its first reach waypoint an approach from above starts.
APPROACH_HEIGHT = 0.2
#: The same for a placing, whose first reach waypoint (the lift pose above the target)
#: is already high: 0.2 m more is out of the arm's reach over the island.
PLACE_APPROACH_HEIGHT = 0.1


def _approaches(reach: Sequence[Pose], height: float = APPROACH_HEIGHT) -> list[tuple[Pose, ...]]:
    """The reach waypoints as given, then the same preceded by a waypoint
    :data:`APPROACH_HEIGHT` straight above the first (same orientation): the hand comes
    in over the neighbours and descends onto the reach, instead of sweeping straight
    from where the arm is. Deliberate addition (CRAM reached straight for its first
    waypoint): the arm probes check the path the arm sweeps
    (:meth:`projection.ProjectedWorldModel.probe_arm_trajectory`), and where the
    straight reach would sweep through a neighbour, the approach from above is the next
    solution of the same arm and grasp."""
    first = reach[0]
    above = Pose(
        (first.position[0], first.position[1], first.position[2] + height),
        first.orientation,
        first.frame,
    )
    return [tuple(reach), (above, *reach)]


@rule(
    "action",
    "picking-up",
    doc=RuleDoc(
        "Pick up a perceived object from where the robot stands (plan pick-up): open the "
        "gripper while reaching, grasp, grip, lift; the object is attached to the wrist.",
        keys=(
            Key(
                "object",
                "object designator (perceived: detecting returned it)",
                "the object; its newest member's transform or pose is used",
                required=True,
            ),
            Key("arm", "'left' | 'right'", "the arm", default="right, then left"),
            Key(
                "grasp",
                "grasp name (executive.knowledge.grasps(type))",
                "how to hold it: 'top', 'back', 'front', 'left-side', 'right-side'",
                default="the type's grasps in knowledge order",
            ),
        ),
        raises=(ManipulationLowLevelFailure, GripperLowLevelFailure),
        ignores=(ManipulationLowLevelFailure,),
        performs=("setting-gripper", "reaching", "grasping", "gripping", "lifting", "retracting"),
        note="Solutions: arm-major, grasp-minor, each reached straight and then from 0.2 m "
        "above (a bowl also turned by 90, -90 and 180 degrees); perform() takes the first. "
        "plans.check_picking_up_collisions(action) probes them in the belief and returns the "
        "first that works (fetching does). Grasping and lifting failures are ignored; a "
        "failed grip backs the hand out first; a grip that holds nothing, or an object lost "
        "while lifting, raises GripperClosedCompletely (ObjectDetached told).",
    ),
)
def _picking_up(d: Designator) -> Iterator[Any]:
    given = d.get("object")
    if not isinstance(given, ObjectDesignator):
        raise DesignatorError(f"{d.short()} needs an object designator", d)
    obj: ObjectDesignator = given.current()
    otype = obj.type
    try:
        info = knowledge.object_knowledge(otype)
    except LookupError as exc:
        raise DesignatorError(f"{d.short()}: {exc}", d) from None
    transform = _object_transform(obj, d)
    frames = [transform]
    if otype in knowledge.ROTATIONALLY_SYMMETRIC:
        # CRAM: bTo's rotation -> identity (the object as if facing the robot); then,
        # deliberately, that frame turned by pi/2, -pi/2 and pi as further solutions
        # (grasp-minor): the left arm has no IK for some top grasps in front of it
        frames = []
        for yaw in (0.0, math.pi / 2, -math.pi / 2, math.pi):
            m = transform.matrix()
            m[:3, :3] = Transform((0.0, 0.0, 0.0), yaw_quaternion(yaw)).matrix()[:3, :3]
            frames.append(Transform.from_matrix(m, transform.frame, transform.child_frame))
    arm_given = _given_arm(d)
    arms = (arm_given,) if arm_given is not None else arm_names()
    grasp_names = (d["grasp"],) if "grasp" in d else knowledge.grasps(otype)
    # the arm-major, grasp-minor order, reordered by what experience taught (a stable
    # sort of the (arm, grasp) pairs: the environment's preferences, None: unchanged)
    pairs: list[tuple[str, str | None]] = [(a, g) for a in arms for g in grasp_names]
    preferences = current_environment().preferences
    if preferences is not None:
        pairs = _checked_order(pairs, preferences.order_choices("picking-up", otype, pairs))
    # (arm, grasp) -> the tool frame's depth and place across (plans.overhang; absent:
    # the grasp's own)
    depths: dict[tuple[str, str], tuple[float, float]] = {}
    if knowledge.is_lying(transform):
        # a toppled object: only the grasps from above that fit this arm's gripper
        # (plans.toppled), and the side grasps that hold an end overhanging the counter's
        # edge (plans.overhang) at their depth; deliberate addition, CRAM's grasps
        # assume it upright
        name = obj.get("name")
        for a in arms:
            for o in overhanging_grasps(name if isinstance(name, str) else None, otype, a):
                depths[(a, o.grasp)] = (o.depth, o.across)
        if "grasp" not in d:
            pairs = [
                (a, g)
                for a, g in pairs
                if g in lying_grasps(otype, transform, (str(g),), a) or (a, str(g)) in depths
            ]
    for arm, grasp in pairs:
        assert grasp is not None
        hand = arm_description(arm)
        standard_to_tool = hand.standard_to_tool
        # the type's opening, but no wider than this arm's gripper opens
        widest = hand.gripper.max_opening
        for grasp_name, frame in ((grasp, f) for f in frames):
            try:
                depth, across = depths.get((arm, grasp_name), (None, None))
                poses = knowledge.grasp_poses(
                    otype, grasp_name, frame, standard_to_tool, depth, across
                )
            except LookupError as exc:
                raise DesignatorError(f"{d.short()}: {exc}", d) from None
            for reach in _approaches(poses[:2]):
                yield (
                    pick_up,
                    {
                        "object_designator": obj,
                        "arm": arm,
                        "grasp": grasp_name,
                        "opening": min(info.opening, widest),
                        "effort": info.effort,
                        "reach_poses": reach,
                        "grasp_poses": (poses[2],),
                        "lift_poses": tuple(poses[3:]),
                    },
                )


def _checked_order(
    pairs: list[tuple[str, str | None]], ordered: list[tuple[str, str | None]]
) -> list[tuple[str, str | None]]:
    """A preferences' order, checked to be a reordering (never an addition or a drop)."""
    if sorted(ordered, key=str) != sorted(pairs, key=str):
        raise TypeError(
            f"Preferences.order_choices must return a reordering of {pairs}, got {ordered}"
        )
    return ordered


register_resources(pick_up, hand_of)


# ------------------------------------------------------------------------------- placing
@cpl.plan(name="place")
async def place(
    object_designator: Any,
    arm: str,
    reach_poses: Sequence[Pose],
    put_poses: Sequence[Pose],
    retract_poses: Sequence[Pose],
    grasp: str | None = None,
    release_opening: float | None = None,
) -> None:
    """Put the held object down.

    1. ``reaching`` (its manipulation failure propagates); 2. ``putting`` (ignored);
    3. ``releasing`` to ``release_opening`` (None: fully open; gripper failures
    ignored); 4. ``ObjectDetached`` (the world model lets the object settle);
    5. ``retracting`` (ignored).

    Deliberate difference from CRAM (whose placing opens the gripper fully): the
    placing grounding releases at :func:`release_opening`, as wide as the pick opened
    to grasp the object: a spoon put down 6 cm beside a cup was let go of with the
    fingers opened to 0.10 m, and a finger pushed the cup (seed 2)."""
    await perform(_arm_action("reaching", arm, reach_poses))
    await perform_ignoring(_arm_action("putting", arm, put_poses), ManipulationLowLevelFailure)
    releasing = (
        an.action(type="releasing", gripper=arm)
        if release_opening is None
        else an.action(type="releasing", gripper=arm, position=release_opening)
    )
    await perform_ignoring(releasing, GripperLowLevelFailure)
    emit(ObjectDetached(object_designator, arm, hand_link_of(arm)))
    await perform_ignoring(
        _arm_action("retracting", arm, retract_poses), ManipulationLowLevelFailure
    )


#: Opening (m) the released fingers clear the held object by at least: above the opening
#: measured while it is held (a gripper that holds it closes on it).
RELEASE_CLEARANCE = 0.01


def release_opening(object_type: str, arm: str) -> float:
    """How wide a placing opens ``arm``'s gripper to let go of an object of
    ``object_type``: the opening its pick used (the type's
    :func:`executive.knowledge.gripper_opening`, no wider than the gripper opens), and at
    least :data:`RELEASE_CLEARANCE` wider than the fingers are now (where the world model
    measures them), so the fingers clear the object wherever it was grasped."""
    widest = arm_description(arm).gripper.max_opening
    opening = min(knowledge.gripper_opening(object_type), widest)
    measured = current_environment().world.gripper_opening(arm)
    if measured is not None:
        opening = max(opening, min(float(measured) + RELEASE_CLEARANCE, widest))
    return opening


def _closest_grasp(
    object_type: str, rotation: np.ndarray, standard_to_tool: Sequence[Sequence[float]]
) -> knowledge.Grasp:
    """The type's grasp whose tool orientation (in the object frame) is closest, for a
    tool frame ``standard_to_tool`` (rows) from the standard gripper."""
    g_prime_t_g = np.array(standard_to_tool)

    def angle(g: knowledge.Grasp) -> float:
        delta = (np.array(g.rotation) @ g_prime_t_g).T @ rotation
        return math.acos(max(-1.0, min(1.0, (np.trace(delta) - 1.0) / 2.0)))

    return min(knowledge.object_knowledge(object_type).grasps, key=angle)


def _put_back_pose(
    object_type: str,
    object_t_tool: Transform,
    held: Pose,
    standard_to_tool: Sequence[Sequence[float]],
) -> Pose:
    """Where a placing without a target puts the object: straight back down from where
    the hand holds it by the grasp's lift offset (object frame), i.e. where a pick-up
    lifted it from. Deliberate difference: CRAM's targetless placing puts the object
    "down" at the pose it is held at, reaching above it first, which takes an arm that
    just lifted an object at the limit of its reach beyond that limit (the seed's cup,
    held 1.07 m high)."""
    g = _closest_grasp(object_type, object_t_tool.matrix()[:3, :3], standard_to_tool)
    lowered = held.matrix() @ Transform(tuple(-v for v in g.second_lift_offset)).matrix()
    return Transform.from_matrix(lowered, held.frame).to_pose()


#: Types whose yaw on the table does not matter (round): more placing yaws are tried.
ROUND_TYPES = frozenset({"bowl", "cup", "plate"})


def _yaw_variants(object_type: str, target: Pose, held: Pose, free_yaw: bool) -> list[Pose]:
    """The target orientations a placing tries, in order (see the module docstring):
    ``target`` in ``base_footprint``; ``held`` the object's pose in ``base_footprint``."""
    if free_yaw:
        offsets = [0.0, math.pi / 2, -math.pi / 2, math.pi]
        if object_type in ROUND_TYPES:
            offsets += [math.pi / 4, -math.pi / 4, 3 * math.pi / 4, -3 * math.pi / 4]
        return [
            Pose.from_xyz_yaw(*target.position, held.yaw + off, frame=target.frame)
            for off in offsets
        ]
    turned = yaw_quaternion(math.pi)
    flipped = Transform((0.0, 0.0, 0.0), turned).matrix() @ target.matrix()
    flipped[:3, 3] = target.position
    return [target, Transform.from_matrix(flipped, target.frame).to_pose()]


def placing_waypoints(
    object_type: str,
    object_t_tool: Transform,
    target_in_base: Pose,
    standard_to_tool: Sequence[Sequence[float]],
) -> tuple[str, list[Pose]]:
    """The grasp closest to the measured tool pose in the object frame, and the five
    waypoints at the target in CRAM's picking order (pregrasp ... 2nd lift): the measured
    gripper-in-object transform, with that grasp's offsets added in the object frame.
    ``standard_to_tool``: the holding arm's
    :attr:`executive.ArmDescription.standard_to_tool` (which grasp is closest depends on
    how the robot's tool frame sits on the standard gripper)."""
    g = _closest_grasp(object_type, object_t_tool.matrix()[:3, :3], standard_to_tool)
    b_t_o = target_in_base.matrix()
    o_t_g = object_t_tool.matrix()
    out = []
    for offset in g.offsets():
        m = o_t_g.copy()
        m[:3, 3] += offset
        out.append(Transform.from_matrix(b_t_o @ m, target_in_base.frame).to_pose())
    return g.name, out


@rule(
    "action",
    "placing",
    doc=RuleDoc(
        "Put a held object down from where the robot stands (plan place): reach, put, "
        "open the gripper, ObjectDetached, retract. The object lands at the target with "
        "the grasp it was picked with.",
        keys=(
            Key(
                "object",
                "object designator with a name",
                "which held object",
                default="whatever the arm(s) hold",
            ),
            Key("arm", "'left' | 'right'", "the holding arm", default="each arm that holds one"),
            Key(
                "target",
                "location designator or executive.Pose (map or base_footprint)",
                "where the object's origin goes; its orientation is the object's",
                default="straight back down where it was lifted from",
            ),
            Key(
                "free-yaw",
                "bool",
                "ignore the target's orientation: try the held yaw, then turned by 90, -90, "
                "180 degrees (round types: every 45)",
                default="False: the target's yaw, then that + 180 degrees",
            ),
        ),
        raises=(ManipulationLowLevelFailure,),
        ignores=(ManipulationLowLevelFailure, GripperLowLevelFailure),
        performs=("reaching", "putting", "releasing", "retracting"),
        note="DesignatorError if the robot holds no such object. The reach failure "
        "propagates; putting, releasing and retracting failures are ignored. Solutions: "
        "each target solution: its yaw variants reached straight, then the same reached "
        "from 0.1 m above; plans.check_placing_collisions(action) probes them (delivering "
        "does).",
    ),
)
def _placing(d: Designator) -> Iterator[Any]:
    world = current_environment().world
    given = d.get("object")
    arm_given = _given_arm(d)
    arms = (arm_given,) if arm_given is not None else arm_names()
    base = base_frame()
    in_hand = [(arm, world.object_in_hand(arm)) for arm in arms]
    held = [(arm, n) for arm, n in in_hand if n is not None]
    if isinstance(given, ObjectDesignator) and given.current().get("name"):
        name = given.current().get("name")
        held = [(arm, n) for arm, n in held if n == name]
    if not held:
        raise DesignatorError(f"{d.short()}: the robot holds no such object", d)
    target = d.get("target")
    free_yaw = bool(d.get("free-yaw", False))
    for arm, name in held:
        obj = given.current() if isinstance(given, ObjectDesignator) else an.object(name=name)
        otype = world.object_type(name)
        obj_map = world.object_pose(name, "map").to_transform()
        tool_map = world.link_pose(tool_frame_of(arm), "map").to_transform()
        object_t_tool = obj_map.inverse() * tool_map
        standard_to_tool = arm_description(arm).standard_to_tool
        opening = release_opening(otype, arm)
        if target is None:
            held_now = world.object_pose(name, base)
            targets: Any = [_put_back_pose(otype, object_t_tool, held_now, standard_to_tool)]
        elif isinstance(target, LocationDesignator):
            targets = target.current().solutions()
        elif isinstance(target, Pose):
            targets = [target]
        else:
            raise DesignatorError(f"{d.short()}: target must be a location or a pose", d)
        held_pose = world.object_pose(name, base)
        for target_pose in targets:
            solutions = []
            for variant in _yaw_variants(otype, to_base(target_pose), held_pose, free_yaw):
                grasp_name, poses = placing_waypoints(
                    otype, object_t_tool, variant, standard_to_tool
                )
                poses.reverse()
                solutions.append((grasp_name, poses))
            # every yaw reached straight, then every yaw from above (_approaches)
            for approach in range(2):
                for grasp_name, poses in solutions:
                    yield (
                        place,
                        {
                            "object_designator": obj,
                            "arm": arm,
                            "reach_poses": _approaches(poses[:2], PLACE_APPROACH_HEIGHT)[approach],
                            "put_poses": (poses[2],),
                            "retract_poses": tuple(poses[3:]),
                            "grasp": grasp_name,
                            "release_opening": opening,
                        },
                    )


register_resources(place, hand_of)


async def release_held(object_designator: Any) -> None:
    """Let go of ``object_designator`` wherever it is: for each arm the world model says
    holds it, open that gripper (gripper failures ignored) and emit ``ObjectDetached``
    (the object drops and settles). Nothing held: nothing happens. The cleanup of
    ``drop-at-sink``: CRAM only detached inside ``place``, so a failed drop left the object
    in the hand for the rest of the demo."""
    world = current_environment().world
    name = object_name(object_designator)
    for arm in arm_names():
        if world.object_in_hand(arm) == name:
            await perform_ignoring(an.action(type="releasing", gripper=arm), GripperLowLevelFailure)
            emit(ObjectDetached(object_designator, arm, hand_link_of(arm)))
