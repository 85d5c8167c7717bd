"""The collision model an arm motion planner checks configurations against: a private
PyBullet client (never stepped) holding the robot (with self-collision), the kitchen and
every object of a :class:`projection.World` (the belief world: what the robot believes
in), objects held by the robot attached to their links, and an arm's joint chain read
from the loaded body by name (:class:`ArmChain`), so it serves any robot.

Measured and designed after the motion-planning reference note (OMPL 2.x + PyBullet):

- one check = one ``resetJointStatesMultiDof`` + the held objects' poses + one
  ``performCollisionDetection`` + ``getContactPoints`` of the robot and of each held
  object: tens of microseconds, about the same with 6 or 50 bodies (the broadphase
  prunes); per-pair ``getClosestPoints`` grows with the bodies;
- padding is by inflating the obstacles' primitives (``getContactPoints`` ignores a
  positive margin): the objects' and the kitchen links' boxes are static inflated copies
  (the kitchen URDF stays loaded for its names and joints but collides with nothing); the
  held objects are not inflated and are dynamic (mass > 0), since Bullet makes no
  contacts between two static bodies;
- self-collision: the robot is loaded with ``URDF_USE_SELF_COLLISION |
  URDF_USE_SELF_COLLISION_EXCLUDE_PARENT`` and only the chain's *checked pairs* count
  (:meth:`CollisionModel.self_pairs`): a link that the chain moves against any link it
  moves relative to, minus adjacent links (adjacency skips links without geometry: the
  PR2's wrist roll link has none, so the wrist flex link and the palm are adjacent) and
  minus pairs in contact in nearly every sampled configuration (MoveIt's Setup
  Assistant's "always in collision").
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Self

import numpy as np
import pybullet as pb

from projection._geometry import Tf
from projection._names import UnknownName
from projection._objects import object_type
from projection._world import ASSETS, World

__all__ = [
    "CONTACT_TOLERANCE",
    "PADDING",
    "QUANTUM",
    "QUANTUM_ANGLE",
    "ArmChain",
    "CollisionModel",
]

#: How far (m) obstacles are inflated in a planning model: at least half the largest tool
#: displacement between two checked states (0.05 rad moves the PR2's tool up to ~4 cm).
PADDING = 0.02
#: Penetration (m) beyond which a contact counts (resting contacts report about -1 mm).
CONTACT_TOLERANCE = 0.001
_DIGITS = 4  # rounding (m, rad) of the world digest
#: Quantum (m) of positions, and (rad, about) of orientations and joints, in a model's
#: :attr:`CollisionModel.coarse_digest`: worlds equal up to these share cached plans.
QUANTUM = 0.001
QUANTUM_ANGLE = 0.01
#: Random configurations sampled to find the self pairs that always touch.
_SELF_SAMPLES = 200
_ALWAYS = 0.95  # a pair touching in this fraction of the samples is never checked
#: Links up to this many geometric links apart in the tree are adjacent (never checked).
_ADJACENT_DEPTH = 2


def _quantised(
    position: Sequence[float], orientation: Sequence[float], joints: Sequence[float] = ()
) -> tuple[int, ...]:
    """A pose (and joint values) as integers: positions in :data:`QUANTUM` steps, the
    quaternion's components in QUANTUM_ANGLE / 2 steps (a component step of e turns by at
    most about 2e rad), joints in :data:`QUANTUM_ANGLE` steps. The quaternion's sign is
    fixed (w >= 0) so that equal rotations quantise alike."""
    q = list(orientation)
    if q[3] < 0.0 or (q[3] == 0.0 and q[:3] < [0.0, 0.0, 0.0]):
        q = [-v for v in q]
    half = QUANTUM_ANGLE / 2.0
    return (
        *(round(v / QUANTUM) for v in position),
        *(round(v / half) for v in q),
        *(round(v / QUANTUM_ANGLE) for v in joints),
    )


@dataclass(frozen=True)
class ArmChain:
    """An arm's joint chain, read from a loaded body by joint and link names.

    ``joints`` (names, planning order) and ``indices`` (the body's joint indices);
    ``lower``/``upper`` the URDF limits (a continuous joint has ``lower > upper`` as
    PyBullet reports it: ``continuous`` marks it, the planner bounds it around its start);
    ``max_velocity`` (rad/s or m/s) from the URDF; ``tool_link`` the link index held
    objects are expressed in; ``touch_links`` the link indices allowed to touch what the
    arm grasps (gripper palm and fingers); ``moving_links`` every link whose pose depends on
    a chain joint (descendants of the first)."""

    joints: tuple[str, ...]
    indices: tuple[int, ...]
    lower: tuple[float, ...]
    upper: tuple[float, ...]
    continuous: tuple[bool, ...]
    max_velocity: tuple[float, ...]
    tool_link: int
    touch_links: frozenset[int]
    moving_links: frozenset[int]

    @classmethod
    def from_body(
        cls,
        client: int,
        body: int,
        joints: Sequence[str],
        tool_link: str,
        touch_links: Iterable[str],
    ) -> ArmChain:
        """The chain of ``joints`` (names) of ``body`` in ``client``. Unknown joint or link
        names, a fixed joint, or an empty chain: :class:`LookupError`/:class:`ValueError`
        naming what to fix."""
        if isinstance(joints, str) or not joints:
            raise ValueError(f"an arm chain needs a sequence of joint names, got {joints!r}")
        by_joint: dict[str, tuple[int, Sequence[object]]] = {}
        by_link: dict[str, int] = {pb.getBodyInfo(body, physicsClientId=client)[0].decode(): -1}
        parent: dict[int, int] = {}
        for i in range(pb.getNumJoints(body, physicsClientId=client)):
            info = pb.getJointInfo(body, i, physicsClientId=client)
            by_joint[info[1].decode()] = (i, info)
            by_link[info[12].decode()] = i
            parent[i] = int(info[16])
        indices, lower, upper, velocity = [], [], [], []
        for name in joints:
            if name not in by_joint:
                raise UnknownName("joint", name, by_joint)
            i, info = by_joint[name]
            if info[2] not in (pb.JOINT_REVOLUTE, pb.JOINT_PRISMATIC):
                raise ValueError(f"joint {name!r} is not revolute or prismatic: it cannot plan")
            indices.append(i)
            lower.append(float(info[8]))  # type: ignore[arg-type]
            upper.append(float(info[9]))  # type: ignore[arg-type]
            v = float(info[11])  # type: ignore[arg-type]
            velocity.append(v if v > 0.0 else 1.0)
        if len(set(indices)) != len(indices):
            raise ValueError(f"an arm chain names a joint twice: {list(joints)}")
        for link in (tool_link, *touch_links):
            if link not in by_link:
                raise UnknownName("link", link, by_link)

        def ancestors(link: int) -> set[int]:
            out = set()
            while link >= 0:
                out.add(link)
                link = parent[link]
            return out

        first = min(indices)
        moving = frozenset(i for i in parent if first in ancestors(i))
        return cls(
            joints=tuple(joints),
            indices=tuple(indices),
            lower=tuple(lower),
            upper=tuple(upper),
            continuous=tuple(lo > hi for lo, hi in zip(lower, upper)),
            max_velocity=tuple(velocity),
            tool_link=by_link[tool_link],
            touch_links=frozenset(by_link[n] for n in touch_links),
            moving_links=moving,
        )


@dataclass
class _Held:
    body: int
    link: int
    grasp: Tf  # the object's pose in the link's frame (URDF link frame, not inertial)


class CollisionModel:
    """A private PyBullet client with a copy of a world's robot, kitchen and objects for
    collision checks of arm configurations (see the module docstring).

    ``CollisionModel.from_world(world, padding=PADDING)``: the robot, the kitchen and the
    objects of ``world`` as they are now; obstacles (objects not held) inflated by
    ``padding`` (0: the world's exact geometry, for verifying); objects attached to a robot
    link are held (they move with it, exact geometry). :meth:`sync` copies the world again.
    ``close()`` is idempotent; the model is a context manager."""

    def __init__(
        self,
        robot_urdf: Path,
        fixed_urdfs: Sequence[Path],
        padding: float,
        known_good: Sequence[Mapping[str, float]] = (),
    ) -> None:
        if not (math.isfinite(padding) and padding >= 0.0):
            raise ValueError(f"padding must be a finite distance >= 0 m, got {padding!r}")
        self.padding = padding
        self._c = int(pb.connect(pb.DIRECT))
        if self._c < 0:  # pragma: no cover - PyBullet out of clients
            raise RuntimeError("could not connect to PyBullet")
        c = self._c
        self._closed = False
        flags = pb.URDF_USE_SELF_COLLISION | pb.URDF_USE_SELF_COLLISION_EXCLUDE_PARENT
        self.robot: int = pb.loadURDF(
            str(robot_urdf), useFixedBase=True, flags=flags, physicsClientId=c
        )
        self.fixed: tuple[int, ...] = tuple(
            pb.loadURDF(str(p), useFixedBase=True, physicsClientId=c) for p in fixed_urdfs
        )
        # invariant: names[body] is the object name of every object body; links[body]
        # maps the link names of the robot and the fixed bodies to indices
        self.names: dict[int, str] = {}
        self.links: dict[int, dict[str, int]] = {}
        for body in (self.robot, *self.fixed):
            names = {pb.getBodyInfo(body, physicsClientId=c)[0].decode(): -1}
            for i in range(pb.getNumJoints(body, physicsClientId=c)):
                names[pb.getJointInfo(body, i, physicsClientId=c)[12].decode()] = i
            self.links[body] = names
        # invariant: proxy[b] = (fixed body, link) for each inflated stand-in body b of a
        # fixed body's link (padding > 0: the fixed bodies' box links are inflated copies,
        # the URDF links themselves collide with nothing)
        self.proxy: dict[int, tuple[int, int]] = {}
        if padding > 0.0:
            for body in self.fixed:
                self._inflate_links(body)
        self.links_joints: dict[str, int] = {}  # the robot's movable joints by name
        for i in range(pb.getNumJoints(self.robot, physicsClientId=c)):
            info = pb.getJointInfo(self.robot, i, physicsClientId=c)
            if info[2] != pb.JOINT_FIXED:
                self.links_joints[info[1].decode()] = i
        for config in known_good:
            for name in config:
                if name not in self.links_joints:
                    raise UnknownName("joint", name, self.links_joints)
        self.known_good = tuple(dict(k) for k in known_good)
        self.digest: tuple[object, ...] = ()
        self.coarse_digest: tuple[object, ...] = ()
        # (client, body) -> its movable joint indices (sync reads the world's often)
        self._movable_joints: dict[tuple[int, int], frozenset[int]] = {}
        self.objects: dict[str, int] = {}
        self.held: dict[str, _Held] = {}
        # invariant: every (object body, robot link) pair whose contacts are switched off
        # (:meth:`ignore_contacts`: a held object and the fingers holding it). PyBullet
        # filters pairs by body id and can keep a filter past the body's removal, while
        # the model re-creates its objects at every sync: :meth:`sync` switches these
        # back on before it removes the bodies. Seed 29 without projection: the filter
        # from a bowl carried earlier outlived 35 syncs, the fingers passed through the
        # bowl standing on the island unseen, and a planned retract knocked it 4 cm
        self._ignored: set[tuple[int, int]] = set()
        self._self_pairs: dict[tuple[int, ...], frozenset[tuple[int, int]]] = {}
        # invariant: the self pairs Bullet makes contacts for (None: all, as loaded)
        self._focus: frozenset[tuple[int, int]] | None = None
        # one reset: Bullet then tests the fixed robot against the fixed kitchen
        pb.resetBasePositionAndOrientation(self.robot, (0, 0, 0), (0, 0, 0, 1), physicsClientId=c)

    def _inflate_links(self, body: int) -> None:
        """Replace the collision boxes of ``body``'s links by static copies inflated by
        the padding (a link with other shapes keeps its own, uninflated)."""
        c = self._c
        pad = self.padding
        for link in range(-1, pb.getNumJoints(body, physicsClientId=c)):
            shapes = pb.getCollisionShapeData(body, link, physicsClientId=c)
            if not shapes or any(s[2] != pb.GEOM_BOX for s in shapes):
                continue
            shape = pb.createCollisionShapeArray(
                [pb.GEOM_BOX] * len(shapes),
                halfExtents=[[v / 2.0 + pad for v in s[3]] for s in shapes],
                collisionFramePositions=[list(s[5]) for s in shapes],
                collisionFrameOrientations=[list(s[6]) for s in shapes],
                physicsClientId=c,
            )
            stand_in = int(pb.createMultiBody(0.0, shape, -1, physicsClientId=c))
            pb.setCollisionFilterGroupMask(body, link, 0, 0, physicsClientId=c)
            self.proxy[stand_in] = (body, link)
        self._place_proxies()

    def _place_proxies(self) -> None:
        """Put each inflated stand-in at its link's (inertial) frame."""
        c = self._c
        for stand_in, (body, link) in self.proxy.items():
            if link < 0:
                pos, orn = pb.getBasePositionAndOrientation(body, physicsClientId=c)
            else:
                ls = pb.getLinkState(body, link, computeForwardKinematics=1, physicsClientId=c)
                pos, orn = ls[0], ls[1]
            pb.resetBasePositionAndOrientation(stand_in, pos, orn, physicsClientId=c)

    @classmethod
    def from_world(cls, world: World, padding: float = PADDING) -> CollisionModel:
        robot = world.robot
        # the named configurations every arm defines (park, carry, ...), all arms in each
        first = robot.arm(world.arms[0])
        names = [n for n in first.states if all(n in robot.arm(a).states for a in world.arms)]
        known_good = [
            {
                j: v
                for arm in world.arms
                for j, v in zip(robot.arm(arm).joints, robot.arm(arm).state(name))
            }
            for name in names
        ]
        model = cls(robot.urdf(), [ASSETS / "kitchen.urdf"], padding, known_good)
        try:
            model.sync(world)
        except BaseException:
            model.close()
            raise
        return model

    # ------------------------------------------------------------------ lifecycle
    @property
    def client(self) -> int:
        if self._closed:
            raise RuntimeError("this CollisionModel is closed")
        return self._c

    def close(self) -> None:
        if not self._closed:
            self._closed = True
            pb.disconnect(physicsClientId=self._c)

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------------ copying a world
    def sync(self, world: World) -> bool:
        """Copy ``world``'s robot base and joints, kitchen joints and objects (re-created:
        a cheap createMultiBody each) into the model, unless the world is the one last
        copied (the same :attr:`digest`): then nothing is touched. Whether it copied."""
        c = self.client
        wc = world.client
        src_bodies = (world.robot_body, world.kitchen_body)
        bodies: list[tuple[tuple[float, ...], tuple[float, ...], list[int], list[float]]] = []
        digest: list[object] = []
        coarse: list[object] = []
        for src in src_bodies:
            pos, orn = pb.getBasePositionAndOrientation(src, physicsClientId=wc)
            n = pb.getNumJoints(src, physicsClientId=wc)
            joints = [s[0] for s in pb.getJointStates(src, range(n), physicsClientId=wc)]
            movable = [i for i in range(n) if self._movable(wc, src, i)]
            bodies.append((pos, orn, movable, [joints[i] for i in movable]))
            digest.append(tuple(round(v, _DIGITS) for v in (*pos, *orn, *joints)))
            coarse.append(_quantised(pos, orn, joints))
        attachments = world.attachments
        objects = []
        for name, otype in world.objects.items():
            pose = world.object_pose(name)
            link = attachments.get(name)
            place = tuple(round(v, _DIGITS) for v in (*pose.position, *pose.orientation))
            digest.append((name, otype, link, place))
            coarse.append((name, otype, link, _quantised(pose.position, pose.orientation)))
            objects.append((name, otype, link, pose))
        # invariant: equal digests <=> the same world up to rounding (robot, kitchen,
        # objects, what is held); plan caches key on it
        full = (self.padding, tuple(digest))
        if full == self.digest:
            return False
        self.digest = full
        # invariant: equal coarse digests <=> the same world up to QUANTUM (m) and
        # QUANTUM_ANGLE (rad): plans are reused across them, verified again
        self.coarse_digest = (self.padding, tuple(coarse))
        for dst, (pos, orn, movable, values) in zip((self.robot, *self.fixed), bodies):
            pb.resetBasePositionAndOrientation(dst, pos, orn, physicsClientId=c)
            if movable:
                pb.resetJointStatesMultiDof(dst, movable, [[v] for v in values], physicsClientId=c)
        self._place_proxies()  # a drawer may have moved
        for ignored_body, ignored_link in self._ignored:
            pb.setCollisionFilterPair(
                self.robot, ignored_body, ignored_link, -1, 1, physicsClientId=c
            )
        self._ignored.clear()
        for body in self.objects.values():
            pb.removeBody(body, physicsClientId=c)
        self.objects.clear()
        self.names.clear()
        self.held.clear()
        robot_links = self.links[self.robot]
        for name, otype, link, pose in objects:
            held = link is not None and link in robot_links
            body = self._add_object(otype, (pose.position, pose.orientation), held)
            self.objects[name] = body
            self.names[body] = name
            if held:
                assert link is not None
                index = robot_links[link]
                ls = pb.getLinkState(
                    self.robot, index, computeForwardKinematics=1, physicsClientId=c
                )
                ip, iq = pb.invertTransform(ls[4], ls[5])
                gp, gq = pb.multiplyTransforms(ip, iq, pose.position, pose.orientation)
                self.held[name] = _Held(body, index, (tuple(gp), tuple(gq)))
        return True

    def ignore_contacts(self, body: int, link: int) -> None:
        """Switch off contacts between the object ``body`` and the robot's ``link`` (a
        held object resting in the gripper) until the next :meth:`sync` that copies the
        objects again."""
        pb.setCollisionFilterPair(self.robot, body, link, -1, 0, physicsClientId=self.client)
        self._ignored.add((body, link))

    def _movable(self, client: int, body: int, joint: int) -> bool:
        """Whether ``body``'s ``joint`` (in ``client``) is not fixed (memoised per body:
        a body's joint types never change)."""
        key = (client, body)
        movable = self._movable_joints.get(key)
        if movable is None:
            n = pb.getNumJoints(body, physicsClientId=client)
            movable = frozenset(
                i
                for i in range(n)
                if pb.getJointInfo(body, i, physicsClientId=client)[2] != pb.JOINT_FIXED
            )
            self._movable_joints[key] = movable
        return joint in movable

    def _add_object(self, otype: str, tf: Tf, held: bool) -> int:
        c = self._c
        t = object_type(otype)
        if held:  # the world's own geometry, dynamic: it makes contacts with static bodies
            return int(pb.loadURDF(str(ASSETS / "objects" / t.urdf_name), *tf, physicsClientId=c))
        # an obstacle: the type's primitives (a URDF cylinder loads as its inscribed hull:
        # the primitive is the true shape), inflated, static (no contacts with the kitchen
        # or other obstacles are ever computed)
        pad = self.padding
        kinds, extents, radii, lengths, positions, orientations = [], [], [], [], [], []
        for s in t.shapes:
            if s.kind == "box":
                kinds.append(pb.GEOM_BOX)
                extents.append([v / 2.0 + pad for v in s.size])
                radii.append(0.0)
                lengths.append(0.0)
            else:  # cylinder: (radius, length, 0)
                kinds.append(pb.GEOM_CYLINDER)
                extents.append([0.0, 0.0, 0.0])
                radii.append(s.size[0] + pad)
                lengths.append(s.size[1] + 2.0 * pad)
            positions.append(list(s.xyz))
            orientations.append(list(pb.getQuaternionFromEuler(s.rpy)))
        shape = pb.createCollisionShapeArray(
            kinds,
            radii=radii,
            halfExtents=extents,
            lengths=lengths,
            collisionFramePositions=positions,
            collisionFrameOrientations=orientations,
            physicsClientId=c,
        )
        return int(pb.createMultiBody(0.0, shape, -1, tf[0], tf[1], physicsClientId=c))

    # ------------------------------------------------------------------ names
    def allowed_bodies(self, allowed: Iterable[str]) -> tuple[frozenset[int], frozenset[int]]:
        """``allowed`` (object names and link names of the fixed bodies, e.g. a counter's
        surface) as (object bodies, fixed-body link keys ``body * 1000 + link``).
        Unknown names: :class:`LookupError` naming the known ones."""
        if isinstance(allowed, str):
            raise TypeError(f"allowed contacts are a set of names, not the string {allowed!r}")
        bodies: set[int] = set()
        links: set[int] = set()
        for name in allowed:
            if name in self.objects:
                bodies.add(self.objects[name])
                continue
            for body in self.fixed:
                if name in self.links[body]:
                    links.add(body * 1000 + self.links[body][name])
                    break
            else:
                known = [*self.objects, *(n for b in self.fixed for n in self.links[b])]
                raise UnknownName("allowed contact", name, known)
        return frozenset(bodies), frozenset(links)

    def describe(self, body: int, link: int) -> str:
        body, link = self.proxy.get(body, (body, link))
        if body in self.names:
            return self.names[body]
        for b, names in self.links.items():
            if b == body:
                for n, i in names.items():
                    if i == link:
                        return n
        return f"body {body} link {link}"  # pragma: no cover - every body is named

    # ------------------------------------------------------------------ self pairs
    def self_pairs(self, chain: ArmChain) -> frozenset[tuple[int, int]]:
        """The robot link pairs (both orders) whose contact is a self-collision when
        ``chain`` moves (see the module docstring). Computed once per chain; the sampling
        is seeded, so it is the same set every time."""
        key = chain.indices
        if key in self._self_pairs:
            return self._self_pairs[key]
        c = self.client
        robot = self.robot
        self._filter(None)  # the samples below see every self contact
        n = pb.getNumJoints(robot, physicsClientId=c)
        parent = {i: int(pb.getJointInfo(robot, i, physicsClientId=c)[16]) for i in range(n)}
        geometric = {
            i for i in range(-1, n) if pb.getCollisionShapeData(robot, i, physicsClientId=c)
        }
        chain_joints = set(chain.indices)

        def geometric_parent(i: int) -> int | None:
            p = parent.get(i, -1)
            while p >= 0 and p not in geometric:
                p = parent[p]
            return p if p in geometric else None

        def moved_by(i: int) -> frozenset[int]:  # chain joints between the root and link i
            out = set()
            while i >= 0:
                if i in chain_joints:
                    out.add(i)
                i = parent[i]
            return frozenset(out)

        adjacent: set[tuple[int, int]] = set()
        for i in geometric:
            up = geometric_parent(i)
            for _ in range(_ADJACENT_DEPTH):
                if up is None:
                    break
                adjacent |= {(i, up), (up, i)}
                up = geometric_parent(up)
        candidates = {
            (a, b)
            for a in geometric & chain.moving_links
            for b in geometric
            if a != b and (a, b) not in adjacent and moved_by(a) != moved_by(b)
        }
        candidates |= {(b, a) for a, b in candidates}
        saved = [s[0] for s in pb.getJointStates(robot, chain.indices, physicsClientId=c)]
        # the pairs touching in the robot's known-good configurations (MoveIt's "default")
        default: set[tuple[int, int]] = set()
        joints = self.links_joints
        everything = sorted(joints.values())
        everything_saved = [s[0] for s in pb.getJointStates(robot, everything, physicsClientId=c)]
        for config in self.known_good:
            idx = [joints[n] for n in config]
            pb.resetJointStatesMultiDof(
                robot, idx, [[float(v)] for v in config.values()], physicsClientId=c
            )
            pb.performCollisionDetection(physicsClientId=c)
            default |= {
                (p[3], p[4])
                for p in pb.getContactPoints(bodyA=robot, bodyB=robot, physicsClientId=c)
                if p[8] < -CONTACT_TOLERANCE
            }
        pb.resetJointStatesMultiDof(
            robot, everything, [[v] for v in everything_saved], physicsClientId=c
        )
        default |= {(b, a) for a, b in default}
        # the pairs that touch in nearly every configuration are no information
        rng = np.random.default_rng(0)
        lo = np.array(
            [lo if not cont else -math.pi for lo, cont in zip(chain.lower, chain.continuous)]
        )
        hi = np.array(
            [hi if not cont else math.pi for hi, cont in zip(chain.upper, chain.continuous)]
        )
        touching: dict[tuple[int, int], int] = {}
        for _ in range(_SELF_SAMPLES):
            q = rng.uniform(lo, hi)
            pb.resetJointStatesMultiDof(
                robot, chain.indices, [[float(v)] for v in q], physicsClientId=c
            )
            pb.performCollisionDetection(physicsClientId=c)
            seen = {
                (p[3], p[4])
                for p in pb.getContactPoints(bodyA=robot, bodyB=robot, physicsClientId=c)
                if p[8] < -CONTACT_TOLERANCE
            }
            for a, b in seen | {(b, a) for a, b in seen}:
                touching[(a, b)] = touching.get((a, b), 0) + 1
        pb.resetJointStatesMultiDof(robot, chain.indices, [[v] for v in saved], physicsClientId=c)
        always = {p for p, k in touching.items() if k >= _ALWAYS * _SELF_SAMPLES}
        pairs = frozenset(candidates - always - default)
        self._self_pairs[key] = pairs
        return pairs

    def focus(self, chain: ArmChain) -> None:
        """Let Bullet make self contacts only between ``chain``'s checked pairs (the
        others are filtered out before the narrowphase: the simplified links of a robot
        overlap at many joints, and each overlap costs contact points on every check).
        Focusing another chain restores the pairs the first one filtered."""
        self._filter(self.self_pairs(chain))

    def _filter(self, pairs: frozenset[tuple[int, int]] | None) -> None:
        """Bullet makes self contacts for ``pairs`` only (None: for every pair)."""
        if self._focus == pairs:
            return
        c = self.client
        robot = self.robot
        links = range(-1, pb.getNumJoints(robot, physicsClientId=c))
        for a in links:
            for b in links:
                if a < b:
                    on = self._focus is None or (a, b) in self._focus
                    want = pairs is None or (a, b) in pairs
                    if on != want:
                        pb.setCollisionFilterPair(robot, robot, a, b, int(want), physicsClientId=c)
        self._focus = pairs

    def chain(self, joints: Sequence[str], tool_link: str, touch_links: Iterable[str]) -> ArmChain:
        """:meth:`ArmChain.from_body` on this model's robot."""
        return ArmChain.from_body(self.client, self.robot, joints, tool_link, touch_links)
