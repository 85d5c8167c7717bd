"""Designator helpers shared by the action rules of the navigation, search, fetch, deliver,
transport and environment-access plans: the robot's name in location designators, and
the checks that turn a missing or malformed property into a ``DesignatorError`` raised by
the rule (before anything moves).
"""

from __future__ import annotations

from typing import Any

from executive import (
    Designator,
    DesignatorError,
    DesignatorInputError,
    LocationDesignator,
    ObjectDesignator,
    Pose,
    current_environment,
)

from ._common import as_location

__all__ = ["ROBOT"]


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
            if isinstance(place, str):  # (on "name"): a link or an object of the world
                link = place
                if link in getattr(world, "objects", ()):
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


def _object(d: Designator) -> ObjectDesignator:
    value = d.get("object")
    if not isinstance(value, ObjectDesignator):
        raise DesignatorError(f"{d.short()} needs an object designator", d)
    return value
