"""Atomic actions (CRAM's ``cram_mobile_pick_place_plans/src/atomic-action-*.lisp``): each
action type resolves, through a static rule, to one plan that performs motions and handles
the failures CRAM HEAD handles there.

============================  ==========================  =================================
action type                   plan                        failures
============================  ==========================  =================================
going (target | pose)         go-to-target                navigation low-level: 0 retries
looking (target | pose |      look-at                     ptu low-level: 0 retries (HEAD)
  frame | direction | object)
detecting (object)            perceive                    perception low-level: 4 retries
                                                          (1 with a cad-model)
moving-torso (joint-angle)    move-torso                  propagate
reaching, retracting,         move-arms-in-sequence       manipulation low-level ignored at
lifting, grasping, putting,                               intermediate waypoints; the last
pulling, pushing                                          waypoint's failure propagates
positioning-arm               position-arms               manipulation low-level ignored
gripping (gripper, effort?)   grip                        gripper low-level: 1 retry
releasing (gripper,          release                     gripper low-level ignored
  position?)
opening-gripper,              open-or-close-gripper       gripper low-level ignored
closing-gripper, opening /
closing with a gripper
setting-gripper               set-gripper-to-position     gripper low-level ignored
============================  ==========================  =================================

Every plan is evaporation-safe: it holds nothing to clean up, and ``going`` emits its
``RobotStateChanged`` in a ``finally`` (CRAM's ``unwind-protect``).

The robot parts each action claims for its duration (:func:`executive.register_resources`;
what a concurrent goal on a claimed part does: :mod:`executive._resources`): ``going``
the base, ``looking`` the head, ``detecting`` the head shared (perception coexists with
other perception and motions, not with a ``looking`` outside its subtree),
``moving-torso`` the torso, the arm actions the arms that have waypoints or a
configuration, the gripper actions the grippers they name.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterator, Sequence
from itertools import zip_longest
from typing import Any

import cpl
from executive import (
    ArmJointLimits,
    Designator,
    DesignatorError,
    DesignatorInputError,
    GripperLowLevelFailure,
    Key,
    ManipulationLowLevelFailure,
    NavigationLowLevelFailure,
    ObjectData,
    ObjectDesignator,
    PerceptionLowLevelFailure,
    Pose,
    PtuLowLevelFailure,
    Resource,
    Retry,
    RuleDoc,
    TorsoLowLevelFailure,
    a,
    an,
    current_environment,
    emit,
    equate,
    perform,
    register_resources,
    rule,
)
from executive.events import ObjectDetached, ObjectPerceived, RobotStateChanged

from ._common import (
    CountedRetries,
    arm_description,
    arm_names,
    arms_left_to_right,
    as_location,
    grippers_named,
    hand_link_of,
    perform_ignoring,
    the_base,
)

_log = logging.getLogger(__name__)

__all__ = [
    "go_to_target",
    "grip",
    "look_at",
    "move_arms_in_sequence",
    "move_torso",
    "open_or_close_gripper",
    "park_arms",
    "perceive",
    "position_arms",
    "release",
    "set_gripper_to_position",
]


# ----------------------------------------------------------------------------- helpers
_TARGET = "location designator or executive.Pose"
_GRIPPER = Key("gripper", "'left' | 'right' | ('left', 'right')", "the gripper(s)", required=True)


def _arm(d: Designator, key: str = "arm", default: str | None = None) -> str:
    value = d.get(key, default)
    known = arm_names()
    if value not in known:
        raise DesignatorError(f"{d.short()}: {key} must be one of {known}, got {value!r}")
    return str(value)


def _gripper(d: Designator) -> Any:
    value = d.get("gripper")
    grippers = value if isinstance(value, tuple) else (value,)
    known = arms_left_to_right()
    if not grippers or any(g not in known for g in grippers):
        choices = ", ".join(repr(g) for g in known) + (" or both" if len(known) > 1 else "")
        raise DesignatorError(f"{d.short()} needs gripper {choices}, got {value!r}")
    return value


def _poses(d: Designator, key: str) -> tuple[Pose, ...]:
    value = d.get(key, ())
    values = value if isinstance(value, tuple) else (value,)
    if not all(isinstance(p, Pose) for p in values):
        raise DesignatorError(f"{d.short()}: {key} must be a list of poses, got {value!r}")
    return values


# -------------------------------------------------------------------------------- going
@cpl.plan(name="go-to-target")
async def go_to_target(target: Any) -> None:
    """Perform the ``going`` motion to ``target`` (a location designator or a pose).

    Handles ``navigation-low-level-failure`` with a counter of 0 (CRAM HEAD), so it always
    propagates. Emits ``RobotStateChanged`` whatever happens (also on evaporation)."""
    motion = a.motion(type="going", target=as_location(target))
    try:
        await cpl.with_retry(
            lambda: perform(motion),
            on=NavigationLowLevelFailure,
            counter=CountedRetries(0, "going"),
        )
    finally:
        emit(RobotStateChanged(reason="going"))


@rule(
    "action",
    "going",
    doc=RuleDoc(
        "Drive the base to the target (plan go-to-target), with no collision check: use "
        "navigating to choose a collision-free pose.",
        keys=(
            Key("target", _TARGET, "where the base goes (map)", default="pose"),
            Key("pose", _TARGET, "alias of target", default="-"),
        ),
        raises=(NavigationLowLevelFailure,),
        retries=(
            Retry(
                0,
                (NavigationLowLevelFailure,),
                "none: CRAM HEAD's counter of 0, the failure propagates",
                counter="going",
            ),
        ),
        motions=("going",),
        note="One of target or pose is required. Emits RobotStateChanged, also on failure.",
    ),
)
def _going(d: Designator) -> Iterator[Any]:
    target = d.get("target", d.get("pose"))
    if target is None:
        raise DesignatorError(f"{d.short()} needs a target (location designator or pose)", d)
    yield go_to_target, {"target": target}


_HEAD, _TORSO = (Resource.head(),), (Resource.torso(),)
register_resources(go_to_target, the_base)


# ------------------------------------------------------------------------------ looking
@cpl.plan(name="look-at")
async def look_at(motion: Designator) -> None:
    """Perform the ``looking`` motion.

    Quirk kept: CRAM HEAD declares one retry on ``ptu-low-level-failure`` but its handler
    body is empty, so PTU failures propagate: 0 effective retries, written as a visible
    counter of 0. Retrying the same goal could not succeed (the pan/tilt limits do not
    change); ``turning-towards`` owns the working recovery (turn the base, look again)."""
    await cpl.with_retry(
        lambda: perform(motion), on=PtuLowLevelFailure, counter=CountedRetries(0, "looking")
    )


@rule(
    "action",
    "looking",
    doc=RuleDoc(
        "Point the head (plan look-at); the base does not turn: use turning-towards for a "
        "target the head cannot reach.",
        keys=(
            Key("target", _TARGET, "the point to look at", default="pose"),
            Key("pose", _TARGET, "alias of target", default="-"),
            Key("object", "object designator (perceived)", "look at its pose", default="-"),
            Key("frame", "frame name", "look at the frame's origin", default="-"),
            Key("direction", "'forward'", "look straight ahead", default="-"),
        ),
        raises=(PtuLowLevelFailure,),
        retries=(
            Retry(
                0,
                (PtuLowLevelFailure,),
                "none: CRAM HEAD's empty handler, the failure propagates",
                counter="looking",
            ),
        ),
        motions=("looking",),
        note="One of the keys is required; the first given, in the order listed, is used.",
    ),
)
def _looking(d: Designator) -> Iterator[Any]:
    props: dict[str, Any] = {}
    for key in ("target", "pose"):
        if d.get(key) is not None:
            props["target"] = as_location(d.get(key))
            break
    else:
        for key in ("object", "frame", "direction"):
            if d.get(key) is not None:
                props[key] = d.get(key)
                break
    if not props:
        raise DesignatorError(f"{d.short()} needs target, pose, object, frame or direction", d)
    yield look_at, {"motion": a.motion(type="looking", **props)}


register_resources(look_at, lambda _args: _HEAD)


# ---------------------------------------------------------------------------- detecting
def _as_designator(wanted: ObjectDesignator, result: Any) -> ObjectDesignator:
    """The perception result as an object designator (process modules return a
    designator, a list of them, or :class:`executive.ObjectData`)."""
    if isinstance(result, (list, tuple)) and result:
        result = result[0]
    if isinstance(result, ObjectDesignator):
        return result
    if not isinstance(result, ObjectData) or not isinstance(result.pose, Pose):
        raise DesignatorError(f"perception returned no pose for {wanted.short()}: {result!r}")
    return wanted.copy(
        name=result.name or wanted.get("name"),
        type=result.type or wanted.type,
        pose=result.pose,
        transform=result.transform,
    )


@cpl.plan(name="perceive")
async def perceive(object_designator: ObjectDesignator) -> ObjectDesignator:
    """Perform the ``detecting`` motion for the object.

    Retries ``perception-low-level-failure`` 4 times (once if the object has a
    ``cad-model``), then lets it propagate. Emits ``ObjectPerceived``, equates the input
    designator to the result and returns the result."""
    retries = CountedRetries(1 if "cad-model" in object_designator else 4, "detecting")
    motion = a.motion(type="detecting", object=object_designator)
    result = await cpl.with_retry(
        lambda: perform(motion), on=PerceptionLowLevelFailure, counter=retries
    )
    perceived = _as_designator(object_designator, result)
    equate(object_designator, perceived)
    emit(ObjectPerceived(perceived))
    return perceived


@rule(
    "action",
    "detecting",
    doc=RuleDoc(
        "Perceive the object from where the robot stands (plan perceive): the robot "
        "neither drives nor turns its head. Returns the perceived object designator "
        "(with name, pose and transform), equated to the one given; emits ObjectPerceived.",
        keys=(
            Key(
                "object",
                "object designator",
                "what to find: type, optionally name (cad-model: 1 retry only)",
                required=True,
            ),
        ),
        raises=(PerceptionLowLevelFailure,),
        retries=(
            Retry(
                4,
                (PerceptionLowLevelFailure,),
                "detect again from the same place",
                counter="detecting",
                note="1 if the object designator has a cad-model",
            ),
        ),
        motions=("detecting",),
    ),
)
def _detecting(d: Designator) -> Iterator[Any]:
    obj = d.get("object")
    if not isinstance(obj, ObjectDesignator):
        raise DesignatorError(f"{d.short()} needs an object designator", d)
    yield perceive, {"object_designator": obj}


register_resources(perceive, lambda _args: _HEAD, shared=True)


# -------------------------------------------------------------------------------- torso
@cpl.plan(name="move-torso")
async def move_torso(joint_angle: float) -> None:
    """Perform ``moving-torso``; torso failures (manipulation low-level) propagate."""
    await perform(a.motion(type="moving-torso", joint_angle=joint_angle))


@rule(
    "action",
    "moving-torso",
    doc=RuleDoc(
        "Set the torso height (plan move-torso).",
        keys=(Key("joint-angle", "number (m)", "the torso lift joint's position", required=True),),
        raises=(TorsoLowLevelFailure,),
        motions=("moving-torso",),
    ),
)
def _moving_torso(d: Designator) -> Iterator[Any]:
    angle = d.get("joint-angle")
    if not isinstance(angle, (int, float)):
        raise DesignatorError(f"{d.short()} needs a joint-angle (a number)", d)
    yield move_torso, {"joint_angle": float(angle)}


register_resources(move_torso, lambda _args: _TORSO)


# ----------------------------------------------------------------------------- arm moves
@cpl.plan(name="move-arms-in-sequence")
async def move_arms_in_sequence(
    left_poses: Sequence[Pose], right_poses: Sequence[Pose], collision_mode: str | None = None
) -> None:
    """Perform ``moving-tcp`` through the waypoint pairs (the shorter list padded with
    ``None``: that arm stays). Manipulation low-level failures at intermediate waypoints
    are ignored; at the last waypoint they propagate. Deliberate difference from CRAM: a
    *gripper* failure (the held object fell out during the motion) is never ignored: the
    caller must learn that the hand is empty (see :func:`plans.pick_place.pick_up`)."""
    pairs = [(lp, rp) for lp, rp in zip_longest(left_poses, right_poses) if lp or rp]
    for i, (lp, rp) in enumerate(pairs):
        motion = a.motion(
            type="moving-tcp", left_pose=lp, right_pose=rp, collision_mode=collision_mode
        )
        if i < len(pairs) - 1:

            async def move(motion: Designator = motion) -> None:
                await perform(motion)

            await cpl.with_failure_handling(
                move,
                [
                    (GripperLowLevelFailure, _reraise),
                    (ManipulationLowLevelFailure, lambda _f: cpl.return_(None)),
                ],
            )
        else:
            await perform(motion)


def _reraise(failure: BaseException) -> None:
    raise failure


_COLLISION_MODES = {
    "reaching": None,
    "retracting": None,
    "lifting": "allow-hand",
    "grasping": "allow-all",
    "putting": "allow-all",
    "pulling": "allow-all",
    "pushing": "allow-all",
}


def _arm_motion_rule(action_type: str) -> Any:
    def ground(d: Designator) -> Iterator[Any]:
        yield (
            move_arms_in_sequence,
            {
                "left_poses": _poses(d, "left-poses"),
                "right_poses": _poses(d, "right-poses"),
                "collision_mode": _COLLISION_MODES[action_type],
            },
        )

    ground.__name__ = ground.__qualname__ = action_type.replace("-", "_")
    return ground


def _arm_motion_doc(action_type: str) -> RuleDoc:
    mode = _COLLISION_MODES[action_type]
    return RuleDoc(
        f"Move the tool frame(s) through the waypoints (plan move-arms-in-sequence); "
        f"the motions' collision-mode is {mode or 'None'} (the projection ignores it).",
        keys=(
            Key(
                "left-poses",
                "tuple of executive.Pose (base_footprint or map)",
                "the left tool frame's waypoints",
                default="left arm stays",
            ),
            Key(
                "right-poses",
                "tuple of executive.Pose (base_footprint or map)",
                "the right tool frame's waypoints",
                default="right arm stays",
            ),
        ),
        raises=(ManipulationLowLevelFailure, GripperLowLevelFailure),
        ignores=(ManipulationLowLevelFailure,),
        motions=("moving-tcp",),
        note="A manipulation failure at an intermediate waypoint is ignored, at the last it "
        "propagates; a gripper failure (the held object fell out) always propagates. The "
        "shorter list is padded: that arm stays.",
    )


for _action_type in _COLLISION_MODES:
    rule("action", _action_type, doc=_arm_motion_doc(_action_type))(_arm_motion_rule(_action_type))
register_resources(
    move_arms_in_sequence,
    lambda args: tuple(Resource.arm(side) for side in ("left", "right") if args[f"{side}_poses"]),
)


@cpl.plan(name="position-arms")
async def position_arms(left: tuple[float, ...] | None, right: tuple[float, ...] | None) -> None:
    """Perform ``moving-arm-joints``; manipulation low-level failures are ignored.
    Deliberate difference from CRAM: a gripper failure (the held object fell out while the
    arm moved) is ignored too, but not silently: the world model is told with
    ``ObjectDetached`` (so the belief does not keep a phantom object in the hand, which a
    later ``placing`` would "put down"), and it is logged."""
    motion = a.motion(type="moving-arm-joints", left_joint_states=left, right_joint_states=right)

    async def move() -> None:
        await perform(motion)

    def dropped(failure: BaseException) -> None:
        _object_fell_out(failure, [arm for arm, q in (("left", left), ("right", right)) if q])
        cpl.return_(None)

    await cpl.with_failure_handling(
        move,
        [
            (GripperLowLevelFailure, dropped),
            (ManipulationLowLevelFailure, lambda _f: cpl.return_(None)),
        ],
    )


def _object_fell_out(failure: BaseException, arms: Sequence[str]) -> None:
    world = current_environment().world
    for arm in arms:
        name = world.object_in_hand(arm)
        if name is None:
            continue
        _log.warning("%s fell out of the %s gripper while moving the arm: %s", name, arm, failure)
        emit(ObjectDetached(an.object(name=name), arm, hand_link_of(arm)))


def _configuration(d: Designator, arm: str) -> tuple[float, ...] | None:
    """The joint values of ``arm``'s configuration: a named one, or joint values checked
    here, before anything moves (``position-arms`` ignores manipulation failures, so a bad
    value used to move nothing and report nothing): one finite number per arm joint and,
    if the world knows the limits (:class:`executive.ArmJointLimits`), each within them.
    A bad value is a :class:`executive.DesignatorInputError` naming the joint."""
    key = f"{arm}-configuration"
    value = d.get(key)
    if value is None:
        return None
    try:
        description = arm_description(arm)
    except LookupError as exc:
        raise DesignatorInputError(f"{d.short()}: {key}: {exc}", d) from None
    if not isinstance(value, tuple):
        try:
            return description.state(str(value))
        except LookupError as exc:
            raise DesignatorInputError(f"{d.short()}: {exc}", d) from None
    joints = description.joints
    if len(value) != len(joints) or not all(
        isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value
    ):
        raise DesignatorInputError(
            f"{d.short()}: {key} takes a configuration name or {len(joints)} finite joint "
            f"values ({', '.join(joints)}); got {value!r}",
            d,
        )
    env = current_environment()
    world = env.world if env.has_world else None
    if isinstance(world, ArmJointLimits):
        for v, (joint, lo, hi) in zip(value, world.arm_joint_limits(arm)):
            if not lo - _LIMIT_TOLERANCE <= v <= hi + _LIMIT_TOLERANCE:
                raise DesignatorInputError(
                    f"{d.short()}: {key}: {joint} = {v!r} is outside its limits "
                    f"[{lo:.4f}, {hi:.4f}]",
                    d,
                )
    return tuple(float(v) for v in value)


#: Joint values this far past a limit (radians or metres) are still accepted (rounding).
_LIMIT_TOLERANCE = 1e-6


_CONFIGURATION = "'park' | 'carry' | joint values (rad), one per arm joint"


@rule(
    "action",
    "positioning-arm",
    doc=RuleDoc(
        "Move the arms to joint configurations (plan position-arms); park_arms() is both "
        "arms to 'carry' (CRAM HEAD's default).",
        keys=(
            Key(
                "left-configuration",
                _CONFIGURATION,
                "the left arm's configuration",
                default="left arm stays",
            ),
            Key(
                "right-configuration",
                _CONFIGURATION,
                "the right arm's configuration",
                default="right arm stays",
            ),
        ),
        ignores=(ManipulationLowLevelFailure, GripperLowLevelFailure),
        motions=("moving-arm-joints",),
        note="At least one configuration is required. Failures are ignored; a held object "
        "that fell out is logged and the world model told (ObjectDetached).",
    ),
)
def _positioning_arm(d: Designator) -> Iterator[Any]:
    left, right = _configuration(d, "left"), _configuration(d, "right")
    if left is None and right is None:
        raise DesignatorError(
            f"{d.short()} needs left-configuration and/or right-configuration ('park', "
            "'carry' or joint values, one per arm joint)",
            d,
        )
    yield position_arms, {"left": left, "right": right}


register_resources(
    position_arms,
    lambda args: tuple(Resource.arm(side) for side in ("left", "right") if args[side]),
)


async def park_arms(configuration: str = "carry") -> None:
    """Both arms to a named configuration (CRAM's ``park-arms``). The default is
    ``carry``: CRAM HEAD's ``:carry t`` default (quirk kept); pass ``"park"`` for the arms
    at the sides. Failures are ignored (by ``position-arms``). Every arm the robot has
    (a one-armed robot: its ``left``)."""
    await perform(
        an.action(
            type="positioning-arm",
            **{f"{arm}_configuration": configuration for arm in arms_left_to_right()},
        )
    )


# ------------------------------------------------------------------------------ grippers
@cpl.plan(name="grip")
async def grip(gripper: Any, effort: float | None = None) -> None:
    """Perform ``gripping``; retries a ``gripper-low-level-failure`` once, then lets it
    propagate."""
    motion = a.motion(type="gripping", gripper=gripper, effort=effort)
    await cpl.with_retry(
        lambda: perform(motion), on=GripperLowLevelFailure, counter=CountedRetries(1, "regrips")
    )


@rule(
    "action",
    "gripping",
    doc=RuleDoc(
        "Close the gripper on the object between its fingers (plan grip).",
        keys=(_GRIPPER, Key("effort", "number (Nm)", "grip effort", default="the driver's")),
        raises=(GripperLowLevelFailure,),
        retries=(Retry(1, (GripperLowLevelFailure,), "grip again", counter="regrips"),),
        motions=("gripping",),
    ),
)
def _gripping(d: Designator) -> Iterator[Any]:
    effort = d.get("effort")
    # checked here, where the action is named (the motion checks it again)
    if effort is not None and (
        isinstance(effort, bool)
        or not isinstance(effort, (int, float))
        or not math.isfinite(effort)
        or effort < 0
    ):
        raise DesignatorInputError(f"{d.short()}: effort must be a number >= 0, got {effort!r}", d)
    yield grip, {"gripper": _gripper(d), "effort": None if effort is None else float(effort)}


@cpl.plan(name="release")
async def release(gripper: Any, position: float | None = None) -> None:
    """Open the gripper (fully, or to ``position`` metres); gripper failures are
    ignored."""
    if position is None:
        motion = a.motion(type="opening-gripper", gripper=gripper)
    else:
        motion = a.motion(type="moving-gripper-joint", gripper=gripper, joint_angle=position)
    await perform_ignoring(motion, GripperLowLevelFailure)


def _gripper_position(d: Designator, gripper: Any, position: Any) -> float:
    """``position`` checked to be an opening (m) every gripper named reaches; else a
    DesignatorError before anything moves (the gripper plans ignore gripper failures, so
    an opening out of range would otherwise be dropped without a word)."""
    if isinstance(position, bool) or not isinstance(position, (int, float)):
        raise DesignatorError(f"{d.short()} needs a position (metres)", d)
    widest = min(
        arm_description(g).gripper.max_opening
        for g in (gripper if isinstance(gripper, tuple) else (gripper,))
    )
    if not 0.0 <= position <= widest:
        raise DesignatorError(
            f"{d.short()}: position is the gripper opening in metres, from 0 to "
            f"{widest}; got {position!r}",
            d,
        )
    return float(position)


@rule(
    "action",
    "releasing",
    doc=RuleDoc(
        "Open the gripper (plan release): fully, or to the given position; the world "
        "model is not told: emit ObjectDetached (placing does).",
        keys=(
            _GRIPPER,
            Key(
                "position",
                "number (m), 0 to the gripper's max_opening",
                "open only this wide (placing: the opening the pick used, so the fingers "
                "do not press the neighbours); out of range: DesignatorError",
                default="fully open",
            ),
        ),
        ignores=(GripperLowLevelFailure,),
        motions=("opening-gripper", "moving-gripper-joint"),
    ),
)
def _releasing(d: Designator) -> Iterator[Any]:
    gripper = _gripper(d)
    position = d.get("position")
    if position is not None:
        position = _gripper_position(d, gripper, position)
    yield release, {"gripper": gripper, "position": position}


@cpl.plan(name="open-or-close-gripper")
async def open_or_close_gripper(gripper: Any, action_type: str) -> None:
    """Open or close the gripper; gripper failures are ignored."""
    motion = a.motion(type=f"{action_type}-gripper", gripper=gripper)
    await perform_ignoring(motion, GripperLowLevelFailure)


def _open_close_rule(action_type: str) -> Any:
    def ground(d: Designator) -> Iterator[Any]:
        if d.get("gripper") is not None:
            yield open_or_close_gripper, {"gripper": _gripper(d), "action_type": action_type}

    ground.__name__ = ground.__qualname__ = f"{action_type}_gripper"
    return ground


def _open_close_doc(verb: str, alias: bool) -> RuleDoc:
    summary = (
        f"With a gripper: CRAM HEAD's name of {verb}-gripper (no solution without one)."
        if alias
        else f"{'Open' if verb == 'opening' else 'Close'} the gripper fully (plan "
        "open-or-close-gripper)."
    )
    return RuleDoc(
        summary,
        keys=(_GRIPPER,),
        ignores=(GripperLowLevelFailure,),
        motions=(f"{verb}-gripper",),
    )


for _verb in ("opening", "closing"):
    rule("action", f"{_verb}-gripper", doc=_open_close_doc(_verb, False))(_open_close_rule(_verb))
    rule("action", _verb, doc=_open_close_doc(_verb, True))(_open_close_rule(_verb))


@cpl.plan(name="set-gripper-to-position")
async def set_gripper_to_position(gripper: Any, position: float) -> None:
    """Perform ``moving-gripper-joint``; gripper failures are ignored."""
    motion = a.motion(type="moving-gripper-joint", gripper=gripper, joint_angle=position)
    await perform_ignoring(motion, GripperLowLevelFailure)


@rule(
    "action",
    "setting-gripper",
    doc=RuleDoc(
        "Set the gripper opening (plan set-gripper-to-position).",
        keys=(
            _GRIPPER,
            Key(
                "position",
                "number (m), 0 to the gripper's max_opening",
                "the opening; out of range: DesignatorError before anything moves",
                required=True,
            ),
        ),
        ignores=(GripperLowLevelFailure,),
        motions=("moving-gripper-joint",),
    ),
)
def _setting_gripper(d: Designator) -> Iterator[Any]:
    gripper = _gripper(d)
    position = _gripper_position(d, gripper, d.get("position"))
    yield set_gripper_to_position, {"gripper": gripper, "position": position}


for _gripper_plan in (grip, release, open_or_close_gripper, set_gripper_to_position):
    register_resources(_gripper_plan, grippers_named)
