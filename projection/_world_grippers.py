"""The grippers of a :class:`projection.World`: open, close, grip until contact, or an
opening in metres."""

from __future__ import annotations

from collections.abc import Sequence

import pybullet as pb

from executive.failures import GripperClosedCompletely, GripperGoalNotReached
from projection._geometry import finite as _finite
from projection._world_base import WorldBase

__all__ = ["Grippers"]


#: ``grip`` closes in this many equal steps over the finger joints' range (the PR2-like
#: robot: 2.5 mm per finger)
GRIP_STEPS = 20


class Grippers(WorldBase):
    """Gripper motions (a mixin of :class:`projection.World`)."""

    def _finger_position(self, arm: str, opening: float) -> float:
        """The finger joints' value for ``opening`` metres (clamped into the range) by the
        arm's :class:`executive.GripperDescription`."""
        g = self.robot.arm(arm).gripper
        opening = min(max(opening, 0.0), g.max_opening)
        if g.closed_position == 0.0 and g.open_position * 2 == g.max_opening:
            return opening / 2.0  # each finger opens half the width (exactly)
        return g.joint_position(opening)

    def gripper(self, action: str | float, arm: str | Sequence[str]) -> None:
        """``"open"`` (the arm's ``gripper.max_opening``: the PR2-like robot 0.10 m),
        ``"close"`` (fully), ``"grip"`` (close until a finger touches an object; fails with
        :class:`GripperClosedCompletely` unless a gripper link of that arm then touches an
        object; the gripper stays closed, as in CRAM), or an opening in metres (outside
        [0, max_opening] by > 1e-4 -> :class:`GripperGoalNotReached`, world unchanged).
        ``arm``: "left", "right" or both (the arms the robot has). Attaching is the
        caller's job."""
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
            for a in arms:
                widest = self.robot.arm(a).gripper.max_opening
                if not -1e-4 <= opening <= widest + 1e-4:
                    raise GripperGoalNotReached(
                        f"opening {opening} outside [0, {widest}]", action=action
                    )
        for a in arms:
            fingers = self._fingers[a]
            g = self.robot.arm(a).gripper
            if action == "open":
                self._set_joints(fingers, [g.open_position] * len(fingers))
            elif action == "close":
                self._set_joints(fingers, [g.closed_position] * len(fingers))
            elif action == "grip":
                self._close_until_contact(a)
                if not self._gripper_touches(a):
                    raise GripperClosedCompletely(action=action, arm=a)
            else:
                q = self._finger_position(a, float(action))
                self._set_joints(fingers, [q] * len(fingers))

    def _gripper_touches(self, arm: str, distance: float = 1e-3) -> bool:
        c = self._c
        for obj in self._objects.values():
            for li in self._gripper_links[arm]:
                if pb.getClosestPoints(self._robot, obj.body, distance, li, -1, physicsClientId=c):
                    return True
        return False

    def _close_until_contact(self, arm: str) -> None:
        fingers = self._fingers[arm]
        g = self.robot.arm(arm).gripper
        c = self._c
        finger_links = fingers  # finger link index == finger joint index
        step = abs(g.open_position - g.closed_position) / GRIP_STEPS
        # in the closing direction, sign-free: d is the distance left to closed
        sign = 1.0 if g.open_position > g.closed_position else -1.0
        d = max(sign * (v - g.closed_position) for v in self._get_joints(fingers))
        while d > 0.0:
            d = max(0.0, d - step)
            q = g.closed_position + sign * d
            self._set_joints(fingers, [q] * len(fingers))
            for obj in self._objects.values():
                for li in finger_links:
                    if pb.getClosestPoints(self._robot, obj.body, 5e-4, li, -1, physicsClientId=c):
                        return
