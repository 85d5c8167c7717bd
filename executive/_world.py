"""The world contract: what plans, rules and scene set-up may ask of a world, split by role.

- :class:`WorldModel` -- the belief state an environment needs: poses and the event hook.
- :class:`WorldQueries` -- read-only questions plans ask (types, what a hand holds, links
  and bounding boxes).
- :class:`WorldProbes` -- CRAM's projection checks: imagine a motion, report, change
  nothing.
- :class:`ProjectionWorld` -- queries and probes together: what an
  :class:`executive.Environment`'s ``world`` is, and so what every plan may use.
- :class:`SceneSetup` -- what a demo needs to lay out a scene on a world before a robot
  acts in it (spawn, remove, attach); not part of an environment.
- optional capabilities of an environment's world, each a runtime-checkable protocol that
  plans test with ``isinstance`` (a world model that cannot tell simply lacks it, and the
  plan skips what needs it): :class:`ArmSweepProbe`, :class:`ContainerOpeningProbe`,
  :class:`ContainerStates` (how far a drawer is open), :class:`ObjectInventory` (every
  object the model knows) and :class:`ObjectSpawning` (stand-ins in imagination). Plans
  never reach behind a world model (no ``getattr`` on it, no unwrapping of what it wraps):
  what they may ask is what these protocols say.

Implementations: ``projection.ProjectedWorldModel`` and ``projection.RealWorldModel``
(PyBullet), :class:`executive.testing.InMemoryWorld` (plain Python); ``projection.World``
is a :class:`SceneSetup`. CRAM reaches the world through Prolog queries and the
``cram-occasions-events`` interface; we make the same questions a typed Python contract.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

from ._pose import Pose

if TYPE_CHECKING:
    from ._kitchen import KitchenDescription
    from ._robot import RobotDescription
    from .events import Event

__all__ = [
    "AABB",
    "ArmJointLimits",
    "ArmSweepProbe",
    "ContainerOpeningProbe",
    "ContainerStates",
    "ObjectInventory",
    "ObjectSpawning",
    "ProbeResult",
    "ProjectionWorld",
    "SceneSetup",
    "WorldModel",
    "WorldProbes",
    "WorldQueries",
]

#: An axis-aligned bounding box in ``map``: ``(min corner, max corner)``.
AABB = tuple[tuple[float, ...], tuple[float, ...]]


@runtime_checkable
class WorldModel(Protocol):
    """The belief state an environment needs (projection implements it with PyBullet,
    :class:`executive.testing.InMemoryWorld` in memory).

    Methods raise :class:`executive.PerceptionObjectNotInWorld` for unknown objects.
    """

    def object_pose(self, name: str, frame: str = "map") -> Pose:
        """The current pose of the named object in ``frame``."""
        ...

    def robot_pose(self) -> Pose:
        """The robot base's pose in ``map``."""
        ...

    def handle_event(self, event: Event) -> None:
        """Update the belief state for an event (attach, detach, container opened...)."""
        ...


@runtime_checkable
class WorldQueries(WorldModel, Protocol):
    """The read-only questions plans ask of the belief state."""

    def object_type(self, name: str) -> str:
        """The type of a known object (``PerceptionObjectNotInWorld`` otherwise)."""
        ...

    def object_in_hand(self, arm: str) -> str | None:
        """The name of the object attached to ``arm``'s gripper, if any."""
        ...

    def link_pose(self, link: str, frame: str = "map") -> Pose:
        """The pose of a robot or environment link (``LookupError`` for unknown links)."""
        ...

    def link_aabb(self, link: str) -> AABB:
        """A robot or environment link's bounding box in ``map`` (``LookupError`` for a
        link the world has no extent for)."""
        ...

    def object_aabb(self, name: str) -> AABB:
        """An object's bounding box in ``map`` (``LookupError`` when the world has no
        extent for it)."""
        ...

    def gripper_opening(self, arm: str) -> float | None:
        """The distance (m) between ``arm``'s finger pads, from the robot's joint states;
        None when the world does not know it (plans then cannot verify a grasp)."""
        ...

    @property
    def robot(self) -> RobotDescription | None:
        """The description of the robot this world model holds (its arms, frames, named
        states: :class:`executive.RobotDescription`); None for a world with no robot body
        (plans then reach it through :attr:`executive.Environment.robot`, which raises
        :class:`executive.NoRobotDescription`)."""
        ...

    @property
    def kitchen(self) -> KitchenDescription | None:
        """The description of the kitchen this world model holds (the surfaces, container
        and floor height the plans use by role, and the demo scene:
        :class:`executive.KitchenDescription`); None for a world with no kitchen (plans
        then reach it through :attr:`executive.Environment.kitchen`, which raises
        :class:`executive.NoKitchenDescription`)."""
        ...


@dataclass(frozen=True)
class ProbeResult:
    """The outcome of a projection probe: ``ok``, or why not (``failure`` is the typed
    failure the real motion would raise, e.g. ``ManipulationPoseUnreachable``), and at which
    waypoint (``index``)."""

    ok: bool
    failure: BaseException | None = None
    index: int | None = None


@runtime_checkable
class WorldProbes(Protocol):
    """The probes behind CRAM's projection checks (``check-navigating-collisions``,
    ``check-picking-up-collisions``, ``check-placing-collisions``,
    ``check-placing-pose-stability``, ``check-environment-manipulation-collisions``).

    Every probe leaves the world exactly as it found it. Plans iterate designator
    solutions around these probes (in :mod:`plans`); projection implements them with
    PyBullet. Poses may be given in ``map`` or the robot's base frame.
    """

    def probe_base_pose(self, pose: Pose) -> ProbeResult:
        """Would the robot (with what it holds) stand collision-free at ``pose``?"""
        ...

    def probe_arm_trajectory(
        self,
        arm: str,
        waypoints: Sequence[Pose],
        *,
        robot_pose: Pose | None = None,
        gripper_opening: float | None = None,
        allowed_contacts: Sequence[str] = (),
        check_collisions: Sequence[bool] | bool = True,
        swept: bool | None = None,
        collision_modes: Sequence[str | None] | None = None,
    ) -> ProbeResult:
        """Move ``arm``'s tool frame through ``waypoints`` (IK with torso resampling) from
        ``robot_pose`` (default: where the robot is). A waypoint fails if IK does not reach
        it, or, where ``check_collisions`` is true for it, if the robot then touches
        anything but its attached objects and the ``allowed_contacts`` (object or link
        names). ``swept``: whether the path the arm takes *between* checked waypoints
        must not sweep through objects either (None: the world model's default; a world
        model that cannot tell checks the waypoints only). ``collision_modes``: the
        collision mode of the ``moving-tcp`` motion that will go to each waypoint (None:
        avoid all, a free motion a controller may plan around objects; ``"allow-all"``,
        ``"allow-hand"``: a contact motion along the straight tool line), so that the
        swept check follows the path the robot will take; None for the argument: not
        known (the straight tool line is checked)."""
        ...

    def probe_placing_stability(self, object_type: str, pose: Pose) -> ProbeResult:
        """Would an object of ``object_type`` released at ``pose`` stay put (moved less than
        0.2 m after ~600 simulated steps)?"""
        ...


@runtime_checkable
class ArmSweepProbe(Protocol):
    """An optional probe (a world model that cannot tell simply lacks it; plans then skip
    the check): would moving the arms to joint values sweep the robot, or what it holds,
    through an object? ``projection``'s world models implement it with the real arm
    controller's path."""

    def probe_arm_configuration(
        self,
        left: Sequence[float] | None = None,
        right: Sequence[float] | None = None,
        *,
        allowed_contacts: Sequence[str] = (),
    ) -> ProbeResult:
        """``left``/``right``: one value per joint of that arm (its description's
        ``joints``), ``None``: that arm stays (or the robot has no such arm)."""
        ...


@runtime_checkable
class ArmJointLimits(Protocol):
    """An optional query (a world model that cannot tell simply lacks it; plans then leave
    the limits to the process module): the arm's joints and their limits, from the robot's
    description, so that bad joint values are refused before anything moves."""

    def arm_joint_limits(self, arm: str) -> tuple[tuple[str, float, float], ...]:
        """``(joint name, lower, upper)`` (radians or metres) of ``arm``'s joints, in the
        order joint values are given."""
        ...


@runtime_checkable
class ContainerOpeningProbe(Protocol):
    """An optional probe (a world model that cannot tell simply lacks it; plans then skip
    the check): would opening ``container`` by ``distance`` push it into the robot, i.e.
    would the opened container touch a robot link other than ``arm``'s gripper (which
    holds its handle)? ``projection``'s world models implement it on their kitchen."""

    def probe_container_opening(self, container: Any, distance: float, arm: str) -> ProbeResult:
        """``container``: its designator or link/joint name; the world is left as it was."""
        ...


@runtime_checkable
class ContainerStates(Protocol):
    """An optional query (a world model that cannot tell simply lacks it; plans then take
    a container's distances as given): where a jointed container (a drawer) is between
    its limits. ``projection``'s world models implement it from their kitchen's joints."""

    def container_state(self, link_or_joint: str) -> tuple[float, float, float]:
        """``(position, lower, upper)`` of the container's joint (a drawer: metres open
        along its axis; closed at ``lower``). ``LookupError`` for a link or joint that is
        not a jointed container of this world."""
        ...


@runtime_checkable
class ObjectInventory(Protocol):
    """An optional query (a world model that cannot tell simply lacks it): every object
    the world model knows, by name (what projection reasoning compares before and after an
    imagined run). ``projection``'s world models implement it."""

    def object_names(self) -> Sequence[str]:
        """The names of every object in the model (held ones included), in a stable
        order."""
        ...


@runtime_checkable
class ObjectSpawning(Protocol):
    """An optional capability of an *imagined* world (a world model without it cannot
    host stand-ins; plans then skip the reasoning that needs them): add and remove
    objects, e.g. the stand-ins :mod:`plans.viewpoints` spawns to test what a viewpoint
    sees. ``projection.ProjectedWorldModel`` implements it; a real robot's world model
    does not (reality is not spawned into)."""

    def spawn_object(self, name: str, type: str, pose: Pose) -> str:
        """Add an object of a known type at ``pose``; returns its name. One that would
        reach into another object or the robot is refused with ``ValueError`` (the world
        unchanged)."""
        ...

    def remove_object(self, name: str) -> None:
        """Remove an object (``LookupError`` if unknown)."""
        ...


@runtime_checkable
class ProjectionWorld(WorldQueries, WorldProbes, Protocol):
    """A world model that can answer and *imagine*: the queries and the probes. This is
    the type of :attr:`executive.Environment.world`, so the whole of what a plan may ask
    of the world."""


@runtime_checkable
class SceneSetup(Protocol):
    """What laying out a scene needs (CRAM's demo ``spawn-object`` calls): a world the
    caller owns, set up before (or outside) the robot's environment. ``projection.World``
    implements it."""

    @property
    def objects(self) -> Mapping[str, str]:
        """Object name -> type of every object in the world."""
        ...

    def object_pose(self, name: str, frame: str = "map") -> Pose:
        """An object's pose (``LookupError`` for unknown objects)."""
        ...

    def link_aabb(self, link: str) -> AABB:
        """A link's bounding box in ``map`` (``LookupError`` for unknown links)."""
        ...

    def spawn_object(self, name: str, type: str, pose: Pose) -> str:
        """Add an object of a known type at ``pose``; returns its name. An object that
        would reach into another object or the robot is refused with ``ValueError`` (the
        world unchanged)."""
        ...

    def remove_object(self, name: str) -> None:
        """Remove an object (``LookupError`` if unknown)."""
        ...

    def attach(self, name: str, link: str) -> None:
        """Attach an object rigidly to a link at their current relative pose."""
        ...
