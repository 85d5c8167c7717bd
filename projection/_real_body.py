"""The simulated real robot's body: the true world shared by its six process modules,
with the fault generators, the physics clock (the true world is stepped for the
simulated time that passed), the belief robot kept in step with the true one, and the
motion speeds.

- **Time.** Every motion takes simulated time on the cpl clock (``cpl.sleep``) in
  :data:`CONTROL_PERIOD` steps; arm, torso, head and finger motions take
  ``max joint delta / joint velocity limit``.
- **Physics.** The true world is stepped at :data:`PHYSICS_RATE` Hz for the simulated time
  that passed (once, however many modules move), with the robot and the objects it holds
  kinematic, so free objects settle, slip off, fall or are pushed by the robot. Stepping is
  skipped while every free object rests and none touches the robot.
- **Belief.** The robot knows its own state: after every step the belief robot (base,
  joints, held objects) is set to the true one (:func:`sync_robot`).
- **Faults.** Each kind of a :class:`FaultProfile` draws from its own generator (spawned
  from the seed), so a kind's fault sequence does not depend on how often the others
  were drawn.
"""

from __future__ import annotations

import asyncio
import math
from collections.abc import Callable
from dataclasses import replace

import numpy as np
import pybullet as pb

import cpl
from executive import Pose
from projection._real_faults import FaultProfile
from projection._world import World

__all__ = [
    "ARM_JOINT_VELOCITY",
    "BASE_ANGULAR_VELOCITY",
    "BASE_VELOCITY",
    "CONTROL_PERIOD",
    "DETECTION_TIME",
    "FINGER_VELOCITY",
    "HEAD_JOINT_VELOCITY",
    "PHYSICS_RATE",
    "TORSO_VELOCITY",
    "settle",
    "sync_robot",
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


def sync_robot(true_world: World, belief_world: World) -> None:
    """Set the belief robot's base and joints to the true robot's; objects the belief robot
    holds follow. Nothing else in the belief changes."""
    # compare the robot parts only (what a snapshot of each holds, without the objects:
    # this runs at every control step of every real motion)
    true_world._check()
    belief_world._check()
    base, joints = true_world._base, true_world._get_joints(true_world._dofs)
    if belief_world._base == base and belief_world._get_joints(belief_world._dofs) == joints:
        return
    belief = belief_world.snapshot()
    belief_world.restore(replace(belief, base=base, robot_joints=joints))
    robot = belief_world.robot_body
    for name, link, (rp, rq) in belief.attachments:
        body, index = belief_world._links.get(link, (-1, -1))
        if body == robot and index >= 0:  # a robot link (not the base), as World.robot_links
            lp = belief_world.link_pose(link)
            pos, orn = pb.multiplyTransforms(lp.position, lp.orientation, rp, rq)
            belief_world.set_object_pose(name, Pose(pos, orn), allow_overlap=True)


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
        links = true_world.robot_links
        self.gripper_links = {
            arm: [i for n, i in links.items() if n in true_world.gripper_links(arm)]
            for arm in true_world.arms
        }
        neck = true_world.robot.neck
        joints = _joint_indices(true_world)
        # pan then tilt
        self.head = {j: joints[j] for j in (neck.pan_joint, neck.tilt_joint)}

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
        attached = world._attached
        free = [o.body for n, o in world._objects.items() if n not in attached]
        if not free:
            return False
        lin_eps, ang_eps = _AT_REST
        for body in free:
            (lx, ly, lz), (ax, ay, az) = pb.getBaseVelocity(body, physicsClientId=c)
            # |v| by hand: numpy's norm costs ~6 us per 3-vector, this runs per step
            if (
                math.sqrt(lx * lx + ly * ly + lz * lz) > lin_eps
                or math.sqrt(ax * ax + ay * ay + az * az) > ang_eps
            ):
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


def settle(world: World, steps: int = 100) -> None:
    """Step the world's physics ``steps`` times (1/240 s each) with the robot and attached
    objects held, so that freshly spawned objects come to rest."""
    body = _Body(world, world, FaultProfile.none())
    body._simulate(steps)
