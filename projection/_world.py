"""The projection world: one PyBullet client with the PR2-like robot, the kitchen and the
household objects, and CRAM's low-level projection functions (``urdf-proj``) as methods.

Design decisions (measured, see ``bench/projection_ops.py``):

- The robot is loaded with ``useFixedBase=True`` and moved by teleport
  (``resetBasePositionAndOrientation``); the kitchen is fixed and never reset. After the
  robot's first reset Bullet tests its links against the static kitchen (the "quirk" of
  the performance notes): that is exactly what a navigation probe needs, so the world does
  one reset at start-up and every probe is ``reset + performCollisionDetection +
  getContactPoints(robot)``.
- A contact counts as a collision when its penetration exceeds
  :data:`COLLISION_TOLERANCE` (resting contacts report about -1 mm).
- Snapshots are manual (poses, velocities, joints, attachments, registry): PyBullet's
  ``saveState`` costs milliseconds and cannot undo spawns or removals.
- ``detect`` casts rays from the camera to a grid of points in the object's AABB
  (``rayTestBatch``); a render (``getCameraImage``) at CRAM's 320x200 costs more than the
  whole 20 ms budget twice over.
- IK is PyBullet's ``calculateInverseKinematics`` on the tool frame with huge damping on
  every non-arm joint (so only the arm's 7 joints move), several seeds, FK verification,
  and CRAM's torso resampling (the 0.05 m grid, current height first, then from the upper
  limit down). Two fast paths that never change an answer: a sound reach pre-check (the
  wrist must lie in the annulus the arm can span around the circle of shoulder-lift
  positions, with the FK tolerance as margin) skips heights before any IK call, and a
  per-world LRU memo keyed by (arm, goal in the torso frame, seed joints) replays earlier
  solutions, each re-verified by FK. Measured: ordering the heights by distance from the
  current one cost more on the demo grasps than CRAM's order, so CRAM's order stays.

Every failing method leaves the world as it was unless its docstring says otherwise.
Poses are :class:`executive._pose.Pose` in ``map`` or ``base_footprint``.
"""

from __future__ import annotations

import difflib
import math
import os
from collections import OrderedDict
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np
import pybullet as pb

from executive import knowledge
from executive._pose import Pose, Transform
from executive.failures import (
    EnvironmentManipulationGoalNotReached,
    GripperClosedCompletely,
    GripperGoalNotReached,
    ManipulationPoseUnreachable,
    NavigationPoseUnreachable,
    PerceptionObjectNotFound,
    PtuGoalNotReached,
    TorsoGoalNotReached,
)
from projection import _urdf
from projection._objects import object_type

__all__ = [
    "COLLISION_TOLERANCE",
    "DEFAULT_TORSO",
    "Contact",
    "PerceivedObject",
    "Snapshot",
    "World",
]

ASSETS = Path(__file__).resolve().parent / "assets"
COLLISION_TOLERANCE = 0.002  #: penetration (m) beyond which a contact is a collision
DEFAULT_TORSO = 0.15  #: torso height of a new world (m): camera at 1.42 m
TORSO_STEP = 0.05  #: torso resampling step of move_tcp (m)
IK_CACHE_SIZE = 4096  #: default bound of a world's IK memo (entries)
#: slack of the reach test (m): 1 cm FK tolerance + 0.1 rad x TOOL_X, rounded up
_REACH_MARGIN = 0.03
FRAMES = ("map", "base_footprint")
ROBOT = "pr2"
KITCHEN = "kitchen"
_Vec = tuple[float, float, float]
_Quat = tuple[float, float, float, float]
_Tf = tuple[_Vec, _Quat]
_ARM_PREFIX = {"left": "l", "right": "r"}
_IK_SEEDS = (
    (0.0, 0.5, 0.0, -1.2, 0.0, -0.6, 0.0),
    (0.0, 0.2, 0.0, -1.6, 0.0, -1.2, 0.0),
    (0.4, 0.8, 1.5, -1.5, 0.0, -0.8, 0.0),
    (0.44, -0.32, 1.91, -2.07, 3.01, -1.55, 1.13),
    (1.2, 0.3, 0.5, -1.0, -1.5, -1.0, 0.5),
    (-0.3, 0.9, 2.5, -2.0, 1.0, -0.4, -1.0),
    (0.8, -0.2, 3.0, -0.8, -2.0, -1.8, 2.0),
)  # left-arm IK seeds after the current state; mirrored for the right arm
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


@dataclass(frozen=True)
class Contact:
    """One contact between two named bodies (links by name; ``distance`` < 0 =
    penetration)."""

    body_a: str
    link_a: str
    body_b: str
    link_b: str
    distance: float


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


@dataclass
class _Obj:
    type: str
    body: int


def _finite(values: Iterable[float], what: str) -> tuple[float, ...]:
    out = tuple(float(v) for v in values)
    if not all(math.isfinite(v) for v in out):
        raise ValueError(f"{what} must be finite, got {out!r}")
    return out


def _yaw_quat(yaw: float) -> _Quat:
    return (0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0))


def _quat_yaw(q: Sequence[float]) -> float:
    x, y, z, w = q
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def _quat_mul(a: Sequence[float], b: Sequence[float]) -> _Quat:
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz)


def _wrist_point(pos: Sequence[float], orn: Sequence[float]) -> _Vec:
    """The wrist (``?_wrist_flex_link`` origin): TOOL_X behind the tool along its x."""
    x, y, z, w = orn
    ax = (1 - 2 * (y * y + z * z), 2 * (x * y + z * w), 2 * (x * z - y * w))
    t = _urdf.TOOL_X
    return (pos[0] - ax[0] * t, pos[1] - ax[1] * t, pos[2] - ax[2] * t)


def _angle(q1: Sequence[float], q2: Sequence[float]) -> float:
    dot = abs(sum(a * b for a, b in zip(q1, q2)))
    return 2.0 * math.acos(min(1.0, dot))



def _static_plane(client: int) -> int:
    """A static, infinite ground plane at z = 0 in ``client``."""
    shape = pb.createCollisionShape(pb.GEOM_PLANE, physicsClientId=client)
    return int(pb.createMultiBody(0, shape, physicsClientId=client))

class World:
    """A PyBullet projection world (see the module docstring).

    ``World(seed=None, gui=False)``; ``close()`` is idempotent and the world is a context
    manager; any use after ``close()`` raises :class:`RuntimeError`. A new world has the
    robot at the map origin, both arms parked, the torso at :data:`DEFAULT_TORSO`, the
    head looking forward, grippers open and the drawer closed. ``rng`` is a seeded
    :class:`numpy.random.Generator`.
    """

    def __init__(self, seed: int | None = None, gui: bool = False) -> None:
        self._c = -1
        self._side = -1
        if gui:
            if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
                raise RuntimeError("World(gui=True) needs a display (DISPLAY is not set)")
            self._c = pb.connect(pb.GUI)
        else:
            self._c = pb.connect(pb.DIRECT)
        if self._c < 0:
            raise RuntimeError("could not connect to PyBullet")
        self.rng: np.random.Generator = np.random.default_rng(seed)
        c = self._c
        pb.setGravity(0, 0, -9.81, physicsClientId=c)
        self._kitchen = pb.loadURDF(
            str(ASSETS / "kitchen.urdf"), useFixedBase=True, physicsClientId=c
        )
        self._robot = pb.loadURDF(str(ASSETS / "pr2.urdf"), useFixedBase=True, physicsClientId=c)
        # The floor: a static plane at z = 0, so that what falls lands somewhere. It is not
        # part of the kitchen (costmaps treat kitchen links as obstacles); resting contact
        # with the robot's base is within COLLISION_TOLERANCE and never counts.
        self._floor = _static_plane(c)
        self._links: dict[str, tuple[int, int]] = {}
        self._kitchen_joints: dict[str, int] = {}
        self._robot_joints: dict[str, int] = {}
        self._limits: dict[int, tuple[float, float]] = {}
        pairs = ((self._robot, self._robot_joints), (self._kitchen, self._kitchen_joints))
        for body, joints in pairs:
            base_name = pb.getBodyInfo(body, physicsClientId=c)[0].decode()
            self._links[base_name] = (body, -1)
            for i in range(pb.getNumJoints(body, physicsClientId=c)):
                info = pb.getJointInfo(body, i, physicsClientId=c)
                self._links[info[12].decode()] = (body, i)
                if info[2] != pb.JOINT_FIXED:
                    joints[info[1].decode()] = i
                    if body == self._robot:
                        self._limits[i] = (float(info[8]), float(info[9]))
        self._kitchen_limits = {
            n: tuple(pb.getJointInfo(self._kitchen, i, physicsClientId=c)[8:10])
            for n, i in self._kitchen_joints.items()
        }
        self._link_names = {v: k for k, v in self._links.items()}
        self._dofs = sorted(self._limits)  # movable robot joints, IK order
        self._arm_joints = {
            arm: [self._robot_joints[f"{p}_{j}"] for j in knowledge.ARM_JOINTS]
            for arm, p in _ARM_PREFIX.items()
        }
        self._fingers = {
            arm: [self._robot_joints[f"{p}_gripper_l_finger_joint"],
                  self._robot_joints[f"{p}_gripper_r_finger_joint"]]
            for arm, p in _ARM_PREFIX.items()
        }
        self._tool = {
            arm: self._links[f"{p}_gripper_tool_frame"][1] for arm, p in _ARM_PREFIX.items()
        }
        self._shoulder = {
            arm: self._links[f"{p}_shoulder_lift_link"][1] for arm, p in _ARM_PREFIX.items()
        }
        self._gripper_links = {
            arm: [i for n, (b, i) in self._links.items()
                  if b == self._robot and n.startswith(f"{p}_gripper")]
            for arm, p in _ARM_PREFIX.items()
        }
        self._torso = self._robot_joints["torso_lift_joint"]
        self._torso_slot = self._dofs.index(self._torso)
        self._arm_slots = {arm: [self._dofs.index(i) for i in idx]
                           for arm, idx in self._arm_joints.items()}
        self._ik_damping: dict[str, list[float]] = {}
        for arm, slots in self._arm_slots.items():
            damping = [1e3] * len(self._dofs)
            for k in slots:
                damping[k] = 0.05
            self._ik_damping[arm] = damping
        mirrored = tuple((-a, b, -r, e, -f, w, -x) for a, b, r, e, f, w, x in _IK_SEEDS)
        self._ik_seeds = {"left": _IK_SEEDS, "right": mirrored}
        #: tool-frame positions of the seeds in the torso frame (filled on first IK)
        self._seed_tools: dict[str, list[tuple[float, ...]]] = {}
        #: bound of the per-world IK memo (0 disables it); see :meth:`move_tcp`
        self.ik_cache_size: int = IK_CACHE_SIZE
        self.ik_cache_stats: dict[str, int] = {"hits": 0, "misses": 0}
        self._ik_cache: OrderedDict[tuple[Any, ...], tuple[float, ...] | None] = OrderedDict()
        self._pan = self._robot_joints["head_pan_joint"]
        self._tilt = self._robot_joints["head_tilt_joint"]
        self._camera = self._links["head_mount_kinect_rgb_optical_frame"][1]
        self._objects: dict[str, _Obj] = {}
        self._bodies: dict[int, str] = {self._robot: ROBOT, self._kitchen: KITCHEN}
        self._attached: dict[str, tuple[str, _Tf]] = {}
        self._base: tuple[float, float, float] = (0.0, 0.0, 0.0)
        self._closed = False
        # initial state: one base reset (so the fixed robot is tested against the fixed
        # kitchen from the start), arms parked, torso default, grippers open, head forward
        self._reset_base(0.0, 0.0, 0.0)
        self._set_joints([self._torso], [DEFAULT_TORSO])
        for arm in _ARM_PREFIX:
            self._set_joints(self._arm_joints[arm], knowledge.arm_configuration("park", arm))
            self._set_joints(self._fingers[arm], [_urdf.FINGER_MAX] * 2)
        self._init_reach()

    def _init_reach(self) -> None:
        """Arm reach geometry in base_footprint at torso height 0, read by FK."""
        robot = self._robot
        h0 = self._get_joints([self._torso])[0]
        bp, bq = self._base_tf()
        ip, iq = pb.invertTransform(bp, bq)

        def local(index: int) -> _Vec:
            p = self._link_tf(robot, index)[0]
            return tuple(pb.multiplyTransforms(ip, iq, p, (0, 0, 0, 1))[0])  # type: ignore

        tx, ty, tz = local(self._links["torso_lift_link"][1])
        self._torso_xy = (tx, ty)
        self._torso_z0 = tz - h0
        self._pan_centre: dict[str, _Vec] = {}
        self._pan_radius: dict[str, float] = {}
        for arm, p in _ARM_PREFIX.items():
            cx, cy, cz = local(self._links[f"{p}_shoulder_pan_link"][1])
            sx, sy, _ = local(self._shoulder[arm])
            self._pan_centre[arm] = (cx, cy, cz - h0)
            self._pan_radius[arm] = math.hypot(sx - cx, sy - cy) + 1e-4
        a, b = _urdf.UPPER_ARM, _urdf.FOREARM
        elbow = self._limits[self._arm_joints["left"][3]]
        fold = max(abs(elbow[0]), abs(elbow[1]))
        reach_min = math.sqrt(a * a + b * b + 2 * a * b * math.cos(fold)) if fold < math.pi else 0
        margin = _REACH_MARGIN
        self._reach_max2 = (a + b + margin) ** 2
        self._reach_min2 = max(0.0, reach_min - margin) ** 2

    # ------------------------------------------------------------------ lifecycle
    def close(self) -> None:
        """Disconnect (idempotent)."""
        if self._closed:
            return
        self._closed = True
        for cid in (self._side, self._c):
            if cid >= 0:
                try:
                    pb.disconnect(physicsClientId=cid)
                except pb.error:  # pragma: no cover - already gone
                    pass
        self._side = -1

    def __enter__(self) -> World:
        self._check()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __del__(self) -> None:  # pragma: no cover - best effort
        try:
            self.close()
        except Exception:
            pass

    def _check(self) -> int:
        if self._closed:
            raise RuntimeError("this World is closed")
        return self._c

    @property
    def client(self) -> int:
        """The PyBullet client id (pass it as ``physicsClientId``)."""
        return self._check()

    @property
    def robot_body(self) -> int:
        return self._robot

    @property
    def kitchen_body(self) -> int:
        return self._kitchen

    def body_of(self, name: str) -> int:
        """PyBullet body id of an object, ``"pr2"`` or ``"kitchen"``; unknown ->
        :class:`LookupError`."""
        self._check()
        if name == ROBOT:
            return self._robot
        if name == KITCHEN:
            return self._kitchen
        return self._obj(name).body

    # ------------------------------------------------------------------ names, poses
    @property
    def objects(self) -> Mapping[str, str]:
        """Object name -> type (a read-only copy)."""
        self._check()
        return MappingProxyType({n: o.type for n, o in self._objects.items()})

    @property
    def link_names(self) -> tuple[str, ...]:
        return tuple(self._links)

    @property
    def attachments(self) -> Mapping[str, str]:
        """Attached object name -> link name."""
        return MappingProxyType({n: link for n, (link, _) in self._attached.items()})

    def _obj(self, name: str) -> _Obj:
        try:
            return self._objects[name]
        except (KeyError, TypeError):
            raise LookupError(
                f"no object {name!r} in the world; objects: {', '.join(self._objects) or 'none'}"
            ) from None

    def _link(self, link: str) -> tuple[int, int]:
        try:
            return self._links[link]
        except (KeyError, TypeError):
            close = difflib.get_close_matches(str(link), self._links, n=5, cutoff=0.5)
            hint = f"; did you mean {', '.join(close)}?" if close else ""
            raise LookupError(f"unknown link {link!r}{hint}") from None

    def _link_tf(self, body: int, index: int) -> _Tf:
        c = self._c
        if index < 0:
            pos, orn = pb.getBasePositionAndOrientation(body, physicsClientId=c)
            return tuple(pos), tuple(orn)  # type: ignore[return-value]
        s = pb.getLinkState(body, index, computeForwardKinematics=1, physicsClientId=c)
        return tuple(s[4]), tuple(s[5])  # type: ignore[return-value]

    def _base_tf(self) -> _Tf:
        x, y, yaw = self._base
        return (x, y, 0.0), _yaw_quat(yaw)

    def _to_map(self, pose: Pose) -> _Tf:
        if not isinstance(pose, Pose):
            raise TypeError(f"expected an executive Pose, got {type(pose).__name__}")
        if pose.frame == "map":
            return pose.position, pose.orientation
        if pose.frame == "base_footprint":
            bp, bq = self._base_tf()
            pos, orn = pb.multiplyTransforms(bp, bq, pose.position, pose.orientation)
            return tuple(pos), tuple(orn)  # type: ignore[return-value]
        raise ValueError(f"unsupported frame {pose.frame!r}; known frames: {', '.join(FRAMES)}")

    def _express(self, tf: _Tf, frame: str) -> Pose:
        if frame == "map":
            return Pose(tf[0], tf[1], "map")
        if frame == "base_footprint":
            bp, bq = self._base_tf()
            ip, iq = pb.invertTransform(bp, bq)
            pos, orn = pb.multiplyTransforms(ip, iq, tf[0], tf[1])
            return Pose(pos, orn, "base_footprint")
        raise ValueError(f"unsupported frame {frame!r}; known frames: {', '.join(FRAMES)}")

    def object_pose(self, name: str, frame: str = "map") -> Pose:
        """An object's pose in ``map`` or ``base_footprint``; unknown -> LookupError."""
        self._check()
        pos, orn = pb.getBasePositionAndOrientation(self._obj(name).body, physicsClientId=self._c)
        return self._express((tuple(pos), tuple(orn)), frame)  # type: ignore[arg-type]

    def robot_pose(self) -> Pose:
        """``base_footprint`` in ``map``."""
        self._check()
        p, q = self._base_tf()
        return Pose(p, q, "map")

    def link_pose(self, link: str, frame: str = "map") -> Pose:
        """A robot or kitchen link's frame; unknown -> LookupError naming close matches."""
        self._check()
        return self._express(self._link_tf(*self._link(link)), frame)

    def link_aabb(self, link: str) -> tuple[_Vec, _Vec]:
        """The world AABB (min, max) of a link's collision shapes."""
        self._check()
        body, index = self._link(link)
        lo, hi = pb.getAABB(body, index, physicsClientId=self._c)
        return tuple(lo), tuple(hi)  # type: ignore[return-value]

    def object_aabb(self, name: str) -> tuple[_Vec, _Vec]:
        self._check()
        lo, hi = pb.getAABB(self._obj(name).body, -1, physicsClientId=self._c)
        return tuple(lo), tuple(hi)  # type: ignore[return-value]

    def joint_position(self, joint: str) -> float:
        """A robot or kitchen joint's position; unknown -> LookupError."""
        self._check()
        if joint in self._robot_joints:
            return float(pb.getJointState(self._robot, self._robot_joints[joint],
                                          physicsClientId=self._c)[0])
        if joint in self._kitchen_joints:
            return float(pb.getJointState(self._kitchen, self._kitchen_joints[joint],
                                          physicsClientId=self._c)[0])
        known = [*self._robot_joints, *self._kitchen_joints]
        close = difflib.get_close_matches(str(joint), known, n=5, cutoff=0.5)
        raise LookupError(f"unknown joint {joint!r}; close matches: {', '.join(close) or 'none'}")

    def arm_joints(self, arm: str) -> tuple[float, ...]:
        """The 7 arm joint values (``knowledge.ARM_JOINTS`` order)."""
        self._check()
        return self._get_joints(self._arm_joints[self._arm(arm)])

    @property
    def torso_height(self) -> float:
        self._check()
        return self._get_joints([self._torso])[0]

    def gripper_opening(self, arm: str) -> float:
        """Distance between the finger pads (m) = sum of both finger joints."""
        self._check()
        return float(sum(self._get_joints(self._fingers[self._arm(arm)])))

    # ------------------------------------------------------------------ registry
    def spawn_object(self, name: str, type: str, pose: Pose) -> str:
        """Add an object of a known type at ``pose`` (map or base_footprint), at rest.
        Duplicate name -> ValueError; unknown type -> LookupError naming the known ones;
        NaN pose -> ValueError. The world is unchanged on error."""
        c = self._check()
        if not isinstance(name, str) or not name or name in (ROBOT, KITCHEN):
            raise ValueError(f"object name must be a non-empty string other than pr2/kitchen, "
                             f"got {name!r}")
        if name in self._objects:
            raise ValueError(f"an object called {name!r} already exists")
        otype = object_type(type)
        pos, orn = self._to_map(pose)
        body = pb.loadURDF(str(ASSETS / "objects" / otype.urdf_name), pos, orn, physicsClientId=c)
        self._objects[name] = _Obj(otype.name, body)
        self._bodies[body] = name
        return name

    def remove_object(self, name: str) -> None:
        """Remove an object (and its attachment); unknown -> LookupError."""
        self._check()
        obj = self._obj(name)
        pb.removeBody(obj.body, physicsClientId=self._c)
        del self._objects[name]
        del self._bodies[obj.body]
        self._attached.pop(name, None)

    def set_object_pose(self, name: str, pose: Pose) -> None:
        """Teleport an object (velocities zeroed); attached objects keep their link."""
        self._check()
        obj = self._obj(name)
        pos, orn = self._to_map(pose)
        pb.resetBasePositionAndOrientation(obj.body, pos, orn, physicsClientId=self._c)
        pb.resetBaseVelocity(obj.body, (0, 0, 0), (0, 0, 0), physicsClientId=self._c)
        if name in self._attached:
            self._attach_rel(name, self._attached[name][0])

    # ------------------------------------------------------------------ attachments
    def attach(self, name: str, link: str) -> None:
        """Attach an object rigidly to a robot or kitchen link (at their current relative
        pose); an existing attachment is replaced (CRAM detaches from the kitchen first).
        Unknown object or link -> LookupError."""
        self._check()
        self._obj(name)
        self._link(link)
        self._attach_rel(name, link)

    def _attach_rel(self, name: str, link: str) -> None:
        lp, lq = self._link_tf(*self._links[link])
        op, oq = pb.getBasePositionAndOrientation(self._objects[name].body, physicsClientId=self._c)
        ip, iq = pb.invertTransform(lp, lq)
        rel = pb.multiplyTransforms(ip, iq, op, oq)
        self._attached[name] = (link, (tuple(rel[0]), tuple(rel[1])))  # type: ignore[arg-type]

    def detach(self, name: str, settle_steps: int = 10) -> None:
        """Release an attached object and let it settle for ``settle_steps`` physics steps
        (1/240 s each). Only that object moves: every other object is put back exactly
        where it was, and it does not collide with the robot while settling. Not attached ->
        ValueError; unknown -> LookupError."""
        c = self._check()
        obj = self._obj(name)
        if name not in self._attached:
            raise ValueError(f"object {name!r} is not attached; attached: "
                             f"{', '.join(self._attached) or 'none'}")
        if settle_steps < 0:
            raise ValueError(f"settle_steps must be >= 0, got {settle_steps}")
        del self._attached[name]
        pb.resetBaseVelocity(obj.body, (0, 0, 0), (0, 0, 0), physicsClientId=c)
        if settle_steps:
            self._settle([name], settle_steps)

    def _settle(self, names: Sequence[str], steps: int) -> None:
        c = self._c
        movers = {self._objects[n].body for n in names}
        frozen = [
            (o.body, pb.getBasePositionAndOrientation(o.body, physicsClientId=c))
            for o in self._objects.values()
            if o.body not in movers
        ]
        robot_q = self._get_joints(self._dofs)
        kitchen_idx = list(self._kitchen_joints.values())
        kitchen_q = self._get_joints(kitchen_idx, self._kitchen)
        robot_links = [-1, *range(pb.getNumJoints(self._robot, physicsClientId=c))]
        for b in movers:
            for li in robot_links:
                pb.setCollisionFilterPair(self._robot, b, li, -1, 0, physicsClientId=c)
        try:
            for _ in range(steps):
                pb.stepSimulation(physicsClientId=c)
        finally:
            for b in movers:
                for li in robot_links:
                    pb.setCollisionFilterPair(self._robot, b, li, -1, 1, physicsClientId=c)
            for body, (pos, orn) in frozen:
                pb.resetBasePositionAndOrientation(body, pos, orn, physicsClientId=c)
                pb.resetBaseVelocity(body, (0, 0, 0), (0, 0, 0), physicsClientId=c)
            # joints are not held by motors here: put them back exactly
            self._set_joints(self._dofs, robot_q)
            self._set_joints(kitchen_idx, kitchen_q, self._kitchen)
        self._update_attached()

    def _update_attached(self, owner: int | None = None) -> None:
        c = self._c
        for name, (link, (rp, rq)) in self._attached.items():
            body, index = self._links[link]
            if owner is not None and body != owner:
                continue
            lp, lq = self._link_tf(body, index)
            pos, orn = pb.multiplyTransforms(lp, lq, rp, rq)
            ob = self._objects[name].body
            pb.resetBasePositionAndOrientation(ob, pos, orn, physicsClientId=c)
            pb.resetBaseVelocity(ob, (0, 0, 0), (0, 0, 0), physicsClientId=c)

    # ------------------------------------------------------------------ joints helpers
    def _get_joints(self, indices: Sequence[int], body: int | None = None) -> tuple[float, ...]:
        states = pb.getJointStates(
            self._robot if body is None else body, indices, physicsClientId=self._c
        )
        return tuple(float(s[0]) for s in states)

    def _set_joints(self, indices: Sequence[int], values: Sequence[float],
                    body: int | None = None) -> None:
        b = self._robot if body is None else body
        for i, v in zip(indices, values):
            pb.resetJointState(b, i, v, 0.0, physicsClientId=self._c)

    def _reset_base(self, x: float, y: float, yaw: float) -> None:
        pb.resetBasePositionAndOrientation(
            self._robot, (x, y, 0.0), _yaw_quat(yaw), physicsClientId=self._c
        )
        self._base = (x, y, yaw)

    @staticmethod
    def _arm(arm: str) -> str:
        if arm not in _ARM_PREFIX:
            raise ValueError(f"unknown arm {arm!r}; known arms: left, right")
        return arm

    def _arms(self, arm: str | Sequence[str]) -> list[str]:
        arms = [arm] if isinstance(arm, str) else list(arm)
        if not arms:
            raise ValueError("no arm given; known arms: left, right")
        return [self._arm(a) for a in arms]

    # ------------------------------------------------------------------ collisions
    def contacts(self, name: str, tolerance: float = COLLISION_TOLERANCE) -> list[Contact]:
        """Current contacts of ``name`` (object, ``"pr2"`` or ``"kitchen"``) penetrating
        more than ``tolerance``; runs collision detection first."""
        c = self._check()
        body = self.body_of(name)
        pb.performCollisionDetection(physicsClientId=c)
        return [self._contact(q) for q in pb.getContactPoints(bodyA=body, physicsClientId=c)
                if q[8] < -tolerance]

    def _contact(self, q: Sequence[Any]) -> Contact:
        def lname(body: int, index: int) -> str:
            if body in (self._robot, self._kitchen):
                return self._link_names.get((body, index), str(index))
            return "object"

        def bname(body: int) -> str:
            return "floor" if body == self._floor else self._bodies.get(body, str(body))

        return Contact(bname(q[1]), lname(q[1], q[3]), bname(q[2]), lname(q[2], q[4]),
                       float(q[8]))

    def robot_collisions(self, ignore: Iterable[str] = ()) -> list[Contact]:
        """Collisions of the robot, and of objects attached to robot links, with anything
        except each other and the names in ``ignore``."""
        c = self._check()
        pb.performCollisionDetection(physicsClientId=c)
        return self._collisions(set(ignore), first_only=False)

    def robot_in_collision(self, ignore: Iterable[str] = ()) -> bool:
        """Whether :meth:`robot_collisions` is non-empty (faster: stops at the first)."""
        c = self._check()
        pb.performCollisionDetection(physicsClientId=c)
        return bool(self._collisions(set(ignore), first_only=True))

    def _collisions(self, ignore: set[str], first_only: bool) -> list[Contact]:
        c = self._c
        robot = self._robot
        carried = {self._objects[n].body for n, (link, _) in self._attached.items()
                   if self._links[link][0] == robot}
        skip = carried | {robot} | {self.body_of(n) for n in ignore if n in self._objects or
                                    n == KITCHEN}
        out: list[Contact] = []
        tol = -COLLISION_TOLERANCE
        for q in pb.getContactPoints(bodyA=robot, physicsClientId=c):
            if q[8] < tol and q[2] not in skip:
                out.append(self._contact(q))
                if first_only:
                    return out
        for b in carried:
            for q in pb.getContactPoints(bodyA=b, physicsClientId=c):
                if q[8] < tol and q[2] not in skip:
                    out.append(self._contact(q))
                    if first_only:
                        return out
        return out

    # ------------------------------------------------------------------ navigation
    def drive(self, pose: Pose) -> None:
        """Teleport the base to ``pose`` (map or base_footprint; z, roll and pitch are
        ignored); attached objects follow. If the robot or an object it carries then
        collides with anything else, the previous pose is restored and
        :class:`NavigationPoseUnreachable` (``location=pose``) is raised."""
        self._check()
        pos, orn = self._to_map(pose)
        c = self._c
        prev = self._base
        carried = []
        if self._attached:
            carried = [(b, pb.getBasePositionAndOrientation(b, physicsClientId=c))
                       for b in (self._objects[n].body for n in self._attached)]
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
        """Set ``torso_lift_joint``. A goal outside [0, 0.33] by more than 1e-4 ->
        :class:`TorsoGoalNotReached` (``torso=height``), world unchanged."""
        self._check()
        (h,) = _finite([height], "torso height")
        lo, hi = self._limits[self._torso]
        clamped = min(max(h, lo), hi)
        if abs(clamped - h) > 1e-4:
            raise TorsoGoalNotReached(
                f"torso height {h:.4f} outside [{lo}, {hi}]", torso=height
            )
        self._set_joints([self._torso], [clamped])
        self._update_attached(self._robot)

    def move_joints(self, left: Sequence[float] | None = None,
                    right: Sequence[float] | None = None) -> None:
        """Set the 7 arm joints of the given sides. Wrong length, non-finite values or
        values outside the joint limits -> ValueError naming them; world unchanged."""
        self._check()
        goals: list[tuple[list[int], tuple[float, ...]]] = []
        for arm, values in (("left", left), ("right", right)):
            if values is None:
                continue
            vals = _finite(values, f"{arm} arm joints")
            if len(vals) != 7:
                raise ValueError(f"{arm} arm needs 7 joint values "
                                 f"({', '.join(knowledge.ARM_JOINTS)}), got {len(vals)}")
            indices = self._arm_joints[arm]
            for i, v, jname in zip(indices, vals, knowledge.ARM_JOINTS):
                lo, hi = self._limits[i]
                if not lo - 1e-6 <= v <= hi + 1e-6:
                    raise ValueError(f"{arm} {jname} = {v:.4f} outside [{lo}, {hi}]")
            goals.append((indices, vals))
        for indices, vals in goals:
            self._set_joints(indices, vals)
        self._update_attached(self._robot)

    def set_arm_configuration(self, name: str, arms: str | Sequence[str] = ("left", "right")
                              ) -> None:
        """Put arms into a named configuration ("park", "carry"); unknown -> LookupError."""
        self._check()
        chosen = self._arms(arms)
        values = {a: knowledge.arm_configuration(name, a) for a in chosen}
        self.move_joints(values.get("left"), values.get("right"))

    def park_arms(self, configuration: str = "park") -> None:
        """Both arms to ``configuration`` (CRAM's park-arms; CRAM defaults to carrying)."""
        self.set_arm_configuration(configuration)

    def move_tcp(self, left: Pose | None = None, right: Pose | None = None) -> None:
        """Move the tool frames (``?_gripper_tool_frame``) to the given poses (map or
        base_footprint) by IK verified with FK (< 1 cm, < 0.1 rad), trying the current
        torso height first, then the other heights of the :data:`TORSO_STEP` grid from the
        upper limit down, skipping heights at which a goal's wrist is provably out of the
        arm's reach. With both arms, both must succeed at the same height. No collision
        check (as CRAM HEAD). Unreachable -> :class:`ManipulationPoseUnreachable`, robot
        unchanged. IK results are memoised per world (see :meth:`_solve_arm_cached`)."""
        self._check()
        goals = {arm: self._to_map(p) for arm, p in (("left", left), ("right", right))
                 if p is not None}
        if not goals:
            return
        saved = self._get_joints(self._dofs)
        current = saved[self._torso_slot]
        lo, hi = self._limits[self._torso]
        heights = [current]
        h = hi
        while h > lo - 1e-9:
            if abs(h - current) > 1e-6:
                heights.append(h)
            h -= TORSO_STEP
        if abs(heights[-1] - lo) > 1e-6 and abs(current - lo) > 1e-6:
            heights.append(lo)
        # goals in base_footprint (the IK result depends only on the robot-relative
        # target, the torso height and the seed, never on the rest of the world)
        local = {arm: self._in_base(pos, orn) for arm, (pos, orn) in goals.items()}
        wrists = {arm: _wrist_point(p, q) for arm, (p, q) in local.items()}
        torso_set = current
        try:
            for h in heights:
                if not all(self._in_reach(arm, wrists[arm], h) for arm in goals):
                    continue
                if h != torso_set:
                    self._set_joints([self._torso], [h])
                    torso_set = h
                solutions = {}
                for arm, (pos, orn) in goals.items():
                    q = self._solve_arm_cached(arm, pos, orn, local[arm], h, saved)
                    if q is None:
                        break
                    solutions[arm] = q
                else:
                    for arm, q in solutions.items():
                        self._set_joints(self._arm_joints[arm], q)
                    self._update_attached(self._robot)
                    return
        except BaseException:
            self._set_joints(self._dofs, saved)
            raise
        self._set_joints(self._dofs, saved)
        raise ManipulationPoseUnreachable(
            "no IK solution at any torso height", left=left, right=right
        )

    # IK internals ----------------------------------------------------------------
    def _in_base(self, pos: Sequence[float], orn: Sequence[float]) -> _Tf:
        """A map pose in base_footprint (the robot is always upright: yaw only)."""
        x, y, yaw = self._base
        cy, sy = math.cos(yaw), math.sin(yaw)
        dx, dy = pos[0] - x, pos[1] - y
        q = _quat_mul((0.0, 0.0, -math.sin(yaw / 2.0), math.cos(yaw / 2.0)), orn)
        return (cy * dx + sy * dy, -sy * dx + cy * dy, float(pos[2])), q

    def _in_reach(self, arm: str, wrist: _Vec, height: float) -> bool:
        """False only when no arm configuration at torso ``height`` can put the wrist
        (``?_wrist_flex_link``, :data:`_urdf.TOOL_X` behind the tool frame) within the FK
        tolerances of ``wrist`` (base_footprint): the shoulder-lift joint lies on a circle
        of radius ``r`` about the shoulder-pan axis whatever the pan angle, and the wrist is
        between the folded (elbow at its limit) and the stretched arm length from it.
        Sound by construction: pan and the other limits are ignored, with a margin of
        the 1 cm / 0.1 rad verification tolerance (0.01 + 0.1 * TOOL_X)."""
        cx, cy, cz = self._pan_centre[arm]
        dx, dy = wrist[0] - cx, wrist[1] - cy
        dz = wrist[2] - (cz + height)
        rxy = math.hypot(dx, dy)
        r = self._pan_radius[arm]
        near2 = (rxy - r) ** 2 + dz * dz
        far2 = (rxy + r) ** 2 + dz * dz
        return near2 <= self._reach_max2 and far2 >= self._reach_min2

    def _solve_arm_cached(self, arm: str, pos: Sequence[float], orn: Sequence[float],
                          local: _Tf, height: float, saved: Sequence[float]
                          ) -> tuple[float, ...] | None:
        """:meth:`_solve_arm` memoised per world (LRU, :attr:`ik_cache_size` entries).

        The key is the arm, the goal in ``torso_lift_link`` (base_footprint goal shifted by
        the torso height; rounded to 1e-4 m / 1e-4 in the quaternion) and the seed (the
        arm's joints before the call, rounded to 1e-4 rad): the solver's answer depends on
        nothing else (the base pose only by a rigid transform, objects not at all), so a
        goal reached at torso ``h`` and a goal ``dz`` higher at ``h + dz`` share an entry.
        A cached solution is applied and FK-verified against the exact goal (a failure
        falls back to a fresh solve); a cached "no solution" is trusted for goals within
        the rounding of the one that was solved."""
        size = self.ik_cache_size
        if size <= 0:
            return self._solve_arm(arm, pos, orn, saved)
        slots = self._arm_slots[arm]
        (x, y, z), q = local
        if q[3] < 0 or (q[3] == 0 and (q[0], q[1], q[2]) < (0.0, 0.0, 0.0)):
            q = (-q[0], -q[1], -q[2], -q[3])
        key = (
            arm,
            round((x - self._torso_xy[0]) * 1e4), round((y - self._torso_xy[1]) * 1e4),
            round((z - self._torso_z0 - height) * 1e4),
            round(q[0] * 1e4), round(q[1] * 1e4), round(q[2] * 1e4), round(q[3] * 1e4),
            *(round(saved[k] * 1e4) for k in slots),
        )
        cache = self._ik_cache
        if key in cache:
            hit = cache[key]
            cache.move_to_end(key)
            if hit is None:
                self.ik_cache_stats["hits"] += 1
                return None
            if self._verify(arm, hit, pos, orn):
                self.ik_cache_stats["hits"] += 1
                return hit
            self._set_joints(self._arm_joints[arm], [saved[k] for k in slots])
        self.ik_cache_stats["misses"] += 1
        sol = self._solve_arm(arm, pos, orn, saved)
        cache[key] = sol
        if len(cache) > size:
            cache.popitem(last=False)
        return sol

    def _verify(self, arm: str, q: Sequence[float], pos: Sequence[float],
                orn: Sequence[float]) -> bool:
        """Set the arm to ``q`` and check the tool frame by FK (< 1 cm, < 0.1 rad)."""
        self._set_joints(self._arm_joints[arm], q)
        s = pb.getLinkState(self._robot, self._tool[arm], computeForwardKinematics=1,
                            physicsClientId=self._c)
        return math.dist(s[4], pos) < 0.01 and _angle(s[5], orn) < 0.1

    def _seed_order(self, arm: str, pos: Sequence[float], start: tuple[float, ...]) -> list[
        tuple[float, ...]
    ]:
        """IK seeds for a goal at ``pos`` (map), nearest first: the arm's current joints
        and the seed library, ordered by how far each one's tool frame (in the torso frame,
        so independent of base pose and torso height) is from the goal. A nearby start
        (consecutive waypoints) stays first; a distant goal starts from the library seed
        whose hand is already near it, instead of from wherever the arm happens to be."""
        library = self._seed_tools.get(arm)
        indices = self._arm_joints[arm]
        tool = self._tool[arm]
        torso = self._links["torso_lift_link"]
        if library is None:
            library = []
            for seed in self._ik_seeds[arm]:
                self._set_joints(indices, seed)
                library.append(self._in_torso(self._link_tf(self._robot, tool)[0], torso))
            self._set_joints(indices, start)
            self._seed_tools[arm] = library
        self._set_joints(indices, start)
        goal = self._in_torso(pos, torso)
        here = self._in_torso(self._link_tf(self._robot, tool)[0], torso)
        ranked = sorted(
            [(math.dist(here, goal), -1, start)]
            + [(math.dist(t, goal), i, s) for i, (t, s) in enumerate(
                zip(library, self._ik_seeds[arm]))],
            key=lambda e: (e[0], e[1]),
        )
        return [seed for _, _, seed in ranked]

    def _in_torso(self, point: Sequence[float], torso: tuple[int, int]) -> tuple[float, ...]:
        tp, tq = self._link_tf(*torso)
        ip, iq = pb.invertTransform(tp, tq)
        local, _ = pb.multiplyTransforms(ip, iq, point, (0.0, 0.0, 0.0, 1.0))
        return tuple(local)

    def clear_ik_cache(self) -> None:
        """Forget every memoised IK result of this world (see :meth:`move_tcp`)."""
        self._ik_cache.clear()

    def _solve_arm(self, arm: str, pos: Sequence[float], orn: Sequence[float],
                   saved: Sequence[float]) -> tuple[float, ...] | None:
        """IK for one arm at the current torso; the arm is left at the solution or at its
        saved values when there is none."""
        c = self._c
        robot = self._robot
        indices = self._arm_joints[arm]
        tool = self._tool[arm]
        damping = self._ik_damping[arm]
        slots = self._arm_slots[arm]
        limits = [self._limits[i] for i in indices]
        start = tuple(saved[k] for k in slots)
        seeds = self._seed_order(arm, pos, start)
        for seed in seeds:
            self._set_joints(indices, seed)
            sol = pb.calculateInverseKinematics(
                robot, tool, pos, orn, jointDamping=damping, maxNumIterations=100,
                residualThreshold=1e-4, physicsClientId=c,
            )
            q = tuple(_into_limits(sol[k], lo, hi) for k, (lo, hi) in zip(slots, limits))
            if self._verify(arm, q, pos, orn):
                return q
        self._set_joints(indices, start)
        return None

    # ------------------------------------------------------------------ grippers
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
                raise ValueError(f"unknown gripper action {action!r}; known: open, close, grip, "
                                 "or an opening in metres")
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
                if pb.getClosestPoints(self._robot, obj.body, distance, li, -1,
                                       physicsClientId=c):
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
                    if pb.getClosestPoints(self._robot, obj.body, 5e-4, li, -1,
                                           physicsClientId=c):
                        return

    # ------------------------------------------------------------------ head
    def look_at(self, target: Pose | str) -> None:
        """Point the camera (optical z) at a Pose (map or base_footprint), at a link's
        origin (a link name), or ``"forward"`` (pan = tilt = 0). Pan/tilt beyond their
        limits by > 1e-5 -> :class:`PtuGoalNotReached` (``target=...``), head unchanged."""
        self._check()
        if isinstance(target, str):
            if target == "forward":
                self._set_joints([self._pan, self._tilt], [0.0, 0.0])
                return
            point = self._link_tf(*self._link(target))[0]
        else:
            point = self._to_map(target)[0]
        pan, tilt = self._ptu_angles(point)
        (plo, phi), (tlo, thi) = self._limits[self._pan], self._limits[self._tilt]
        cpan, ctilt = min(max(pan, plo), phi), min(max(tilt, tlo), thi)
        if abs(cpan - pan) > 1e-5 or abs(ctilt - tilt) > 1e-5:
            raise PtuGoalNotReached(
                f"pan {pan:.3f} / tilt {tilt:.3f} beyond the limits", target=target
            )
        self._set_joints([self._pan, self._tilt], [pan, tilt])

    def _ptu_angles(self, point: Sequence[float]) -> tuple[float, float]:
        tp, tq = self._link_tf(*self._links["torso_lift_link"])
        ip, iq = pb.invertTransform(tp, tq)
        p_t = np.asarray(pb.multiplyTransforms(ip, iq, point, (0, 0, 0, 1))[0])
        d = p_t - np.asarray(_urdf.HEAD_PAN_XYZ)
        pan = math.atan2(d[1], d[0])
        if math.hypot(d[0], d[1]) < 1e-9:
            pan = 0.0
        # target in the pan frame, relative to the tilt axis
        cp, sp = math.cos(pan), math.sin(pan)
        q = np.array([cp * d[0] + sp * d[1], -sp * d[0] + cp * d[1], d[2]])
        q -= np.asarray(_urdf.HEAD_TILT_XYZ)
        cx, _, cz = _urdf.CAMERA_XYZ
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
        the camera sees: rays from ``head_mount_kinect_rgb_optical_frame`` to a 3x3x3
        grid in the object's AABB; a ray that first hits the object is a visible sample
        only inside CRAM's 50° x 73° (320x200) frustum; a ray that hits something else
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
        cands = [(n, o) for n, o in self._objects.items()
                 if o.type == otype and (oname is None or n == oname)]
        found: list[PerceivedObject] = []
        if cands:
            cam_p, cam_q = self._link_tf(self._robot, self._camera)
            for n, o in cands:
                if self._visible(o.body, cam_p, cam_q) >= threshold:
                    map_tf = pb.getBasePositionAndOrientation(o.body, physicsClientId=c)
                    mpose = Pose(map_tf[0], map_tf[1], "map")
                    bpose = self._express((tuple(map_tf[0]), tuple(map_tf[1])), "base_footprint")  # type: ignore[arg-type]
                    found.append(PerceivedObject(n, o.type, bpose, mpose,
                                                 bpose.to_transform(n)))
        if not found:
            raise PerceptionObjectNotFound(f"no visible {otype}" + (f" named {oname}" if oname
                                           else ""), object=designator)
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
        gx, gy, gz = np.meshgrid(lo[0] + f * (hi[0] - lo[0]), lo[1] + f * (hi[1] - lo[1]),
                                 lo[2] + f * (hi[2] - lo[2]), indexing="ij")
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
        tan_y = math.tan(_CAMERA_FOV_Y / 2)
        with np.errstate(divide="ignore", invalid="ignore"):
            in_view = ((z > _CAMERA_NEAR) & (z < _CAMERA_FAR)
                       & (np.abs(local[:, 0] / z) <= tan_y * _CAMERA_ASPECT)
                       & (np.abs(local[:, 1] / z) <= tan_y))
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

    # ------------------------------------------------------------------ containers
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

    def set_container(self, link_or_joint: str, position: float) -> None:
        """Set a container joint to ``position`` (clamped to its limits)."""
        self._check()
        joint = self._container_joint(link_or_joint)
        (v,) = _finite([position], "position")
        lo, hi = self._kitchen_limits[joint]
        self._set_joints([self._kitchen_joints[joint]], [min(max(v, lo), hi)], self._kitchen)
        self._update_attached(self._kitchen)

    # ------------------------------------------------------------------ snapshots
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
            tuple(objs),  # type: ignore[arg-type]
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
                self.spawn_object(n, t, Pose(pos, orn, "map"))
                obj = self._objects[n]
            pb.resetBasePositionAndOrientation(obj.body, pos, orn, physicsClientId=c)
            pb.resetBaseVelocity(obj.body, lin, ang, physicsClientId=c)
        self._objects = {n: self._objects[n] for n, *_ in snap.objects}  # snapshot order
        self._attached = {n: (link, rel) for n, link, rel in snap.attachments}

    # ------------------------------------------------------------------ stability
    def placing_pose_stable(self, object_type_name: str, pose: Pose, steps: int = 600,
                            threshold: float = 0.2) -> bool:
        """Simulate an object of the type at ``pose`` in a side client holding only the
        kitchen (with this world's kitchen joint positions) for up to ``steps`` steps;
        stable unless it moved more than ``threshold`` metres. Stops early once the object
        is at rest. The main world is untouched. Unknown type -> LookupError."""
        self._check()
        otype = object_type(object_type_name)
        pos, orn = self._to_map(pose)
        side = self._side_client()
        for name, index in self._kitchen_joints.items():
            pb.resetJointState(self._side_kitchen, index,
                               self.joint_position(name), physicsClientId=side)
        body = pb.loadURDF(str(ASSETS / "objects" / otype.urdf_name), pos, orn,
                           physicsClientId=side)
        try:
            start = np.asarray(pos)
            still = 0
            for k in range(steps):
                pb.stepSimulation(physicsClientId=side)
                if k % 10 == 9:
                    now = pb.getBasePositionAndOrientation(body, physicsClientId=side)[0]
                    p_now = np.asarray(now)
                    if np.linalg.norm(p_now - start) > threshold:
                        return False
                    lin, ang = pb.getBaseVelocity(body, physicsClientId=side)
                    still = still + 1 if (np.linalg.norm(lin) < 1e-3 and
                                          np.linalg.norm(ang) < 1e-2) else 0
                    if still >= 3 and k >= 60:
                        return True
            p_end = np.asarray(pb.getBasePositionAndOrientation(body, physicsClientId=side)[0])
            return bool(np.linalg.norm(p_end - start) <= threshold)
        finally:
            pb.removeBody(body, physicsClientId=side)

    def _side_client(self) -> int:
        if self._side < 0:
            self._side = pb.connect(pb.DIRECT)
            pb.setGravity(0, 0, -9.81, physicsClientId=self._side)
            self._side_kitchen = pb.loadURDF(str(ASSETS / "kitchen.urdf"), useFixedBase=True,
                                             physicsClientId=self._side)
            _static_plane(self._side)
        return self._side

    def __iter__(self) -> Iterator[str]:
        return iter(self.objects)

    def __repr__(self) -> str:
        state = "closed" if self._closed else f"client {self._c}, {len(self._objects)} objects"
        return f"<World {state}>"


def _into_limits(v: float, lo: float, hi: float) -> float:
    """Wrap a full-turn joint (limits ±π) into its range, clamp the others."""
    if hi - lo >= 2 * math.pi - 1e-3:
        v = (v - lo) % (2 * math.pi) + lo
    return min(max(v, lo), hi)


def _takes_default(get: Any) -> bool:
    """Whether ``get`` accepts a default (dict.get and designators do)."""
    try:
        get("type", None)
    except TypeError:
        return False
    return True
