"""Joint-space arm motion planning: OMPL's RRTConnect against a :class:`CollisionModel`,
shortcut, verified densely against the exact geometry and time-parameterised with the
joint velocity (and an acceleration) limit.

A query (:meth:`ArmMotionPlanner.plan`) goes, as the motion-planning reference note
measured it on this machine:

1. bad input (wrong length, not finite, outside the joint limits, unknown allowed
   contacts): :class:`ValueError`/:class:`LookupError` before anything is checked;
2. start or goal in collision in the exact geometry: :class:`ManipulationPoseUnreachable`
   naming the contacts, without planning;
3. the goal already reached: a one-state trajectory; the straight joint-space line when
   it is clear (pybullet-planning's ``direct_path``): no sampling at all;
4. otherwise RRTConnect (single-threaded: PRM deadlocks with a Python checker; extensions
   of at most :data:`RANGE` rad) on a fresh ``SimpleSetup`` seeded right before it is
   built, stopped by a budget of validity checks (deterministic) with a wall-clock
   timeout as a safety net only; then one bounded round of simplification
   (:func:`_simplify`; deterministic: time-bounded simplification is not); within one query each
   configuration is scanned once (the sampler, the straight line, shortcutting and the
   retry after a graze ask again for about one state in eight: answered from a memo).
   Bullet keeps contact manifolds between scans, so the contact points a scan reports
   (not, in the samples measured, whether the state is valid) depend on the states
   scanned before it: on the seed-1 demo 79 of 80 plans came out bit-identical with and
   without the memo, one query that found a path after a graze grazed twice with it;
5. the path checked every :data:`VERIFY_RESOLUTION` rad in the exact geometry (the planning
   model's obstacles are inflated by :data:`projection._collision_model.PADDING` so that
   grazes between checked states are caught; the robot's own links are not, and most
   grazes are self grazes: torso against palm, one arm against the other); a graze is
   repaired lazily, as LazyPRM checks an edge only once a path uses it: every grazing
   state of the path is forbidden to the planning check within
   :data:`REPAIR_RADIUS` (:class:`_Forbidden`) and the query is planned again, from the
   same seed, at most :data:`REPAIR_ROUNDS` times (each within the check budget); still
   grazing: a failure (``reason`` "path not verified"). The repaired path is the one
   remembered (``ArmTrajectory.repairs``: the rounds it took). The previous repair
   (planning once more at half the resolution) left 47 of 4,773 seeded random right-arm
   queries in the open unverified; this one 1 of 6,102 (most need one round). On the
   demo (seeds 2, 4, 6 at 5 % faults with projection) the real controller fell back to
   its router 47 times before, 16 times with this repair (the rest: budget spent, a
   goal in collision, four rounds that still grazed);
6. timed: each straight segment between the path's vertices gets a trapezoidal velocity
   profile, from rest to rest, synchronised over the joints so that the arm moves exactly
   along the checked line.

Deliberate difference from MoveIt (TOTG time parameterisation): the arm stops at each
vertex of the shortcut path instead of blending the corners, so the swept configurations
are exactly the checked ones (a blend cuts corners by up to TOTG's path tolerance,
unchecked); shortcutting leaves few vertices, so the cost is a few short stops.

Near the start and the goal (within :data:`ESCAPE` rad) a configuration the padding
rejects is accepted when the exact geometry is clear: an arm that starts next to an object
(it just placed it, it is about to grasp it) can leave and reach it, as MoveIt's start-state
"jiggle" lets it.

What counts as a collision for a chain's motion: a contact of a link the chain moves (or
of an object its hand holds) with anything but its allowed contacts; self contacts of the
checked pairs only (:meth:`CollisionModel.self_pairs`). The parts of the robot that stand
still (the other arm, what it holds, the torso) are obstacles, but their own contacts are
not this motion's. A held object may keep touching the robot links it touches at the start.
Contacts present at the query's ends may persist while they get no deeper
(``_Checker.tolerate_end_contacts``): self contacts at the start and the goal (the
simplified links of a PR2-like robot overlap by centimetres in configurations its IK
reaches), a slight contact with an object at the start only near the start. Deliberate
difference from MoveIt, which rejects a goal in collision and "jiggles" a start out of a
slight one: the robot is at its start and is sent to its goal anyway (the old router
otherwise), so planning around them is the safer answer.

Determinism: the same model state, query, seed and parameters give the same trajectory
(the seed goes to ``ompl.util.RNG.setSeed`` right before the ``SimpleSetup`` is built;
nothing else draws from OMPL's generators in between).
"""

from __future__ import annotations

import itertools
import logging
import math
from collections import OrderedDict
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass

import numpy as np
import pybullet as pb
from ompl import base as ob
from ompl import geometric as og
from ompl import util as ou

from executive.failures import ManipulationPoseUnreachable
from projection._collision_model import (
    CONTACT_TOLERANCE,
    QUANTUM_ANGLE,
    ArmChain,
    CollisionModel,
    _quantised,
)
from projection._trajectories import nearest_turn_of

__all__ = [
    "ACCELERATION",
    "CACHE_SIZE",
    "DEEPEN_TOLERANCE",
    "END_CONTACT_DEPTH",
    "ESCAPE",
    "MAX_CHECKS",
    "RANGE",
    "REPAIR_RADIUS",
    "REPAIR_ROUNDS",
    "RESOLUTION",
    "TIMEOUT",
    "VERIFY_RESOLUTION",
    "ArmMotionPlanner",
    "ArmTrajectory",
    "time_parameterise",
]

log = logging.getLogger(__name__)

#: Largest joint-space (L2, rad) step between two checked states while planning.
RESOLUTION = 0.05
#: Step (rad) at which a finished path is verified against the exact geometry.
VERIFY_RESOLUTION = 0.01
#: Longest joint-space step (L2, rad) one RRTConnect extension tries. OMPL's default (a
#: fifth of the space's extent: 2.2 rad for a PR2 arm) leaves a tree stuck at its root
#: when the arm starts or ends tucked between its own torso and the other arm (two carry
#: poses): almost every 2 rad segment out of there hits something, so the start tree kept
#: its one vertex for the whole budget (measured: 13 of the 16 failed plans of seed 3 at
#: 10 % faults with projection, each spending the full 20 000 checks, 0.6 s). With 1 rad
#: the trees grow out of such a pocket: on seeds 2, 4, 6, 7 at 5 % faults 11 samplings ran
#: out of budget instead of 35, sampling took 32 % less time and shortcutting the more
#: jagged paths 48 % more (6.6 vertices a path instead of 5.4: a stop more); the runs took
#: 5 % less wall time. It does not make more motions planned: most of the queries that no
#: longer run out of budget now find a path that grazes the robot's own body between its
#: checked states (the exact verification's self contacts, which the planning model does
#: not pad), and fall back all the same (seeds 2, 4, 6 at 5 %: 53 fallbacks instead of
#: 57); they fail in a fraction of the time.
RANGE = 1.0
#: How many times a path that grazes in the exact geometry is planned again with its
#: grazing states forbidden (:class:`_Forbidden`), before the query fails.
REPAIR_ROUNDS = 4
#: Radius (rad, L2) around a grazing state within which the planning check rejects
#: states after a graze (:class:`_Forbidden`).
REPAIR_RADIUS = 0.08
#: Validity checks a plan may spend (the deterministic budget).
MAX_CHECKS = 20_000
#: Wall-clock safety net (s) of one planning call; hitting it is a logged failure.
TIMEOUT = 5.0
#: Joint acceleration limit (rad/s^2) of the time parameterisation (URDFs carry none).
ACCELERATION = 2.0
#: Distance (rad, L2) from the start or goal within which the exact geometry decides.
ESCAPE = 0.2
#: How much deeper (m) than at the start or goal a contact present there may get on the
#: way (:meth:`_Checker.tolerate_end_contacts`): the jitter of Bullet's contact depths.
DEEPEN_TOLERANCE = 0.002
#: Deepest penetration (m) of a contact with an object or the kitchen at the start that
#: may persist near the start (an upper arm or a held object resting against an object);
#: deeper, the start is in collision. Self contacts persist at any depth, at the start
#: and the goal (see ``_Checker.tolerate_end_contacts``).
END_CONTACT_DEPTH = 0.02

#: A joint configuration: a sequence of floats or a 1-d array.
Q = Sequence[float] | np.ndarray
Check = Callable[[Q], bool]
#: Plans an :class:`ArmMotionPlanner` remembers (imagined runs repeat the same motions).
CACHE_SIZE = 256
_DIGITS = 4  # rounding (m, rad) of the exact cache keys, as of the model digest


@dataclass(frozen=True)
class ArmTrajectory:
    """A timed joint path of one arm chain.

    ``positions`` (N x joints): consecutive rows at most the planning resolution apart,
    joined by straight joint-space segments; the first row is the start, the last the goal,
    exactly (a continuous joint's goal as :meth:`ArmMotionPlanner.plan` unwrapped it).
    ``times`` (N,): seconds from the start, non-decreasing, 0 first. ``planned``:
    whether a sampling planner ran (False: the straight line or nothing). ``checks``: the
    validity checks spent (planning, shortcutting and verifying)."""

    joints: tuple[str, ...]
    positions: np.ndarray
    times: np.ndarray
    planned: bool
    checks: int
    #: how many times the path grazed in the exact geometry and was planned again
    #: (:data:`REPAIR_ROUNDS` at most)
    repairs: int = 0

    @property
    def duration(self) -> float:
        return float(self.times[-1])

    def at(self, t: float) -> tuple[float, ...]:
        """The configuration ``t`` seconds after the start (clamped to the trajectory)."""
        return tuple(
            float(np.interp(t, self.times, self.positions[:, j])) for j in range(len(self.joints))
        )


@dataclass(frozen=True)
class _Entry:
    """A remembered answer: the query's exact key (the world to 1e-4, the start and
    goal), and either the path (``vertices``, whether it was sampled, the trajectory
    returned) or the deterministic failure (the check budget spent)."""

    exact_key: tuple[object, ...]
    vertices: np.ndarray | None
    planned: bool
    trajectory: ArmTrajectory | None
    failure: ManipulationPoseUnreachable | None = None


def _frozen(trajectory: ArmTrajectory) -> ArmTrajectory:
    """``trajectory`` with read-only arrays (a remembered trajectory is shared)."""
    trajectory.positions.flags.writeable = False
    trajectory.times.flags.writeable = False
    return trajectory


def _segment_times(d: np.ndarray, vmax: np.ndarray, amax: float, u: np.ndarray) -> np.ndarray:
    """Times at path fractions ``u`` of a rest-to-rest trapezoidal profile along the joint
    displacement ``d`` (the slowest joint at its velocity / acceleration limit)."""
    moving = np.abs(d) > 1e-12
    if not moving.any():
        return np.zeros_like(u)
    v = float(np.min(vmax[moving] / np.abs(d[moving])))  # max du/dt
    a = float(np.min(amax / np.abs(d[moving])))  # max d2u/dt2
    if v * v / a >= 1.0:  # triangle: never reaches v
        ta = math.sqrt(1.0 / a)
        total = 2.0 * ta
        ua = 0.5
    else:
        ta = v / a
        total = 1.0 / v + v / a
        ua = 0.5 * v * ta
    t = np.empty_like(u)
    first = u <= ua
    last = u >= 1.0 - ua
    t[first] = np.sqrt(2.0 * u[first] / a)
    t[last] = total - np.sqrt(np.maximum(0.0, 2.0 * (1.0 - u[last]) / a))
    mid = ~first & ~last
    t[mid] = ta + (u[mid] - ua) / v
    return t


def time_parameterise(
    vertices: np.ndarray, max_velocity: Sequence[float], acceleration: float, step: float
) -> tuple[np.ndarray, np.ndarray]:
    """Dense positions (at most ``step`` apart, L2, the vertices included) and their
    times along the polyline ``vertices``: on each segment a trapezoidal velocity profile
    from rest to rest, synchronised over the joints, no joint faster than its
    ``max_velocity`` nor accelerating more than ``acceleration``."""
    vmax = np.asarray(max_velocity, dtype=float)
    rows = [vertices[0]]
    times = [0.0]
    t0 = 0.0
    for a, b in itertools.pairwise(vertices):
        d = b - a
        k = max(1, math.ceil(float(np.linalg.norm(d)) / step))
        u = np.arange(1, k + 1, dtype=float) / k
        ts = _segment_times(d, vmax, acceleration, u)
        for j in range(k):
            rows.append(b if j == k - 1 else a + u[j] * d)
            times.append(t0 + float(ts[j]))
        t0 = times[-1]
    return np.array(rows), np.array(times)


def _simplify(simplifier: og.PathSimplifier, path: og.PathGeometric) -> None:
    """Shorten a sampled path in one bounded round, all of it drawing on OMPL's seeded
    generator: vertex reduction, collapsing close vertices, one partial shortcut (which
    cuts across segments, not only between vertices) and a last vertex reduction.

    Not ``simplifyMax``, which repeats that round, with B-spline smoothing in between,
    until a round changes nothing. Both were applied to the same 117 sampled paths of the
    seed-3 demo at 10 % faults: this one spent 55 000 validity checks against 336 000, and
    left 5.1 vertices a path against 6.4. The paths are 12 % longer in joint space
    (7.43 rad against 6.61), but the timed trajectories are as long: 7.70 s against 7.73 s.
    Every vertex is a stop, and the stops saved make up for the distance. On that run the
    saving was about a quarter of the run's wall time."""
    simplifier.reduceVertices(path)
    simplifier.collapseCloseVertices(path)
    simplifier.partialShortcutPath(path)
    simplifier.reduceVertices(path)


def _dense(vertices: np.ndarray, step: float) -> Iterable[np.ndarray]:
    """The states along the polyline at most ``step`` apart (L2), endpoints included."""
    yield vertices[0]
    for a, b in itertools.pairwise(vertices):
        k = max(1, math.ceil(float(np.linalg.norm(b - a)) / step))
        for j in range(1, k + 1):
            yield b if j == k else a + (j / k) * (b - a)


class _Forbidden:
    """The configurations one query's planning check rejects after its paths grazed
    (lazy collision checking, as LazyPRM checks an edge only once a path uses it): each
    state the exact verification found in contact between the planning model's checked
    states is the centre of a ball (``radius``, L2) no planned state may enter, so the
    next plan passes farther from the graze. A ball never holds the query's ends (its
    start, its goal's turns): near them it shrinks to half the distance to the nearest.

    Deliberate difference from padding the robot's own links (tried: more fallbacks, and
    a plan that grazed the padded self model by a hair swept the milk): only the states
    proven to graze are excluded, the rest of the space stays as the planning model has
    it."""

    def __init__(self, radius: float, *ends: np.ndarray) -> None:
        self.radius = radius
        self.ends = ends
        # invariant: as many radii as centres; each radius <= self.radius and below the
        # centre's distance to the start and to the goal
        self._centres: list[np.ndarray] = []
        self._radii: list[float] = []
        self._stacked: tuple[np.ndarray, np.ndarray] | None = None  # (centres, radii^2)

    def __len__(self) -> int:
        return len(self._centres)

    def add(self, q: np.ndarray) -> None:
        """Forbid the ball around ``q`` (skipped when ``q`` lies within a quarter of a
        forbidden ball's radius from its centre: a graze is tens of dense states in a
        row)."""
        end = min(float(np.linalg.norm(q - e)) for e in self.ends)
        r = min(self.radius, 0.5 * end)
        if r <= 0.0:
            return
        if self._centres:
            centres, r2 = self._arrays()
            if np.any(np.sum((centres - q) ** 2, axis=1) < r2 / 16.0):
                return
        self._centres.append(np.array(q, dtype=float))
        self._radii.append(r)
        self._stacked = None

    def _arrays(self) -> tuple[np.ndarray, np.ndarray]:
        if self._stacked is None:
            self._stacked = (np.array(self._centres), np.array(self._radii) ** 2)
        return self._stacked

    def near(self, q: Q) -> bool:
        """Whether ``q`` lies in a forbidden ball."""
        if not self._centres:
            return False
        centres, r2 = self._arrays()
        d2 = np.sum((centres - np.asarray(q, dtype=float)) ** 2, axis=1)
        return bool(np.any(d2 < r2))


class _Checker:
    """Collision checks of one chain in one model, with allowed contacts: the chain's
    touch links and the held objects may touch the allowed objects and fixed-body links;
    nothing else may touch anything but its own checked-pair exceptions."""

    def __init__(self, model: CollisionModel, chain: ArmChain, allowed: Iterable[str]) -> None:
        self.model = model
        self.chain = chain
        model.focus(chain)
        self.pairs = model.self_pairs(chain)
        self.allowed_bodies, self.allowed_links = model.allowed_bodies(allowed)
        self.held = [h for h in model.held.values() if h.link in chain.moving_links]
        self.held_bodies = frozenset(h.body for h in self.held)
        for h in self.held:  # the held object rests in the gripper: no contacts there
            for link in chain.touch_links:
                model.ignore_contacts(h.body, link)
        self.calls = 0
        # (held body, robot link) contacts present at the start (tolerate_held_contacts)
        self.held_touch: set[tuple[int, int]] = set()
        # (body A, link A, body B, link B) -> the deepest signed distance (m, < 0) of that
        # contact at the query's start or goal (tolerate_end_contacts): it may persist on
        # the way while it gets no deeper than that (plus DEEPEN_TOLERANCE)
        self.persisting: dict[tuple[int, int, int, int], float] = {}
        self.start = np.zeros(len(chain.indices))  # the query's start (tolerate_end_contacts)
        # how close two robot links may come before they count as a self contact, and
        # how much deeper a contact present at the start or goal may get on the way.
        # Deliberately no self margin in a padded model: with
        # one, plans that now graze the robot's own body (logged) succeed, and one of
        # them swept the milk off the counter on the seed-1 demo (a path within a
        # millimetre of the believed milk, 2 mm from the real one; not traced further)
        self.self_margin = -CONTACT_TOLERANCE
        self.deepen = DEEPEN_TOLERANCE

    def _set(self, q: Q) -> None:
        m = self.model
        c = m.client
        pb.resetJointStatesMultiDof(
            m.robot,
            self.chain.indices,
            np.asarray(q, dtype=float).reshape(-1, 1).tolist(),
            physicsClientId=c,
        )
        for h in self.held:
            ls = pb.getLinkState(m.robot, h.link, computeForwardKinematics=1, physicsClientId=c)
            pos, orn = pb.multiplyTransforms(ls[4], ls[5], *h.grasp)
            pb.resetBasePositionAndOrientation(h.body, pos, orn, physicsClientId=c)

    def _allowed(self, body: int, link: int) -> bool:
        body, link = self.model.proxy.get(body, (body, link))
        return body in self.allowed_bodies or body * 1000 + link in self.allowed_links

    def tolerate_held_contacts(self, q: Q) -> None:
        """Let each held object keep touching the robot links it touches at ``q`` (the
        start): a carried bowl resting against its own upper arm, as the simplified links
        lay them, is no collision with the world (MoveIt's touch links, taken from the
        start)."""
        m = self.model
        c = m.client
        self._set(q)
        pb.performCollisionDetection(physicsClientId=c)
        for h in self.held:
            for p in pb.getContactPoints(bodyA=h.body, bodyB=m.robot, physicsClientId=c):
                if p[8] < -CONTACT_TOLERANCE:
                    self.held_touch.add((h.body, p[4]))

    def tolerate_end_contacts(self, start: Q, goal: Q) -> None:
        """Let contacts present at the query's ends persist while they get no deeper than
        there (plus :data:`DEEPEN_TOLERANCE`): self contacts at the start or the goal, at
        any depth and along the whole path (the simplified links of a PR2-like robot
        overlap by centimetres in configurations its IK reaches, torso against upper arm;
        the robot's own links are nothing the arm could push away); a contact with an
        object or the kitchen at the start, no deeper than :data:`END_CONTACT_DEPTH`, only
        within :data:`ESCAPE` of the start (the arm leaves it: an upper arm resting
        against an object; sliding along it further would push it). The robot stands at
        its start and is sent to its goal whatever the planner says, so such a contact is
        no reason to give up planning. MoveIt's start-state "jiggle" and allowed start
        contacts serve the same end. A contact with an object at the goal is not
        excused: the goal is in collision."""
        robot = self.model.robot
        found: dict[tuple[int, int, int, int], float] = {}
        for which, q in (("start", start), ("goal", goal)):
            for key, depth in self._contact_points(q):
                if which == "goal" and not (key[0] == robot and key[2] == robot):
                    continue
                found[key] = min(depth, found.get(key, 0.0))
        # in a padded model, a contact at the start is deeper by the padding
        deepest = END_CONTACT_DEPTH + self.model.padding
        self.persisting = {
            k: d - self.deepen
            for k, d in found.items()
            if (k[0] == robot and k[2] == robot) or d >= -deepest
        }
        self.start = np.asarray(start, dtype=float)

    def _persists(self, body: int, q: Q) -> bool:
        """Whether a contact of the moving part with ``body`` present at the start still
        may persist at ``q``: a self contact anywhere, another within ESCAPE of the
        start."""
        if body == self.model.robot:
            return True
        return float(np.linalg.norm(np.asarray(q, dtype=float) - self.start)) < ESCAPE

    def _contact_points(self, q: Q) -> list[tuple[tuple[int, int, int, int], float]]:
        """The forbidden contact points at ``q``: (body A, link A, body B, link B) and the
        signed distance (m, < -CONTACT_TOLERANCE), before any persisting contact is
        excused."""
        saved = self.persisting
        self.persisting = {}
        try:
            return self._scan(q, first_only=False)
        finally:
            self.persisting = saved

    def contacts(self, q: Q, first_only: bool = False) -> list[tuple[str, str]]:
        """The forbidden contacts at ``q`` as (moving part, what it touches) names."""
        self.calls += 1
        describe = self.model.describe
        return [
            (describe(a, la), describe(b, lb)) for (a, la, b, lb), _d in self._scan(q, first_only)
        ]

    def _scan(self, q: Q, first_only: bool) -> list[tuple[tuple[int, int, int, int], float]]:
        m = self.model
        c = m.client
        robot = m.robot
        self._set(q)
        pb.performCollisionDetection(physicsClientId=c)
        tol = -CONTACT_TOLERANCE
        persisting = self.persisting
        out: list[tuple[tuple[int, int, int, int], float]] = []
        touch = self.chain.touch_links
        moving = self.chain.moving_links
        self_tol = self.self_margin
        for p in pb.getContactPoints(bodyA=robot, physicsClientId=c):
            body = p[2]
            if p[8] >= (self_tol if body == robot else tol):
                continue
            la, lb = p[3], p[4]
            if body != robot and la not in moving and body not in self.held_bodies:
                continue  # the rest of the robot stands still: its contacts are not ours
            if (body, la) in self.held_touch:
                continue
            if body == robot:
                if (la, lb) not in self.pairs:
                    continue
            elif la in touch and self._allowed(body, lb):
                continue
            key = (robot, la, body, lb)
            if key in persisting and p[8] >= persisting[key] and self._persists(body, q):
                continue  # present at the start (or goal), no deeper here
            out.append((key, p[8]))
            if first_only:
                return out
        for h in self.held:
            for p in pb.getContactPoints(bodyA=h.body, physicsClientId=c):
                if p[8] >= tol or p[2] == robot:  # robot contacts were reported above
                    continue
                if self._allowed(p[2], p[4]):
                    continue
                key = (h.body, -1, p[2], p[4])
                if key in persisting and p[8] >= persisting[key] and self._persists(p[2], q):
                    continue
                out.append((key, p[8]))
                if first_only:
                    return out
        return out

    def valid(self, q: Q) -> bool:
        return not self.contacts(q, first_only=True)


class ArmMotionPlanner:
    """Plans one arm chain's motions in a padded :class:`CollisionModel` (``model``) and
    verifies them in an exact one (``verifier``, padding 0), both copies of the same
    world (see the module docstring). ``ArmMotionPlanner.for_world(world, chain_spec)``
    builds both; the caller closes them (:meth:`close`)."""

    def __init__(
        self,
        model: CollisionModel,
        verifier: CollisionModel,
        chain: ArmChain,
        *,
        resolution: float = RESOLUTION,
        verify_resolution: float = VERIFY_RESOLUTION,
        acceleration: float = ACCELERATION,
        repair_radius: float = REPAIR_RADIUS,
    ) -> None:
        if verifier.padding != 0.0:
            raise ValueError(
                f"the verifier checks the exact geometry: padding 0, got {verifier.padding}"
            )
        for name, v in (
            ("resolution", resolution),
            ("verify_resolution", verify_resolution),
            ("acceleration", acceleration),
            ("repair_radius", repair_radius),
        ):
            if not (math.isfinite(v) and v > 0.0):
                raise ValueError(f"{name} must be a finite number > 0, got {v!r}")
        self.model = model
        self.verifier = verifier
        # (model coarse digest, start and goal quantised, chain, seed, allowed, budget) ->
        # its _Entry; least recently used first, at most CACHE_SIZE. A hit in the exact
        # world of the entry returns its trajectory; one in a world equal only up to the
        # quanta has its path verified again in the exact geometry of the world now.
        self._cache: OrderedDict[object, _Entry] = OrderedDict()
        #: Queries answered from the cache, and planned (or failed) afresh.
        self.cache_hits = 0
        self.cache_misses = 0
        #: Plans that grazed and verified after repairs, and the repair rounds spent
        #: (successful or not): see :class:`_Forbidden`.
        self.repaired = 0
        self.repair_rounds = 0
        # the world around the chain as of the last sync (_local_digest; None: not
        # synced from a World here, the model's coarse digest keys the cache)
        self._local: tuple[object, ...] | None = None
        self._span_cache: tuple[int, float] | None = None
        self.chain = chain
        self.resolution = resolution
        self.verify_resolution = verify_resolution
        self.acceleration = acceleration
        self.repair_radius = repair_radius

    @classmethod
    def for_world(
        cls,
        world: object,
        joints: Sequence[str],
        tool_link: str,
        touch_links: Iterable[str],
        **kwargs: float,
    ) -> ArmMotionPlanner:
        """Both models copied from ``world`` (a :class:`projection.World`), the chain
        read from its robot by name."""
        from projection._world import World

        if not isinstance(world, World):
            raise TypeError(f"expected a projection World, got {type(world).__name__}")
        touch = tuple(touch_links)
        model = CollisionModel.from_world(world)
        try:
            verifier = CollisionModel.from_world(world, padding=0.0)
        except BaseException:
            model.close()
            raise
        try:
            planner = cls(model, verifier, model.chain(joints, tool_link, touch), **kwargs)
            planner._local = planner._local_digest(world)
            return planner
        except BaseException:
            model.close()
            verifier.close()
            raise

    def close(self) -> None:
        self.model.close()
        self.verifier.close()

    def sync(self, world: object) -> None:
        """Copy ``world`` into both models again (objects moved, grasped, released)."""
        from projection._world import World

        if not isinstance(world, World):
            raise TypeError(f"expected a projection World, got {type(world).__name__}")
        self.model.sync(world)
        self.verifier.sync(world)
        self._local = self._local_digest(world)

    def _span(self) -> tuple[int, float]:
        """The chain's first moving link and an upper bound (m) of how far any point of
        the links it moves can get from that link's origin, whatever the joints: over the
        moving links, the sum of the origin-to-parent-origin distances down the tree to
        the link (the chain stretches no further) plus the farthest corner of the link's
        box from its origin (what the hand holds is added per world:
        :meth:`_local_digest`)."""
        if self._span_cache is not None:
            return self._span_cache
        m = self.model
        c = m.client
        links = sorted(self.chain.moving_links)
        parent = {i: int(pb.getJointInfo(m.robot, i, physicsClientId=c)[16]) for i in links}
        first = min(self.chain.indices)
        origin = {
            i: np.array(
                pb.getLinkState(m.robot, i, computeForwardKinematics=1, physicsClientId=c)[4]
            )
            for i in links
        }
        # along the tree: how far link i's origin can get from the first one's, plus the
        # reach of its own box around its origin
        reach: dict[int, float] = {}
        span = 0.0
        for i in links:  # parents first: joint indices grow down the tree
            up = parent[i]
            reach[i] = (
                reach[up] + float(np.linalg.norm(origin[i] - origin[up])) if up in reach else 0.0
            )
            lo, hi = pb.getAABB(m.robot, i, physicsClientId=c)
            for corner in itertools.product(*zip(lo, hi)):
                span = max(span, reach[i] + float(np.linalg.norm(np.array(corner) - origin[i])))
        self._span_cache = (first, span)
        return self._span_cache

    def _local_digest(self, world: object) -> tuple[object, ...]:
        """The part of ``world`` this chain's plans depend on, quantised
        (:data:`projection._collision_model.QUANTUM`): every robot joint, and the objects
        and kitchen links whose boxes come within the chain's span (:meth:`_span`) of its
        first link, with their poses *relative to the robot's base*. A motion planned at
        one base pose serves another where the same things stand around the arm (the
        imagined runs try several base poses; most arm motions there are self-collision
        detours). Bodies beyond the span cannot touch the chain; the path of a hit is
        verified again in the exact geometry anyway."""
        from projection._world import World

        assert isinstance(world, World)
        first, span = self._span()
        m = self.model
        for h in m.held.values():  # as far as a held object's box reaches past its link
            state = pb.getLinkState(
                m.robot, h.link, computeForwardKinematics=1, physicsClientId=m.client
            )
            link = state[4]
            lo, hi = pb.getAABB(h.body, -1, physicsClientId=m.client)
            span += max(
                float(np.linalg.norm(np.array(corner) - np.array(link)))
                for corner in itertools.product(*zip(lo, hi))
            )
        wc = world.client
        robot = world.robot_body
        n = pb.getNumJoints(robot, physicsClientId=wc)
        joints = [v[0] for v in pb.getJointStates(robot, range(n), physicsClientId=wc)]
        state = pb.getLinkState(robot, first, computeForwardKinematics=1, physicsClientId=wc)
        shoulder = np.array(state[4])
        base = world.robot_pose()
        inv = pb.invertTransform(base.position, base.orientation)

        def near(lo: Sequence[float], hi: Sequence[float]) -> bool:
            gap = np.maximum(0.0, np.maximum(np.array(lo) - shoulder, shoulder - np.array(hi)))
            return float(np.linalg.norm(gap)) <= span

        def local(pos: Sequence[float], orn: Sequence[float]) -> tuple[int, ...]:
            p, q = pb.multiplyTransforms(inv[0], inv[1], pos, orn)
            return _quantised(p, q)

        around: list[object] = []
        attachments = world.attachments
        for name, otype in world.objects.items():
            if near(*world.object_aabb(name)):
                pose = world.object_pose(name)
                around.append(
                    (name, otype, attachments.get(name), local(pose.position, pose.orientation))
                )
        kitchen = world.kitchen_body
        for i in range(-1, pb.getNumJoints(kitchen, physicsClientId=wc)):
            if not pb.getCollisionShapeData(kitchen, i, physicsClientId=wc):
                continue  # no geometry: nothing to touch
            if not near(*pb.getAABB(kitchen, i, physicsClientId=wc)):
                continue
            if i < 0:
                pos, orn = pb.getBasePositionAndOrientation(kitchen, physicsClientId=wc)
            else:
                ls = pb.getLinkState(kitchen, i, computeForwardKinematics=1, physicsClientId=wc)
                pos, orn = ls[4], ls[5]
            around.append((i, local(pos, orn)))
        return (self.model.padding, _quantised((), (0.0, 0.0, 0.0, 1.0), joints), tuple(around))

    # ------------------------------------------------------------------ input
    def _config(self, q: Q, what: str) -> np.ndarray:
        chain = self.chain
        try:
            arr = np.array([float(v) for v in q], dtype=float)
        except (TypeError, ValueError):
            raise ValueError(f"{what} must be a sequence of numbers, got {q!r}") from None
        if arr.shape != (len(chain.joints),):
            raise ValueError(
                f"{what} needs {len(chain.joints)} values ({', '.join(chain.joints)}), "
                f"got {arr.size}"
            )
        if not np.all(np.isfinite(arr)):
            raise ValueError(f"{what} must be finite, got {arr.tolist()}")
        for j, (v, lo, hi, cont) in enumerate(zip(arr, chain.lower, chain.upper, chain.continuous)):
            if cont:
                continue
            if not lo - 1e-6 <= v <= hi + 1e-6:
                raise ValueError(f"{what}: {chain.joints[j]} = {v:.4f} outside [{lo}, {hi}]")
            arr[j] = min(max(v, lo), hi)
        return arr

    def _nearest(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """``b`` with each continuous joint moved by whole turns to the value nearest
        its value in ``a``: IK wraps a continuous joint into [-pi, pi], so a goal 0.5 rad
        past the wrap would otherwise be reached by turning the joint 5.8 rad the long
        way round (seed 4 without projection knocked the milk so)."""
        out = b.copy()
        for j, cont in enumerate(self.chain.continuous):
            if cont:
                out[j] = nearest_turn_of(float(b[j]), float(a[j]))
        return out

    def _turns(self, a: np.ndarray, b: np.ndarray) -> list[np.ndarray]:
        """The goals of a query from ``a`` to ``b`` (``b`` at its nearest turn): ``b``
        first, then ``b`` with its continuous joints one turn the other way round ``a``
        (every combination; none without continuous joints). The straight line and the
        sampler go to ``b``; only when the sampler finds no path there within its budget
        does it try the others (:meth:`_sample_turns`)."""
        cont = [j for j, c in enumerate(self.chain.continuous) if c]
        out = [b]
        for k in range(1, len(cont) + 1):
            for chosen in itertools.combinations(cont, k):
                g = b.copy()
                for j in chosen:
                    g[j] += -2.0 * math.pi if b[j] >= a[j] else 2.0 * math.pi
                out.append(g)
        return out

    def collisions(self, q: Q, allowed_contacts: Iterable[str] = ()) -> list[tuple[str, str]]:
        """The forbidden contacts (moving part, what it touches) at ``q`` in the exact
        geometry; the model is left at ``q``."""
        arr = self._config(q, "configuration")
        return _Checker(self.verifier, self.chain, allowed_contacts).contacts(arr)

    # ------------------------------------------------------------------ queries
    def plan(
        self,
        start: Q,
        goal: Q,
        *,
        seed: int = 1,
        allowed_contacts: Iterable[str] = (),
        max_checks: int = MAX_CHECKS,
        timeout: float = TIMEOUT,
    ) -> ArmTrajectory:
        """A collision-free timed path from ``start`` to ``goal`` (see the module
        docstring). ``allowed_contacts``: object names and fixed-body link names the touch
        links and held objects may touch on the way (a free motion allows none). A
        continuous joint of ``goal`` is reached at its turn nearest ``start`` (whole turns
        away: the trajectory ends there, the same pose), or at its other turn when no path
        there is found within the budget (:meth:`_sample_turns`).
        ``seed`` >= 0 (OMPL replaces 0 by 1, so it gets ``seed + 1``). No path:
        :class:`ManipulationPoseUnreachable` (``reason`` names why)."""
        if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
            raise ValueError(f"seed must be an int >= 0, got {seed!r}")
        if isinstance(max_checks, bool) or not isinstance(max_checks, int) or max_checks < 1:
            raise ValueError(f"max_checks must be an int >= 1, got {max_checks!r}")
        if not (math.isfinite(timeout) and timeout > 0.0):
            raise ValueError(f"timeout must be a finite number of seconds > 0, got {timeout!r}")
        a = self._config(start, "start")
        b = self._nearest(a, self._config(goal, "goal"))
        allowed = frozenset(allowed_contacts) if not isinstance(allowed_contacts, str) else None
        if allowed is None:
            raise TypeError(
                f"allowed_contacts is a set of names, not the string {allowed_contacts!r}"
            )
        key, exact_key = self._keys(a, b, seed, allowed, max_checks)
        cached = self._cache.get(key)
        if cached is not None and cached.exact_key == exact_key:
            # the same query in the same world: the same answer, nothing checked again
            self._hit(key)
            if cached.failure is not None:
                raise ManipulationPoseUnreachable(
                    str(cached.failure.message), **cached.failure.details
                )
            assert cached.trajectory is not None
            return cached.trajectory
        padded = _Checker(self.model, self.chain, allowed)
        exact = _Checker(self.verifier, self.chain, allowed)
        for checker in (padded, exact):
            checker.tolerate_held_contacts(a)
            checker.tolerate_end_contacts(a, b)
        for q, what in ((a, "start"), (b, "goal")):
            hits = exact.contacts(q)
            if hits:
                raise ManipulationPoseUnreachable(
                    f"arm {what} configuration in collision: "
                    + ", ".join(f"{x} touches {y}" for x, y in sorted(set(hits))),
                    reason=f"{what} in collision",
                    contacts=tuple(sorted(set(hits))),
                )
        if float(np.max(np.abs(b - a))) < 1e-9:
            return ArmTrajectory(
                self.chain.joints, b[None, :].copy(), np.zeros(1), False, exact.calls
            )

        # configuration (its float64 bytes) -> whether it is valid, for this query only:
        # the sampler, the straight line and the shortcutting ask again for states they
        # checked already (about one check in eight on a reach past a cereal box); the
        # answer depends on nothing but the configuration while the query runs (the
        # models, the allowed and persisting contacts are fixed until it returns)
        memo: dict[bytes, bool] = {}
        ends = [a, *self._turns(a, b)]  # the start, the goal's turns (the nearest first)

        def check(q: Q) -> bool:
            v = np.asarray(q, dtype=float)
            k = v.tobytes()
            known = memo.get(k)
            if known is not None:
                return known
            ok = padded.valid(v)
            if not ok:
                near = min(np.linalg.norm(v - e) for e in ends) < ESCAPE
                ok = bool(near and exact.valid(v))
            memo[k] = ok
            return ok

        if cached is not None and cached.vertices is not None:
            # the same query in a world equal up to the quanta: the remembered path, its
            # ends moved to this query's, if the exact geometry confirms it now
            vertices = cached.vertices.copy()
            vertices[0], vertices[-1] = a, self._nearest(cached.vertices[-1], b)
            if all(exact.valid(q) for q in _dense(vertices, self.verify_resolution)):
                self._hit(key)
                positions, times = time_parameterise(
                    vertices, self.chain.max_velocity, self.acceleration, self.resolution
                )
                positions[0], positions[-1] = a, vertices[-1]
                trajectory = _frozen(
                    ArmTrajectory(self.chain.joints, positions, times, cached.planned, exact.calls)
                )
                self._remember(key, _Entry(exact_key, vertices, cached.planned, trajectory))
                return trajectory
        self.cache_misses += 1
        try:
            trajectory, vertices = self._plan(a, b, check, padded, exact, seed, max_checks, timeout)
        except ManipulationPoseUnreachable as e:
            if e.details.get("reason") == "budget spent":  # deterministic: remembered
                self._remember(key, _Entry(exact_key, None, False, None, e))
            raise
        trajectory = _frozen(trajectory)
        self._remember(key, _Entry(exact_key, vertices, trajectory.planned, trajectory))
        return trajectory

    def _keys(
        self, a: np.ndarray, b: np.ndarray, seed: int, allowed: frozenset[str], max_checks: int
    ) -> tuple[tuple[object, ...], tuple[object, ...]]:
        """The cache key of a query (the world and the configurations quantised: see
        :data:`projection._collision_model.QUANTUM`) and its exact key (to 1e-4)."""
        query = (self.chain.joints, seed, allowed, max_checks)
        key = (
            self._local if self._local is not None else self.model.coarse_digest,
            tuple(int(v) for v in np.round(a / QUANTUM_ANGLE)),
            tuple(int(v) for v in np.round(b / QUANTUM_ANGLE)),
            *query,
        )
        exact_key = (
            self.model.digest,
            tuple(np.round(a, _DIGITS).tolist()),
            tuple(np.round(b, _DIGITS).tolist()),
            *query,
        )
        return key, exact_key

    def _hit(self, key: object) -> None:
        self.cache_hits += 1
        self._cache.move_to_end(key)

    def _remember(self, key: object, value: _Entry) -> None:
        self._cache[key] = value
        self._cache.move_to_end(key)
        while len(self._cache) > CACHE_SIZE:
            self._cache.popitem(last=False)

    def _plan(
        self,
        a: np.ndarray,
        b: np.ndarray,
        check: Check,
        padded: _Checker,
        exact: _Checker,
        seed: int,
        max_checks: int,
        timeout: float,
    ) -> tuple[ArmTrajectory, np.ndarray]:
        """The straight line or a sampled path, verified densely in the exact geometry;
        a path that grazes is repaired lazily (see :class:`_Forbidden`): the grazing
        states are forbidden to the planning check and the query is planned again, at
        most :data:`REPAIR_ROUNDS` times, each within the check budget."""
        resolution = self.resolution
        goals = self._turns(a, b)
        forbidden = _Forbidden(self.repair_radius, a, *goals)

        def lazy(q: Q) -> bool:
            return not forbidden.near(q) and check(q)

        for attempt in range(1 + REPAIR_ROUNDS):
            vertices = self._straight(a, b, lazy, resolution)
            planned = vertices is None
            if vertices is None:
                vertices = self._sample_turns(
                    a, goals, lazy, padded, seed + 1, resolution, max_checks, timeout
                )
            grazes = self._grazes(vertices, exact)
            if not grazes:
                positions, times = time_parameterise(
                    vertices, self.chain.max_velocity, self.acceleration, resolution
                )
                positions[0], positions[-1] = a, vertices[-1]
                calls = padded.calls + exact.calls
                if attempt:
                    self.repaired += 1
                    log.info("arm path repaired after %d graze(s) (%d checks)", attempt, calls)
                return (
                    ArmTrajectory(
                        self.chain.joints, positions, times, planned, calls, repairs=attempt
                    ),
                    vertices,
                )
            q, ((body_a, link_a, body_b, link_b), depth) = grazes[0]
            log.info(
                "arm path grazes an obstacle at resolution %.3f rad (attempt %d): %s touches "
                "%s by %.1f mm (%s; %d grazing states)",
                resolution,
                attempt + 1,
                self.verifier.describe(body_a, link_a),
                self.verifier.describe(body_b, link_b),
                -1000.0 * depth,
                "deeper than at the start or goal"
                if (body_a, link_a, body_b, link_b) in exact.persisting
                else "new",
                len(grazes),
            )
            self.repair_rounds += 1
            for q, _hit in grazes:
                forbidden.add(q)
        raise ManipulationPoseUnreachable(
            "no arm path that the exact geometry confirms (it grazed after "
            f"{REPAIR_ROUNDS} repairs)",
            reason="path not verified",
        )

    def _grazes(
        self, vertices: np.ndarray, exact: _Checker
    ) -> list[tuple[np.ndarray, tuple[tuple[int, int, int, int], float]]]:
        """Every state along ``vertices`` (every :data:`VERIFY_RESOLUTION` rad) in
        contact in the exact geometry, with its first contact: the whole path is scanned,
        so that one repair round forbids every graze of the path at once."""
        out = []
        for q in _dense(vertices, self.verify_resolution):
            exact.calls += 1
            hits = exact._scan(q, first_only=True)
            if hits:
                out.append((np.array(q, dtype=float), hits[0]))
        return out

    def follow(
        self, waypoints: Sequence[Q], *, allowed_contacts: Iterable[str] = ()
    ) -> ArmTrajectory:
        """The straight joint-space segments through ``waypoints`` (e.g. IK solutions
        along a straight tool line: pregrasp -> grasp, a lift, the last centimetres of a
        placing), checked every :data:`VERIFY_RESOLUTION` rad in the exact geometry with
        ``allowed_contacts`` (the object grasped may touch the fingers, the counter the
        object lifted off) and timed. A forbidden contact:
        :class:`ManipulationPoseUnreachable` naming it."""
        if isinstance(allowed_contacts, str):
            raise TypeError(
                f"allowed_contacts is a set of names, not the string {allowed_contacts!r}"
            )
        if len(waypoints) < 1:
            raise ValueError("follow needs at least one waypoint")
        vertices = np.array([self._config(q, f"waypoint {i}") for i, q in enumerate(waypoints)])
        exact = _Checker(self.verifier, self.chain, allowed_contacts)
        for q in _dense(vertices, self.verify_resolution):
            hits = exact.contacts(q)
            if hits:
                raise ManipulationPoseUnreachable(
                    "straight arm motion in collision: "
                    + ", ".join(f"{x} touches {y}" for x, y in sorted(set(hits))),
                    reason="straight motion in collision",
                    contacts=tuple(sorted(set(hits))),
                )
        positions, times = time_parameterise(
            vertices, self.chain.max_velocity, self.acceleration, self.resolution
        )
        return ArmTrajectory(self.chain.joints, positions, times, False, exact.calls)

    # ------------------------------------------------------------------ internals
    @staticmethod
    def _straight(a: np.ndarray, b: np.ndarray, check: Check, step: float) -> np.ndarray | None:
        line = np.array([a, b])
        if all(check(q) for q in _dense(line, step)):
            return line
        return None

    def _sample_turns(
        self,
        a: np.ndarray,
        goals: Sequence[np.ndarray],
        check: Check,
        padded: _Checker,
        seed: int,
        resolution: float,
        max_checks: int,
        timeout: float,
    ) -> np.ndarray:
        """:meth:`_sample` to the goal's nearest turn (``goals[0]``); when that spends
        its budget and the chain has continuous joints, again to their other turns
        (``goals[1:]``, OMPL's ``GoalStates``), with a budget of their own: an arm
        tucked between its torso and the other arm may find no way out turning its
        forearm the short way, and one the long way."""
        try:
            return self._sample(a, goals[:1], check, padded, seed, resolution, max_checks, timeout)
        except ManipulationPoseUnreachable as e:
            if len(goals) == 1 or e.details.get("reason") != "budget spent":
                raise
        log.info("no arm path to the goal's nearest turn within the budget: trying the others")
        return self._sample(a, goals[1:], check, padded, seed, resolution, max_checks, timeout)

    def _sample(
        self,
        a: np.ndarray,
        goals: Sequence[np.ndarray],
        check: Check,
        padded: _Checker,
        seed: int,
        resolution: float,
        max_checks: int,
        timeout: float,
    ) -> np.ndarray:
        chain = self.chain
        n = len(chain.joints)
        space = ob.RealVectorStateSpace(n)
        bounds = ob.RealVectorBounds(n)
        for j in range(n):
            if chain.continuous[j]:  # the start and the goals' turns, half a turn beyond
                lo = min(a[j], *(g[j] for g in goals)) - math.pi
                hi = max(a[j], *(g[j] for g in goals)) + math.pi
            else:
                lo, hi = chain.lower[j], chain.upper[j]
            bounds.setLow(j, float(lo))
            bounds.setHigh(j, float(hi))
        space.setBounds(bounds)
        # the seed right before the SimpleSetup and planner draw their generators; OMPL
        # logs a misleading "already started" error on every reseed: silenced
        ou.setLogLevel(ou.LOG_NONE)
        ou.RNG.setSeed(seed)
        ou.setLogLevel(ou.LOG_WARN)
        ss = og.SimpleSetup(space)
        si = ss.getSpaceInformation()
        calls = [0]

        def valid(s: object) -> bool:
            calls[0] += 1
            return check(s[0:n])  # type: ignore[index]

        ss.setStateValidityChecker(valid)
        si.setStateValidityCheckingResolution(resolution / space.getMaximumExtent())

        def state(q: np.ndarray) -> object:
            s = space.allocState()
            s[0:n] = [float(v) for v in q]
            space.enforceBounds(s)
            return s

        ss.setStartState(state(a))
        goal = ob.GoalStates(si)
        for g in goals:
            goal.addState(state(g))
        ss.setGoal(goal)
        planner = og.RRTConnect(si)
        planner.setRange(RANGE)
        ss.setPlanner(planner)
        timed_out = ob.timedPlannerTerminationCondition(timeout)
        ptc = ob.plannerOrTerminationCondition(
            timed_out, ob.PlannerTerminationCondition(lambda: calls[0] >= max_checks)
        )
        ss.solve(ptc)
        if not ss.haveExactSolutionPath():
            reason = "budget spent" if calls[0] >= max_checks else "timeout"
            if reason == "timeout":
                log.warning("arm planning hit its %.1f s safety timeout", timeout)
            raise ManipulationPoseUnreachable(
                f"no collision-free arm path found ({reason}: {calls[0]} checks)",
                reason=reason,
                checks=calls[0],
            )
        path = ss.getSolutionPath()
        simplifier = ss.getPathSimplifier()
        _simplify(simplifier, path)
        vertices = np.array([s[0:n] for s in path.getStates()], dtype=float)
        vertices[0] = a
        reached = min(goals, key=lambda g: float(np.max(np.abs(vertices[-1] - g))))
        if float(np.max(np.abs(vertices[-1] - reached))) > 1e-9:
            vertices = np.vstack([vertices, reached])
        else:
            vertices[-1] = reached
        return vertices
