"""The robot's teleporting motions in a :class:`projection.World` (CRAM's projection
``drive``, ``move-torso``, ``move-joints``, ``park-arms``): each checks its goal and
leaves the world unchanged on failure."""

from __future__ import annotations

import math
from collections.abc import Sequence

import pybullet as pb

from executive._pose import Pose
from executive.failures import NavigationPoseUnreachable, TorsoGoalNotReached
from projection._geometry import finite as _finite
from projection._geometry import quat_yaw as _quat_yaw
from projection._trajectories import wrap_angle
from projection._world_collisions import Collisions

__all__ = ["BodyMotions"]


class BodyMotions(Collisions):
    """Base, torso and arm-joint motions (a mixin of :class:`projection.World`)."""

    def drive(self, pose: Pose) -> None:
        """Teleport the base to ``pose`` (map or base_footprint; z, roll and pitch are
        ignored); attached objects follow. If the robot or an object it carries then
        collides with anything else, the previous pose is restored and
        :class:`NavigationPoseUnreachable` (``location=pose``) is raised; so it is for a
        goal outside the room (:attr:`room`), where nothing would stop a teleport."""
        self._check()
        pos, orn = self._to_map(pose)
        x0, y0, x1, y1 = self._room
        if not (x0 <= pos[0] <= x1 and y0 <= pos[1] <= y1):
            raise NavigationPoseUnreachable(
                f"Navigation pose unreachable: ({pos[0]:.2f}, {pos[1]:.2f}) is outside the "
                f"room (x {x0:.2f}..{x1:.2f}, y {y0:.2f}..{y1:.2f})",
                location=pose,
            )
        c = self._c
        prev = self._base
        carried = []
        if self._attached:
            carried = [
                (b, pb.getBasePositionAndOrientation(b, physicsClientId=c))
                for b in (self._objects[n].body for n in self._attached)
            ]
        self._reset_base(pos[0], pos[1], _quat_yaw(orn))
        if carried:
            self._update_attached(self._robot)
        pb.performCollisionDetection(physicsClientId=c)
        if self._collisions(set(), first_only=True):
            self._reset_base(*prev)
            for b, (p, q) in carried:  # exactly, not via the float32 link states
                pb.resetBasePositionAndOrientation(b, p, q, physicsClientId=c)
            raise NavigationPoseUnreachable(location=pose)

    # ------------------------------------------------------------------ torso, arms
    def move_torso(self, height: float) -> None:
        """Set the torso joint (the PR2-like robot's ``torso_lift_joint``). A goal outside
        its limits (the PR2-like robot: [0, 0.33]) by more than 1e-4 ->
        :class:`TorsoGoalNotReached` (``torso=height``), world unchanged."""
        self._check()
        (h,) = _finite([height], "torso height")
        lo, hi = self._limits[self._torso]
        clamped = min(max(h, lo), hi)
        if abs(clamped - h) > 1e-4:
            raise TorsoGoalNotReached(f"torso height {h:.4f} outside [{lo}, {hi}]", torso=height)
        self._set_joints([self._torso], [clamped])
        self._update_attached(self._robot)

    def move_joints(
        self, left: Sequence[float] | None = None, right: Sequence[float] | None = None
    ) -> None:
        """Set the arm joints (each arm's description's ``joints``, in order) of the given
        sides. An arm the robot lacks, wrong length, non-finite values or values outside
        the joint limits -> ValueError naming them; world unchanged. A continuous joint
        (limits ``-inf, inf``) takes any value and reads back wrapped into [-pi, pi)."""
        self._check()
        goals: list[tuple[list[int], tuple[float, ...]]] = []
        for arm, values in (("left", left), ("right", right)):
            if values is None:
                continue
            names = self.robot.arm(self._arm(arm)).joints
            vals = _finite(values, f"{arm} arm joints")
            if len(vals) != len(names):
                raise ValueError(
                    f"{arm} arm needs {len(names)} joint values "
                    f"({', '.join(names)}), got {len(vals)}"
                )
            indices = self._arm_joints[arm]
            for i, v, jname in zip(indices, vals, names):
                lo, hi = self._limits[i]
                if not lo - 1e-6 <= v <= hi + 1e-6:
                    raise ValueError(f"{arm} {jname} = {v:.4f} outside [{lo}, {hi}]")
            # a continuous joint is kept in [-pi, pi) (the same pose): a path that turns
            # it across the wrap is interpolated unwrapped, its readings stay wrapped
            vals = tuple(
                wrap_angle(v) if math.isinf(self._limits[i][1]) else v
                for i, v in zip(indices, vals)
            )
            goals.append((indices, vals))
        for indices, vals in goals:
            self._set_joints(indices, vals)
        self._update_attached(self._robot)

    def set_arm_configuration(self, name: str, arms: str | Sequence[str] | None = None) -> None:
        """Put arms (default: all the robot has) into a named configuration of their
        descriptions ("park", "carry"); unknown -> LookupError."""
        self._check()
        chosen = self._arms(self._sides if arms is None else arms)
        values = {a: self.robot.arm(a).state(name) for a in chosen}
        self.move_joints(values.get("left"), values.get("right"))

    def park_arms(self, configuration: str = "park") -> None:
        """Every arm to ``configuration`` (CRAM's park-arms; CRAM defaults to carrying)."""
        self.set_arm_configuration(configuration)
