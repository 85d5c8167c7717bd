"""Robot-independent motion groundings (CRAM's ``cram_common_designators/src/motions.lisp``)
and the object fallback rule, registered on the frozen builtin rule set.

We take v0.8.1's property names where HEAD differs (``going`` takes ``pose``,
``moving-tcp`` takes ``left-pose``/``right-pose``, the gripper motions are
``opening-gripper``/``closing-gripper``) and accept HEAD's spellings as aliases
(``going (target L)``, ``opening``/``closing`` with a ``gripper``, ``left-target``,
``left-configuration``). Commands use CRAM's names; their arguments use Python spelling so a
process module can read ``args["joint_angle"]``.

=========================  ====================================  =============================
motion type                properties                            command and arguments
=========================  ====================================  =============================
going                      pose | target (location), speed?      move-base {pose, speed}
moving-torso               joint-angle                           move-torso {joint_angle}
looking                    pose | target | frame | direction |   move-head {pose | frame |
                           joint-states | object                 direction | joint_states}
detecting                  object                                detect {object}
opening-gripper, opening   gripper                               move-gripper-joint
closing-gripper, closing   gripper                                 {action: open|close, gripper}
gripping                   gripper, effort?                      move-gripper-joint {grip ...}
moving-gripper-joint       gripper, joint-angle                  move-gripper-joint {angle ...}
moving-tcp                 left-pose?, right-pose? (>= 1),       move-tcp {left, right,
                           collision-mode?                         collision_mode}
moving-arm-joints          left-joint-states?,                   move-joints {left, right}
                           right-joint-states? (>= 1)
=========================  ====================================  =============================

The resources each command uses while it runs (:mod:`executive._resources`): ``move-base``
the base, ``move-torso`` the torso, ``move-head`` and ``detect`` the head (perception reads
the camera where the head points), ``move-gripper-joint`` the grippers it names,
``move-tcp`` and ``move-joints`` the arms that have a goal.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from types import MappingProxyType
from typing import Any, Final

from ._designator import Designator
from ._pose import Pose
from ._resources import Resource
from ._ruledoc import Key, RuleDoc
from ._rules import WILDCARD, builtin_rules
from ._solutions import MotionCommand, ObjectData
from .failures import (
    DesignatorError,
    DesignatorInputError,
    GripperClosedCompletely,
    GripperGoalNotReached,
    ManipulationGoalNotReached,
    ManipulationPoseUnreachable,
    NavigationGoalNotReached,
    NavigationPoseUnreachable,
    PerceptionObjectNotFound,
    PtuGoalNotReached,
    TorsoGoalNotReached,
)

__all__: list[str] = []

_ARMS = ("left", "right")


def _pose_like(d: Designator, key: str, value: Any) -> Pose:
    """A Pose, or a location designator referenced to its current solution."""
    if isinstance(value, Pose):
        return value
    if isinstance(value, Designator) and value.kind == "location":
        pose: Pose = value.current().reference()
        return pose
    raise DesignatorError(
        f"{d.short()}: {key} must be an executive.Pose or a location designator, got {value!r}",
        d,
    )


def _number(
    d: Designator, key: str, required: bool = True, *, minimum: float | None = None
) -> float | None:
    """``d``'s ``key`` as a finite float (``None`` if absent and not ``required``); with
    ``minimum``, a value below it (a negative speed or effort) is refused too."""
    value = d.get(key)
    if value is None:
        if required:
            raise DesignatorError(f"{d.short()} needs a {key} property (a number)", d)
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise DesignatorInputError(f"{d.short()}: {key} must be a finite number, got {value!r}", d)
    if minimum is not None and value < minimum:
        raise DesignatorInputError(
            f"{d.short()}: {key} must be a number >= {minimum:g}, got {value!r}", d
        )
    return float(value)


def _gripper(d: Designator) -> str | tuple[str, ...]:
    value = d.get("gripper")
    if value is None:
        raise DesignatorError(
            f"{d.short()} needs a gripper property: 'left', 'right' or ('left', 'right')", d
        )
    grippers = value if isinstance(value, tuple) else (value,)
    if not grippers or any(g not in _ARMS for g in grippers):
        raise DesignatorError(
            f"{d.short()}: gripper must be 'left', 'right' or ('left', 'right'), got {value!r}",
            d,
        )
    return value  # type: ignore[no-any-return]


def going(d: Designator) -> Iterator[MotionCommand]:
    pose = d.get("pose")
    target = d.get("target")
    if pose is None and target is None:
        raise DesignatorError(
            f"{d.short()} needs a pose or target property, e.g. "
            "a.motion(type='going', pose=executive.Pose((x, y, 0)))",
            d,
        )
    goal = _pose_like(d, "pose", pose) if pose is not None else _pose_like(d, "target", target)
    args: dict[str, Any] = {"pose": goal}
    speed = _number(d, "speed", required=False, minimum=0.0)
    if speed == 0.0:
        raise DesignatorInputError(f"{d.short()}: speed must be > 0 (m/s), got 0", d)
    if speed is not None:
        args["speed"] = speed
    yield MotionCommand("move-base", args)


def moving_torso(d: Designator) -> Iterator[MotionCommand]:
    yield MotionCommand("move-torso", {"joint_angle": _number(d, "joint-angle")})


def looking(d: Designator) -> Iterator[MotionCommand]:
    for key in ("pose", "target"):
        value = d.get(key)
        if value is not None:
            yield MotionCommand("move-head", {"pose": _pose_like(d, key, value)})
            return
    obj = d.get("object")
    if obj is not None:
        if not isinstance(obj, Designator) or obj.kind != "object":
            raise DesignatorError(f"{d.short()}: object must be an object designator", d)
        pose = obj.current().get("pose")
        if not isinstance(pose, Pose):
            raise DesignatorError(
                f"{d.short()}: the object {obj.short()} has no pose; perceive it first", d
            )
        yield MotionCommand("move-head", {"pose": pose})
        return
    frame = d.get("frame")
    if frame is not None:
        if not isinstance(frame, str):
            raise DesignatorError(f"{d.short()}: frame must be a frame name, got {frame!r}", d)
        yield MotionCommand("move-head", {"frame": frame})
        return
    direction = d.get("direction")
    if direction is not None:
        if direction != "forward":
            raise DesignatorError(
                f"{d.short()}: the only direction is 'forward', got {direction!r}", d
            )
        yield MotionCommand("move-head", {"direction": direction})
        return
    states = d.get("joint-states")
    if states is not None:
        yield MotionCommand("move-head", {"joint_states": states})
        return
    raise DesignatorError(
        f"{d.short()} needs one of pose, target, object, frame, direction or joint-states", d
    )


def detecting(d: Designator) -> Iterator[MotionCommand]:
    obj = d.get("object")
    if not isinstance(obj, Designator) or obj.kind != "object":
        raise DesignatorError(
            f"{d.short()} needs an object property holding an object designator, e.g. "
            "a.motion(type='detecting', object=an.object(type='cup'))",
            d,
        )
    yield MotionCommand("detect", {"object": obj.current()})


def _open_close(action: str) -> Any:
    def rule(d: Designator) -> Iterator[MotionCommand]:
        yield MotionCommand("move-gripper-joint", {"action": action, "gripper": _gripper(d)})

    rule.__name__ = rule.__qualname__ = f"{action}_gripper"
    return rule


def gripping(d: Designator) -> Iterator[MotionCommand]:
    args: dict[str, Any] = {"action": "grip", "gripper": _gripper(d)}
    effort = _number(d, "effort", required=False, minimum=0.0)
    if effort is not None:
        args["effort"] = effort
    yield MotionCommand("move-gripper-joint", args)


def moving_gripper_joint(d: Designator) -> Iterator[MotionCommand]:
    angle = _number(d, "joint-angle")
    yield MotionCommand(
        "move-gripper-joint", {"action": "angle", "gripper": _gripper(d), "joint_angle": angle}
    )


def moving_tcp(d: Designator) -> Iterator[MotionCommand]:
    sides: dict[str, Pose | None] = {}
    for side in _ARMS:
        value = d.get(f"{side}-pose")
        if value is None:
            value = d.get(f"{side}-target")
        sides[side] = None if value is None else _pose_like(d, f"{side}-pose", value)
    if sides["left"] is None and sides["right"] is None:
        raise DesignatorError(f"{d.short()} needs a left-pose or a right-pose property", d)
    yield MotionCommand(
        "move-tcp",
        {"left": sides["left"], "right": sides["right"], "collision_mode": d.get("collision-mode")},
    )


def moving_arm_joints(d: Designator) -> Iterator[MotionCommand]:
    sides: dict[str, tuple[float, ...] | None] = {}
    for side in _ARMS:
        value = d.get(f"{side}-joint-states")
        if value is None:
            value = d.get(f"{side}-configuration")
        if value is not None:
            if not isinstance(value, tuple) or not all(
                isinstance(v, (int, float)) and not isinstance(v, bool) for v in value
            ):
                raise DesignatorError(
                    f"{d.short()}: {side}-joint-states must be a list of joint values, got "
                    f"{value!r}",
                    d,
                )
            value = tuple(float(v) for v in value)
        sides[side] = value
    if sides["left"] is None and sides["right"] is None:
        raise DesignatorError(
            f"{d.short()} needs a left-joint-states or a right-joint-states property", d
        )
    yield MotionCommand("move-joints", {"left": sides["left"], "right": sides["right"]})


def perceived_object(d: Designator) -> Iterator[ObjectData]:
    """Fallback for every object designator: one that carries a pose (it was perceived, or
    the pose was given) resolves to its :class:`ObjectData`; one without yields nothing."""
    pose = d.get("pose")
    if isinstance(pose, Pose):
        known = {"name", "type", "pose", "transform"}
        yield ObjectData(
            name=d.get("name"),
            type=d.get("type"),
            pose=pose,
            transform=d.get("transform"),
            extra={k: v for k, v in d.properties if k not in known},
        )


# -------------------------------------------------------------------- documentation
# What each motion reads, and what the process modules that execute it raise: the
# generated designator reference (aiocram reference) is built from these docs, and the
# keys declared here are the keys a motion designator may have.
_POSE = "executive.Pose or location designator"
_GRIPPER = Key(
    "gripper", "'left' | 'right' | ('left', 'right')", "the gripper(s) to move", required=True
)
_ARM_FAILURES = (ManipulationPoseUnreachable, ManipulationGoalNotReached)
_GRIPPER_FAILURES = (GripperClosedCompletely, GripperGoalNotReached)


def _tcp_key(side: str) -> Key:
    return Key(f"{side}-pose", _POSE, f"the {side} tool frame's goal", default="arm stays")


def _tcp_alias(side: str) -> Key:
    return Key(f"{side}-target", _POSE, f"CRAM HEAD's name of {side}-pose", default="-")


def _joints_key(side: str) -> Key:
    return Key(
        f"{side}-joint-states",
        "joint values (rad), one per arm joint",
        f"the {side} arm's joints",
        default="arm stays",
    )


def _joints_alias(side: str) -> Key:
    return Key(
        f"{side}-configuration",
        "joint values (rad), one per arm joint",
        f"alias of {side}-joint-states",
        default="-",
    )


_DOCS: Final = MappingProxyType(
    {
        "going": RuleDoc(
            "Drive the base to a pose (map); command move-base.",
            keys=(
                Key("pose", _POSE, "the base goal (z = 0)", default="target"),
                Key("target", _POSE, "CRAM HEAD's name of pose", default="-"),
                Key("speed", "number (m/s)", "speed limit", default="the controller's"),
            ),
            raises=(NavigationPoseUnreachable, NavigationGoalNotReached),
            note="One of pose or target is required.",
        ),
        "moving-torso": RuleDoc(
            "Set the torso height; command move-torso.",
            keys=(Key("joint-angle", "number (m)", "torso lift joint position", required=True),),
            raises=(TorsoGoalNotReached,),
        ),
        "looking": RuleDoc(
            "Point the head (pan/tilt); command move-head.",
            keys=(
                Key("pose", _POSE, "the point to look at", default="target"),
                Key("target", _POSE, "CRAM HEAD's name of pose", default="-"),
                Key("object", "object designator (perceived)", "look at its pose", default="-"),
                Key("frame", "frame name", "look at the frame's origin", default="-"),
                Key("direction", "'forward'", "look straight ahead", default="-"),
                Key("joint-states", "(pan, tilt) (rad)", "set the head joints", default="-"),
            ),
            raises=(PtuGoalNotReached,),
            note="Exactly one of the keys is used, in the order listed.",
        ),
        "detecting": RuleDoc(
            "Perceive the object from where the robot stands, without moving; command detect. "
            "Returns the perceived object designator(s).",
            keys=(Key("object", "object designator", "what to find (type, name)", required=True),),
            raises=(PerceptionObjectNotFound,),
        ),
        "opening-gripper": RuleDoc(
            "Open the gripper fully; command move-gripper-joint (open).",
            keys=(_GRIPPER,),
            raises=_GRIPPER_FAILURES,
        ),
        "opening": RuleDoc(
            "CRAM HEAD's name of opening-gripper.", keys=(_GRIPPER,), raises=_GRIPPER_FAILURES
        ),
        "closing-gripper": RuleDoc(
            "Close the gripper fully; command move-gripper-joint (close).",
            keys=(_GRIPPER,),
            raises=_GRIPPER_FAILURES,
        ),
        "closing": RuleDoc(
            "CRAM HEAD's name of closing-gripper.", keys=(_GRIPPER,), raises=_GRIPPER_FAILURES
        ),
        "gripping": RuleDoc(
            "Close the gripper on an object; fails if it closes on nothing; command "
            "move-gripper-joint (grip).",
            keys=(_GRIPPER, Key("effort", "number (Nm)", "grip effort", default="the driver's")),
            raises=_GRIPPER_FAILURES,
        ),
        "moving-gripper-joint": RuleDoc(
            "Set the gripper opening; command move-gripper-joint (angle).",
            keys=(_GRIPPER, Key("joint-angle", "number (m)", "the opening", required=True)),
            raises=_GRIPPER_FAILURES,
        ),
        "moving-tcp": RuleDoc(
            "Move the tool frame(s) to poses (IK); command move-tcp. A held object that falls "
            "out on the way is a gripper failure.",
            keys=(
                _tcp_key("left"),
                _tcp_key("right"),
                _tcp_alias("left"),
                _tcp_alias("right"),
                Key(
                    "collision-mode",
                    "None | 'allow-hand' | 'allow-all'",
                    "CRAM's collision mode, passed to the process module (the projection "
                    "ignores it, as CRAM HEAD did)",
                    default="None",
                ),
            ),
            raises=(*_ARM_FAILURES, GripperClosedCompletely),
            note="At least one of left-pose and right-pose is required.",
        ),
        "moving-arm-joints": RuleDoc(
            "Set the arm joints; command move-joints.",
            keys=(
                _joints_key("left"),
                _joints_key("right"),
                _joints_alias("left"),
                _joints_alias("right"),
            ),
            raises=(*_ARM_FAILURES, GripperClosedCompletely),
            note="At least one arm's joints are required.",
        ),
    }
)

for _type, _fn in (
    ("going", going),
    ("moving-torso", moving_torso),
    ("looking", looking),
    ("detecting", detecting),
    ("opening-gripper", _open_close("open")),
    ("opening", _open_close("open")),
    ("closing-gripper", _open_close("close")),
    ("closing", _open_close("close")),
    ("gripping", gripping),
    ("moving-gripper-joint", moving_gripper_joint),
    ("moving-tcp", moving_tcp),
    ("moving-arm-joints", moving_arm_joints),
):
    # keys declared (by the doc): a motion with a key no rule reads fails to resolve
    builtin_rules.register("motion", _type, _fn, doc=_DOCS[_type])
builtin_rules.register(
    "object",
    WILDCARD,
    perceived_object,
    priority=1000,
    doc=RuleDoc(
        "Fallback for every object designator: one that carries a pose (it was perceived, "
        "or the pose was given) resolves to its ObjectData; one without has no solution.",
        keys=(
            Key("pose", "executive.Pose", "where the object is", default="no solution"),
            Key("name", "str", "the object's name in the world", default="-"),
            Key("type", "str", "the object type", default="-"),
            Key("transform", "executive.Transform", "base -> object when perceived", default="-"),
        ),
        note="Every other key is kept in ObjectData.extra.",
        any_key=True,
    ),
)


_BASE = (Resource.base(),)
_TORSO = (Resource.torso(),)
_HEAD = (Resource.head(),)
_ARM = {side: Resource.arm(side) for side in _ARMS}
_GRIPPER_PART = {side: Resource.gripper(side) for side in _ARMS}


def _grippers(args: Any) -> tuple[Resource, ...]:
    value = args["gripper"]
    return tuple(_GRIPPER_PART[g] for g in ((value,) if isinstance(value, str) else value))


def _arms(args: Any) -> tuple[Resource, ...]:
    return tuple(_ARM[side] for side in _ARMS if args.get(side) is not None)


for _command, _uses in (
    ("move-base", lambda _args: _BASE),
    ("move-torso", lambda _args: _TORSO),
    ("move-head", lambda _args: _HEAD),
    ("detect", lambda _args: _HEAD),
    ("move-gripper-joint", _grippers),
    ("move-tcp", _arms),
    ("move-joints", _arms),
):
    builtin_rules.register_resources(_command, _uses)
