"""The six projection process modules (CRAM's ``pr2-proj-navigation``, ``-torso``, ``-ptu``,
``-perception``, ``-grippers``, ``-arms``): each resolves its motion designator to a
:class:`executive.MotionCommand` and calls the :class:`~projection._world.World`'s
low-level function, which teleports (as in CRAM), then lets the motion's modelled
duration (:mod:`projection._durations`) pass on the projection's timeline (the
:class:`cpl.Timeline` that ``with_projected_robot`` makes current; without one a motion
takes no time). The effect lands at the start: a motion evaporated during its duration
is complete in the projected world (a projected motion is atomic); the evaporation takes
effect at the next motion.

Deliberate difference from CRAM: CRAM's projected motions take no time and its
projection has no clock since 2017 (monitors and time-outs are inert there); here they
take projected time, so ``cpl.sleep``, ``wait_for(timeout=)`` and ``timeout_policy`` in a
monitor mean in projection what they mean on the robot.

=============  ===========================================================  ================
module         motion types                                                 world function
=============  ===========================================================  ================
navigation     going                                                        ``drive``
torso          moving-torso                                                 ``move_torso``
ptu            looking                                                      ``look_at``
perception     detecting                                                    ``detect``
grippers       opening-gripper, closing-gripper, gripping,                  ``gripper``
               moving-gripper-joint; opening/closing with a ``gripper``
arms           moving-tcp, moving-arm-joints                                ``move_tcp``,
                                                                            ``move_joints``
=============  ===========================================================  ================

Each module lists the robot parts it drives (:attr:`executive.ProcessModule.resources`:
the base, the torso, the head, the grippers and the arms of the world's robot),
so the projection environment knows the robot's parts.

Failures are the world's typed low-level failures (``NavigationPoseUnreachable``,
``TorsoGoalNotReached``, ``PtuGoalNotReached``, ``PerceptionObjectNotFound``,
``GripperClosedCompletely``/``GripperGoalNotReached``, ``ManipulationPoseUnreachable``,
``ManipulationGoalNotReached``); the world is unchanged when one is raised.
"""

from __future__ import annotations

import abc
import math
from collections.abc import Mapping
from typing import Any, ClassVar

import pybullet as pb

import cpl
import executive
from executive import Designator, MotionCommand, Pose, ProcessModule, Resource, an, equate
from executive.events import ObjectPerceived, emit, object_name
from executive.failures import (
    ManipulationGoalInCollision,
    ManipulationGoalNotReached,
    PtuGoalNotReached,
)
from projection._durations import DETECTION_TIME, RobotState, motion_seconds, robot_state
from projection._swept_motions import arm_motion_sweep
from projection._world import World

__all__ = [
    "ArmsPM",
    "CommandDispatch",
    "GrippersPM",
    "NavigationPM",
    "PerceptionPM",
    "ProjectionProcessModule",
    "PtuPM",
    "TorsoPM",
    "gripper_goal",
    "move_arm_joints",
    "perceived_designator",
    "projection_process_modules",
]

_PTU_TOLERANCE = 1e-5
#: Collision modes of a ``moving-tcp`` whose path may touch objects (CRAM's meanings).
_CONTACTS_ALLOWED = frozenset({"allow-all", "allow-hand"})


class CommandDispatch(ProcessModule):
    """A process module that executes resolved commands: :meth:`command_of` resolves a
    motion designator to its :class:`executive.MotionCommand` and checks that this module
    executes it (:attr:`commands`), else raises :class:`executive.DesignatorError`. Shared
    by the projected and the real robot's modules."""

    commands: ClassVar[frozenset[str]] = frozenset()

    def command_of(self, motion: Designator) -> MotionCommand:
        command, args = motion.reference()
        if command not in self.commands:
            raise executive.DesignatorError(
                f"process module {self.name!r} cannot execute the command {command!r} of "
                f"{motion.short()} (it executes {', '.join(sorted(self.commands))})",
                motion,
            )
        return MotionCommand(command, args)


class ProjectionProcessModule(CommandDispatch):
    """A process module acting on one :class:`World`. Subclasses implement
    :meth:`run` for each resolved command; a command this module does not know raises
    :class:`executive.DesignatorError`."""

    def __init__(self, world: World, name: str) -> None:
        if not isinstance(world, World):
            raise TypeError(f"a projection process module needs a projection.World, got {world!r}")
        super().__init__(name)
        self.world = world

    async def execute(self, motion: Designator) -> Any:
        command = self.command_of(motion)
        timeline = cpl.current_timeline()
        if timeline is None:  # no projected time here: the motion takes none
            return self.run(command, motion)
        before = robot_state(self.world)
        result = self.run(command, motion)
        seconds = self.seconds(before, robot_state(self.world))
        if seconds > 0:
            await cpl.sleep(seconds)
        return result

    def seconds(self, before: RobotState, after: RobotState) -> float:
        """The projected duration of a motion that took the robot from ``before`` to
        ``after`` (:func:`projection._durations.motion_seconds`)."""
        return motion_seconds(before, after)

    @abc.abstractmethod
    def run(self, command: MotionCommand, motion: Designator) -> Any:
        """Execute one resolved command (synchronously: projected motions teleport)."""


def perceived_designator(
    motion: Designator, wanted: Designator, type: str, name: str, pose: Pose, transform: Any
) -> Designator:
    """The result of a ``detecting`` motion: a new object designator ``(type T) (name N)
    (pose <map pose>) (transform <base_footprint -> N>)`` followed by ``wanted``'s other
    properties, equated to the motion's object designator (or ``wanted``), and announced
    with :class:`executive.events.ObjectPerceived`."""
    own = {"type", "name", "pose", "transform"}
    perceived = an.object(
        ("type", type),
        ("name", name),
        ("pose", pose),
        ("transform", transform),
        *((k, v) for k, v in wanted.properties if k not in own),
    )
    original = motion.get("object")
    equate(original if isinstance(original, Designator) else wanted, perceived)
    emit(ObjectPerceived(perceived))
    return perceived


def gripper_goal(command: MotionCommand) -> tuple[str, str | float, list[str]]:
    """A gripper command's ``(action, goal, arms)``: the goal is the action (``open``,
    ``close``, ``grip``) or, for ``angle``, the opening in metres."""
    args = command.arguments
    action = args["action"]
    goal = args["joint_angle"] if action == "angle" else action
    grippers = args["gripper"]
    return action, goal, [grippers] if isinstance(grippers, str) else list(grippers)


def move_arm_joints(world: World, args: Mapping[str, Any]) -> None:
    """:meth:`World.move_joints` for a ``move-joints`` command; bad values raise
    :class:`executive.ManipulationGoalNotReached` (arms unchanged)."""
    try:
        world.move_joints(left=args.get("left"), right=args.get("right"))
    except ValueError as exc:
        raise ManipulationGoalNotReached(
            str(exc), left=args.get("left"), right=args.get("right")
        ) from exc


class NavigationPM(ProjectionProcessModule):
    """``going`` -> :meth:`World.drive`; a pose in collision raises
    :class:`executive.NavigationPoseUnreachable` with the robot where it was."""

    motion_types = frozenset({"going"})
    resources = frozenset({Resource.base()})
    commands = frozenset({"move-base"})

    def __init__(self, world: World) -> None:
        super().__init__(world, "navigation")

    def run(self, command: MotionCommand, motion: Designator) -> None:
        self.world.drive(command.arguments["pose"])


class TorsoPM(ProjectionProcessModule):
    """``moving-torso`` -> :meth:`World.move_torso`; outside the joint limits raises
    :class:`executive.TorsoGoalNotReached`."""

    motion_types = frozenset({"moving-torso"})
    resources = frozenset({Resource.torso()})
    commands = frozenset({"move-torso"})

    def __init__(self, world: World) -> None:
        super().__init__(world, "torso")

    def run(self, command: MotionCommand, motion: Designator) -> None:
        self.world.move_torso(command.arguments["joint_angle"])


class PtuPM(ProjectionProcessModule):
    """``looking`` -> :meth:`World.look_at` (a pose; a frame: its origin, ``map`` and
    ``base_footprint`` included; ``forward``) or, for ``joint-states`` ``(pan, tilt)``,
    the head joints directly. Beyond the pan/tilt limits raises
    :class:`executive.PtuGoalNotReached`, head unchanged; an unknown frame
    :class:`LookupError`."""

    motion_types = frozenset({"looking"})
    resources = frozenset({Resource.head()})
    commands = frozenset({"move-head"})

    def __init__(self, world: World) -> None:
        super().__init__(world, "ptu")
        c, robot = world.client, world.robot_body
        self._head: dict[str, tuple[int, float, float]] = {}
        for i in range(pb.getNumJoints(robot, physicsClientId=c)):
            info = pb.getJointInfo(robot, i, physicsClientId=c)
            if info[1].decode() in (world.robot.neck.pan_joint, world.robot.neck.tilt_joint):
                self._head[info[1].decode()] = (i, float(info[8]), float(info[9]))

    def run(self, command: MotionCommand, motion: Designator) -> None:
        args = command.arguments
        if args.get("pose") is not None:
            self.world.look_at(args["pose"])
        elif args.get("frame") is not None:
            frame = args["frame"]
            if frame in ("map", "base_footprint"):
                self.world.look_at(Pose(frame=frame))
            else:
                self.world.look_at(frame)
        elif args.get("direction") is not None:
            self.world.look_at("forward")
        else:
            self._set_head(args.get("joint_states"))

    def _set_head(self, states: Any) -> None:
        if (
            not isinstance(states, (tuple, list))
            or len(states) != 2
            or not all(
                isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
                for v in states
            )
        ):
            raise ValueError(f"looking joint-states must be (pan, tilt) in radians, got {states!r}")
        c, robot = self.world.client, self.world.robot_body
        goals = []
        neck = self.world.robot.neck
        for joint, value in zip((neck.pan_joint, neck.tilt_joint), states):
            i, lo, hi = self._head[joint]
            if not lo - _PTU_TOLERANCE <= value <= hi + _PTU_TOLERANCE:
                raise PtuGoalNotReached(
                    f"{joint} {value:.3f} beyond its limits [{lo:.3f}, {hi:.3f}]",
                    target=tuple(states),
                )
            goals.append((i, min(max(float(value), lo), hi)))
        for i, value in goals:
            pb.resetJointState(robot, i, value, 0.0, physicsClientId=c)


class PerceptionPM(ProjectionProcessModule):
    """``detecting`` -> :meth:`World.detect`. Returns a new object designator
    ``(type T) (name N) (pose <map pose>) (transform <base_footprint -> N>)`` followed by
    the input's other properties, equated to the input designator, for the first visible
    match, and emits :class:`executive.events.ObjectPerceived`. Nothing visible raises
    :class:`executive.PerceptionObjectNotFound`."""

    motion_types = frozenset({"detecting"})
    commands = frozenset({"detect"})

    def __init__(self, world: World) -> None:
        super().__init__(world, "perception")

    def seconds(self, before: RobotState, after: RobotState) -> float:
        return DETECTION_TIME

    def run(self, command: MotionCommand, motion: Designator) -> Designator:
        wanted: Designator = command.arguments["object"]
        found = self.world.detect(wanted)[0]
        return perceived_designator(
            motion, wanted, found.type, found.name, found.map_pose, found.transform
        )


class GripperMotions:
    """The gripper module's motions, shared by the projected and the real robot:
    ``opening-gripper``/``closing-gripper``/``gripping``/``moving-gripper-joint``, and
    CRAM HEAD's ``opening``/``closing`` when they carry a ``gripper``."""

    motion_types = frozenset(
        {"opening-gripper", "closing-gripper", "gripping", "moving-gripper-joint"}
    )
    commands = frozenset({"move-gripper-joint"})

    @staticmethod
    def gripper_resources(world: World) -> frozenset[Resource]:
        """The grippers of ``world``'s robot (one per arm, in its description's order)."""
        return frozenset(Resource.gripper(a) for a in world.robot.arm_names)

    def accepts(self, motion: Designator) -> bool:
        return motion.type in self.motion_types or (
            motion.type in ("opening", "closing") and "gripper" in motion
        )


class GrippersPM(GripperMotions, ProjectionProcessModule):
    """``opening-gripper``/``closing-gripper``/``gripping``/``moving-gripper-joint`` (and
    ``opening``/``closing`` that carry a ``gripper``) -> :meth:`World.gripper`. The joint
    angle of ``moving-gripper-joint`` is the opening in metres. Raises
    :class:`executive.GripperClosedCompletely` when gripping nothing (the gripper stays
    closed), :class:`executive.GripperGoalNotReached` for an opening outside
    [0, max_opening] of the arm's gripper (the PR2-like robot: 0.1 m)."""

    def __init__(self, world: World) -> None:
        super().__init__(world, "grippers")
        self.resources = self.gripper_resources(world)

    def run(self, command: MotionCommand, motion: Designator) -> None:
        _action, goal, arms = gripper_goal(command)
        self.world.gripper(goal, arms)


class ArmsPM(ProjectionProcessModule):
    """``moving-tcp`` -> :meth:`World.move_tcp` (IK with torso resampling) and
    ``moving-arm-joints`` -> :meth:`World.move_joints`.
    No IK solution raises :class:`executive.ManipulationPoseUnreachable`; joint values of
    the wrong count or outside the limits :class:`executive.ManipulationGoalNotReached`;
    the arms are unchanged on failure.

    The goal is not merely teleported to: the module computes the path the simulated
    real arm controller would follow to it (:func:`projection._arm_planner.controller_path`,
    the same code the real arms module runs: the straight tool line or configuration
    move, rerouted around free objects, or planned by OMPL when
    ``World.arm_motion_planning`` is on) and a path that would sweep the robot, or what it
    holds, through a free object the motion does not own (one it does not touch where it
    starts or ends, nor the object of the ``picking-up`` or ``placing`` it is part of:
    the object reached for, the one just released; the knock count's "own") is a predicted
    failure: :class:`executive.ManipulationGoalInCollision` (``swept=(names...)``), the
    world left unchanged. A ``moving-tcp`` whose collision mode allows contacts
    (``allow-all``: grasping, putting, pulling, pushing; ``allow-hand``: lifting) is not
    checked, as CRAM's collision modes mean: those short straight motions touch their
    object, its support or the handle by design, and the plans' probes check them. The
    answers are remembered per world (:func:`projection._swept_motions.arm_motion_sweep`),
    so a motion a probe checked costs a lookup. The projected duration is that path's at
    the real robot's joint speeds (its :func:`~projection._arm_planner.leg_seconds`, as
    the real arms module times it: a planned detour takes longer than the straight line),
    where a path is computed: when no free object is within the arm's reach nothing can
    be swept, the path is neither computed nor planned (imagining stays fast), and the
    straight move's duration (a lower bound) is taken.

    Deliberate difference from CRAM: CRAM's projected arms teleport (only the goal's IK
    and, on request, its collisions are checked), so a plan imagined there never sees an
    arm sweep a neighbour over on its way; here it does."""

    motion_types = frozenset({"moving-tcp", "moving-arm-joints"})
    commands = frozenset({"move-tcp", "move-joints"})

    def __init__(self, world: World) -> None:
        super().__init__(world, "arms")
        # the robot's arms, in its description's order
        self.resources = frozenset(Resource.arm(a) for a in world.robot.arm_names)
        # invariant: the duration (s) of the path of the motion run() last completed,
        # None before any and after a failure; seconds() reads it once
        self._path_seconds: float | None = None

    def run(self, command: MotionCommand, motion: Designator) -> None:
        self._path_seconds = None
        world = self.world
        args: Mapping[str, Any] = command.arguments
        arms = [a for a in world.arms if args.get(a) is not None]
        torso = world.torso_height
        start = {a: world.arm_joints(a) for a in world.arms}
        if command.command == "move-tcp":
            self.world.move_tcp(left=args.get("left"), right=args.get("right"))
        else:
            move_arm_joints(self.world, args)
        if not arms:
            return
        if command.command == "move-tcp" and args.get("collision_mode") in _CONTACTS_ALLOWED:
            return
        goal_torso = world.torso_height
        goal = {a: world.arm_joints(a) for a in arms}
        sweep = arm_motion_sweep(world, command.command, arms, args, torso, start)
        swept = tuple(n for n in sweep.swept if n not in _own_objects())
        if swept:
            world.move_torso(torso)
            world.move_joints(**{a: start[a] for a in arms})
            raise ManipulationGoalInCollision(
                f"moving the {' and '.join(arms)} arm(s) "
                f"({command.command}) sweeps through {', '.join(swept)}",
                arms=tuple(arms),
                swept=swept,
            )
        world.move_torso(goal_torso)
        world.move_joints(**goal)
        self._path_seconds = sweep.seconds

    def seconds(self, before: RobotState, after: RobotState) -> float:
        """The duration of the controller's path (see the class docstring); at least the
        straight move's (:func:`projection._durations.motion_seconds`)."""
        path, self._path_seconds = self._path_seconds, None
        straight = motion_seconds(before, after)
        return straight if path is None else max(straight, path)


#: Actions whose object a motion inside them may move (the knock count's "own" actions).
_OWN_ACTIONS = frozenset({"picking-up", "placing", "pushing-object"})


def _own_objects() -> frozenset[str]:
    """The objects of the ``picking-up``/``placing``/``pushing-object`` actions the
    running task is inside
    (a motion may sweep its own object: the plan-level probes allow it, and the knock
    count does not count it)."""
    own: set[str] = set()
    task = cpl.current_task()
    while task is not None:
        desig = executive.action_of(task)
        if desig is not None and str(desig.type) in _OWN_ACTIONS:
            obj = desig.get("object")
            if obj is not None:
                try:
                    own.add(object_name(obj))
                except ValueError:  # an object designator without a name: none owned
                    pass
        task = task.parent
    return frozenset(own)


def projection_process_modules(world: World) -> tuple[ProjectionProcessModule, ...]:
    """New instances of the six modules on ``world``, in CRAM's order (navigation, torso,
    ptu, perception, grippers, arms). ``TypeError`` if ``world`` is not a World."""
    return (
        NavigationPM(world),
        TorsoPM(world),
        PtuPM(world),
        PerceptionPM(world),
        GrippersPM(world),
        ArmsPM(world),
    )
