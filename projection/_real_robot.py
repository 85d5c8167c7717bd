"""The simulated *real* robot: a second PyBullet :class:`World` is the true world, the
robot's belief is another; plans and projection reason on the belief, the real process
modules act on the truth and sense it.

- **Time.** Every motion takes simulated time on the cpl clock (``cpl.sleep``) in
  :data:`CONTROL_PERIOD` steps: the base drives along a straight line while turning at
  :data:`BASE_VELOCITY` / :data:`BASE_ANGULAR_VELOCITY` (each step a teleport with a
  collision check: a collision on the way stops the robot where it was and raises
  :class:`executive.NavigationGoalNotReached`); arm, torso, head and finger motions take
  ``max joint delta / joint velocity limit``. Who picks the clock is the caller
  (``cpl.run(..., clock=real_robot_clock(speed))``).
- **Physics.** The true world is stepped at :data:`PHYSICS_RATE` Hz for the simulated time
  that passed (once, however many modules move), with the robot and the objects it holds
  kinematic, so free objects settle, slip off, fall or are pushed by the robot. Stepping is
  skipped while every free object rests and none touches the robot.
- **Belief.** The robot knows its own state: after every step the belief robot (base,
  joints, held objects) is set to the true one. Objects are learned by perception only:
  ``detect`` returns poses with Gaussian noise (x, y, yaw; z is kept), misses an object at
  ``miss_rate``, and :class:`RealWorldModel` puts what was perceived into the belief.
- **Faults.** A seeded :class:`FaultProfile` injects typed low-level failures at given
  rates; each kind draws from its own generator (spawned from the seed), so a kind's fault
  sequence does not depend on how often the others were drawn.
"""

from __future__ import annotations

import abc
import asyncio
import itertools
import math
from collections.abc import AsyncIterator, Callable, Mapping, Sequence
from contextlib import asynccontextmanager
from dataclasses import dataclass, fields, replace
from typing import Any, ClassVar, Literal, TypeVar

import numpy as np
import pybullet as pb

import cpl
import executive
from cpl.testing import MockClock
from executive import Designator, MotionCommand, Pose, ProbeResult, ProcessModule, an, equate
from executive.events import (
    ContainerClosed,
    ContainerOpened,
    Event,
    ObjectAttached,
    ObjectDetached,
    ObjectPerceived,
    RobotStateChanged,
    emit,
    object_name,
)
from executive.failures import (
    GripperClosedCompletely,
    ManipulationGoalNotReached,
    ManipulationPoseUnreachable,
    NavigationGoalNotReached,
    NavigationPoseUnreachable,
    PerceptionObjectNotFound,
    PtuGoalNotReached,
)
from executive.knowledge import ARM_JOINTS
from projection._objects import object_type
from projection._process_modules import GripperMotions, PtuPM
from projection._world import World
from projection._world_model import DETACH_SETTLE_STEPS, ProjectedWorldModel

T = TypeVar("T")

__all__ = [
    "ARM_JOINT_VELOCITY",
    "BASE_ANGULAR_VELOCITY",
    "BASE_VELOCITY",
    "CONTROL_PERIOD",
    "DEMO_OBJECTS",
    "DETECTION_TIME",
    "FINGER_VELOCITY",
    "HEAD_JOINT_VELOCITY",
    "PHYSICS_RATE",
    "TORSO_VELOCITY",
    "FaultProfile",
    "RealWorldModel",
    "make_world_pair",
    "real_process_modules",
    "real_robot_clock",
    "with_real_robot",
]

BASE_VELOCITY = 0.6  #: m/s, the base's linear velocity limit
BASE_ANGULAR_VELOCITY = 1.0  #: rad/s, the base's angular velocity limit
ARM_JOINT_VELOCITY = 1.0  #: rad/s, every arm joint
TORSO_VELOCITY = 0.05  #: m/s, the torso lift
HEAD_JOINT_VELOCITY = 2.0  #: rad/s, pan and tilt
FINGER_VELOCITY = 0.05  #: m/s per finger joint (the opening changes twice as fast)
DETECTION_TIME = 0.5  #: s one detection takes
CONTROL_PERIOD = 0.05  #: s of simulated time per motion step
PHYSICS_RATE = 240.0  #: Hz of the true world's physics
MAX_CATCH_UP = 2.0  #: s of physics simulated at most for one step (after a long idle time)
_FAULT_FRACTION = (0.2, 0.8)  #: where along a motion a mid-way fault strikes
_AT_REST = (1e-3, 1e-2)  #: linear (m/s) and angular (rad/s) speeds of an object at rest
_PREFIX = {"left": "l", "right": "r"}
_DRAWER_LINK = "sink_area_left_upper_drawer_main"

SceneObject = tuple[str, Pose] | tuple[str, Pose, str]

#: CRAM's demo objects (map; z is replaced by the resting height on the sink counter; the
#: spoon lies in the drawer, attached to it): name -> (type, pose[, attached link]).
DEMO_OBJECTS: Mapping[str, SceneObject] = {
    "breakfast-cereal-1": ("breakfast-cereal", Pose((1.4, 0.4, 0.85))),
    "cup-1": ("cup", Pose((1.3, 0.6, 0.9))),
    "bowl-1": ("bowl", Pose((1.4, 0.8, 0.87))),
    "milk-1": ("milk", Pose.from_xyz_yaw(1.4, 0.62, 0.95, math.pi)),
    "spoon-1": ("spoon", Pose.from_xyz_yaw(1.4, 1.0, 0.74132, math.pi), _DRAWER_LINK),
}


# ----------------------------------------------------------------------- fault profile
@dataclass(frozen=True)
class FaultProfile:
    """Which low-level failures the real robot injects, and how well it sees.

    Rates are probabilities per motion: ``navigation`` (``going`` stops part of the way:
    :class:`executive.NavigationGoalNotReached`), ``ptu`` (``looking`` stops part of the
    way: :class:`executive.PtuGoalNotReached`), ``perception`` (a detection fails:
    :class:`executive.PerceptionObjectNotFound`), ``grasp_slip`` (a grip that closed on an
    object loses it: :class:`executive.GripperClosedCompletely`, nothing held), ``drop``
    (after a successful grip, the object falls out during the next arm motion of that arm,
    which then raises :class:`executive.GripperClosedCompletely`), ``ik`` (``moving-tcp``
    finds no IK solution: :class:`executive.ManipulationPoseUnreachable`).
    ``detection_noise`` = (position std in m, applied to x and y; yaw std in rad);
    ``miss_rate``: probability that a visible object is not seen. ``seed`` seeds every
    draw (None: fresh entropy). Values outside [0, 1] or negative noise: ValueError.
    """

    navigation: float = 0.0
    ptu: float = 0.0
    perception: float = 0.0
    grasp_slip: float = 0.0
    drop: float = 0.0
    ik: float = 0.0
    detection_noise: tuple[float, float] = (0.01, 0.03)
    miss_rate: float = 0.0
    seed: int | None = 0

    #: The failure kinds (the fields that :meth:`uniform` sets).
    KINDS: ClassVar[tuple[str, ...]] = (
        "navigation",
        "ptu",
        "perception",
        "grasp_slip",
        "drop",
        "ik",
    )

    def __post_init__(self) -> None:
        for key in (*self.KINDS, "miss_rate"):
            value = getattr(self, key)
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise TypeError(f"FaultProfile.{key} must be a number in [0, 1], got {value!r}")
            if not 0.0 <= value <= 1.0:
                raise ValueError(f"FaultProfile.{key} must be in [0, 1], got {value!r}")
        noise = tuple(self.detection_noise)
        if len(noise) != 2 or not all(
            isinstance(v, (int, float)) and math.isfinite(v) and v >= 0 for v in noise
        ):
            raise ValueError(
                "FaultProfile.detection_noise is (position std m, yaw std rad), both >= 0, "
                f"got {self.detection_noise!r}"
            )
        object.__setattr__(self, "detection_noise", (float(noise[0]), float(noise[1])))
        if self.seed is not None and (
            isinstance(self.seed, bool) or not isinstance(self.seed, int)
        ):
            raise TypeError(f"FaultProfile.seed must be an int or None, got {self.seed!r}")

    @classmethod
    def uniform(cls, rate: float, **others: Any) -> FaultProfile:
        """Every failure kind (:attr:`KINDS`) at ``rate``; ``others`` set the remaining
        fields (``detection_noise``, ``miss_rate``, ``seed``)."""
        rates: dict[str, Any] = dict.fromkeys(cls.KINDS, rate)
        return cls(**rates, **others)

    @classmethod
    def none(cls, seed: int | None = 0) -> FaultProfile:
        """A perfect robot: no failures, no misses, no detection noise."""
        return cls(detection_noise=(0.0, 0.0), seed=seed)

    @classmethod
    def parse(cls, text: str) -> FaultProfile:
        """From a command-line string: ``"0.1"`` (uniform), or comma-separated
        ``key=value`` items (keys: the kinds, ``miss_rate``, ``seed``,
        ``detection_noise=POS:YAW``), optionally led by a bare uniform rate:
        ``"0.05,grasp_slip=0.2,seed=3"``. Malformed text: ValueError naming the keys."""
        known = {f.name for f in fields(cls)}
        values: dict[str, Any] = {}
        items = [item.strip() for item in text.split(",") if item.strip()]
        if not items:
            raise ValueError("an empty fault profile; give a rate like '0.1' or 'ik=0.2'")
        for k, item in enumerate(items):
            key, sep, raw = item.partition("=")
            key = key.strip().replace("-", "_")
            try:
                if not sep:
                    if k != 0:
                        raise ValueError(item)
                    values.update({kind: float(key) for kind in cls.KINDS})
                elif key not in known:
                    raise ValueError(item)
                elif key == "seed":
                    values[key] = None if raw.strip().lower() == "none" else int(raw)
                elif key == "detection_noise":
                    pos, _, yaw = raw.partition(":")
                    values[key] = (float(pos), float(yaw or 0.0))
                else:
                    values[key] = float(raw)
            except ValueError:
                raise ValueError(
                    f"bad fault profile item {item!r} in {text!r}: use a rate or key=value "
                    f"with keys {', '.join(sorted(known))}"
                ) from None
        return cls(**values)

    @property
    def rates(self) -> Mapping[str, float]:
        """Failure kind -> rate."""
        return {kind: getattr(self, kind) for kind in self.KINDS}


# ----------------------------------------------------------------------- clocks
def real_robot_clock(speed: float | None = None) -> cpl.Clock:
    """The clock to run a real-robot plan on (``cpl.run(main, clock=...)``): ``None`` or
    ``math.inf``: as fast as possible (``MockClock(autojump=True)``); otherwise simulated
    time runs ``speed`` times faster than the wall clock (``ScaledClock(speed)``;
    ``1.0`` = real time). Not > 0: ValueError."""
    if speed is None or speed == math.inf:
        return MockClock(autojump=True)
    return cpl.ScaledClock(speed)


def _check_clock(speed: float) -> None:
    """Raise ValueError unless the running loop runs at ``speed`` (see with_real_robot)."""
    loop = asyncio.get_running_loop()
    clock = getattr(loop.time, "__self__", None)
    if isinstance(clock, MockClock):
        rate = math.inf
    elif isinstance(clock, cpl.ScaledClock):
        rate = clock.factor
    elif isinstance(clock, cpl.Clock):
        rate = 1.0
    else:
        rate = 1.0  # the loop's own monotonic time
    if rate != speed:
        raise ValueError(
            f"with_real_robot(speed={speed}) but the loop runs at {rate}x wall time: run the "
            f"plan with cpl.run(..., clock=projection.real_robot_clock({speed}))"
        )


# ----------------------------------------------------------------------- the body
def _wrap(angle: float) -> float:
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


def _robot_links(world: World) -> dict[str, int]:
    c, robot = world.client, world.robot_body
    return {
        pb.getJointInfo(robot, i, physicsClientId=c)[12].decode(): i
        for i in range(pb.getNumJoints(robot, physicsClientId=c))
    }


def sync_robot(true_world: World, belief_world: World) -> None:
    """Set the belief robot's base and joints to the true robot's; objects the belief robot
    holds follow. Nothing else in the belief changes."""
    truth = true_world.snapshot()
    belief = belief_world.snapshot()
    if belief.base == truth.base and belief.robot_joints == truth.robot_joints:
        return
    belief_world.restore(replace(belief, base=truth.base, robot_joints=truth.robot_joints))
    links = _robot_links(belief_world)
    for name, link, (rp, rq) in belief.attachments:
        if link in links:
            lp = belief_world.link_pose(link)
            pos, orn = pb.multiplyTransforms(lp.position, lp.orientation, rp, rq)
            belief_world.set_object_pose(name, Pose(pos, orn))


class _Body:
    """The true robot shared by the six real modules: worlds, fault generators, the physics
    clock and the drops armed by grips."""

    def __init__(self, true_world: World, belief_world: World, faults: FaultProfile) -> None:
        self.true = true_world
        self.belief = belief_world
        self.faults = faults
        streams = np.random.SeedSequence(faults.seed).spawn(len(FaultProfile.KINDS) + 2)
        self.rngs = {kind: np.random.default_rng(s) for kind, s in zip(FaultProfile.KINDS, streams)}
        self.noise_rng = np.random.default_rng(streams[-2])
        self.miss_rng = np.random.default_rng(streams[-1])
        self.physics_time: float | None = None
        self.drops: dict[str, float] = {}  # arm -> fraction of its next motion
        c, robot = true_world.client, true_world.robot_body
        self.robot_links = [-1, *range(pb.getNumJoints(robot, physicsClientId=c))]
        links = _robot_links(true_world)
        self.gripper_links = {
            arm: [i for n, i in links.items() if n.startswith(f"{p}_gripper")]
            for arm, p in _PREFIX.items()
        }
        self.head = {j: i for j, i in _joint_indices(true_world).items() if j.startswith("head_")}

    # -- faults -------------------------------------------------------------------
    def fault(self, kind: str) -> float | None:
        """Draw a fault of ``kind``: the fraction of the motion at which it strikes, or
        None. Always draws twice, so the sequence depends only on the number of draws."""
        rng = self.rngs[kind]
        strike = float(rng.random())
        fraction = float(rng.uniform(*_FAULT_FRACTION))
        return fraction if strike < getattr(self.faults, kind) else None

    # -- time and physics ---------------------------------------------------------
    async def step(self, seconds: float) -> None:
        """Let ``seconds`` of simulated time pass (cpl.sleep), then catch physics up."""
        await cpl.sleep(seconds)
        self.physics()

    def physics(self) -> None:
        """Step the true world's physics up to the loop's current time (at most
        :data:`MAX_CATCH_UP` s at once), robot and held objects kinematic."""
        now = asyncio.get_running_loop().time()
        last = self.physics_time
        self.physics_time = now
        if last is None or now <= last:
            return
        steps = round(min(now - last, MAX_CATCH_UP) * PHYSICS_RATE)
        if steps > 0 and self._restless():
            self._simulate(steps)

    def _restless(self) -> bool:
        world, c = self.true, self.true.client
        attached = world.attachments
        free = [world.body_of(n) for n in world.objects if n not in attached]
        if not free:
            return False
        lin_eps, ang_eps = _AT_REST
        for body in free:
            lin, ang = pb.getBaseVelocity(body, physicsClientId=c)
            if np.linalg.norm(lin) > lin_eps or np.linalg.norm(ang) > ang_eps:
                return True
        robot = world.robot_body
        pb.performCollisionDetection(physicsClientId=c)
        return any(pb.getContactPoints(robot, body, physicsClientId=c) for body in free)

    def _simulate(self, steps: int) -> None:
        world, c = self.true, self.true.client
        before = world.snapshot()
        attached = world.attachments
        robot = world.robot_body
        kinematic = [(robot, i) for i in self.robot_links]
        kinematic += [(world.body_of(n), -1) for n in attached]
        masses = [(b, i, pb.getDynamicsInfo(b, i, physicsClientId=c)[0]) for b, i in kinematic]
        for b, i, _ in masses:
            pb.changeDynamics(b, i, mass=0.0, physicsClientId=c)
        try:
            for k in range(steps):
                pb.stepSimulation(physicsClientId=c)
                if k % 24 == 23 and not self._restless():
                    break
        finally:
            for b, i, m in masses:
                pb.changeDynamics(b, i, mass=m, physicsClientId=c)
        after = {entry[0]: entry for entry in world.snapshot().objects}
        objects = tuple(e if e[0] in attached else after[e[0]] for e in before.objects)
        world.restore(replace(before, objects=objects))

    def sync(self) -> None:
        sync_robot(self.true, self.belief)

    async def animate(
        self,
        duration: float,
        pose_at: Callable[[float], None],
        stop_at: float | None = None,
        on_fraction: tuple[float, Callable[[], None]] | None = None,
    ) -> bool:
        """Move along ``pose_at(s)``, s from 0 to 1, over ``duration`` simulated seconds in
        :data:`CONTROL_PERIOD` steps; physics and belief follow each step. Returns False,
        stopped where it was, once s would pass ``stop_at``. ``on_fraction`` = (s, fn)
        calls ``fn`` once s reaches it. Evaporation stops the motion where it is."""
        n = max(1, math.ceil(duration / CONTROL_PERIOD - 1e-9))
        try:
            for k in range(1, n + 1):
                s = k / n
                if stop_at is not None and s > stop_at:
                    return False
                if duration > 0:
                    await self.step(duration / n)
                pose_at(s)
                if on_fraction is not None and s >= on_fraction[0]:
                    on_fraction[1]()
                    on_fraction = None
                self.sync()
        finally:
            self.sync()
        return True


def _joint_indices(world: World) -> dict[str, int]:
    c, robot = world.client, world.robot_body
    out = {}
    for i in range(pb.getNumJoints(robot, physicsClientId=c)):
        info = pb.getJointInfo(robot, i, physicsClientId=c)
        if info[2] != pb.JOINT_FIXED:
            out[info[1].decode()] = i
    return out


# ----------------------------------------------------------------------- modules
class RealProcessModule(ProcessModule):
    """A process module of the real robot. Subclasses implement :meth:`run` for each
    resolved command; an unknown command raises :class:`executive.DesignatorError`.
    Evaporation stops the motion where it is and :meth:`on_cancel` brings the belief robot
    to the true one."""

    commands: ClassVar[frozenset[str]] = frozenset()

    def __init__(self, body: _Body, name: str) -> None:
        super().__init__(name)
        self.body = body
        self.world = body.true

    async def execute(self, motion: Designator) -> Any:
        command, args = motion.reference()
        if command not in self.commands:
            raise executive.DesignatorError(
                f"process module {self.name!r} cannot execute the command {command!r} of "
                f"{motion.short()} (it executes {', '.join(sorted(self.commands))})",
                motion,
            )
        self.body.physics()
        return await self.run(MotionCommand(command, args), motion)

    @abc.abstractmethod
    async def run(self, command: MotionCommand, motion: Designator) -> Any:
        """Execute one resolved command on the true world, taking simulated time."""

    async def on_cancel(self, motion: Designator) -> None:
        self.body.sync()


class RealNavigationPM(RealProcessModule):
    """``going``: follow a base path to the pose at most :data:`BASE_VELOCITY` (or the
    motion's ``speed``, if lower) and :data:`BASE_ANGULAR_VELOCITY`.

    The base's local planner (:func:`_base_path`) picks the first of a few candidate paths
    (straight while turning; turn, then drive; drive, then turn; face the travel
    direction; a dog-leg through the midpoint) that is collision-free in the true world;
    if none is, it drives straight. A collision on the way, or a navigation fault, stops
    the robot at its last pose and raises :class:`executive.NavigationGoalNotReached`
    (``location=goal``)."""

    motion_types = frozenset({"going"})
    commands = frozenset({"move-base"})

    def __init__(self, body: _Body) -> None:
        super().__init__(body, "navigation")

    async def run(self, command: MotionCommand, motion: Designator) -> None:
        world = self.world
        goal: Pose = command.arguments["pose"]
        start = world.robot_pose()
        if goal.frame == "base_footprint":
            goal = start.to_transform("base_footprint") * goal
        elif goal.frame != "map":
            raise ValueError(f"unsupported frame {goal.frame!r}; known: map, base_footprint")
        speed = command.arguments.get("speed")
        v = min(BASE_VELOCITY, speed) if speed is not None and speed > 0 else BASE_VELOCITY
        path = _base_path(world, start, goal)
        legs = [
            max(
                math.hypot(b[0] - a[0], b[1] - a[1]) / v,
                abs(_wrap(b[2] - a[2])) / BASE_ANGULAR_VELOCITY,
            )
            for a, b in itertools.pairwise(path)
        ]
        duration = sum(legs)
        blocked: list[BaseException] = []

        def pose_at(s: float) -> None:
            if blocked:
                return
            x, y, yaw = _along_base(path, legs, s)
            try:
                world.drive(Pose.from_xyz_yaw(x, y, 0.0, yaw))
            except NavigationPoseUnreachable as exc:
                blocked.append(exc)

        stop = self.body.fault("navigation")
        n = max(1, math.ceil(duration / CONTROL_PERIOD - 1e-9))
        done = True
        try:
            for k in range(1, n + 1):
                if stop is not None and k / n > stop:
                    done = False
                    break
                await self.body.step(duration / n)
                pose_at(k / n)
                self.body.sync()
                if blocked:
                    break
        finally:
            self.body.sync()
        if blocked:
            raise NavigationGoalNotReached(
                f"collision on the way to {goal!r}; stopped at {world.robot_pose()!r}",
                location=goal,
            ) from blocked[0]
        if not done:
            raise NavigationGoalNotReached(
                f"the base stopped at {world.robot_pose()!r} on the way to {goal!r}",
                location=goal,
            )


class RealTorsoPM(RealProcessModule):
    """``moving-torso`` at :data:`TORSO_VELOCITY`; outside the joint limits raises
    :class:`executive.TorsoGoalNotReached` before moving."""

    motion_types = frozenset({"moving-torso"})
    commands = frozenset({"move-torso"})

    def __init__(self, body: _Body) -> None:
        super().__init__(body, "torso")

    async def run(self, command: MotionCommand, motion: Designator) -> None:
        world = self.world
        start = world.torso_height
        world.move_torso(command.arguments["joint_angle"])  # validates (raises, unchanged)
        goal = world.torso_height
        world.move_torso(start)
        await self.body.animate(
            abs(goal - start) / TORSO_VELOCITY,
            lambda s: world.move_torso(start + s * (goal - start)),
        )


class RealPtuPM(RealProcessModule):
    """``looking`` (as the projection ``ptu`` module computes the goal) at
    :data:`HEAD_JOINT_VELOCITY`. Beyond the limits raises :class:`executive.PtuGoalNotReached`
    before moving; a ptu fault stops the head part of the way and raises it too."""

    motion_types = frozenset({"looking"})
    commands = frozenset({"move-head"})

    def __init__(self, body: _Body) -> None:
        super().__init__(body, "ptu")
        self._goal = PtuPM(body.true)

    def _set(self, values: Sequence[float]) -> None:
        c, robot = self.world.client, self.world.robot_body
        for i, v in zip(self.body.head.values(), values):
            pb.resetJointState(robot, i, v, 0.0, physicsClientId=c)

    async def run(self, command: MotionCommand, motion: Designator) -> None:
        joints = list(self.body.head)
        start = [self.world.joint_position(j) for j in joints]
        self._goal.run(command, motion)  # raises PtuGoalNotReached, head unchanged
        goal = [self.world.joint_position(j) for j in joints]
        self._set(start)
        delta = max(abs(g - s) for g, s in zip(goal, start))
        stop = self.body.fault("ptu")
        reached = await self.body.animate(
            delta / HEAD_JOINT_VELOCITY,
            lambda s: self._set([a + s * (b - a) for a, b in zip(start, goal)]),
            stop_at=stop,
        )
        if not reached:
            raise PtuGoalNotReached("the head stopped on the way", target=command.arguments)


class RealPerceptionPM(RealProcessModule):
    """``detecting``: after :data:`DETECTION_TIME`, the true world's visible matches
    (:meth:`World.detect`), each missed at ``miss_rate``, the first one reported with a
    noisy pose as ``(type T) (name N) (pose <map pose>) (transform <base_footprint -> N>)``
    plus the input's other properties, equated to the input and announced with
    :class:`executive.events.ObjectPerceived`. Nothing seen, or a perception fault, raises
    :class:`executive.PerceptionObjectNotFound`."""

    motion_types = frozenset({"detecting"})
    commands = frozenset({"detect"})

    def __init__(self, body: _Body) -> None:
        super().__init__(body, "perception")

    async def run(self, command: MotionCommand, motion: Designator) -> Designator:
        body = self.body
        wanted: Designator = command.arguments["object"]
        failed = body.fault("perception")
        await body.step(DETECTION_TIME)
        if failed is not None:
            raise PerceptionObjectNotFound("perception failed to find the object", object=wanted)
        try:
            visible = self.world.detect(wanted)
        except PerceptionObjectNotFound:
            visible = []
        seen = [o for o in visible if not body.miss_rng.random() < body.faults.miss_rate]
        if not seen:
            raise PerceptionObjectNotFound(
                f"no {wanted.get('type')} seen ({len(visible)} visible, all missed)"
                if visible
                else f"no visible {wanted.get('type')}",
                object=wanted,
            )
        found = seen[0]
        pos_std, yaw_std = body.faults.detection_noise
        noise = body.noise_rng.normal(0.0, 1.0, 3) * (pos_std, pos_std, yaw_std)
        true_pose = found.map_pose
        turn = Pose.from_xyz_yaw(0.0, 0.0, 0.0, float(noise[2])).as_rotation()
        x, y, z = true_pose.position
        map_pose = Pose(
            (x + float(noise[0]), y + float(noise[1]), z),
            (turn * true_pose.as_rotation()).as_quat(),
        )
        base = self.world.robot_pose().to_transform("base_footprint")
        in_base = base.inverse() * map_pose
        own = {"type", "name", "pose", "transform"}
        perceived = an.object(
            ("type", found.type),
            ("name", found.name),
            ("pose", map_pose),
            ("transform", in_base.to_transform(found.name)),
            *((k, v) for k, v in wanted.properties if k not in own),
        )
        original = motion.get("object")
        equate(original if isinstance(original, Designator) else wanted, perceived)
        emit(ObjectPerceived(perceived))
        return perceived


class RealGrippersPM(GripperMotions, RealProcessModule):
    """Gripper motions at :data:`FINGER_VELOCITY` (the projection ``grippers`` module's
    types). ``gripping`` closes until contact; nothing between the fingers, or a
    ``grasp_slip`` fault, raises :class:`executive.GripperClosedCompletely` with nothing
    held; a ``drop`` fault arms a drop for the arm's next motion. An opening outside
    [0, 0.1] raises :class:`executive.GripperGoalNotReached` before moving."""

    def __init__(self, body: _Body) -> None:
        super().__init__(body, "grippers")

    async def run(self, command: MotionCommand, motion: Designator) -> None:
        world, body = self.world, self.body
        args = command.arguments
        action = args["action"]
        goal_action = args["joint_angle"] if action == "angle" else action
        grippers = args["gripper"]
        arms = [grippers] if isinstance(grippers, str) else list(grippers)
        start = {arm: world.gripper_opening(arm) for arm in arms}
        goal: dict[str, float] = {}
        empty: list[str] = []
        for arm in arms:  # the goal, computed by the world (raises before moving)
            try:
                world.gripper(goal_action, arm)
            except GripperClosedCompletely:
                empty.append(arm)
            goal[arm] = world.gripper_opening(arm)
            world.gripper(start[arm], arm)
        delta = max(abs(goal[a] - start[a]) for a in arms)

        def pose_at(s: float) -> None:
            for arm in arms:
                world.gripper(start[arm] + s * (goal[arm] - start[arm]), arm)

        await body.animate(delta / 2.0 / FINGER_VELOCITY, pose_at)
        if empty:
            raise GripperClosedCompletely(action=action, arm=empty[0])
        if action == "grip":
            for arm in arms:
                if body.fault("grasp_slip") is not None:
                    raise GripperClosedCompletely(
                        f"the object slipped out of the {arm} gripper", action=action, arm=arm
                    )
                drop = body.fault("drop")
                if drop is not None:
                    body.drops[arm] = drop
                else:
                    body.drops.pop(arm, None)


class RealArmsPM(RealProcessModule):
    """``moving-tcp`` (the true world's IK with torso resampling; an ``ik`` fault or no
    solution raises :class:`executive.ManipulationPoseUnreachable` before moving) and
    ``moving-arm-joints`` (bad values: :class:`executive.ManipulationGoalNotReached`),
    at :data:`ARM_JOINT_VELOCITY` and :data:`TORSO_VELOCITY`. No collision checks: the arm
    pushes what it meets. A drop armed by a grip makes the held object fall part of the
    way; the motion then ends and raises :class:`executive.GripperClosedCompletely`."""

    motion_types = frozenset({"moving-tcp", "moving-arm-joints"})
    commands = frozenset({"move-tcp", "move-joints"})

    def __init__(self, body: _Body) -> None:
        super().__init__(body, "arms")

    async def run(self, command: MotionCommand, motion: Designator) -> None:
        world, body = self.world, self.body
        args: Mapping[str, Any] = command.arguments
        arms = [a for a in ("left", "right") if args.get(a) is not None]
        start = {a: world.arm_joints(a) for a in ("left", "right")}
        torso = world.torso_height
        if command.command == "move-tcp":
            if body.fault("ik") is not None:
                raise ManipulationPoseUnreachable(
                    "no IK solution found", left=args.get("left"), right=args.get("right")
                )
            if not _imagined_goal(world, body.belief, arms, args):
                world.move_tcp(left=args.get("left"), right=args.get("right"))
            _clear_ik(world, arms, args, torso, start)
        else:
            try:
                world.move_joints(left=args.get("left"), right=args.get("right"))
            except ValueError as exc:
                raise ManipulationGoalNotReached(
                    str(exc), left=args.get("left"), right=args.get("right")
                ) from exc
        goal = {a: world.arm_joints(a) for a in arms}
        goal_torso = world.torso_height
        world.move_torso(torso)
        world.move_joints(**{a: start[a] for a in arms})
        first: _Config = (torso, {a: start[a] for a in arms})
        last: _Config = (goal_torso, goal)
        if command.command == "move-tcp":
            # The plan's waypoints assume the tool moves straight between them (a reach
            # approaches its object along the grasp axis): follow that line.
            path = _cartesian_path(world, arms, args, first, last)
            routed = _reroute_cartesian(world, arms, path, start, goal)
            if routed is not None:
                path = [
                    (torso + (goal_torso - torso) * i / max(1, len(routed) - 1), c)
                    for i, c in enumerate(routed)
                ]
        else:
            # Configuration moves (park, carry) are routed around free objects.
            joints = _arm_path(world, arms, start, goal) or []
            path = [
                (torso + (goal_torso - torso) * i / max(1, len(joints) - 1), c)
                for i, c in enumerate(joints)
            ]
        world.move_torso(torso)
        world.move_joints(**{a: start[a] for a in arms})
        legs = [_leg_seconds(u, v) for u, v in itertools.pairwise(path)]
        duration = sum(legs)

        def pose_at(s: float) -> None:
            t, config = _along_configs(path, legs, s)
            world.move_torso(t)
            world.move_joints(**config)

        dropped: list[str] = []
        drop = self._armed_drop(arms)
        trigger = None
        if drop is not None:
            arm, name, fraction = drop

            def release() -> None:
                world.detach(name, settle_steps=0)
                world.gripper("close", arm)
                dropped.append(name)

            trigger = (fraction, release)
        await body.animate(duration, pose_at, on_fraction=trigger)
        if dropped:
            raise GripperClosedCompletely(
                f"{dropped[0]} slipped out of the {drop[0] if drop else ''} gripper",
                action="hold",
                arm=drop[0] if drop else None,
                object=dropped[0],
            )

    def _armed_drop(self, arms: Sequence[str]) -> tuple[str, str, float] | None:
        links = _robot_links(self.world)
        for arm in arms:
            fraction = self.body.drops.get(arm)
            if fraction is None:
                continue
            for name, link in self.world.attachments.items():
                if link in links and link.startswith(_PREFIX[arm] + "_"):
                    del self.body.drops[arm]
                    return arm, name, fraction
        return None


_BasePose = tuple[float, float, float]
#: Spacing (m, rad) of the collision probes along a candidate base path.
BASE_PATH_STEP = (0.05, 0.1)


def _base_candidates(a: _BasePose, b: _BasePose) -> list[list[_BasePose]]:
    """Candidate base paths from ``a`` to ``b`` (x, y, yaw), most direct first."""
    (x0, y0, t0), (x1, y1, t1) = a, b
    heading = math.atan2(y1 - y0, x1 - x0) if math.hypot(x1 - x0, y1 - y0) > 1e-6 else t0
    xm = (x0 + x1) / 2.0
    return [
        [a, b],
        [a, (x0, y0, t1), b],
        [a, (x1, y1, t0), b],
        [a, (x0, y0, heading), (x1, y1, heading), b],
        [a, (xm, y0, t0), (xm, y1, t1), b],
        [a, (x0, y0, t1), (xm, y0, t1), (xm, y1, t1), b],
    ]


def _path_free(world: World, path: list[_BasePose]) -> bool:
    """Whether the robot (with what it holds) stays collision-free along ``path``; the
    world is left exactly as it was."""
    snap = world.snapshot()
    try:
        for (x0, y0, t0), (x1, y1, t1) in itertools.pairwise(path):
            dyaw = _wrap(t1 - t0)
            n = max(
                1,
                math.ceil(math.hypot(x1 - x0, y1 - y0) / BASE_PATH_STEP[0]),
                math.ceil(abs(dyaw) / BASE_PATH_STEP[1]),
            )
            for k in range(1, n + 1):
                f = k / n
                try:
                    world.drive(
                        Pose.from_xyz_yaw(
                            x0 + f * (x1 - x0), y0 + f * (y1 - y0), 0.0, t0 + f * dyaw
                        )
                    )
                except NavigationPoseUnreachable:
                    return False
        return True
    finally:
        world.restore(snap)


def _base_path(world: World, start: Pose, goal: Pose) -> list[_BasePose]:
    """The base path the simulated robot's local planner follows: the first collision-free
    candidate of :func:`_base_candidates`, else the straight one (which then stops at the
    obstacle, as a blocked robot does)."""
    a = (start.position[0], start.position[1], start.yaw)
    b = (goal.position[0], goal.position[1], goal.yaw)
    candidates = _base_candidates(a, b)
    for path in candidates:
        if _path_free(world, path):
            return path
    return candidates[0]


def _along_base(path: list[_BasePose], legs: list[float], s: float) -> _BasePose:
    """The base pose at fraction ``s`` of the path's duration (legs in seconds)."""

    def lerp(p: _BasePose, q: _BasePose, f: float) -> _BasePose:
        return (p[0] + f * (q[0] - p[0]), p[1] + f * (q[1] - p[1]), p[2] + f * _wrap(q[2] - p[2]))

    return _along_timed(path, legs, s, lerp)


def _along_timed(path: list[T], legs: list[float], s: float, lerp: Callable[[T, T, float], T]) -> T:
    """The point at fraction ``s`` of a polyline's total duration, where ``legs[i]`` is
    the duration of the segment ``path[i] -> path[i + 1]``."""
    total = sum(legs)
    if total <= 0.0:
        return path[-1]
    d = s * total
    for (p, q), leg in zip(itertools.pairwise(path), legs):
        if d <= leg or q is path[-1]:
            return lerp(p, q, 1.0 if leg <= 0.0 else min(1.0, d / leg))
        d -= leg
    return path[-1]


_Config = tuple[float, dict[str, tuple[float, ...]]]  # torso height, arm joints by arm
#: Spacing (m, rad) of the tool-frame waypoints of a Cartesian arm motion.
CARTESIAN_STEP = (0.02, 0.1)
_TOOL = {"left": "l_gripper_tool_frame", "right": "r_gripper_tool_frame"}


def _leg_seconds(u: _Config, v: _Config) -> float:
    joints = max((abs(q - p) for a in u[1] for p, q in zip(u[1][a], v[1][a])), default=0.0)
    return max(joints / ARM_JOINT_VELOCITY, abs(v[0] - u[0]) / TORSO_VELOCITY)


def _along_configs(path: list[_Config], legs: list[float], s: float) -> _Config:
    """The configuration at fraction ``s`` of a configuration path's duration."""

    def lerp(u: _Config, v: _Config, f: float) -> _Config:
        return (
            u[0] + f * (v[0] - u[0]),
            {a: tuple(p + f * (q - p) for p, q in zip(u[1][a], v[1][a])) for a in u[1]},
        )

    return _along_timed(path, legs, s, lerp)


def _cartesian_path(
    world: World, arms: Sequence[str], goals: Mapping[str, Any], first: _Config, last: _Config
) -> list[_Config]:
    """Configurations that move each tool frame along the straight line (position) and
    the shortest rotation (orientation) to its goal, by IK at small steps seeded with the
    previous step's solution. If an intermediate step has no IK solution, the path is
    the straight joint-space one. Leaves the robot wherever the last step put it."""
    from scipy.spatial.transform import Rotation, Slerp

    robot = world.robot_pose().to_transform("base_footprint")
    lines = {}
    steps = 1
    for a in arms:
        start = world.link_pose(_TOOL[a])
        goal: Pose = goals[a]
        if goal.frame == "base_footprint":
            goal = robot * goal
        rots = Rotation.from_quat([start.orientation, goal.orientation])
        lines[a] = (np.array(start.position), np.array(goal.position), Slerp([0.0, 1.0], rots))
        steps = max(
            steps,
            math.ceil(start.distance_to(goal) / CARTESIAN_STEP[0]),
            math.ceil(start.angle_to(goal) / CARTESIAN_STEP[1]),
        )
    path: list[_Config] = [first]
    for k in range(1, steps):
        f = k / steps
        targets = {
            a: Pose(p + f * (g - p), sl([f]).as_quat()[0], "map") for a, (p, g, sl) in lines.items()
        }
        try:
            world.move_tcp(**targets)
        except ManipulationPoseUnreachable:
            return [first, last]
        path.append((world.torso_height, {a: world.arm_joints(a) for a in arms}))
    path.append(last)
    return path


def _arm_blocked(world: World, arms: Sequence[str]) -> bool:
    """Whether a link of ``arms`` other than the gripper's (or an object they hold)
    touches a free object: the gripper may touch the object it reaches for."""
    free = {n for n in world.objects if n not in world.attachments}
    prefixes = tuple(f"{_PREFIX[a]}_" for a in arms)
    for c in world.robot_collisions():
        if c.body_b not in free:
            continue
        link = c.link_a or ""
        if link.startswith(prefixes) and "gripper" not in link:
            return True
    return False


def _imagined_goal(
    world: World, belief: World, arms: Sequence[str], args: Mapping[str, Any]
) -> bool:
    """Put the true robot's arms and torso at the configuration the *belief* world's IK
    gives for this goal. The belief robot mirrors the true one, and its IK memo holds the
    configurations that projection's probes checked for collisions (the checks walk the
    same waypoints from the same start), so the robot executes what it imagined instead
    of an arbitrary other IK solution that may lay its forearm among the objects. The
    belief world is left as it was. False if the belief's IK finds no solution (the
    caller then solves in the true world)."""
    snap = belief.snapshot()
    try:
        belief.move_tcp(left=args.get("left"), right=args.get("right"))
        goal = {a: belief.arm_joints(a) for a in arms}
        height = belief.torso_height
    except ManipulationPoseUnreachable:
        return False
    finally:
        belief.restore(snap)
    world.move_torso(height)
    world.move_joints(**goal)
    return True


def _clear_ik(
    world: World,
    arms: Sequence[str],
    args: Mapping[str, Any],
    torso: float,
    start: _ArmConfig,
) -> None:
    """The true world's IK picks the first solution at the first torso height that
    reaches the goal, with no collision check, and may lay the elbow or forearm among the
    objects next to the one reached for (projection's IK, seeded differently, checked
    another configuration). Like a collision-aware IK, try the other torso heights (from
    the arm's start) when this goal configuration makes an arm link other than the
    gripper touch a free object, and keep the first that does not; none: the first
    solution. Leaves the robot at the chosen goal configuration."""
    if not _arm_blocked(world, arms):
        return
    chosen = (world.torso_height, {a: world.arm_joints(a) for a in arms})
    index = _joint_indices(world)["torso_lift_joint"]
    info = pb.getJointInfo(world.robot_body, index, physicsClientId=world.client)
    lo, hi = float(info[8]), float(info[9])
    heights = sorted(
        {round(lo + (hi - lo) * k / 6, 4) for k in range(7)} - {round(chosen[0], 4)},
        key=lambda h: abs(h - torso),
    )
    for h in heights:
        world.move_torso(h)
        world.move_joints(**{a: start[a] for a in arms})
        try:
            world.move_tcp(left=args.get("left"), right=args.get("right"))
        except ManipulationPoseUnreachable:
            continue
        if abs(world.torso_height - h) < 1e-6 and not _arm_blocked(world, arms):
            return
    world.move_torso(chosen[0])
    world.move_joints(**chosen[1])


def _reroute_cartesian(
    world: World,
    arms: Sequence[str],
    path: list[_Config],
    start: _ArmConfig,
    goal: _ArmConfig,
) -> list[_ArmConfig] | None:
    """A joint-space route (:func:`_arm_path`, no fallback) replacing the Cartesian
    ``path`` of a ``moving-tcp`` when that line sweeps the arm through a free object other
    than those touched at its start or end (the object a reach approaches, the one the
    hand is next to), e.g. from the carry pose to a pregrasp straight through a
    neighbouring object; None (keep the line) when it is clear, when the torso moves
    along it, or when no route is clear either. Leaves the arms and torso wherever the
    checks put them (the caller resets)."""
    torso = path[0][0]
    if abs(path[-1][0] - torso) > 1e-3:
        return None
    free = {n for n in world.objects if n not in world.attachments}
    if not free:
        return None
    world.move_torso(torso)
    world.move_joints(**path[0][1])
    allowed = _touched(world, free)
    world.move_joints(**path[-1][1])
    allowed |= _touched(world, free)
    others = free - allowed
    hit = False
    for _t, config in path[1:-1]:
        world.move_joints(**config)
        if _touched(world, others):
            hit = True
            break
    if not hit:
        return None
    world.move_joints(**start)
    return _arm_path(world, arms, start, goal, fallback=False)


#: Samples per straight joint-space segment when checking an arm path for collisions.
PATH_CHECK_SAMPLES = 12
#: The raised-arm via configuration (shoulder lifted, elbow bent) the controller routes
#: through when the straight path would hit a free object.
RAISED_SHOULDER_LIFT = -0.45
RAISED_ELBOW_FLEX = -1.9

_ArmConfig = dict[str, tuple[float, ...]]


def _touched(world: World, free: set[str]) -> set[str]:
    """The free objects the robot (or what it holds) touches now."""
    return {c.body_b for c in world.robot_collisions() if c.body_b in free}


def _path_hits(
    world: World,
    arms: Sequence[str],
    a: _ArmConfig,
    b: _ArmConfig,
    allowed: set[str] | frozenset[str] = frozenset(),
) -> bool:
    """Whether the straight joint-space segment a -> b makes an arm touch a free object
    (one not attached to anything) other than those in ``allowed``. Leaves the arms at
    ``b``."""
    free = {n for n in world.objects if n not in world.attachments} - set(allowed)
    if not free:
        return False
    for k in range(1, PATH_CHECK_SAMPLES + 1):
        f = k / PATH_CHECK_SAMPLES
        world.move_joints(
            **{arm: [p + f * (q - p) for p, q in zip(a[arm], b[arm])] for arm in arms}
        )
        if _touched(world, free):
            return True
    return False


#: Heights (m) by which the controller lifts a tool straight up (at the same torso
#: height) to route an arm over the free objects around it.
LIFT_HEIGHTS = (0.1, 0.2, 0.3)


def _lifted(world: World, arms: Sequence[str], config: _ArmConfig, dz: float) -> _ArmConfig | None:
    """``config`` with each arm's tool frame ``dz`` higher (same orientation, same torso
    height), by the true world's IK; None when an arm has no such solution. Leaves the
    arms wherever the IK put them (the caller resets)."""
    torso = world.torso_height
    out: _ArmConfig = {}
    for a in arms:
        world.move_joints(**{a: config[a]})
        tool = world.link_pose(_TOOL[a])
        up = Pose((tool.position[0], tool.position[1], tool.position[2] + dz), tool.orientation)
        try:
            world.move_tcp(**{a: up})
        except ManipulationPoseUnreachable:
            return None
        if abs(world.torso_height - torso) > 1e-6:
            world.move_torso(torso)
            return None
        out[a] = world.arm_joints(a)
    return out


def _arm_path(
    world: World,
    arms: Sequence[str],
    start: _ArmConfig,
    goal: _ArmConfig,
    fallback: bool = True,
) -> list[_ArmConfig] | None:
    """The joint-space path the simulated controller follows: straight when that touches
    no free object, else the first clear one of: through a raised-arm via configuration;
    lifting the tool straight up first (:data:`LIFT_HEIGHTS`), then straight, through the
    raised via, along the straight tool line to the goal, or down onto the goal from
    above. A lift that starts in contact with an
    object (the hand next to an object after a failed grip) may touch that object, and
    the final descent may touch what the goal touches (a pregrasp at its object).
    Nothing clear: straight anyway (the arm then pushes what it meets, as an arm without
    a planner would; ``fallback=False``: None). A real PR2 plans collision-free arm paths;
    projection teleports, so plans never see this. Leaves the arms wherever the last check
    put them (the caller resets)."""
    straight = [{a: start[a] for a in arms}, {a: goal[a] for a in arms}]
    if not _path_hits(world, arms, start, goal):
        return straight
    lift, elbow = ARM_JOINTS.index("shoulder_lift_joint"), ARM_JOINTS.index("elbow_flex_joint")

    def raised(config: _ArmConfig) -> _ArmConfig:
        via: _ArmConfig = {}
        for a in arms:
            q = list(config[a])
            q[lift], q[elbow] = RAISED_SHOULDER_LIFT, RAISED_ELBOW_FLEX
            via[a] = tuple(q)
        return via

    free = {n for n in world.objects if n not in world.attachments}
    world.move_joints(**{a: start[a] for a in arms})
    at_start = _touched(world, free)
    world.move_joints(**{a: goal[a] for a in arms})
    at_goal = _touched(world, free)

    def clear(path: list[_ArmConfig], lifts_first: bool, descends_last: bool) -> bool:
        world.move_joints(**path[0])
        last = len(path) - 2
        for i, (u, v) in enumerate(itertools.pairwise(path)):
            allowed: set[str] = set()
            if i == 0 and lifts_first:
                allowed |= at_start
            if i == last and descends_last:
                allowed |= at_goal
            world.move_joints(**u)
            if _path_hits(world, arms, u, v, allowed):
                return False
        return True

    def over(up: _ArmConfig) -> list[_ArmConfig] | None:
        """From ``up``, the tool frames along straight lines to the goal's (IK at small
        steps, the torso kept): a lift, then a Cartesian approach."""
        torso = world.torso_height
        world.move_joints(**goal)
        tools = {a: world.link_pose(_TOOL[a]) for a in arms}
        world.move_joints(**up)
        line = _cartesian_path(world, arms, tools, (torso, up), (torso, goal))
        world.move_torso(torso)
        if len(line) <= 2 or any(abs(t - torso) > 1e-6 for t, _c in line):
            return None
        return [c for _t, c in line]

    begin, end = dict(straight[0]), dict(straight[1])
    if clear([begin, raised(start), end], False, False):
        return [begin, raised(start), end]
    for dz in LIFT_HEIGHTS:
        up = _lifted(world, arms, start, dz)
        down = _lifted(world, arms, goal, dz)
        candidates: list[tuple[list[_ArmConfig], bool, bool]] = []
        if up is not None:
            candidates += [
                ([begin, up, end], True, False),
                ([begin, up, raised(up), end], True, False),
            ]
            line = over(up)
            if line is not None:
                candidates.append(([begin, *line], True, True))
            if down is not None:
                candidates.append(([begin, up, down, end], True, True))
        if down is not None:
            candidates.append(([begin, raised(start), down, end], False, True))
        for path, lifts_first, descends_last in candidates:
            if clear(path, lifts_first, descends_last):
                return path
    return straight if fallback else None


def real_process_modules(
    true_world: World, belief_world: World, faults: FaultProfile | None = None
) -> tuple[RealProcessModule, ...]:
    """The six real modules (navigation, torso, ptu, perception, grippers, arms) acting on
    ``true_world`` and keeping ``belief_world``'s robot in step. Their fault draws start
    afresh from ``faults.seed``."""
    body = _Body(true_world, belief_world, faults if faults is not None else FaultProfile())
    return (
        RealNavigationPM(body),
        RealTorsoPM(body),
        RealPtuPM(body),
        RealPerceptionPM(body),
        RealGrippersPM(body),
        RealArmsPM(body),
    )


# ----------------------------------------------------------------------- world model
class RealWorldModel:
    """:class:`executive.ProjectionWorld` of the real robot: queries and probes are the
    belief world's (:class:`ProjectedWorldModel`; plans reason on belief, probes never
    touch the true world), and events change both worlds:

    - ``ObjectAttached``: the belief attaches (raising for unknown objects as in
      projection); the true world attaches only if a gripper link of that arm really
      touches the object;
    - ``ObjectDetached``: both release what they hold (the true object then falls and
      settles under physics);
    - ``ContainerOpened``/``ContainerClosed``: the belief moves the joint (raising beyond
      the limits); the true joint follows, clamped to its limits;
    - ``ObjectPerceived``: the belief object is put at the perceived pose, spawned if the
      belief did not know it;
    - ``RobotStateChanged``: the belief robot is set to the true one.
    """

    def __init__(self, true_world: World, belief_world: World) -> None:
        for w, what in ((true_world, "true_world"), (belief_world, "belief_world")):
            if not isinstance(w, World):
                raise TypeError(f"RealWorldModel needs a projection.World as {what}, got {w!r}")
        if true_world is belief_world:
            raise ValueError("the true world and the belief world must be different worlds")
        self.true_world = true_world
        self.belief_world = belief_world
        self.belief = ProjectedWorldModel(belief_world)
        self._links = _robot_links(true_world)

    # -- queries and probes: the belief's -------------------------------------------
    def object_pose(self, name: str, frame: str = "map") -> Pose:
        return self.belief.object_pose(name, frame)

    def robot_pose(self) -> Pose:
        return self.belief.robot_pose()

    def object_type(self, name: str) -> str:
        return self.belief.object_type(name)

    def object_in_hand(self, arm: str) -> str | None:
        return self.belief.object_in_hand(arm)

    def link_pose(self, link: str, frame: str = "map") -> Pose:
        return self.belief.link_pose(link, frame)

    def link_aabb(self, link: str) -> tuple[tuple[float, ...], tuple[float, ...]]:
        return self.belief.link_aabb(link)

    def object_aabb(self, name: str) -> tuple[tuple[float, ...], tuple[float, ...]]:
        return self.belief.object_aabb(name)

    def probe_base_pose(self, pose: Pose) -> ProbeResult:
        return self.belief.probe_base_pose(pose)

    def probe_arm_trajectory(
        self,
        arm: str,
        waypoints: Sequence[Pose],
        *,
        robot_pose: Pose | None = None,
        gripper_opening: float | None = None,
        allowed_contacts: Sequence[str] = (),
        check_collisions: Sequence[bool] | bool = True,
    ) -> ProbeResult:
        return self.belief.probe_arm_trajectory(
            arm,
            waypoints,
            robot_pose=robot_pose,
            gripper_opening=gripper_opening,
            allowed_contacts=allowed_contacts,
            check_collisions=check_collisions,
        )

    def probe_placing_stability(self, object_type: str, pose: Pose) -> ProbeResult:
        return self.belief.probe_placing_stability(object_type, pose)

    # -- events -----------------------------------------------------------------------
    def handle_event(self, event: Event) -> None:
        """Apply an event to both worlds (see the class docstring). Not an Event:
        TypeError."""
        if not isinstance(event, Event):
            raise TypeError(f"handle_event() needs an executive.events.Event, got {event!r}")
        true = self.true_world
        if isinstance(event, ObjectPerceived):
            self._perceived(event.designator)
        elif isinstance(event, RobotStateChanged):
            sync_robot(true, self.belief_world)
        elif isinstance(event, ObjectAttached):
            self.belief.handle_event(event)
            name = object_name(event.object)
            if name in true.objects and self.holds(event.arm, name):
                true.attach(name, event.link or f"{_PREFIX[event.arm]}_wrist_roll_link")
        elif isinstance(event, ObjectDetached):
            self.belief.handle_event(event)
            name = object_name(event.object)
            if name in true.objects and true.attachments.get(name) in self._links:
                true.detach(name, settle_steps=DETACH_SETTLE_STEPS)
        elif isinstance(event, (ContainerOpened, ContainerClosed)):
            self.belief.handle_event(event)
            joint = _container_joint(true, ProjectedWorldModel._container(event.container))
            sign = 1.0 if isinstance(event, ContainerOpened) else -1.0
            true.set_container(joint, true.joint_position(joint) + sign * event.distance)
        else:
            self.belief.handle_event(event)

    def holds(self, arm: str, name: str) -> bool:
        """Whether a gripper link of ``arm`` touches object ``name`` in the true world."""
        world, c = self.true_world, self.true_world.client
        body = world.body_of(name)
        return any(
            pb.getClosestPoints(world.robot_body, body, 1e-3, li, -1, physicsClientId=c)
            for n, li in self._links.items()
            if n.startswith(f"{_PREFIX[arm]}_gripper")
        )

    def _perceived(self, designator: Any) -> None:
        get = getattr(designator, "get", None)
        if get is None:
            return
        name, otype, pose = get("name"), get("type"), get("pose")
        if not isinstance(name, str) or not isinstance(pose, Pose):
            return
        belief = self.belief_world
        if name in belief.objects:
            if belief.attachments.get(name) not in self._links:  # not in the robot's hand
                belief.set_object_pose(name, pose)
        elif isinstance(otype, str):
            belief.spawn_object(name, otype, pose)

    def __repr__(self) -> str:
        return f"<RealWorldModel true={self.true_world!r} belief={self.belief_world!r}>"


def _container_joint(world: World, name: str) -> str:
    for joint in (name, f"{name}_joint"):
        try:
            world.joint_position(joint)
        except LookupError:
            continue
        return joint
    raise LookupError(f"no container {name!r} in the true world")


# ----------------------------------------------------------------------- environment
_LOCATION_RULES: Any = object()  # sentinel: "use the belief world's location rules"


@asynccontextmanager
async def with_real_robot(
    true_world: World,
    belief_world: World,
    faults: FaultProfile | None = None,
    speed: float | None = None,
    *,
    rules: executive.RuleSet | None = _LOCATION_RULES,
    name: str = "real",
) -> AsyncIterator[executive.Environment]:
    """Run a block with the simulated real robot (like ``with_projected_robot``)::

        async def main() -> None:
            async with projection.with_real_robot(true, belief, FaultProfile.uniform(0.05)):
                await executive.perform(a.motion(type="going", pose=pose))

        cpl.run(main, clock=projection.real_robot_clock(speed))

    The six real modules act on ``true_world``; the world model is a
    :class:`RealWorldModel`; ``rules`` default to
    ``projection._locations.location_rules(belief_world)`` (``None``:
    :data:`executive.static_rules`). ``faults`` default to :class:`FaultProfile()` (noise
    only). The clock belongs to the loop, so the caller picks it; ``speed`` (None: any)
    only checks that the running loop's clock has that speed (ValueError otherwise; see
    :func:`real_robot_clock`). On entry the belief robot is set to the true one. Leaving
    the block (also on failure or evaporation) stops and evaporates every running motion
    and leaves every module offline. Not Worlds, or the same world twice: TypeError /
    ValueError; a closed World: RuntimeError."""
    model = RealWorldModel(true_world, belief_world)
    true_world.client  # noqa: B018 - raise RuntimeError for a closed world
    belief_world.client  # noqa: B018
    if speed is not None:
        _check_clock(speed)
    if rules is _LOCATION_RULES:
        from projection._locations import location_rules

        rules = location_rules(belief_world)
    sync_robot(true_world, belief_world)
    from projection._imagination import ProjectionImagination

    env = executive.Environment(
        name,
        process_modules=real_process_modules(true_world, belief_world, faults),
        world=model,
        rules=rules,
        imagination=ProjectionImagination(belief_world),
    )
    async with executive.environment(env):
        yield env


# ----------------------------------------------------------------------- world pairs
def settle(world: World, steps: int = 100) -> None:
    """Step the world's physics ``steps`` times (1/240 s each) with the robot and attached
    objects held, so that freshly spawned objects come to rest."""
    body = _Body(world, world, FaultProfile.none())
    body._simulate(steps)


_settle = settle


def make_world_pair(
    seed: int | None = 0,
    *,
    objects: Mapping[str, SceneObject] | None = None,
    belief_objects: Literal["none", "exact", "noisy"] = "none",
    noise: tuple[float, float] = (0.02, 0.1),
    gui: bool = False,
) -> tuple[World, World]:
    """Two worlds from the same assets: ``(true_world, belief_world)``, robot and kitchen
    identical. ``objects`` (default :data:`DEMO_OBJECTS`; name -> (type, pose[, link to
    attach to])) are spawned in the true world (types that rest on a surface get their z
    from the counter below), which then settles for 100 physics steps. The belief knows
    them not at all (``"none"``: perception teaches it), exactly (``"exact"``), or with
    Gaussian ``noise`` = (x/y std m, yaw std rad) drawn from ``seed`` (``"noisy"``).
    ``gui=True`` shows the true world in a PyBullet window (needs a display). The caller
    closes both worlds. Bad ``belief_objects``: ValueError."""
    if belief_objects not in ("none", "exact", "noisy"):
        raise ValueError(
            f"belief_objects must be 'none', 'exact' or 'noisy', got {belief_objects!r}"
        )
    true_world, belief_world = World(seed=seed, gui=gui), World(seed=seed)
    try:
        spec = DEMO_OBJECTS if objects is None else objects
        for name, entry in spec.items():
            otype, pose = entry[0], entry[1]
            if objects is None and len(entry) == 2:  # the demo: rest on the sink counter
                top = true_world.link_aabb("sink_area_surface")[1][2]
                z = top + object_type(otype).size[2] / 2.0 + 0.001
                pose = Pose((pose.position[0], pose.position[1], z), pose.orientation)
            true_world.spawn_object(name, otype, pose)
            if len(entry) == 3:
                true_world.attach(name, entry[2])
        _settle(true_world, 100)
        rng = np.random.default_rng(seed)
        if belief_objects != "none":
            for name, otype in true_world.objects.items():
                pose = true_world.object_pose(name)
                if belief_objects == "noisy":
                    d = rng.normal(0.0, 1.0, 3) * (noise[0], noise[0], noise[1])
                    x, y, z = pose.position
                    turn = Pose.from_xyz_yaw(0, 0, 0, float(d[2])).as_rotation()
                    pose = Pose(
                        (x + float(d[0]), y + float(d[1]), z),
                        (turn * pose.as_rotation()).as_quat(),
                    )
                belief_world.spawn_object(name, otype, pose)
                link = true_world.attachments.get(name)
                if link is not None:
                    belief_world.attach(name, link)
    except BaseException:
        true_world.close()
        belief_world.close()
        raise
    return true_world, belief_world
