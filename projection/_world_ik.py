"""Inverse kinematics of a :class:`projection.World` (``move_tcp``): PyBullet's IK on the
tool frame with every non-arm joint damped, several seeds, FK verification, CRAM's torso
resampling, a sound reach pre-check and a per-world LRU memo (see the design notes in
:mod:`projection._world`)."""

from __future__ import annotations

import math
from collections import OrderedDict
from collections.abc import Sequence
from typing import Any

import pybullet as pb

from executive._pose import Pose
from executive.failures import ManipulationPoseUnreachable
from executive.knowledge import ARM_PREFIX
from projection import _urdf
from projection._geometry import Tf as _Tf
from projection._geometry import Vec as _Vec
from projection._geometry import angle as _angle
from projection._geometry import quat_mul as _quat_mul
from projection._world_base import WorldBase

__all__ = ["IK_CACHE_SIZE", "TORSO_STEP", "ArmIK"]

TORSO_STEP = 0.05  #: torso resampling step of move_tcp (m)
IK_CACHE_SIZE = 4096  #: default bound of a world's IK memo (entries)
#: PyBullet IK stops once the tool position is within this distance (m) of the goal (the
#: seed walkthrough's numbers need 0.1 mm: 1 mm printed a held cup at x 0.499, not 0.500).
IK_RESIDUAL = 1e-4
#: Iteration cap of one PyBullet IK call. A reachable goal converges within about 10
#: iterations from the seeds tried; most calls that reach the cap fail the FK check anyway
#: (100 iterations changed 4 of 3200 answers of a demo run and cost 40 % more IK time).
IK_ITERATIONS = 40
#: slack of the reach test (m): 1 cm FK tolerance + 0.1 rad x TOOL_X, rounded up
_REACH_MARGIN = 0.03
_IK_SEEDS = (
    (0.0, 0.5, 0.0, -1.2, 0.0, -0.6, 0.0),
    (0.0, 0.2, 0.0, -1.6, 0.0, -1.2, 0.0),
    (0.4, 0.8, 1.5, -1.5, 0.0, -0.8, 0.0),
    (0.44, -0.32, 1.91, -2.07, 3.01, -1.55, 1.13),
    (1.2, 0.3, 0.5, -1.0, -1.5, -1.0, 0.5),
    (-0.3, 0.9, 2.5, -2.0, 1.0, -0.4, -1.0),
    (0.8, -0.2, 3.0, -0.8, -2.0, -1.8, 2.0),
)  # left-arm IK seeds after the current state; mirrored for the right arm


def _wrist_point(pos: Sequence[float], orn: Sequence[float]) -> _Vec:
    """The wrist (``?_wrist_flex_link`` origin): TOOL_X behind the tool along its x."""
    x, y, z, w = orn
    ax = (1 - 2 * (y * y + z * z), 2 * (x * y + z * w), 2 * (x * z - y * w))
    t = _urdf.TOOL_X
    return (pos[0] - ax[0] * t, pos[1] - ax[1] * t, pos[2] - ax[2] * t)


def _into_limits(v: float, lo: float, hi: float) -> float:
    """Wrap a full-turn joint (limits ±π) into its range, clamp the others."""
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
        mirrored = tuple((-a, b, -r, e, -f, w, -x) for a, b, r, e, f, w, x in _IK_SEEDS)
        self._ik_seeds = {"left": _IK_SEEDS, "right": mirrored}
        #: tool-frame positions of the seeds in the torso frame (filled on first IK)
        self._seed_tools: dict[str, list[tuple[float, ...]]] = {}
        #: bound of the per-world IK memo (0 disables it); see :meth:`move_tcp`
        self.ik_cache_size: int = IK_CACHE_SIZE
        self.ik_cache_stats: dict[str, int] = {"hits": 0, "misses": 0}
        self._ik_cache: OrderedDict[tuple[Any, ...], tuple[float, ...] | None] = OrderedDict()
        self._init_reach()

    def _init_reach(self) -> None:
        """Arm reach geometry in base_footprint at torso height 0, read by FK."""
        robot = self._robot
        h0 = self._get_joints([self._torso])[0]
        bp, bq = self._base_tf()
        ip, iq = pb.invertTransform(bp, bq)

        def local(index: int) -> _Vec:
            p = self._link_tf(robot, index)[0]
            return tuple(pb.multiplyTransforms(ip, iq, p, (0, 0, 0, 1))[0])

        tx, ty, tz = local(self._links["torso_lift_link"][1])
        self._torso_xy = (tx, ty)
        self._torso_z0 = tz - h0
        self._pan_centre: dict[str, _Vec] = {}
        self._pan_radius: dict[str, float] = {}
        for arm, p in ARM_PREFIX.items():
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

    def move_tcp(self, left: Pose | None = None, right: Pose | None = None) -> None:
        """Move the tool frames (``?_gripper_tool_frame``) to the given poses (map or
        base_footprint) by IK verified with FK (< 1 cm, < 0.1 rad), trying the current
        torso height first, then the other heights of the :data:`TORSO_STEP` grid from the
        upper limit down, skipping heights at which a goal's wrist is provably out of the
        arm's reach. With both arms, both must succeed at the same height. No collision
        check (as CRAM HEAD). Unreachable -> :class:`ManipulationPoseUnreachable`, robot
        unchanged. IK results are memoised per world (see :meth:`_solve_arm_cached`)."""
        self._check()
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
        wrists = {arm: _wrist_point(p, q) for arm, (p, q) in local.items()}
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
        # hypot, not squares: a huge finite goal (1e200 m) must be "out of reach", not an
        # OverflowError escaping every plan's failure handling
        near = math.hypot(rxy - r, dz)
        far = math.hypot(rxy + r, dz)
        return near * near <= self._reach_max2 and far * far >= self._reach_min2

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
