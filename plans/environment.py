"""Opening and closing containers (CRAM's ``cram_pr2_environment_manipulation``).

``opening``/``closing (object C) (arm A)? (distance d)?`` for a drawer designator ``C``
(``urdf-name`` of its main link, e.g. ``sink_area_left_upper_drawer_main``): the gripper
takes the handle link (the kitchen's :attr:`executive.ContainerDescription.handle` for
the container it describes, else CRAM's naming: the ``_main`` suffix replaced by
``_handle``; its pose from the world model's ``link_pose``) approaching along the handle
frame's +x axis, and the drawer opens along the handle frame's -x axis. Waypoints, in
``base_footprint`` when the action is referenced (after navigating): pregrasp (0.10 m
before the handle), grasp, the handle moved by the distance (pulled or pushed), and a
retreat 0.10 m further. Both claim the arm and gripper they use for their duration
(:func:`executive.register_resources`).
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from types import MappingProxyType
from typing import Any, Final

import numpy as np

import cpl
from executive import (
    ContainerStates,
    Designator,
    DesignatorError,
    GripperLowLevelFailure,
    Key,
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
)
from executive.events import ContainerClosed, ContainerOpened

from ._common import arm_description, arm_names, base_frame, hand_of, perform_ignoring

__all__ = ["DEFAULT_DISTANCE", "close_container", "handle_link", "open_container"]

#: How far accessing/sealing move a drawer (CRAM's accessing distance, 0.3 m). The
#: kitchen's description says how far its demo opens its container
#: (:attr:`executive.ContainerDescription.opening`, by which the scene places the spoon);
#: tests/plans/test_plans_read_the_kitchen.py checks the projection's kitchen agrees.
DEFAULT_DISTANCE = 0.3
_PREGRASP = 0.10
#: The standard gripper's rotation on the handle (approaching along the handle's +x); the
#: arm's tool frame is this combined with its ``standard_to_tool``.
_HANDLE_STANDARD = np.array(knowledge.STANDARD_ROTATIONS["back"])


def handle_link(container: Designator) -> str:
    """The handle link of a drawer designator: the handle the environment's kitchen
    description gives for it (:attr:`executive.KitchenDescription.container`), else CRAM's
    naming (``..._main`` -> ``..._handle``) for a container it does not describe."""
    name = container.get("urdf-name")
    if not isinstance(name, str):
        raise DesignatorError(f"{container.short()} needs a urdf-name (its main link)", container)
    kitchen = current_environment().world.kitchen
    if kitchen is not None and name == kitchen.container.link:
        return kitchen.container.handle
    return name.removesuffix("_main") + "_handle"


def _arm(d: Designator, action_type: str) -> str:
    arm = d.get("arm", "left")
    known = arm_names()
    if arm not in known:
        raise DesignatorError(f"{d.short()}: arm must be one of {known}", d)
    return str(arm)


def _waypoints(handle: Pose, opening: bool, distance: float, arm: str) -> tuple[Pose, ...]:
    sign = -1.0 if opening else 1.0
    b_t_h = handle.matrix()
    tool = _HANDLE_STANDARD @ np.array(arm_description(arm).standard_to_tool)
    out = []
    for offset in (-_PREGRASP, 0.0, sign * distance, sign * distance - _PREGRASP):
        m = np.eye(4)
        m[:3, :3] = tool
        m[0, 3] = offset
        out.append(Transform.from_matrix(b_t_h @ m, handle.frame).to_pose())
    return tuple(out)


def _arm_action(action_type: str, arm: str, poses: Sequence[Pose]) -> Designator:
    return an.action(type=action_type, **{f"{arm}_poses": tuple(poses)})


@cpl.plan(name="open-container")
async def open_container(
    container: ObjectDesignator, arm: str, distance: float, waypoints: Sequence[Pose], opening: bool
) -> None:
    """Open the drawer: par(set the gripper open, reach the pregrasp); grasp the handle;
    close the gripper; pull; ``ContainerOpened(container, distance)``; release; retract.

    Reach and grasp failures propagate (manipulation low-level); closing, pull, release
    and retract failures are ignored. Deliberate difference from CRAM's ``gripping``: the
    projection's grip test only counts contacts with items, not kitchen links, so a
    ``gripping`` of the handle always fails there."""
    pre, at, pulled, away = waypoints
    widest = arm_description(arm).gripper.max_opening
    await cpl.par(
        cpl.tag("open", perform(an.action(type="setting-gripper", gripper=arm, position=widest))),
        cpl.tag("reach", perform(_arm_action("reaching", arm, [pre]))),
    )
    await perform(_arm_action("grasping", arm, [at]))
    await perform_ignoring(an.action(type="closing-gripper", gripper=arm), GripperLowLevelFailure)
    await perform_ignoring(_arm_action("pulling", arm, [pulled]), ManipulationLowLevelFailure)
    emit(ContainerOpened(container, distance))
    await perform_ignoring(an.action(type="releasing", gripper=arm), GripperLowLevelFailure)
    await perform_ignoring(_arm_action("retracting", arm, [away]), ManipulationLowLevelFailure)


@cpl.plan(name="close-container")
async def close_container(
    container: ObjectDesignator, arm: str, distance: float, waypoints: Sequence[Pose], opening: bool
) -> None:
    """Close the drawer: reach the pregrasp (propagates); touch the handle (propagates);
    push (ignored); ``ContainerClosed(container, distance)``; retract (ignored). No grip,
    as in CRAM."""
    pre, at, pushed, away = waypoints
    await perform(_arm_action("reaching", arm, [pre]))
    await perform(_arm_action("grasping", arm, [at]))
    await perform_ignoring(_arm_action("pushing", arm, [pushed]), ManipulationLowLevelFailure)
    emit(ContainerClosed(container, distance))
    await perform_ignoring(_arm_action("retracting", arm, [away]), ManipulationLowLevelFailure)


def _distance(d: Designator, container: Designator, opening: bool) -> float:
    """The ``distance`` of an opening/closing action, checked before the arm moves
    (deliberate addition): a number > 0 and, where the world model knows the container's
    joint (:class:`executive.ContainerStates`), within its travel from where it is now.
    Otherwise the plan reached for the handle first and failed (or silently stopped) at
    the limit."""
    value = d.get("distance", DEFAULT_DISTANCE)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not value > 0:
        raise DesignatorError(f"{d.short()}: distance must be a number of metres > 0", d)
    distance = float(value)
    world = current_environment().world
    name = container.get("urdf-name")
    if not isinstance(world, ContainerStates) or not isinstance(name, str):
        return distance
    try:
        position, lower, upper = world.container_state(name)
    except LookupError:
        return distance  # not a jointed container this world knows: the plan will say
    room = (upper - position) if opening else (position - lower)
    if distance > room + 1e-4:
        verb = "opened" if opening else "closed"
        raise DesignatorError(
            f"{d.short()}: {name} can be {verb} by at most {max(room, 0.0):.3f} m from "
            f"where it is ({position:.3f} m, travel {lower:.3f}..{upper:.3f} m); got "
            f"distance {distance}",
            d,
        )
    return distance


def _container_rule(action_type: str) -> Any:
    opening = action_type == "opening"

    def ground(d: Designator) -> Iterator[Any]:
        container = d.get("object")
        if not isinstance(container, ObjectDesignator):
            return
        distance = _distance(d, container, opening)
        link = handle_link(container)
        try:
            handle = current_environment().world.link_pose(link, base_frame())
        except LookupError as exc:
            raise DesignatorError(f"{d.short()}: {exc}", d) from None
        arm = _arm(d, action_type)
        yield (
            open_container if opening else close_container,
            {
                "container": container,
                "arm": arm,
                "distance": distance,
                "waypoints": _waypoints(handle, opening, distance, arm),
                "opening": opening,
            },
        )

    ground.__name__ = ground.__qualname__ = f"{action_type}_container"
    return ground


_CONTAINER_STEPS: Final = MappingProxyType(
    {
        "opening": (
            "open-container: open the gripper while reaching the handle, take it, close the "
            "gripper, pull by distance, ContainerOpened, release, retract",
            ("setting-gripper", "reaching", "grasping", "closing-gripper", "pulling", "releasing"),
        ),
        "closing": (
            "close-container: reach the handle, touch it, push by distance, ContainerClosed, "
            "retract (no grip, as in CRAM)",
            ("reaching", "grasping", "pushing"),
        ),
    }
)


def _container_doc(verb: str) -> RuleDoc:
    steps, performs = _CONTAINER_STEPS[verb]
    return RuleDoc(
        f"With an object: {verb} a drawer from where the robot stands (plan {steps}).",
        keys=(
            Key(
                "object",
                "drawer object designator with urdf-name (its main link)",
                "the drawer (no solution without it)",
                required=True,
            ),
            Key("arm", "'left' | 'right'", "the arm", default="'left'"),
            Key(
                "distance",
                "number (m) > 0",
                "how far; beyond the drawer's travel: DesignatorError before anything moves",
                default=str(DEFAULT_DISTANCE),
            ),
        ),
        raises=(ManipulationLowLevelFailure,),
        ignores=(ManipulationLowLevelFailure, GripperLowLevelFailure),
        performs=(*performs, "retracting"),
        note="Reach and grasp failures propagate; the rest is ignored. Usually performed "
        "through accessing / sealing, which navigate and check it first.",
    )


for _verb in ("opening", "closing"):
    rule("action", _verb, doc=_container_doc(_verb))(_container_rule(_verb))
for _plan in (open_container, close_container):
    register_resources(_plan, hand_of)
