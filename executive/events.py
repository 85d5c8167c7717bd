"""World events (CRAM's ``cram_occasions_events``): typed, frozen records that plans emit
when they change the world, and that the environment's world model and subscribers receive.

``emit(event)`` delivers to the current environment: first its world model's
``handle_event`` (so subscribers see the updated belief state), then every callback
subscribed to the event's class or a base class, synchronously, in subscription order.
Outside any environment ``emit`` does nothing and ``subscribe`` raises ``RuntimeError``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, TypeVar

from ._environment import current_environment

__all__ = [
    "ContainerClosed",
    "ContainerOpened",
    "Event",
    "ObjectAttached",
    "ObjectDetached",
    "ObjectPerceived",
    "RobotStateChanged",
    "emit",
    "object_name",
    "subscribe",
]

E = TypeVar("E", bound="Event")


@dataclass(frozen=True, slots=True)
class Event:
    """Base class of every event."""

    cram_name = "event"


@dataclass(frozen=True, slots=True)
class ObjectAttached(Event):
    """``object`` (a designator or a name) is now rigidly held by ``arm``'s ``link``."""

    object: Any
    arm: str
    link: str | None = None
    cram_name = "object-attached"


@dataclass(frozen=True, slots=True)
class ObjectDetached(Event):
    """``object`` was released by ``arm``."""

    object: Any
    arm: str
    link: str | None = None
    cram_name = "object-detached"


@dataclass(frozen=True, slots=True)
class ObjectPerceived(Event):
    """Perception produced ``designator`` (an object designator with a pose)."""

    designator: Any
    cram_name = "object-perceived"


@dataclass(frozen=True, slots=True)
class RobotStateChanged(Event):
    """The robot moved (in projection this only advances the timeline)."""

    reason: str | None = None
    cram_name = "robot-state-changed"


@dataclass(frozen=True, slots=True)
class ContainerOpened(Event):
    """``container`` (a designator or a name) was opened by ``distance`` (metres/radians)."""

    container: Any
    distance: float
    cram_name = "container-opening-event"


@dataclass(frozen=True, slots=True)
class ContainerClosed(Event):
    """``container`` was closed by ``distance``."""

    container: Any
    distance: float
    cram_name = "container-closing-event"


def object_name(obj: Any) -> str:
    """The name of an object given as a name or as a designator with a ``name`` (or
    ``urdf-name``) property; ``ValueError`` if it has none."""
    if isinstance(obj, str):
        return obj
    get = getattr(obj, "get", None)
    if get is not None:
        current = getattr(obj, "current", None)
        desig = current() if current is not None else obj
        for key in ("name", "urdf-name"):
            name = desig.get(key)
            if isinstance(name, str):
                return name
    raise ValueError(f"{obj!r} names no object: give a name or a designator with name=...")


def subscribe(event_type: type[E], callback: Callable[[E], Any]) -> Callable[[], None]:
    """Subscribe ``callback`` to events of ``event_type`` in the current environment.
    Returns a function that unsubscribes."""
    return current_environment().subscribe(event_type, callback)


def emit(event: Event) -> None:
    """Deliver ``event`` in the current environment (world model first, then subscribers).
    ``TypeError`` if ``event`` is not an :class:`Event`."""
    if not isinstance(event, Event):
        raise TypeError(f"emit() needs an executive.events.Event, got {event!r}")
    current_environment().emit(event)
