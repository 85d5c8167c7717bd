"""The robot's imagination: a PyBullet world (PR2-like robot, kitchen, household objects),
CRAM's low-level projection functions, projection process modules, and costmap-based
location resolution. Implements the interfaces that :mod:`executive` defines.

:class:`World` (``projection._world``) is one PyBullet DIRECT client owning the robot,
the kitchen and an object registry, with CRAM's low-level functions as methods: ``drive``,
``move_torso``, ``look_at``, ``detect``, ``move_tcp``, ``move_joints``, ``park_arms``,
``gripper``, ``attach``/``detach``, ``open_container``/``close_container``, plus
``snapshot``/``restore``, collision helpers and ``placing_pose_stable``. Each raises the
typed failure of :mod:`executive.failures` and leaves the world unchanged on failure.

Assets (``projection/assets``: ``pr2.urdf``, ``kitchen.urdf``, ``objects/*.urdf``) are
generated from the parameter tables in ``projection._urdf`` (``python -m
projection._urdf``); object types live in ``projection._objects``, grasps in
:mod:`executive.knowledge`. Importing this package loads nothing and connects to nothing:
PyBullet is only touched when a :class:`World` is built.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

__all__ = ["World"]

if TYPE_CHECKING:
    from projection._world import World


def __getattr__(name: str) -> Any:
    if name == "World":
        from projection._world import World

        return World
    raise AttributeError(f"module 'projection' has no attribute {name!r}")
