"""The kitchen both sides know: names of the kitchen's links and joints that plans refer
to, and CRAM's demo scene (object types and their fixed spawning poses).

Plans name the kitchen's parts through these constants (in designators: ``urdf-name``),
and :mod:`projection` builds its kitchen and its demo scene from the same ones, so a
renamed link or a moved demo pose changes in one place.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from types import MappingProxyType

from executive._pose import Pose

__all__ = [
    "DEMO_ATTACHMENTS",
    "DEMO_OBJECTS",
    "DEMO_POSES",
    "DRAWER_HANDLE",
    "DRAWER_JOINT",
    "DRAWER_LINK",
    "DRAWER_OPENING",
    "FLOOR_HEIGHT",
    "ISLAND_SURFACE",
    "SINK_SURFACE",
]

#: The sink counter's top (where CRAM's demo objects start).
SINK_SURFACE = "sink_area_surface"
#: The kitchen island's top (where the table is set).
ISLAND_SURFACE = "kitchen_island_surface"
#: The drawer under the sink counter (the spoon's container) and its prismatic joint.
DRAWER_LINK = "sink_area_left_upper_drawer_main"
DRAWER_JOINT = f"{DRAWER_LINK}_joint"
#: The drawer's handle (the gripper grasps it to open and close the drawer).
DRAWER_HANDLE = "sink_area_left_upper_drawer_handle"
#: How far (m) the demo's transports open a drawer (CRAM's accessing distance, 0.3 m): the
#: plans open it by this much, and the scene places the spoon where it is reachable then.
DRAWER_OPENING = 0.3

#: The demo's object types, in the order the demo sets them (CRAM's: the bowl first, the
#: cup, spoon and milk targets are placed relative to it). **The one list of demo
#: objects**: a newcomer adds an object here, with its row in :data:`DEMO_POSES` (and
#: :data:`DEMO_ATTACHMENTS` if it starts in a container); ``aiocram demo``, the campaign,
#: :func:`projection.set_up_scene` and :func:`projection.make_world_pair` derive from
#: them (a random scene samples a new type in CRAM's spawning region unless
#: :data:`projection._scene.SPAWN_REGIONS` narrows it).
DEMO_OBJECTS: tuple[str, ...] = ("bowl", "cup", "spoon", "milk", "breakfast-cereal")
#: CRAM's fixed spawning poses of the demo's objects (map), in the order its fixed scene
#: spawns them (:func:`projection.make_world_pair` keeps it).
DEMO_POSES: Mapping[str, Pose] = MappingProxyType(
    {
        "breakfast-cereal": Pose((1.4, 0.4, 0.85)),
        "cup": Pose((1.3, 0.6, 0.9)),
        "bowl": Pose((1.4, 0.8, 0.87)),
        "milk": Pose.from_xyz_yaw(1.4, 0.62, 0.95, math.pi),
        "spoon": Pose.from_xyz_yaw(1.4, 1.0, 0.74132, math.pi),
    }
)
#: Demo objects that start attached to a kitchen link (the spoon lies in the drawer).
DEMO_ATTACHMENTS: Mapping[str, str] = MappingProxyType({"spoon": DRAWER_LINK})
if set(DEMO_POSES) != set(DEMO_OBJECTS) or not set(DEMO_ATTACHMENTS) <= set(DEMO_OBJECTS):
    raise ImportError(  # a newcomer's half-added object: say which row is missing
        "executive.kitchen: every type in DEMO_OBJECTS needs its pose in DEMO_POSES (and "
        "only those): missing "
        f"{sorted(set(DEMO_OBJECTS) - set(DEMO_POSES))}, extra "
        f"{sorted((set(DEMO_POSES) | set(DEMO_ATTACHMENTS)) - set(DEMO_OBJECTS))}"
    )

#: Below this height (m) an object's centre lies on the floor (every counter top is at
#: 0.85 m or more; an object lying on the floor has its centre a few cm up).
FLOOR_HEIGHT = 0.3
