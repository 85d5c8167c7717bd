"""Designator helpers shared by the action rules of the navigation, search, fetch, deliver,
transport and environment-access plans: the robot's name in location designators, and
the checks that turn a missing or malformed property into a ``DesignatorError`` raised by
the rule (before anything moves).

The robot's name in ``reachable-for`` / ``visible-for`` is read from the environment's
robot description (:func:`robot_name`) when the plan builds the location designator, as
CRAM's plans do (``(rob-int:current-robot-name)`` inside the plan body, e.g. fetching's
``(a location (reachable-for ,robot-name) ...)``): the same plan code drives whichever
robot the environment carries, and a designator, once built, names the robot it was built
for (its resolution and the recorded task tree say which robot it was).
"""

from __future__ import annotations

import difflib
import inspect
from collections.abc import Callable
from typing import Any

from executive import (
    Designator,
    DesignatorError,
    DesignatorInputError,
    LocationDesignator,
    ObjectDesignator,
    ObjectInventory,
    Pose,
    WorldQueries,
    current_environment,
    knowledge,
)

from ._common import arm_names, as_location, the_robot

__all__ = ["default_of", "learned_base", "robot_name"]


def robot_name() -> str:
    """The robot's name for ``reachable-for`` / ``visible-for`` location designators: the
    current environment's robot description's :attr:`~executive.RobotDescription.name`
    (none -> :class:`executive.NoRobotDescription` naming the fix)."""
    return the_robot().name


def default_of(fn: Callable[..., Any], parameter: str) -> int:
    """The default of ``fn``'s integer ``parameter`` (a check's or plan's retry budget), so
    a rule's :class:`executive.RuleDoc` states the count the code uses."""
    default = inspect.signature(fn).parameters[parameter].default
    if isinstance(default, bool) or not isinstance(default, int):
        raise TypeError(f"{fn.__qualname__}({parameter}=...) has no integer default")
    return default


def learned_base(action: str, obj: ObjectDesignator) -> dict[str, Any]:
    """``{"experience": (action, type)}`` for a ``reachable-for`` base location when the
    environment carries :class:`executive.Preferences` (learned priors) and the object's
    type is known; else ``{}``, so without preferences the designator is as it always was."""
    if current_environment().preferences is None:
        return {}
    otype = obj.current().get("type")
    return {"experience": (action, otype)} if isinstance(otype, str) and otype else {}


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
    moved (deliberate addition: CRAM checked nothing up front). An environment without a
    world model (``Environment.has_world`` false), or with one that cannot answer link
    queries (not an :class:`executive.WorldQueries`), has nothing to check against: the
    check is skipped and the plan finds out when it gets there."""
    env = current_environment()
    if not env.has_world:
        return
    world = env.world
    if not isinstance(world, WorldQueries):
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
            if isinstance(place, str):  # (on "name"): a link or an object of the world
                link = place
                if isinstance(world, ObjectInventory) and link in world.object_names():
                    continue
            elif isinstance(place, ObjectDesignator):
                link = place.get("urdf-name")
                if not isinstance(link, str):
                    continue
            else:
                continue
            try:
                world.link_pose(link)
            except LookupError as exc:
                raise DesignatorInputError(
                    f"{d.short()}: its {key} is ({relation} ...) {link!r}, which this world "
                    f"does not have ({exc})",
                    d,
                ) from None
        stack.extend((key, v) for k, v in value.properties if isinstance(v, LocationDesignator))


def _given_arm(d: Designator, default: str | None = None) -> str | None:
    """``d``'s ``arm`` (``default`` when absent), checked by the action's own rule: an
    unknown arm is a :class:`executive.DesignatorInputError` naming ``d`` and the known
    arms (it used to surface from an inner ``setting-gripper`` action, after the robot had
    driven and reached)."""
    arm = d.get("arm", default)
    if arm is not None:
        known = arm_names()
        if arm not in known:
            raise DesignatorInputError(
                f"{d.short()}: unknown arm {arm!r}; known arms: {', '.join(known)}", d
            )
    return None if arm is None else str(arm)


def _object(d: Designator) -> ObjectDesignator:
    """``d``'s object designator. Its type, if given, must be one the robot knows (object
    knowledge, or the type of an object of the environment's world): a misspelt type
    (``bwol``) is a :class:`executive.DesignatorInputError` naming the known types, raised
    by the rule before anything moves (it used to drive, turn and look ten times, then
    fail as object-nowhere-to-be-found)."""
    value = d.get("object")
    if not isinstance(value, ObjectDesignator):
        raise DesignatorError(f"{d.short()} needs an object designator", d)
    object_type = value.current().get("type")
    if object_type is not None:
        known = _known_object_types()
        if object_type not in known:
            close = difflib.get_close_matches(str(object_type), known, n=3, cutoff=0.5)
            hint = f"did you mean {', '.join(close)}? " if close else ""
            raise DesignatorInputError(
                f"{d.short()}: unknown object type {object_type!r}; {hint}"
                f"known types: {', '.join(known)}",
                d,
            )
    return value


def _known_object_types() -> list[str]:
    """Object knowledge's types and the types of the world model's objects (where it can
    list them: :class:`executive.ObjectInventory`), sorted."""
    types = set(knowledge.known_types())
    env = current_environment()
    world = env.world if env.has_world else None
    if isinstance(world, ObjectInventory) and isinstance(world, WorldQueries):
        for name in world.object_names():
            try:
                types.add(world.object_type(name))
            except LookupError:
                continue
    return sorted(types)
