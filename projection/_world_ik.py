"""Inverse kinematics of a :class:`projection.World` (``move_tcp``): PyBullet's IK on the
tool frame with every non-arm joint damped, several seeds, FK verification, CRAM's torso
resampling, a sound reach pre-check and a per-world LRU memo (see the design notes in
:mod:`projection._world`)."""

from __future__ import annotations

import itertools
import math
from collections import OrderedDict
from collections.abc import Sequence
from typing import Any

import numpy as np
import pybullet as pb

from executive._pose import Pose
from executive._robot import ArmDescription
from executive.failures import ManipulationPoseUnreachable
from projection import _urdf
from projection._geometry import Tf as _Tf
from projection._geometry import Vec as _Vec
from projection._geometry import angle as _angle
from projection._geometry import quat_mul as _quat_mul
from projection._trajectories import wrap_angle
from projection._world_base import WorldBase

__all__ = ["GENERATED_SEEDS", "IK_CACHE_SIZE", "TORSO_STEP", "ArmIK"]

TORSO_STEP = 0.05  #: torso resampling step of move_tcp (m)
IK_CACHE_SIZE = 4096  #: default bound of a world's IK memo (entries)
#: PyBullet IK stops once the tool position is within this distance (m) of the goal (the
#: seed walkthrough's numbers need 0.1 mm: 1 mm printed a held cup at x 0.499, not 0.500).
IK_RESIDUAL = 1e-4
#: Iteration cap of one PyBullet IK call. A reachable goal converges within about 10
#: iterations from the seeds tried; most calls that reach the cap fail the FK check anyway
#: (100 iterations changed 4 of 3200 answers of a demo run and cost 40 % more IK time).
IK_ITERATIONS = 40
#: slack of the reach test (m): 1 cm FK tolerance + 0.1 rad x the wrist's distance from
#: the tool frame, rounded up; at least this much (the PR2-like robot's 0.18 m: 0.03)
_REACH_MARGIN = 0.03
#: lengths (m) below this are zero (joint origins that coincide); lengths are rounded
#: to it (PyBullet FK is float32-exact) so that a URDF's 0.4 m reads 0.4, not 0.40000002
_LENGTH_EPS = 1e-6
#: the PR2-like robot's wrist in its tool frame (``_urdf.TOOL_X`` behind it)
_PR2_WRIST_OFFSET: _Vec = (-_urdf.TOOL_X, 0.0, 0.0)


def _wrist_point(
    pos: Sequence[float], orn: Sequence[float], offset: _Vec = _PR2_WRIST_OFFSET
) -> _Vec:
    """The wrist (the origin of the arm's last joint) of a tool frame at ``pos``/``orn``:
    ``offset`` is where it lies in the tool frame (rigid; a world passes its arm's, read
    by FK; the default is the PR2-like robot's)."""
    x, y, z, w = orn
    c0 = (1 - 2 * (y * y + z * z), 2 * (x * y + z * w), 2 * (x * z - y * w))
    c1 = (2 * (x * y - z * w), 1 - 2 * (x * x + z * z), 2 * (y * z + x * w))
    c2 = (2 * (x * z + y * w), 2 * (y * z - x * w), 1 - 2 * (x * x + y * y))
    a, b, c = offset
    return (
        pos[0] + c0[0] * a + c1[0] * b + c2[0] * c,
        pos[1] + c0[1] * a + c1[1] * b + c2[1] * c,
        pos[2] + c0[2] * a + c1[2] * b + c2[2] * c,
    )


def _rotate(q: Sequence[float], v: Sequence[float]) -> _Vec:
    """``v`` turned by the unit quaternion ``q``."""
    return _wrist_point((0.0, 0.0, 0.0), q, (v[0], v[1], v[2]))


#: How many seeds :func:`_seeds` spreads over the joint ranges of an arm whose
#: description names no ``ik_seeds`` (8 made the mobile Panda reach all 24 of a grid of
#: back and top grasps on the sink counter that its named states alone reached 15 of)
GENERATED_SEEDS = 8


def _seeds(
    arm: ArmDescription, limits: Sequence[tuple[float, float]]
) -> tuple[tuple[float, ...], ...]:
    """An arm's IK seed library: its description's ``ik_seeds``; without any, its named
    states (park, carry, ...) in the description's order, then :data:`GENERATED_SEEDS`
    configurations drawn (from a fixed seed: the same every time) within the middle 60 %
    of each joint's range (a joint without limits: of [-pi, pi]).

    Deliberate difference from CRAM: CRAM asks a per-robot IK service (the PR2's own, or
    KDL) and knows no seeds; here one damped-least-squares solver serves every robot, and
    the seeds (the robot's knowledge when its description names them) are what make its
    answers good for that robot."""
    if arm.ik_seeds:
        return arm.ik_seeds
    rng = np.random.default_rng(0)
    spans = [(lo, hi) if hi - lo < 4 * math.pi else (-math.pi, math.pi) for lo, hi in limits]
    drawn = tuple(
        tuple(
            float(lo + (hi - lo) * f)
            for (lo, hi), f in zip(spans, rng.uniform(0.2, 0.8, len(spans)))
        )
        for _ in range(GENERATED_SEEDS)
    )
    return tuple(arm.states.values()) + drawn


def _into_limits(v: float, lo: float, hi: float) -> float:
    """Wrap a continuous joint into [-π, π) and a full-turn joint (limits ±π) into its
    range, clamp the others."""
    if math.isinf(lo) or math.isinf(hi):
        return wrap_angle(v)
    if hi - lo >= 2 * math.pi - 1e-3:
        v = (v - lo) % (2 * math.pi) + lo
    return min(max(v, lo), hi)


class ArmIK(WorldBase):
    """``move_tcp`` and its IK (a mixin of :class:`projection.World`)."""

    def _init_ik(self) -> None:
        """IK damping, seeds, memo and reach geometry (called once by ``World``)."""
        self._arm_slots = {
            arm: [self._dofs.index(i) for i in idx] for arm, idx in self._arm_joints.items()
        }
        self._ik_damping: dict[str, list[float]] = {}
        for arm, slots in self._arm_slots.items():
            damping = [1e3] * len(self._dofs)
            for k in slots:
                damping[k] = 0.05
            self._ik_damping[arm] = damping
        self._ik_seeds = {
            a: _seeds(self.robot.arm(a), [self._limits[i] for i in self._arm_joints[a]])
            for a in self._sides
        }
        #: tool-frame positions of the seeds in the torso frame (filled on first IK)
        self._seed_tools: dict[str, list[tuple[float, ...]]] = {}
        #: bound of the per-world IK memo (0 disables it); see :meth:`move_tcp`
        self.ik_cache_size: int = IK_CACHE_SIZE
        self.ik_cache_stats: dict[str, int] = {"hits": 0, "misses": 0}
        self._ik_cache: OrderedDict[tuple[Any, ...], tuple[float, ...] | None] = OrderedDict()
        self._init_reach()

    def _init_reach(self) -> None:
        """Arm reach geometry in base_footprint at torso height 0, read by FK from the
        robot as loaded (any chain): per arm, the first joint's axis point (the "pan
        centre") and, when that axis is vertical, the radius of the circle the second
        joint's origin runs on about it; the wrist (the origin of the last joint's link)
        in the tool frame; the longest wrist distance from the chain's start (the sum of
        the distances between consecutive joint origins) and, for an arm whose wrist
        distance only one elbow joint changes (two segments), the shortest."""
        robot = self._robot
        h0 = self._get_joints([self._torso])[0]
        bp, bq = self._base_tf()
        ip, iq = pb.invertTransform(bp, bq)

        def local(index: int) -> _Vec:
            p = self._link_tf(robot, index)[0]
            return tuple(pb.multiplyTransforms(ip, iq, p, (0, 0, 0, 1))[0])

        tx, ty, tz = local(self._torso_link)
        self._torso_xy = (tx, ty)
        self._torso_z0 = tz - h0
        self._pan_centre: dict[str, _Vec] = {}
        self._pan_radius: dict[str, float] = {}
        self._wrist_offset: dict[str, _Vec] = {}
        self._reach_max2: dict[str, float] = {}
        self._reach_min2: dict[str, float] = {}
        for arm in self._sides:
            idx = self._arm_joints[arm]
            points = [local(i) for i in idx]  # each joint's origin (its child link's)
            cx, cy, cz = points[0]
            self._pan_centre[arm] = (cx, cy, cz - h0)
            if self._axis_vertical(idx[0]) and len(idx) > 1:
                sx, sy, _ = points[1]
                self._pan_radius[arm] = math.hypot(sx - cx, sy - cy) + 1e-4
                start = 1
            else:  # any axis: distances from the first joint's origin only
                self._pan_radius[arm] = 1e-4
                start = 0
            tp, tq = self._link_tf(robot, self._tool[arm])
            wp = self._link_tf(robot, idx[-1])[0]
            tip, tiq = pb.invertTransform(tp, tq)
            off = pb.multiplyTransforms(tip, tiq, wp, (0, 0, 0, 1))[0]
            offset = tuple(round(v, 6) + 0.0 for v in off)
            self._wrist_offset[arm] = (offset[0], offset[1], offset[2])
            chain = points[start:]
            lengths = [round(math.dist(p, q), 6) for p, q in itertools.pairwise(chain)]
            margin = max(_REACH_MARGIN, 0.01 + 0.1 * math.hypot(*offset))
            self._reach_max2[arm] = (sum(lengths) + margin) ** 2
            reach_min = self._folded_reach(idx[start:], chain, lengths)
            self._reach_min2[arm] = max(0.0, reach_min - margin) ** 2

    def _joint_axis(self, index: int) -> _Vec:
        """A robot joint's axis in map (unit), as the robot stands."""
        axis = pb.getJointInfo(self._robot, index, physicsClientId=self._c)[13]
        return _rotate(self._link_tf(self._robot, index)[1], axis)

    def _axis_vertical(self, index: int) -> bool:
        ax, ay, _ = self._joint_axis(index)
        return math.hypot(ax, ay) < 1e-6

    def _folded_reach(
        self, joints: Sequence[int], points: Sequence[_Vec], lengths: Sequence[float]
    ) -> float:
        """The shortest wrist distance from ``points[0]`` an arm can fold to, or 0 when
        that is not provable from the chain alone. Provable for two segments ``a``, ``b``
        meeting at one elbow joint whose axis is perpendicular to both, straight at 0,
        every other joint at the elbow turning about a segment: then the distance is
        ``sqrt(a² + b² + 2ab cos q)``, smallest at the elbow limit farthest from 0."""
        nonzero = [k for k, v in enumerate(lengths) if v > _LENGTH_EPS]
        if len(nonzero) != 2:
            return 0.0
        a, b = lengths[nonzero[0]], lengths[nonzero[1]]
        junction = points[nonzero[0] + 1]
        u = [(q - p) / a for p, q in zip(points[nonzero[0]], junction)]
        end = points[nonzero[1] + 1]
        v = [(q - p) / b for p, q in zip(points[nonzero[1]], end)]
        base_q = self._base_tf()[1]
        inv = (-base_q[0], -base_q[1], -base_q[2], base_q[3])
        elbow = None
        for k, i in enumerate(joints):
            if math.dist(points[k], junction) > 1e-6:
                continue
            axis = _rotate(inv, self._joint_axis(i))
            du = abs(sum(x * y for x, y in zip(axis, u)))
            dv = abs(sum(x * y for x, y in zip(axis, v)))
            if du < 1e-6 and dv < 1e-6:
                if elbow is not None:
                    return 0.0
                elbow = i
            elif not (abs(du - 1.0) < 1e-6 or abs(dv - 1.0) < 1e-6):
                return 0.0
        if elbow is None:
            return 0.0
        # straight at 0 (the formula's zero): the angle between the segments is the elbow
        # joint's value (read, not moved: moving joints here would change the broadphase)
        (q_now,) = self._get_joints([elbow])
        cos_uv = max(-1.0, min(1.0, sum(x * y for x, y in zip(u, v))))
        if abs(math.acos(cos_uv) - abs(q_now)) > 1e-6:
            return 0.0
        lo, hi = self._limits[elbow]
        fold = max(abs(lo), abs(hi))
        return math.sqrt(a * a + b * b + 2 * a * b * math.cos(fold)) if fold < math.pi else 0

    def move_tcp(self, left: Pose | None = None, right: Pose | None = None) -> None:
        """Move the arms' tool frames (their descriptions' ``tool_frame``) to the given
        poses (map or base_footprint) by IK verified with FK (< 1 cm, < 0.1 rad), trying the current
        torso height first, then the other heights of the :data:`TORSO_STEP` grid from the
        upper limit down, skipping heights at which a goal's wrist is provably out of the
        arm's reach. With both arms, both must succeed at the same height. No collision
        check (as CRAM HEAD). Unreachable -> :class:`ManipulationPoseUnreachable`, robot
        unchanged. IK results are memoised per world (see :meth:`_solve_arm_cached`)."""
        self._check()
        for arm, p in (("left", left), ("right", right)):
            if p is not None:
                self._arm(arm)
        goals = {
            arm: self._to_map(p) for arm, p in (("left", left), ("right", right)) if p is not None
        }
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
        wrists = {arm: _wrist_point(p, q, self._wrist_offset[arm]) for arm, (p, q) in local.items()}
        for arm, wrist in wrists.items():
            if not all(map(math.isfinite, wrist)):
                # a goal so far away (e.g. 1e300 m) that its transform overflowed: out of
                # reach, as a plan failure (it used to escape as OverflowError / NaN)
                raise ManipulationPoseUnreachable(
                    f"the {arm} goal is out of reach: its point in map is "
                    f"({', '.join(f'{v:.6g}' for v in goals[arm][0])})",
                    left=left,
                    right=right,
                )
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
        (the last arm joint's origin, rigid in the tool frame) within the FK
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
        # hypot, not squares: a huge finite goal (1e200 m) must be "out of reach", not an
        # OverflowError escaping every plan's failure handling
        near = math.hypot(rxy - r, dz)
        far = math.hypot(rxy + r, dz)
        return near * near <= self._reach_max2[arm] and far * far >= self._reach_min2[arm]

    def _solve_arm_cached(
        self,
        arm: str,
        pos: Sequence[float],
        orn: Sequence[float],
        local: _Tf,
        height: float,
        saved: Sequence[float],
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
            round((x - self._torso_xy[0]) * 1e4),
            round((y - self._torso_xy[1]) * 1e4),
            round((z - self._torso_z0 - height) * 1e4),
            round(q[0] * 1e4),
            round(q[1] * 1e4),
            round(q[2] * 1e4),
            round(q[3] * 1e4),
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

    def _verify(
        self, arm: str, q: Sequence[float], pos: Sequence[float], orn: Sequence[float]
    ) -> bool:
        """Set the arm to ``q`` and check the tool frame by FK (< 1 cm, < 0.1 rad)."""
        self._set_joints(self._arm_joints[arm], q)
        s = pb.getLinkState(
            self._robot, self._tool[arm], computeForwardKinematics=1, physicsClientId=self._c
        )
        return math.dist(s[4], pos) < 0.01 and _angle(s[5], orn) < 0.1

    def _seed_order(
        self, arm: str, pos: Sequence[float], start: tuple[float, ...]
    ) -> list[tuple[float, ...]]:
        """IK seeds for a goal at ``pos`` (map), nearest first: the arm's current joints
        and the seed library, ordered by how far each one's tool frame (in the torso frame,
        so independent of base pose and torso height) is from the goal. A nearby start
        (consecutive waypoints) stays first; a distant goal starts from the library seed
        whose hand is already near it, instead of from wherever the arm happens to be."""
        library = self._seed_tools.get(arm)
        indices = self._arm_joints[arm]
        tool = self._tool[arm]
        torso = (self._robot, self._torso_link)
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
            + [
                (math.dist(t, goal), i, s)
                for i, (t, s) in enumerate(zip(library, self._ik_seeds[arm]))
            ],
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

    def _solve_arm(
        self, arm: str, pos: Sequence[float], orn: Sequence[float], saved: Sequence[float]
    ) -> tuple[float, ...] | None:
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
                robot,
                tool,
                pos,
                orn,
                jointDamping=damping,
                maxNumIterations=IK_ITERATIONS,
                residualThreshold=IK_RESIDUAL,
                physicsClientId=c,
            )
            q = tuple(_into_limits(sol[k], lo, hi) for k, (lo, hi) in zip(slots, limits))
            if self._verify(arm, q, pos, orn):
                return q
        self._set_joints(indices, start)
        return None
