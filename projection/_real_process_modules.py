"""The six process modules of the simulated real robot: they act on the true world,
taking simulated time, inject the faults of a :class:`FaultProfile`, and keep the belief
robot in step (see :mod:`projection._real_body`). Their commands are dispatched as the
projection modules' are (:class:`projection._process_modules.CommandDispatch`)."""

from __future__ import annotations

import abc
import itertools
import math
from collections.abc import Mapping, Sequence
from typing import Any

import pybullet as pb

from executive import Designator, MotionCommand, Pose, Resource, an
from executive.events import ObjectPerceived, emit
from executive.failures import (
    GripperClosedCompletely,
    ManipulationGoalNotReached,
    ManipulationPoseUnreachable,
    NavigationGoalNotReached,
    NavigationPoseUnreachable,
    PerceptionObjectNotFound,
    PtuGoalNotReached,
)
from projection._arm_planner import clear_ik, controller_trajectory, imagined_goal
from projection._base_planner import along_base, base_path
from projection._process_modules import (
    CommandDispatch,
    GripperMotions,
    PtuPM,
    gripper_goal,
    move_arm_joints,
    perceived_designator,
)
from projection._real_body import (
    BASE_ANGULAR_VELOCITY,
    BASE_VELOCITY,
    CONTROL_PERIOD,
    DETECTION_TIME,
    FINGER_VELOCITY,
    HEAD_JOINT_VELOCITY,
    TORSO_VELOCITY,
    _Body,
)
from projection._real_faults import FaultProfile
from projection._trajectories import wrap_angle
from projection._world import World

__all__ = [
    "RealArmsPM",
    "RealGrippersPM",
    "RealNavigationPM",
    "RealPerceptionPM",
    "RealProcessModule",
    "RealPtuPM",
    "RealTorsoPM",
    "real_process_modules",
]


class RealProcessModule(CommandDispatch):
    """A process module of the real robot. Subclasses implement :meth:`run` for each
    resolved command; an unknown command raises :class:`executive.DesignatorError`.
    Evaporation stops the motion where it is and :meth:`on_cancel` brings the belief robot
    to the true one."""

    def __init__(self, body: _Body, name: str) -> None:
        super().__init__(name)
        self.body = body
        self.world = body.true

    async def execute(self, motion: Designator) -> Any:
        command = self.command_of(motion)
        self.body.physics()
        return await self.run(command, motion)

    @abc.abstractmethod
    async def run(self, command: MotionCommand, motion: Designator) -> Any:
        """Execute one resolved command on the true world, taking simulated time."""

    async def on_cancel(self, motion: Designator) -> None:
        self.body.sync()


class RealNavigationPM(RealProcessModule):
    """``going``: follow a base path to the pose at most :data:`BASE_VELOCITY` (or the
    motion's ``speed``, if lower) and :data:`BASE_ANGULAR_VELOCITY`.

    The base's local planner (:func:`base_path`) picks the first of a few candidate paths
    (straight while turning; turn, then drive; drive, then turn; face the travel
    direction; a dog-leg through the midpoint) that is collision-free in the true world;
    if none is, it drives straight. A collision on the way, or a navigation fault, stops
    the robot at its last pose and raises :class:`executive.NavigationGoalNotReached`
    (``location=goal``)."""

    motion_types = frozenset({"going"})
    resources = frozenset({Resource.base()})
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
        path = base_path(world, start, goal)
        legs = [
            max(
                math.hypot(b[0] - a[0], b[1] - a[1]) / v,
                abs(wrap_angle(b[2] - a[2])) / BASE_ANGULAR_VELOCITY,
            )
            for a, b in itertools.pairwise(path)
        ]
        duration = sum(legs)
        blocked: list[BaseException] = []

        def pose_at(s: float) -> None:
            if blocked:
                return
            x, y, yaw = along_base(path, legs, s)
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
    resources = frozenset({Resource.torso()})
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
    resources = frozenset({Resource.head()})
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


#: The visible fraction from which the real perception also reports an object it was not
#: asked for (see :meth:`RealPerceptionPM._neighbours`): a partly hidden neighbour still
#: matters to collision checks.
NEIGHBOUR_VISIBILITY = 0.5


class RealPerceptionPM(RealProcessModule):
    """``detecting``: after :data:`DETECTION_TIME`, the true world's visible matches
    (:meth:`World.detect`), each missed at ``miss_rate``, the first one reported with a
    noisy pose as ``(type T) (name N) (pose <map pose>) (transform <base_footprint -> N>)``
    plus the input's other properties, equated to the input and announced with
    :class:`executive.events.ObjectPerceived`; then every other object in view is
    announced too (:meth:`_neighbours`). Nothing seen, or a perception fault, raises
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
        map_pose = self._noisy(found.map_pose)
        base = self.world.robot_pose().to_transform("base_footprint")
        in_base = base.inverse() * map_pose
        perceived = perceived_designator(
            motion, wanted, found.type, found.name, map_pose, in_base.to_transform(found.name)
        )
        self._neighbours(found.name)
        return perceived

    def _noisy(self, true_pose: Pose) -> Pose:
        pos_std, yaw_std = self.body.faults.detection_noise
        noise = self.body.noise_rng.normal(0.0, 1.0, 3) * (pos_std, pos_std, yaw_std)
        turn = Pose.from_xyz_yaw(0.0, 0.0, 0.0, float(noise[2])).as_rotation()
        x, y, z = true_pose.position
        return Pose(
            (x + float(noise[0]), y + float(noise[1]), z),
            (turn * true_pose.as_rotation()).as_quat(),
        )

    def _neighbours(self, found: str) -> None:
        """Report every other object the camera sees (visible fraction at least
        :data:`NEIGHBOUR_VISIBILITY`, each missed at ``miss_rate``) to the belief with a
        noisy pose (``ObjectPerceived``), so that the plans' collision checks know the
        neighbours of what they reach for, and visibility costmaps its occluders. Objects
        in the robot's hand are not reported. Deliberate difference from the first
        version, which reported only the object asked for (the belief never knew the
        neighbours the arm then knocked over): a real detector reports everything it
        recognises in its view."""
        world, body = self.world, self.body
        links = world.robot_links
        held = {n for n, link in world.attachments.items() if link in links}
        for name, otype in sorted(world.objects.items()):
            if name == found or name in held:
                continue
            if world.visibility(name) < NEIGHBOUR_VISIBILITY:
                continue
            if body.miss_rng.random() < body.faults.miss_rate:
                continue
            pose = self._noisy(world.object_pose(name))
            emit(ObjectPerceived(an.object(type=otype, name=name, pose=pose)))


class RealGrippersPM(GripperMotions, RealProcessModule):
    """Gripper motions at :data:`FINGER_VELOCITY` (the projection ``grippers`` module's
    types). ``gripping`` closes until contact; nothing between the fingers, or a
    ``grasp_slip`` fault, raises :class:`executive.GripperClosedCompletely` with nothing
    held; a ``drop`` fault arms a drop for the arm's next motion. An opening outside
    [0, max_opening] (the arm's gripper; the PR2-like robot: 0.1 m) raises
    :class:`executive.GripperGoalNotReached` before moving."""

    def __init__(self, body: _Body) -> None:
        super().__init__(body, "grippers")
        self.resources = self.gripper_resources(body.true)

    async def run(self, command: MotionCommand, motion: Designator) -> None:
        world, body = self.world, self.body
        action, goal_action, arms = gripper_goal(command)
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
    along the controller's path in time (:func:`projection._arm_planner.controller_trajectory`:
    free motions planned by OMPL in the belief world and following the planned
    trajectory's timing, contact motions along the straight tool line at
    :data:`ARM_JOINT_VELOCITY` and :data:`TORSO_VELOCITY`). A ``moving-tcp`` path the
    controller did not plan and that would push an object it does not start (or, for a
    contact motion, end) at is refused before moving (an approach:
    :class:`executive.ManipulationPoseUnreachable`) or stopped before the contact (a
    retract from an object, a lift: :class:`executive.ManipulationGoalNotReached` after
    moving; :func:`projection._arm_planner.guard_path`). Nothing else is checked on the
    way: a configuration move pushes what it meets.
    A drop armed by a grip makes the held object fall part of the
    way; the motion then ends and raises :class:`executive.GripperClosedCompletely`."""

    motion_types = frozenset({"moving-tcp", "moving-arm-joints"})
    commands = frozenset({"move-tcp", "move-joints"})

    def __init__(self, body: _Body) -> None:
        super().__init__(body, "arms")
        # the robot's arms, in its description's order
        self.resources = frozenset(Resource.arm(a) for a in body.true.robot.arm_names)

    async def run(self, command: MotionCommand, motion: Designator) -> None:
        world, body = self.world, self.body
        args: Mapping[str, Any] = command.arguments
        arms = [a for a in ("left", "right") if args.get(a) is not None]
        start = {a: world.arm_joints(a) for a in world.arms}
        torso = world.torso_height
        if command.command == "move-tcp":
            if body.fault("ik") is not None:
                raise ManipulationPoseUnreachable(
                    "no IK solution found", left=args.get("left"), right=args.get("right")
                )
            if not imagined_goal(world, body.belief, arms, args):
                world.move_tcp(left=args.get("left"), right=args.get("right"))
            clear_ik(world, arms, args, torso, start)
        else:
            move_arm_joints(world, args)
        timed = controller_trajectory(world, command.command, arms, args, torso, start, body.belief)
        duration = timed.duration

        def pose_at(s: float) -> None:
            t, config = timed.at(s * duration)
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
        if timed.short and not dropped:
            # the controller stopped before touching an object it did not start at
            # (guard_path, counted and logged there): the goal is not reached
            raise ManipulationGoalNotReached(
                "the arm stopped before its goal: going on would push an object",
                left=args.get("left"),
                right=args.get("right"),
            )
        if dropped:
            raise GripperClosedCompletely(
                f"{dropped[0]} slipped out of the {drop[0] if drop else ''} gripper",
                action="hold",
                arm=drop[0] if drop else None,
                object=dropped[0],
            )

    def _armed_drop(self, arms: Sequence[str]) -> tuple[str, str, float] | None:
        for arm in arms:
            fraction = self.body.drops.get(arm)
            if fraction is None:
                continue
            links = self.world.arm_links(arm)
            for name, link in self.world.attachments.items():
                if link in links:
                    del self.body.drops[arm]
                    return arm, name, fraction
        return None


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
