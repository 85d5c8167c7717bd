"""Snapshots of a :class:`projection.World`: a cheap copy of its state and an exact
return to it (spawns and removals undone)."""

from __future__ import annotations

from dataclasses import dataclass
from math import copysign
from typing import Any

import pybullet as pb

from executive._pose import Pose
from projection._geometry import Quat as _Quat
from projection._geometry import Tf as _Tf
from projection._geometry import Vec as _Vec
from projection._world_base import WorldBase

__all__ = ["Snapshot", "Snapshots"]


@dataclass(frozen=True)
class Snapshot:
    """An opaque world state for :meth:`World.restore` (only valid for its world)."""

    world_id: int
    base: tuple[float, float, float]
    robot_joints: tuple[float, ...]
    kitchen_joints: tuple[float, ...]
    objects: tuple[tuple[str, str, _Vec, _Quat, _Vec, _Vec], ...]
    attachments: tuple[tuple[str, str, _Tf], ...]

    def isclose(self, other: Snapshot, tol: float = 1e-9) -> bool:
        """The same state up to float rounding (PyBullet renormalises quaternions, so a
        restored state can differ from the saved one by ~1e-17): names, types and links
        equal, every number within ``tol``."""
        a, b = _flat(self), _flat(other)
        return len(a) == len(b) and all(
            x == y if isinstance(x, str) or isinstance(y, str) else abs(x - y) <= tol
            for x, y in zip(a, b)
        )


def _flat(x: Any) -> list[Any]:
    if isinstance(x, Snapshot):
        return _flat([x.base, x.robot_joints, x.kitchen_joints, x.objects, x.attachments])
    if isinstance(x, (tuple, list)):
        return [v for item in x for v in _flat(item)]
    return [x]


def _at_rest(lin: _Vec, ang: _Vec) -> bool:
    """Every component +0.0, bit for bit (-0.0 and NaN are not)."""
    if lin != _ZERO or ang != _ZERO:  # (-0.0 == 0.0: the signs are checked below)
        return False
    return all(copysign(1.0, v) > 0.0 for v in (*lin, *ang))


_ZERO = (0.0, 0.0, 0.0)


class Snapshots(WorldBase):
    """``snapshot`` / ``restore`` (a mixin of :class:`projection.World`)."""

    def snapshot(self) -> Snapshot:
        """A cheap copy of the state: robot base and joints, kitchen joints, objects
        (type, pose, velocity), attachments."""
        c = self._check()
        objs = []
        for n, o in self._objects.items():
            pos, orn = pb.getBasePositionAndOrientation(o.body, physicsClientId=c)
            lin, ang = pb.getBaseVelocity(o.body, physicsClientId=c)
            objs.append((n, o.type, tuple(pos), tuple(orn), tuple(lin), tuple(ang)))
        return Snapshot(
            id(self),
            self._base,
            self._get_joints(self._dofs),
            self._get_joints(list(self._kitchen_joints.values()), self._kitchen),
            tuple(objs),
            tuple((n, link, rel) for n, (link, rel) in self._attached.items()),
        )

    def restore(self, snap: Snapshot) -> None:
        """Return exactly to ``snap``: objects spawned since are removed, removed ones are
        re-spawned. A snapshot of another world -> ValueError."""
        c = self._check()
        if not isinstance(snap, Snapshot) or snap.world_id != id(self):
            raise ValueError("this snapshot was not taken from this world")
        keep = {n for n, *_ in snap.objects}
        for n in [n for n in self._objects if n not in keep]:
            self.remove_object(n)
        self._reset_base(*snap.base)
        self._set_joints(self._dofs, snap.robot_joints)
        self._set_joints(list(self._kitchen_joints.values()), snap.kitchen_joints, self._kitchen)
        for n, t, pos, orn, lin, ang in snap.objects:
            obj = self._objects.get(n)
            if obj is None or obj.type != t:
                if obj is not None:
                    self.remove_object(n)
                self.spawn_object(n, t, Pose(pos, orn, "map"), allow_overlap=True)
                obj = self._objects[n]
            pb.resetBasePositionAndOrientation(obj.body, pos, orn, physicsClientId=c)
            # that reset left the body at rest (+0.0 velocities) and just updated its
            # collider: setting +0.0 again would change nothing
            if not _at_rest(lin, ang):
                pb.resetBaseVelocity(obj.body, lin, ang, physicsClientId=c)
        self._objects = {n: self._objects[n] for n, *_ in snap.objects}  # snapshot order
        self._attached = {n: (link, rel) for n, link, rel in snap.attachments}
