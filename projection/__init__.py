"""The robot's imagination: a PyBullet world (a robot, kitchen, household objects),
CRAM's low-level projection functions, projection process modules, and costmap-based
location resolution. Implements the interfaces that :mod:`executive` defines.

The robot is any :class:`executive.RobotDescription` (``World(robot=...)``; default the
PR2-like robot of ``robots.pr2``, e.g. ``robots.panda.DESCRIPTION`` for a one-armed mobile
Panda): the world loads its URDF and reads its arms, grippers, torso, neck, camera and
reach from the description. Robot-specific names and numbers remain only in the PR2-like
robot's URDF generator (``projection._urdf``) and in a few documented PR2 defaults of
helper functions (the costmaps' shoulders and camera heights, used when no world's robot
is given).

:class:`World` (``projection._world``) is one PyBullet DIRECT client owning the robot,
the kitchen and an object registry, with CRAM's low-level functions as methods: ``drive``,
``move_torso``, ``look_at``, ``detect``, ``move_tcp``, ``move_joints``, ``park_arms``,
``gripper``, ``attach``/``detach``, ``open_container``/``close_container``, plus
``snapshot``/``restore``, collision helpers and ``placing_pose_stable``. Each raises the
typed failure of :mod:`executive.failures` and leaves the world unchanged on failure.

``async with with_projected_robot(world):`` runs a block with the six projection process
modules, a :class:`ProjectedWorldModel` (the belief state and the projection probes) and
the costmap location rules; :mod:`projection.render` draws scenes and costmaps as PNGs.

Assets (``projection/assets``: ``pr2.urdf``, ``kitchen.urdf``, ``objects/*.urdf``) are
generated from the parameter tables in ``projection._urdf`` (``python -m
projection._urdf``); object types live in ``projection._objects``, grasps in
:mod:`executive.knowledge`. Importing this package loads nothing and connects to nothing:
PyBullet is only touched when a :class:`World` is built.
"""

from __future__ import annotations

import importlib
from types import MappingProxyType
from typing import TYPE_CHECKING, Any

# Public name -> module defining it; imported on first access, so importing this package
# imports neither PyBullet nor Pillow.
_EXPORTS = MappingProxyType(
    {
        "World": "projection._world",
        "ProjectedWorldModel": "projection._world_model",
        "with_projected_robot": "projection._environment",
        "ProjectionImagination": "projection._imagination",
        "FaultProfile": "projection._real_faults",
        "RealWorldModel": "projection._real_world_model",
        "make_world_pair": "projection._scene",
        "set_up_scene": "projection._scene",
        "SceneSetUpError": "projection._scene",
        "real_robot_clock": "projection._real_clock",
        "settle": "projection._real_body",
        "with_real_robot": "projection._real_environment",
        "render": "projection.render",
        "SpawnOverlap": "projection._world_base",
        "RobotBody": "projection._robot_body",
        "kinematic_tree": "projection._robot_body",
        "load_robot": "projection._robot_body",
        "BadObjectPose": "projection._world_base",
    }
)

__all__ = [
    "BadObjectPose",
    "FaultProfile",
    "ProjectedWorldModel",
    "ProjectionImagination",
    "RealWorldModel",
    "RobotBody",
    "SceneSetUpError",
    "SpawnOverlap",
    "World",
    "kinematic_tree",
    "load_robot",
    "make_world_pair",
    "real_robot_clock",
    "render",
    "set_up_scene",
    "settle",
    "with_projected_robot",
    "with_real_robot",
]

if TYPE_CHECKING:
    from projection import render
    from projection._environment import with_projected_robot
    from projection._imagination import ProjectionImagination
    from projection._real_body import settle
    from projection._real_clock import real_robot_clock
    from projection._real_environment import with_real_robot
    from projection._real_faults import FaultProfile
    from projection._real_world_model import RealWorldModel
    from projection._robot_body import RobotBody, kinematic_tree, load_robot
    from projection._scene import SceneSetUpError, make_world_pair, set_up_scene
    from projection._world import World
    from projection._world_base import BadObjectPose, SpawnOverlap
    from projection._world_model import ProjectedWorldModel


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'projection' has no attribute {name!r}")
    from projection._quiet import import_pybullet_quietly

    import_pybullet_quietly()  # before any module here imports it: no banner on stderr
    if name == "render":
        return importlib.import_module(module)
    return getattr(importlib.import_module(module), name)
