"""Seeing in a :class:`projection.World`: pointing the head (``look_at``) and detecting
objects by ray casts from the camera (``detect``, ``visibility``)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pybullet as pb

from executive._pose import Pose, Transform
from executive.failures import PerceptionObjectNotFound, PtuGoalNotReached, PtuGoalUnreachable
from projection._world_base import WorldBase

__all__ = ["PerceivedObject", "Perception"]

#: The PR2-like robot's camera (CRAM's 50 degrees at 320x200); a world uses its robot's
#: ``neck.camera`` (``robots.pr2`` agrees with these, tested).
_CAMERA_FOV_Y = math.radians(50.0)
_CAMERA_ASPECT = 320.0 / 200.0
_CAMERA_NEAR, _CAMERA_FAR = 0.1, 10.0


@dataclass(frozen=True)
class PerceivedObject:
    """A detected object: ``pose`` in ``base_footprint`` at detection time (CRAM's
    ``:pose``), ``map_pose`` in ``map``, ``transform`` = base_footprint -> object."""

    name: str
    type: str
    pose: Pose
    map_pose: Pose
    transform: Transform


class Perception(WorldBase):
    """Head pointing and detection (a mixin of :class:`projection.World`)."""

    def look_at(self, target: Pose | str) -> None:
        """Point the camera (optical z) at a Pose (map or base_footprint), at a link's
        origin (a link name), or ``"forward"`` (pan = tilt = 0). Pan/tilt beyond their
        limits by > 1e-5 -> :class:`PtuGoalNotReached` (``target=...``), head unchanged. A
        target whose pan/tilt cannot be computed (a point so far away, e.g. 1e300 m, that
        the transforms overflow to inf or NaN) -> :class:`PtuGoalUnreachable`, head
        unchanged (the head joints used to be set to NaN, blinding detection)."""
        self._check()
        if isinstance(target, str):
            if target == "forward":
                self._set_joints([self._pan, self._tilt], [0.0, 0.0])
                return
            point = self._link_tf(*self._link(target))[0]
        else:
            point = self._to_map(target)[0]
        pan, tilt = self._ptu_angles(point) if all(map(math.isfinite, point)) else (math.nan,) * 2
        if not (math.isfinite(pan) and math.isfinite(tilt)):
            raise PtuGoalUnreachable(
                f"cannot point the camera at the point ({', '.join(f'{v:.6g}' for v in point)}) "
                "in map: too far away to compute pan and tilt",
                target=target,
            )
        (plo, phi), (tlo, thi) = self._limits[self._pan], self._limits[self._tilt]
        cpan, ctilt = min(max(pan, plo), phi), min(max(tilt, tlo), thi)
        if abs(cpan - pan) > 1e-5 or abs(ctilt - tilt) > 1e-5:
            raise PtuGoalNotReached(
                f"pan {pan:.3f} / tilt {tilt:.3f} beyond the limits", target=target
            )
        self._set_joints([self._pan, self._tilt], [pan, tilt])

    def _ptu_angles(self, point: Sequence[float]) -> tuple[float, float]:
        tp, tq = self._link_tf(self._robot, self._torso_link)
        ip, iq = pb.invertTransform(tp, tq)
        p_t = np.asarray(pb.multiplyTransforms(ip, iq, point, (0, 0, 0, 1))[0])
        pan_xyz, tilt_xyz, camera_xyz = self._neck
        d = p_t - np.asarray(pan_xyz)
        pan = math.atan2(d[1], d[0])
        if math.hypot(d[0], d[1]) < 1e-9:
            pan = 0.0
        # target in the pan frame, relative to the tilt axis
        cp, sp = math.cos(pan), math.sin(pan)
        q = np.array([cp * d[0] + sp * d[1], -sp * d[0] + cp * d[1], d[2]])
        q -= np.asarray(tilt_xyz)
        cx, _, cz = camera_xyz
        tilt = 0.0
        for _ in range(4):  # the camera sits off the tilt axis: fixed-point iteration
            ct, st = math.cos(tilt), math.sin(tilt)
            cam = np.array([ct * cx + st * cz, 0.0, -st * cx + ct * cz])
            v = q - cam
            tilt = math.atan2(-v[2], v[0])
        return pan, tilt

    # ------------------------------------------------------------------ perception
    def detect(self, designator: Any, threshold: float = 0.9) -> list[PerceivedObject]:
        """Objects with exactly the designator's ``type`` (and ``name`` if given) that
        the camera sees: rays from the robot's camera frame (its description's
        ``neck.camera.frame``) to a 3x3x3 grid in the object's AABB; a ray that first hits
        the object is a visible sample only inside the camera's field of view (the
        PR2-like robot: CRAM's 50° x 73°, 320x200); a ray that hits something else
        before reaching the grid point is an occluded sample; visible when visible /
        (visible + occluded + out-of-view object samples) >= ``threshold``. Nothing
        visible -> :class:`PerceptionObjectNotFound` (``object=designator``)."""
        c = self._check()
        get = getattr(designator, "get", None)
        if get is None:
            raise TypeError("detect needs a designator or a dict with .get('type')")
        otype = get("type", None) if _takes_default(get) else get("type")
        oname = get("name", None) if _takes_default(get) else get("name")
        if otype is None:
            raise ValueError(f"the designator has no type: {designator!r}")
        cands = [
            (n, o)
            for n, o in self._objects.items()
            if o.type == otype and (oname is None or n == oname)
        ]
        found: list[PerceivedObject] = []
        if cands:
            cam_p, cam_q = self._link_tf(self._robot, self._camera)
            for n, o in cands:
                if self._visible(o.body, cam_p, cam_q) >= threshold:
                    map_tf = pb.getBasePositionAndOrientation(o.body, physicsClientId=c)
                    mpose = Pose(map_tf[0], map_tf[1], "map")
                    bpose = self._express((tuple(map_tf[0]), tuple(map_tf[1])), "base_footprint")
                    found.append(PerceivedObject(n, o.type, bpose, mpose, bpose.to_transform(n)))
        if not found:
            raise PerceptionObjectNotFound(
                f"no visible {otype}" + (f" named {oname}" if oname else ""), object=designator
            )
        return found

    def visibility(self, name: str) -> float:
        """The visible fraction :meth:`detect` computes for an object (0..1)."""
        self._check()
        cam_p, cam_q = self._link_tf(self._robot, self._camera)
        return self._visible(self._obj(name).body, cam_p, cam_q)

    def _visible(self, body: int, cam_p: Sequence[float], cam_q: Sequence[float]) -> float:
        c = self._c
        lo, hi = (np.asarray(v) for v in pb.getAABB(body, -1, physicsClientId=c))
        f = np.array([0.15, 0.5, 0.85])
        gx, gy, gz = np.meshgrid(
            lo[0] + f * (hi[0] - lo[0]),
            lo[1] + f * (hi[1] - lo[1]),
            lo[2] + f * (hi[2] - lo[2]),
            indexing="ij",
        )
        pts = np.stack([gx.ravel(), gy.ravel(), gz.ravel()], axis=1)
        origin = np.asarray(cam_p)
        rel = pts - origin
        dist = np.linalg.norm(rel, axis=1)
        dirs = rel / dist[:, None]
        reach = float(np.linalg.norm(hi - lo))
        ends = origin + dirs * (dist + reach)[:, None]
        rot = np.array(pb.getMatrixFromQuaternion(cam_q)).reshape(3, 3)
        local = rel @ rot  # camera coordinates: z forward, x right, y down
        z = local[:, 2]
        camera = self.robot.neck.camera
        tan_y = math.tan(camera.vertical_fov / 2)
        # the aspect ratio rounded: an aspect given as 2 atan(1.6 tan(v/2)) is 1.6 exactly
        aspect = round(math.tan(camera.horizontal_fov / 2) / tan_y, 12)
        with np.errstate(divide="ignore", invalid="ignore"):
            in_view = (
                (z > _CAMERA_NEAR)
                & (z < _CAMERA_FAR)
                & (np.abs(local[:, 0] / z) <= tan_y * aspect)
                & (np.abs(local[:, 1] / z) <= tan_y)
            )
        starts = np.repeat(origin[None, :], len(pts), axis=0)
        hits = pb.rayTestBatch(starts.tolist(), ends.tolist(), physicsClientId=c)
        total = dist + reach
        visible = occluded = 0
        for k, h in enumerate(hits):
            if h[0] == body:
                if in_view[k]:
                    visible += 1
                else:
                    occluded += 1
            elif h[0] >= 0 and h[2] * total[k] < dist[k] - 1e-6:
                occluded += 1
        n = visible + occluded
        return visible / n if n else 0.0


def _takes_default(get: Any) -> bool:
    """Whether ``get`` accepts a default (dict.get and designators do)."""
    try:
        get("type", None)
    except TypeError:
        return False
    return True
