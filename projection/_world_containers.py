"""Containers of a :class:`projection.World` (the drawer): open, close or set a
container joint; objects attached to its links follow."""

from __future__ import annotations

from executive.failures import EnvironmentManipulationGoalNotReached
from projection._geometry import finite as _finite
from projection._world_base import WorldBase

__all__ = ["Containers"]


class Containers(WorldBase):
    """Container joints (a mixin of :class:`projection.World`)."""

    def _container_joint(self, link_or_joint: str) -> str:
        if link_or_joint in self._kitchen_joints:
            return link_or_joint
        if f"{link_or_joint}_joint" in self._kitchen_joints:
            return f"{link_or_joint}_joint"
        known = list(self._kitchen_joints) + [j[: -len("_joint")] for j in self._kitchen_joints]
        raise LookupError(f"no container {link_or_joint!r}; known: {', '.join(known)}")

    def open_container(self, link_or_joint: str, distance: float) -> None:
        """Move a container joint (e.g. the drawer) by ``+distance``; objects attached to
        its links follow. Beyond the joint limits by > 1e-4 ->
        :class:`EnvironmentManipulationGoalNotReached`, world unchanged."""
        self._move_container(link_or_joint, distance, +1.0)

    def close_container(self, link_or_joint: str, distance: float) -> None:
        """Move a container joint by ``-distance`` (see :meth:`open_container`)."""
        self._move_container(link_or_joint, distance, -1.0)

    def _move_container(self, link_or_joint: str, distance: float, sign: float) -> None:
        self._check()
        joint = self._container_joint(link_or_joint)
        (d,) = _finite([distance], "distance")
        if d < 0:
            raise ValueError(f"distance must be >= 0, got {d}")
        index = self._kitchen_joints[joint]
        cur = self._get_joints([index], self._kitchen)[0]
        goal = cur + sign * d
        lo, hi = self._kitchen_limits[joint]
        if goal < lo - 1e-4 or goal > hi + 1e-4:
            raise EnvironmentManipulationGoalNotReached(
                f"{joint} goal {goal:.3f} outside [{lo}, {hi}]", joint=joint, distance=distance
            )
        self._set_joints([index], [min(max(goal, lo), hi)], self._kitchen)
        self._update_attached(self._kitchen)

    def container_state(self, link_or_joint: str) -> tuple[float, float, float]:
        """``(position, lower, upper)`` of a container joint (the drawer's in metres);
        unknown -> LookupError naming the known ones."""
        self._check()
        joint = self._container_joint(link_or_joint)
        lo, hi = self._kitchen_limits[joint]
        return self.joint_position(joint), float(lo), float(hi)

    def set_container(self, link_or_joint: str, position: float) -> None:
        """Set a container joint to ``position``, within its limits (1e-4 of slack, then
        clamped onto them); further outside -> ValueError naming the limits, world
        unchanged (deliberate: it used to clamp silently)."""
        self._check()
        joint = self._container_joint(link_or_joint)
        (v,) = _finite([position], "position")
        lo, hi = self._kitchen_limits[joint]
        if not lo - 1e-4 <= v <= hi + 1e-4:
            raise ValueError(
                f"set_container({link_or_joint!r}, {position!r}): {joint} moves within "
                f"[{lo}, {hi}]; give a position in that range"
            )
        self._set_joints([self._kitchen_joints[joint]], [min(max(v, lo), hi)], self._kitchen)
        self._update_attached(self._kitchen)
