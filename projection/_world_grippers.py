"""The grippers of a :class:`projection.World`: open, close, grip until contact, or an
opening in metres."""

from __future__ import annotations

from collections.abc import Sequence

import pybullet as pb

from executive.failures import GripperClosedCompletely, GripperGoalNotReached
from projection import _urdf
from projection._geometry import finite as _finite
from projection._world_base import WorldBase

__all__ = ["Grippers"]


class Grippers(WorldBase):
    """Gripper motions (a mixin of :class:`projection.World`)."""

    def gripper(self, action: str | float, arm: str | Sequence[str]) -> None:
        """``"open"`` (0.10 m), ``"close"`` (fully), ``"grip"`` (close until a finger
        touches an object; fails with :class:`GripperClosedCompletely` unless a gripper
        link of that arm then touches an object; the gripper stays closed, as in CRAM), or
        an opening in metres (outside [0, 0.10] by > 1e-4 -> :class:`GripperGoalNotReached`,
        world unchanged). ``arm``: "left", "right" or both. Attaching is the caller's job."""
        self._check()
        arms = self._arms(arm)
        if isinstance(action, str):
            if action not in ("open", "close", "grip"):
                raise ValueError(
                    f"unknown gripper action {action!r}; known: open, close, grip, "
                    "or an opening in metres"
                )
        else:
            (opening,) = _finite([action], "gripper opening")
            if not -1e-4 <= opening <= 2 * _urdf.FINGER_MAX + 1e-4:
                raise GripperGoalNotReached(
                    f"opening {opening} outside [0, {2 * _urdf.FINGER_MAX}]", action=action
                )
        for a in arms:
            fingers = self._fingers[a]
            if action == "open":
                self._set_joints(fingers, [_urdf.FINGER_MAX] * 2)
            elif action == "close":
                self._set_joints(fingers, [0.0, 0.0])
            elif action == "grip":
                self._close_until_contact(a)
                if not self._gripper_touches(a):
                    raise GripperClosedCompletely(action=action, arm=a)
            else:
                q = min(max(float(action) / 2.0, 0.0), _urdf.FINGER_MAX)
                self._set_joints(fingers, [q, q])

    def _gripper_touches(self, arm: str, distance: float = 1e-3) -> bool:
        c = self._c
        for obj in self._objects.values():
            for li in self._gripper_links[arm]:
                if pb.getClosestPoints(self._robot, obj.body, distance, li, -1, physicsClientId=c):
                    return True
        return False

    def _close_until_contact(self, arm: str) -> None:
        fingers = self._fingers[arm]
        q = max(self._get_joints(fingers))
        c = self._c
        finger_links = fingers  # finger link index == finger joint index
        step = 0.0025
        while q > 0.0:
            q = max(0.0, q - step)
            self._set_joints(fingers, [q, q])
            for obj in self._objects.values():
                for li in finger_links:
                    if pb.getClosestPoints(self._robot, obj.body, 5e-4, li, -1, physicsClientId=c):
                        return
