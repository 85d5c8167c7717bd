"""Kitchen descriptions as data: what the plans may know about the environment the robot
works in (the parts of it that CRAM's demo names in designators: ``urdf-name``), and the
demo scene laid out in it, as one typed frozen record.

A :class:`KitchenDescription` names the kitchen's parts by the role the plans give them:
the surface where the demo's objects start, the surface where the table is set, the
:class:`ContainerDescription` of the container that holds an object at the start (its
link, joint, handle and how far the demo opens it), the floor height, and the demo scene
(object types in the order they are set, their fixed spawning poses, and which start
attached to a kitchen link). Everything kitchen-specific lives in such a record, in a
module beside the kitchen's URDF (the top-level ``kitchens`` package); nothing here or in
``plans`` names a kitchen link. Plans read the record from the environment
(:attr:`executive.Environment.kitchen`), as they read the robot's.

Constructing a record checks it (non-empty names, a positive opening, a demo pose for
every demo object and only for those, attachments only of demo objects) and raises
:class:`KitchenDescriptionError` naming the field and what to fix;
:meth:`KitchenDescription.validate` checks it against the kitchen's
:class:`executive.KinematicTree` (every named link and the container's joint exist, the
joint moves the container), before any world loads.

Deliberate difference from CRAM: CRAM's demo spells the kitchen's link names
(``sink_area_surface``, ``kitchen_island_surface``, the drawer) in its plan code and its
spawning poses in the demo file; here they are one value the environment carries, so the
plans run unchanged in another kitchen that describes the same roles.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import TYPE_CHECKING

from ._pose import Pose

if TYPE_CHECKING:
    from ._robot import KinematicTree

__all__ = ["ContainerDescription", "KitchenDescription", "KitchenDescriptionError"]


class KitchenDescriptionError(ValueError):
    """A kitchen description that is not well-formed. Fields: ``kitchen`` (the
    description's name), ``field`` (where in the description, e.g. ``demo_poses``). The
    message says what is wrong and what to fix."""

    def __init__(self, kitchen: str, field: str, problem: str) -> None:
        super().__init__(f"kitchen description {kitchen!r}: {field}: {problem}")
        self.kitchen = kitchen
        self.field = field


def _name(kitchen: str, where: str, value: object) -> None:
    if not isinstance(value, str) or not value:
        raise KitchenDescriptionError(
            kitchen, where, f"must be a non-empty link or joint name, got {value!r}"
        )


@dataclass(frozen=True)
class ContainerDescription:
    """A container of the kitchen the plans open and close (CRAM's drawer under the sink).
    ``link``: its moving link (designators' ``urdf-name``); ``joint``: the joint that
    opens it; ``handle``: the link the gripper grasps; ``opening``: how far (m, > 0) the
    demo's transports open it (CRAM's accessing distance; the scene places what the
    container holds where it is reachable then)."""

    link: str
    joint: str
    handle: str
    opening: float


@dataclass(frozen=True)
class KitchenDescription:
    """What the plans and the world know of one kitchen (see the module docstring).

    ``name``: the kitchen's body in the world (designators say ``part-of`` it).
    ``start_surface``: the link of the surface the demo's objects start on (CRAM's sink
    counter top). ``table_surface``: the link of the surface where the table is set (CRAM's
    kitchen island top). ``container``: the container the demo opens (CRAM's drawer).
    ``floor_height``: below this height (m) an object's centre lies on the floor.
    ``demo_objects``: the demo's object types, in the order they are set (CRAM's: the bowl
    first; the others are placed relative to it). ``demo_poses``: each demo object's fixed
    spawning pose in ``map``, in the order the fixed scene spawns them. ``demo_attachments``:
    demo objects that start attached to a kitchen link (object type -> link)."""

    name: str
    start_surface: str
    table_surface: str
    container: ContainerDescription
    floor_height: float
    # invariant (checked below): demo_poses has exactly the demo_objects' types, and
    # demo_attachments only demo objects; both are read-only mappings
    demo_objects: tuple[str, ...]
    demo_poses: Mapping[str, Pose]
    demo_attachments: Mapping[str, str]

    def __post_init__(self) -> None:
        k = self.name
        if not isinstance(k, str) or not k:
            raise KitchenDescriptionError(str(k), "name", "must be a non-empty string")
        _name(k, "start_surface", self.start_surface)
        _name(k, "table_surface", self.table_surface)
        c = self.container
        if not isinstance(c, ContainerDescription):
            raise KitchenDescriptionError(
                k, "container", f"must be an executive.ContainerDescription, got {c!r}"
            )
        for part in ("link", "joint", "handle"):
            _name(k, f"container.{part}", getattr(c, part))
        if not isinstance(c.opening, (int, float)) or not (
            math.isfinite(c.opening) and c.opening > 0
        ):
            raise KitchenDescriptionError(
                k, "container.opening", f"must be a distance > 0 (m), got {c.opening!r}"
            )
        if not isinstance(self.floor_height, (int, float)) or not math.isfinite(self.floor_height):
            raise KitchenDescriptionError(
                k, "floor_height", f"must be a finite height (m), got {self.floor_height!r}"
            )
        objects = tuple(self.demo_objects)
        object.__setattr__(self, "demo_objects", objects)
        poses = MappingProxyType(dict(self.demo_poses))
        object.__setattr__(self, "demo_poses", poses)
        attachments = MappingProxyType(dict(self.demo_attachments))
        object.__setattr__(self, "demo_attachments", attachments)
        if len(set(objects)) != len(objects):
            raise KitchenDescriptionError(k, "demo_objects", f"lists a type twice: {list(objects)}")
        bad = [p for p in poses.values() if not isinstance(p, Pose)]
        if bad:
            raise KitchenDescriptionError(
                k, "demo_poses", f"values must be executive.Pose, got {bad[0]!r}"
            )
        if set(poses) != set(objects) or not set(attachments) <= set(objects):
            # a newcomer's half-added object: say which row is missing
            raise KitchenDescriptionError(
                k,
                "demo_poses",
                "every type in demo_objects needs its pose in demo_poses (and only those): "
                f"missing {sorted(set(objects) - set(poses))}, extra "
                f"{sorted((set(poses) | set(attachments)) - set(objects))}",
            )

    def validate(self, tree: KinematicTree) -> None:
        """Check the description against the kitchen's URDF tree: every link it names
        exists, and ``container.joint`` is a joint that moves ``container.link``. Raises
        :class:`KitchenDescriptionError` naming the field, with a did-you-mean."""
        links = {
            "start_surface": self.start_surface,
            "table_surface": self.table_surface,
            "container.link": self.container.link,
            "container.handle": self.container.handle,
            **{f"demo_attachments[{t!r}]": link for t, link in self.demo_attachments.items()},
        }
        for where, link in links.items():
            if link not in tree.links:
                raise KitchenDescriptionError(
                    self.name,
                    where,
                    f"no link {link!r} in the kitchen's URDF{_near(link, tree.links)}",
                )
        joint = tree.joints.get(self.container.joint)
        if joint is None:
            raise KitchenDescriptionError(
                self.name,
                "container.joint",
                f"no joint {self.container.joint!r} in the kitchen's URDF"
                f"{_near(self.container.joint, frozenset(tree.joints))}",
            )
        if joint.child != self.container.link:
            raise KitchenDescriptionError(
                self.name,
                "container.joint",
                f"{self.container.joint!r} moves {joint.child!r}, not the container's link "
                f"{self.container.link!r}",
            )


def _near(name: str, known: frozenset[str]) -> str:
    close = difflib.get_close_matches(name, sorted(known), n=3, cutoff=0.6)
    return f" (did you mean {', '.join(map(repr, close))}?)" if close else ""
