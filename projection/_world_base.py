"""The PyBullet client at the heart of a :class:`projection.World`: the robot, the
kitchen and the floor it loads, the names of their links and joints, frames
(``map``, ``base_footprint``), the object registry and attachments. The world's other
concepts (collisions, motions, IK, grippers, perception, containers, snapshots,
stability) are mixins on this base, in their own modules."""

from __future__ import annotations

import math
import os
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType
from typing import Any, Self

import numpy as np
import pybullet as pb

from executive._kitchen import KitchenDescription
from executive._pose import Pose
from executive._robot import ARM_NAMES, KinematicTree, RobotDescription, RobotDescriptionError
from kitchens import iai
from projection._geometry import Tf as _Tf
from projection._geometry import Vec as _Vec
from projection._geometry import yaw_quat as _yaw_quat
from projection._motion_memo import SweepMemo
from projection._names import UnknownName
from projection._objects import object_type
from robots import pr2

_REST = (0.0,)  # a joint's velocity after a reset

__all__ = [
    "ASSETS",
    "DEFAULT_TORSO",
    "FRAMES",
    "KITCHEN",
    "SPAWN_OVERLAP",
    "BadObjectPose",
    "SpawnOverlap",
    "WorldBase",
]

ASSETS = Path(__file__).resolve().parent / "assets"
#: The PR2-like robot's torso height in a new world (m): camera at 1.42 m. A world uses
#: its robot's ``torso.default``.
DEFAULT_TORSO = 0.15
FRAMES = ("map", "base_footprint")
KITCHEN = "kitchen"
#: How deep (m) a new object may reach into another object or the robot when spawned: more
#: is an overlap (:class:`SpawnOverlap`), which physics would resolve by throwing objects.
SPAWN_OVERLAP = 0.005


class BadObjectPose(ValueError):
    """``spawn_object`` / ``set_object_pose`` refused ``pose`` (the world is unchanged):
    not finite in ``map`` (a ``base_footprint`` pose too far away), outside the room, its
    centre under the floor or above :data:`MAX_OBJECT_HEIGHT`, or its centre inside a piece
    of furniture. Fields: ``name`` (the object), ``argument`` (``"pose"``)."""

    def __init__(self, message: str, name: str, argument: str = "pose") -> None:
        super().__init__(message)
        self.name = name
        self.argument = argument


#: How high (m) above the floor an object's centre may be put: nothing in the kitchen is
#: taller than ~2.1 m; higher is a typo, not a scene.
MAX_OBJECT_HEIGHT = 3.0
#: How deep (m) an object's centre may be inside a kitchen link before it is "inside the
#: furniture": objects stand on surfaces with their centre above them (the demo's cereal
#: box, CRAM's pose, has its centre right at the counter top).
FURNITURE_DEPTH = 0.01


class SpawnOverlap(ValueError):
    """``spawn_object`` would put the object into another object or the robot. Fields:
    ``name`` (the object not spawned), ``overlaps`` (what it would overlap)."""

    def __init__(self, message: str, name: str, overlaps: tuple[str, ...]) -> None:
        super().__init__(message)
        self.name = name
        self.overlaps = overlaps


@dataclass
class _Obj:
    type: str
    body: int


def _static_plane(client: int) -> int:
    """A static, infinite ground plane at z = 0 in ``client``."""
    shape = pb.createCollisionShape(pb.GEOM_PLANE, physicsClientId=client)
    return int(pb.createMultiBody(0, shape, physicsClientId=client))


class WorldBase:
    """The client, bodies, names, frames, registry and attachments of a
    :class:`projection.World` (see there)."""

    def __init__(
        self,
        seed: int | None = None,
        gui: bool = False,
        *,
        robot: RobotDescription | None = None,
        kitchen: KitchenDescription | None = None,
    ) -> None:
        if kitchen is None:
            kitchen = iai.DESCRIPTION
        if not isinstance(kitchen, KitchenDescription):
            raise TypeError(
                f"World(kitchen=...) takes an executive.KitchenDescription, got {kitchen!r}"
            )
        # the description is checked against the kitchen's URDF before anything is loaded
        kitchen.validate(KinematicTree.from_urdf(ASSETS / "kitchen.urdf"))
        #: The description of the kitchen this world holds: the surfaces, container and
        #: floor height the plans use by role, and the demo scene.
        self.kitchen: KitchenDescription = kitchen
        if robot is None:
            robot = pr2.DESCRIPTION
        if not isinstance(robot, RobotDescription):
            raise TypeError(f"World(robot=...) takes an executive.RobotDescription, got {robot!r}")
        #: The description of the robot this world holds: its body, joints, links,
        #: camera and initial state all come from it.
        self.robot: RobotDescription = robot
        # the URDF is parsed and the description checked against it before anything is
        # loaded: a misfit is a RobotDescriptionError naming the field, no client opened
        urdf = robot.urdf()
        robot.validate(KinematicTree.from_urdf(urdf))
        for arm_desc in robot.arms:
            for k, ik_seed in enumerate(arm_desc.ik_seeds):
                if len(ik_seed) != len(arm_desc.joints):
                    raise RobotDescriptionError(
                        robot.name,
                        f"arms[{arm_desc.name!r}].ik_seeds[{k}]",
                        f"has {len(ik_seed)} values for {len(arm_desc.joints)} joints "
                        f"({', '.join(arm_desc.joints)})",
                    )
        self._c = -1
        self._side = -1
        if seed is not None and (
            isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0
        ):
            raise ValueError(f"World(seed=...) takes None or an integer >= 0, got {seed!r}")
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
        self._kitchen: int = pb.loadURDF(
            str(ASSETS / "kitchen.urdf"), useFixedBase=True, physicsClientId=c
        )
        self._robot: int = pb.loadURDF(str(urdf), useFixedBase=True, physicsClientId=c)
        # PyBullet poses a body by its base's inertial frame; None when that is the root
        # link's own frame (then the base pose is set directly, as it always was)
        dyn = pb.getDynamicsInfo(self._robot, -1, physicsClientId=c)
        self._base_inertial: _Tf | None = (
            None
            if tuple(dyn[3]) == (0.0, 0.0, 0.0) and tuple(dyn[4]) == (0.0, 0.0, 0.0, 1.0)
            else (tuple(dyn[3]), tuple(dyn[4]))
        )
        # The floor: a static plane at z = 0, so that what falls lands somewhere. It is not
        # part of the kitchen (costmaps treat kitchen links as obstacles); resting contact
        # with the robot's base is within COLLISION_TOLERANCE and never counts.
        self._floor = _static_plane(c)
        # a 1 mm sphere shape (no body) for "is this point inside the furniture?" queries
        self._point_shape = pb.createCollisionShape(pb.GEOM_SPHERE, radius=0.001, physicsClientId=c)
        self._links: dict[str, tuple[int, int]] = {}
        self._kitchen_joints: dict[str, int] = {}
        self._robot_joints: dict[str, int] = {}
        self._limits: dict[int, tuple[float, float]] = {}
        self._parent_link: dict[int, int] = {}  # robot link index -> its parent's (-1: base)
        pairs = ((self._robot, self._robot_joints), (self._kitchen, self._kitchen_joints))
        for body, joints in pairs:
            base_name = pb.getBodyInfo(body, physicsClientId=c)[0].decode()
            self._links[base_name] = (body, -1)
            for i in range(pb.getNumJoints(body, physicsClientId=c)):
                info = pb.getJointInfo(body, i, physicsClientId=c)
                self._links[info[12].decode()] = (body, i)
                if body == self._robot:
                    self._parent_link[i] = int(info[16])
                if info[2] != pb.JOINT_FIXED:
                    joints[info[1].decode()] = i
                    if body == self._robot:
                        lo, hi = float(info[8]), float(info[9])
                        if lo > hi:  # PyBullet's continuous joint: no limits
                            lo, hi = -math.inf, math.inf
                        self._limits[i] = (lo, hi)
        self._kitchen_limits = {
            n: tuple(pb.getJointInfo(self._kitchen, i, physicsClientId=c)[8:10])
            for n, i in self._kitchen_joints.items()
        }
        self._link_names = {v: k for k, v in self._links.items()}
        # the robot's links below its base link -> their link index (what an object can
        # hang from; fixed once the body is loaded)
        self._robot_links: Mapping[str, int] = MappingProxyType(
            {n: i for n, (b, i) in self._links.items() if b == self._robot and i >= 0}
        )
        # invariant: the room, the xy hull of the kitchen's links (walls included); the
        # robot's base never leaves it (``drive`` refuses goals outside)
        boxes = [
            pb.getAABB(self._kitchen, i, physicsClientId=c)
            for i in range(-1, pb.getNumJoints(self._kitchen, physicsClientId=c))
        ]
        self._room = (
            min(lo[0] for lo, _ in boxes),
            min(lo[1] for lo, _ in boxes),
            max(hi[0] for _, hi in boxes),
            max(hi[1] for _, hi in boxes),
        )
        self._dofs = sorted(self._limits)  # movable robot joints, IK order
        # invariant: the robot's arms in CRAM's name order (left before right; a one-armed
        # robot has only "left"), every per-arm table below is keyed by exactly these
        self._sides: tuple[str, ...] = tuple(a for a in ARM_NAMES if a in robot.arm_names)
        self._arm_joints = {
            a: [self._robot_joints[j] for j in robot.arm(a).joints] for a in self._sides
        }
        self._fingers = {
            a: [self._robot_joints[j] for j in robot.arm(a).gripper.joints] for a in self._sides
        }
        self._tool = {a: self._links[robot.arm(a).tool_frame][1] for a in self._sides}
        self._hand = {a: self._links[robot.arm(a).hand_link][1] for a in self._sides}
        # the gripper: every link strictly below the arm's hand link (palm, fingers, tool)
        self._gripper_links = {
            a: [
                i
                for n, (b, i) in self._links.items()
                if b == self._robot and i != self._hand[a] and self._below(i, self._hand[a])
            ]
            for a in self._sides
        }
        # the same by name, and each arm's links (its first joint's link and below)
        self._gripper_link_names = {
            a: frozenset(self._link_names[(self._robot, i)] for i in self._gripper_links[a])
            for a in self._sides
        }
        self._arm_link_names = {
            a: frozenset(
                n
                for n, (b, i) in self._links.items()
                if b == self._robot and self._below(i, self._arm_joints[a][0])
            )
            for a in self._sides
        }
        self._torso = self._robot_joints[robot.torso.joint]
        self._torso_link = self._torso  # the torso joint's child link (same index)
        self._torso_slot = self._dofs.index(self._torso)
        self._pan = self._robot_joints[robot.neck.pan_joint]
        self._tilt = self._robot_joints[robot.neck.tilt_joint]
        self._camera = self._links[robot.neck.camera.frame][1]
        self._objects: dict[str, _Obj] = {}
        self._bodies: dict[int, str] = {self._robot: robot.name, self._kitchen: KITCHEN}
        self._attached: dict[str, tuple[str, _Tf]] = {}
        self._base: tuple[float, float, float] = (0.0, 0.0, 0.0)
        self._closed = False
        #: Whether the simulated controller (``projection._arm_planner``) plans free arm
        #: motions with OMPL (``projection._motion_planner``) rather than the straight
        #: line and its raised-via detours. On by default: the real robot plans every free
        #: arm motion (``controller_trajectory``) in its belief world; off, the old router.
        self.arm_motion_planning = True
        #: Planned motions that fell back to the old router (OMPL found no path, or the
        #: start or goal was in collision), each logged.
        self.motion_planning_fallbacks = 0
        #: Arm motions the simulated controller refused before moving because the path it
        #: did not plan (a tool line, a failed plan's fallback) would sweep a free object,
        #: and those leaving an object (a retract, a lift) that it stopped before they
        #: touched another (``_arm_planner``'s ``guard_path``), each logged.
        self.motions_refused = 0
        self.motions_truncated = 0
        # arm -> its ArmMotionPlanner (own PyBullet clients), built on first use, closed
        # with the world
        self._arm_planners: dict[str, Any] = {}
        #: What arm motions' controller paths sweep, remembered for this world (the
        #: probes and the arms process module ask it; ``projection._swept_motions``).
        self.sweep_memo = SweepMemo()
        # initial state: one base reset (so the fixed robot is tested against the fixed
        # kitchen from the start), arms in the initial state (parked), torso default,
        # grippers open, head forward
        self._reset_base(0.0, 0.0, 0.0)
        self._set_joints([self._torso], [robot.torso.default])
        for arm in self._sides:
            desc = robot.arm(arm)
            self._set_joints(self._arm_joints[arm], desc.state(robot.initial_state))
            self._set_joints(
                self._fingers[arm], [desc.gripper.open_position] * len(desc.gripper.joints)
            )
        forward = robot.neck.states["forward"]
        if forward != (0.0, 0.0):
            self._set_joints([self._pan, self._tilt], forward)
        self._init_reach_facts()
        #: the neck's rigid geometry for pointing the head: the pan joint in the torso
        #: link, the tilt joint in the pan link and the camera in the tilt link (each a
        #: joint origin, so whatever the pan and tilt; rounded to 1 µm: PyBullet's FK is
        #: float32-exact)
        self._neck: tuple[_Vec, _Vec, _Vec] = (
            self._origin_in(self._pan, self._torso_link),
            self._origin_in(self._tilt, self._pan),
            self._origin_in(self._camera, self._tilt),
        )

    def _init_reach_facts(self) -> None:
        """What the location costmaps need of the robot, read by FK from the new world
        (base at the origin, torso at its default, head forward)."""
        robot = self.robot
        # invariant: arm -> its first joint's origin (xy, base_footprint; rounded to 1 µm):
        # the shoulder the drawer costmaps measure the reach from
        self._shoulder_xy: dict[str, tuple[float, float]] = {}
        for a in self._sides:
            p = self._link_tf(self._robot, self._arm_joints[a][0])[0]
            self._shoulder_xy[a] = (round(p[0], 6) + 0.0, round(p[1], 6) + 0.0)
        lo = self._limits[self._torso][0]
        z = self._link_tf(self._robot, self._camera)[0][2]
        #: the camera's height over the floor at the lowest torso (head forward)
        self._camera_z0 = z - (robot.torso.default - lo)

    def shoulder_xy(self, arm: str) -> tuple[float, float]:
        """``arm``'s shoulder (its first joint's axis point) in ``base_footprint`` xy (the
        PR2-like robot: (-0.05, ±0.188))."""
        return self._shoulder_xy[self._arm(arm)]

    def camera_heights(self, count: int = 4) -> tuple[float, ...]:
        """``count`` camera heights (m, to the cm) over the torso's range, lowest first:
        where ``visible-for`` casts its rays from (the PR2-like robot: 1.27 .. 1.60)."""
        lo, hi = self._limits[self._torso]
        step = (hi - lo) / max(1, count - 1)
        return tuple(round(self._camera_z0 + step * k, 2) for k in range(count))

    def reach(self, arm: str | None = None) -> tuple[float, float]:
        """``(minimal_distance, in_reach_distance)`` of ``arm``'s :class:`executive.Reach`,
        or without an arm the widest over the robot's arms."""
        arms = self._sides if arm is None else (self._arm(arm),)
        reaches = [self.robot.arm(a).reach for a in arms]
        return (
            min(r.minimal_distance for r in reaches),
            max(r.in_reach_distance for r in reaches),
        )

    def arm_links(self, arm: str) -> frozenset[str]:
        """Names of ``arm``'s links: its first joint's link and everything below it
        (the PR2-like robot: the ``l_*``/``r_*`` links)."""
        return self._arm_link_names[self._arm(arm)]

    def gripper_links(self, arm: str) -> frozenset[str]:
        """Names of ``arm``'s gripper links: every link strictly below its hand link (the
        PR2-like robot: the ``?_gripper_*`` links)."""
        return self._gripper_link_names[self._arm(arm)]

    def _origin_in(self, link: int, frame: int) -> _Vec:
        """The origin of robot link ``link`` in the frame of robot link ``frame``."""
        fp, fq = self._link_tf(self._robot, frame)
        ip, iq = pb.invertTransform(fp, fq)
        p = pb.multiplyTransforms(ip, iq, self._link_tf(self._robot, link)[0], (0, 0, 0, 1))[0]
        return (round(p[0], 6) + 0.0, round(p[1], 6) + 0.0, round(p[2], 6) + 0.0)

    def _below(self, link: int, ancestor: int) -> bool:
        """Whether robot link index ``link`` is ``ancestor`` or hangs below it."""
        while link >= 0:
            if link == ancestor:
                return True
            link = self._parent_link[link]
        return ancestor == -1

    def motion_cache_counts(self) -> dict[str, int]:
        """How often this world's arm-motion answers were reused: ``plan_hits`` /
        ``plan_misses`` of its arms' OMPL plan caches (``ArmMotionPlanner.plan``),
        ``sweep_hits`` / ``sweep_misses`` of :attr:`sweep_memo` (the controller paths
        checked by the probes and the projected arms module), ``planning_fallbacks``
        (:attr:`motion_planning_fallbacks`: planned motions that took the old router) and
        ``graze_repairs`` (the plans that grazed the exact geometry and verified after
        their grazing states were forbidden: ``ArmMotionPlanner.repaired``),
        ``refused`` / ``truncated`` (:attr:`motions_refused`, :attr:`motions_truncated`).
        For the bench and the campaign report."""
        planners = list(self._arm_planners.values())
        return {
            "plan_hits": sum(p.cache_hits for p in planners),
            "plan_misses": sum(p.cache_misses for p in planners),
            "sweep_hits": self.sweep_memo.hits,
            "sweep_misses": self.sweep_memo.misses,
            "planning_fallbacks": self.motion_planning_fallbacks,
            "graze_repairs": sum(p.repaired for p in planners),
            "refused": self.motions_refused,
            "truncated": self.motions_truncated,
        }

    # ------------------------------------------------------------------ lifecycle
    def close(self) -> None:
        """Disconnect (idempotent)."""
        if self._closed:
            return
        self._closed = True
        for planner in self._arm_planners.values():
            planner.close()
        self._arm_planners.clear()
        for cid in (self._side, self._c):
            if cid >= 0:
                try:
                    pb.disconnect(physicsClientId=cid)
                except pb.error:  # pragma: no cover - already gone
                    pass
        self._side = -1

    def __enter__(self) -> Self:
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
        """PyBullet body id of an object, the robot (``world.robot.name``, e.g. ``"pr2"``)
        or ``"kitchen"``; unknown -> :class:`LookupError`."""
        self._check()
        if name == self.robot.name:
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
    def room(self) -> tuple[float, float, float, float]:
        """The room's floor in map xy, ``(x_min, y_min, x_max, y_max)``: the hull of the
        kitchen's links, walls included. The base does not drive outside it."""
        return self._room

    @property
    def link_names(self) -> tuple[str, ...]:
        return tuple(self._links)

    @property
    def robot_links(self) -> Mapping[str, int]:
        """The robot's links below its base link -> their PyBullet link index: the links
        an object held by the robot hangs from (an attachment to any other link is to the
        kitchen)."""
        return self._robot_links

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
            # the "did you mean" hint is built only if the message is read
            raise UnknownName("link", link, self._links) from None

    def _link_tf(self, body: int, index: int) -> _Tf:
        c = self._c
        if index < 0:
            pos, orn = pb.getBasePositionAndOrientation(body, physicsClientId=c)
            if body == self._robot and self._base_inertial is not None:
                pos, orn = pb.multiplyTransforms(
                    pos, orn, *pb.invertTransform(*self._base_inertial)
                )
            return tuple(pos), tuple(orn)
        s = pb.getLinkState(body, index, computeForwardKinematics=1, physicsClientId=c)
        return tuple(s[4]), tuple(s[5])

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
            return tuple(pos), tuple(orn)
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
        return self._express((tuple(pos), tuple(orn)), frame)

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
        return tuple(lo), tuple(hi)

    def object_aabb(self, name: str) -> tuple[_Vec, _Vec]:
        self._check()
        lo, hi = pb.getAABB(self._obj(name).body, -1, physicsClientId=self._c)
        return tuple(lo), tuple(hi)

    def joint_position(self, joint: str) -> float:
        """A robot or kitchen joint's position; unknown -> LookupError."""
        self._check()
        if joint in self._robot_joints:
            return float(
                pb.getJointState(self._robot, self._robot_joints[joint], physicsClientId=self._c)[0]
            )
        if joint in self._kitchen_joints:
            return float(
                pb.getJointState(
                    self._kitchen, self._kitchen_joints[joint], physicsClientId=self._c
                )[0]
            )
        raise UnknownName(
            "joint",
            joint,
            lambda: [*self._robot_joints, *self._kitchen_joints],
            style="close-matches",
        )

    def has_joint(self, joint: str) -> bool:
        """Whether the robot or the kitchen has a movable joint named ``joint`` (ask this
        instead of catching :meth:`joint_position`'s ``LookupError`` where a miss is
        expected)."""
        return joint in self._robot_joints or joint in self._kitchen_joints

    def arm_joint_limits(self, arm: str) -> tuple[tuple[str, float, float], ...]:
        """``(joint, lower, upper)`` of the arm's joints (its description's ``joints``
        order), from the robot's URDF: the limits :meth:`move_joints` enforces; a
        continuous joint (endless: the PR2's forearm and wrist roll) has ``-inf, inf``."""
        names = self.robot.arm(self._arm(arm)).joints
        return tuple(
            (name, *self._limits[i]) for name, i in zip(names, self._arm_joints[self._arm(arm)])
        )

    def arm_joints(self, arm: str) -> tuple[float, ...]:
        """The arm's joint values (its description's ``joints`` order)."""
        self._check()
        return self._get_joints(self._arm_joints[self._arm(arm)])

    @property
    def torso_height(self) -> float:
        self._check()
        return self._get_joints([self._torso])[0]

    def gripper_opening(self, arm: str) -> float:
        """Distance between the finger pads (m), from the finger joints' mean value by the
        arm's :class:`executive.GripperDescription` (the PR2-like robot: the sum of its
        two finger joints)."""
        self._check()
        g = self.robot.arm(self._arm(arm)).gripper
        q = self._get_joints(self._fingers[self._arm(arm)])
        if len(q) == 2 and g.closed_position == 0.0 and g.open_position * 2 == g.max_opening:
            # two fingers, each opening half the width: the width is their sum exactly
            return float(sum(q))
        mean = sum(q) / len(q)
        f = (mean - g.closed_position) / (g.open_position - g.closed_position)
        return float(f * g.max_opening) + 0.0  # closed: 0.0, not -0.0

    # ------------------------------------------------------------------ registry
    def spawn_object(self, name: str, type: str, pose: Pose, *, allow_overlap: bool = False) -> str:
        """Add an object of a known type at ``pose`` (map or base_footprint), at rest.
        Duplicate name -> ValueError; unknown type -> LookupError naming the known ones;
        NaN pose -> ValueError; reaching more than :data:`SPAWN_OVERLAP` into another
        object or the robot -> :class:`SpawnOverlap` (``allow_overlap=True`` skips that
        check, for probes and restores that check contacts themselves). The world is
        unchanged on error."""
        c = self._check()
        if not isinstance(name, str) or not name or name in (self.robot.name, KITCHEN):
            raise ValueError(
                f"object name must be a non-empty string other than {self.robot.name}/kitchen, "
                f"got {name!r}"
            )
        if name in self._objects:
            raise ValueError(f"an object called {name!r} already exists")
        otype = object_type(type)
        pos, orn = self._checked_pose(name, pose, check_scene=not allow_overlap)
        body = pb.loadURDF(str(ASSETS / "objects" / otype.urdf_name), pos, orn, physicsClientId=c)
        if not allow_overlap:
            overlaps = self._overlaps(body)
            if overlaps:
                pb.removeBody(body, physicsClientId=c)
                raise SpawnOverlap(
                    f"cannot spawn {name!r} at {tuple(round(v, 3) for v in pos)}: it would "
                    f"overlap {', '.join(overlaps)} (deeper than {SPAWN_OVERLAP} m); choose a "
                    "free pose (e.g. sample one with a location designator (for ...))",
                    name,
                    overlaps,
                )
        self._objects[name] = _Obj(otype.name, body)
        self._bodies[body] = name
        return name

    def _checked_pose(self, name: str, pose: Pose, *, check_scene: bool) -> _Tf:
        """``pose`` in map, or :class:`BadObjectPose` saying what is wrong with it. Always
        refused: a non-finite result; with ``check_scene``: a centre outside the room, under
        the floor, above :data:`MAX_OBJECT_HEIGHT` or inside a kitchen link."""
        if not isinstance(pose, Pose):
            raise TypeError(f"pose must be an executive.Pose, got {pose!r}")
        pos, orn = self._to_map(pose)
        where = f"({', '.join(f'{v:.6g}' for v in pos)})"
        if not all(map(math.isfinite, (*pos, *orn))):
            raise BadObjectPose(
                f"cannot put {name!r} at pose {pose!r}: it is {where} in map, not finite "
                "numbers (a base_footprint pose too far away?)",
                name,
            )
        if not check_scene:
            return pos, orn
        x0, y0, x1, y1 = self._room
        if not (x0 <= pos[0] <= x1 and y0 <= pos[1] <= y1):
            raise BadObjectPose(
                f"cannot put {name!r} at pose {where} (map): outside the room, x in "
                f"[{x0:.2f}, {x1:.2f}] and y in [{y0:.2f}, {y1:.2f}]",
                name,
            )
        if not 0.0 <= pos[2] <= MAX_OBJECT_HEIGHT:
            raise BadObjectPose(
                f"cannot put {name!r} at pose {where} (map): its centre must be between the "
                f"floor (z = 0) and {MAX_OBJECT_HEIGHT} m",
                name,
            )
        inside = self._furniture_at(pos)
        if inside is not None:
            raise BadObjectPose(
                f"cannot put {name!r} at pose {where} (map): its centre is inside the "
                f"kitchen's {inside}; put it on a surface or in a container",
                name,
            )
        return pos, orn

    def _furniture_at(self, point: Sequence[float]) -> str | None:
        """The kitchen link whose collision box holds ``point`` more than
        :data:`FURNITURE_DEPTH` deep, or None (a 1 mm sphere shape, no body)."""
        points = pb.getClosestPoints(
            -1,
            self._kitchen,
            0.0,
            collisionShapeA=self._point_shape,
            collisionShapePositionA=point,
            physicsClientId=self._c,
        )
        deepest = min(points, key=lambda q: q[8], default=None)
        if deepest is None or deepest[8] > -FURNITURE_DEPTH - 0.001:
            return None
        return self._link_names.get((self._kitchen, deepest[4]), "body")

    def _overlaps(self, body: int) -> tuple[str, ...]:
        """Names of the objects and the robot that ``body`` reaches into by more than
        :data:`SPAWN_OVERLAP` (the kitchen is not checked: objects stand on it)."""
        c = self._c
        found = []
        others = [(self.robot.name, self._robot)] + [(n, o.body) for n, o in self._objects.items()]
        for other_name, other in others:
            points = pb.getClosestPoints(body, other, 0.0, physicsClientId=c)
            if any(q[8] < -SPAWN_OVERLAP for q in points):
                found.append(other_name)
        return tuple(found)

    def remove_object(self, name: str) -> None:
        """Remove an object (and its attachment); unknown -> LookupError."""
        self._check()
        obj = self._obj(name)
        pb.removeBody(obj.body, physicsClientId=self._c)
        del self._objects[name]
        del self._bodies[obj.body]
        self._attached.pop(name, None)

    def set_object_pose(self, name: str, pose: Pose, *, allow_overlap: bool = False) -> None:
        """Teleport an object (velocities zeroed); attached objects keep their link. A pose
        outside the room, under the floor or inside furniture -> :class:`BadObjectPose`,
        world unchanged (``allow_overlap=True`` only refuses non-finite poses: for probes
        and belief updates that place objects where physics or perception put them)."""
        self._check()
        obj = self._obj(name)
        pos, orn = self._checked_pose(name, pose, check_scene=not allow_overlap)
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
        self._attached[name] = (link, (tuple(rel[0]), tuple(rel[1])))

    def detach(self, name: str, settle_steps: int = 10) -> None:
        """Release an attached object and let it settle for ``settle_steps`` physics steps
        (1/240 s each). Only that object moves: every other object is put back exactly
        where it was, and it does not collide with the robot while settling. Not attached ->
        ValueError; unknown -> LookupError."""
        c = self._check()
        obj = self._obj(name)
        if name not in self._attached:
            raise ValueError(
                f"object {name!r} is not attached; attached: {', '.join(self._attached) or 'none'}"
            )
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
        return tuple([s[0] for s in states])  # PyBullet gives Python floats

    def _set_joints(
        self,
        indices: Sequence[int],
        values: Sequence[float],
        body: int | None = None,
    ) -> None:
        """Reset joints ``indices`` of ``body`` (default: the robot) to ``values`` at rest.

        Several joints go in one ``resetJointStatesMultiDof``: Bullet then recomputes the
        body's link transforms and collider AABBs once, not once per joint (a 7-joint arm
        costs 4.5 µs instead of 24 µs alone, 5x that in the kitchen's broadphase). The
        outcome is a pure function of the arguments and the world's state, so runs stay
        reproducible; it is not bit-identical to N single resets (the broadphase sees one
        AABB update instead of N), which is why this changed the campaign's outcomes once,
        together with :data:`projection._world_ik.IK_ITERATIONS`. Repeated indices: the last
        value wins, as with single resets."""
        b = self._robot if body is None else body
        c = self._c
        if len(indices) == 1:
            pb.resetJointState(b, indices[0], values[0], 0.0, physicsClientId=c)
            return
        if not indices:
            return
        pb.resetJointStatesMultiDof(
            b,
            list(indices),
            [[v] for v in values],
            [_REST] * len(indices),
            physicsClientId=c,
        )

    def _reset_base(self, x: float, y: float, yaw: float) -> None:
        pos: Sequence[float] = (x, y, 0.0)
        orn: Sequence[float] = _yaw_quat(yaw)
        if self._base_inertial is not None:  # the root link's frame, not its inertial one
            pos, orn = pb.multiplyTransforms(pos, orn, *self._base_inertial)
        pb.resetBasePositionAndOrientation(self._robot, pos, orn, physicsClientId=self._c)
        self._base = (x, y, yaw)

    @property
    def arms(self) -> tuple[str, ...]:
        """The robot's arm names, left before right (a one-armed robot: ``("left",)``)."""
        return self._sides

    def _arm(self, arm: str) -> str:
        if arm not in self._sides:
            raise ValueError(f"unknown arm {arm!r}; known arms: {', '.join(self._sides)}")
        return arm

    def _arms(self, arm: str | Sequence[str]) -> list[str]:
        arms = [arm] if isinstance(arm, str) else list(arm)
        if not arms:
            raise ValueError(f"no arm given; known arms: {', '.join(self._sides)}")
        return [self._arm(a) for a in arms]

    def __iter__(self) -> Iterator[str]:
        return iter(self.objects)

    def __repr__(self) -> str:
        state = "closed" if self._closed else f"client {self._c}, {len(self._objects)} objects"
        return f"<World {state}>"
