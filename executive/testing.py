"""Testing without a world: an in-memory world model and a scriptable process module.

::

    world = InMemoryWorld(objects={"cup-1": Pose((1, 0, 0.8))})
    nav = FakeProcessModule(
        name="navigation", accepts="going", fail_on={2: NavigationPoseUnreachable}
    )
    async with executive.environment(world=world, process_modules=[nav]):
        await perform(a.motion(type="going", pose=Pose((1, 2, 0))))
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import cpl

from ._designator import Designator
from ._kitchen import KitchenDescription
from ._pose import Pose, Transform
from ._process_module import ProcessModule
from ._resources import Resource
from ._robot import RobotDescription
from ._world import AABB, ProbeResult
from .events import (
    ContainerClosed,
    ContainerOpened,
    Event,
    ObjectAttached,
    ObjectDetached,
    ObjectPerceived,
    RobotStateChanged,
    object_name,
)
from .failures import (
    HighLevelFailure,
    ManipulationPoseUnreachable,
    NavigationPoseUnreachable,
    PerceptionObjectNotInWorld,
)

__all__ = ["PROBES", "FakeProcessModule", "InMemoryWorld", "WorldObject"]

#: The probe kinds of :class:`InMemoryWorld`: ``base`` (``probe_base_pose``), ``arm``
#: (``probe_arm_trajectory``), ``stability`` (``probe_placing_stability``).
PROBES = ("base", "arm", "stability")


@dataclass
class WorldObject:
    """An object of the in-memory world. ``attached_to`` is ``(arm, link)`` while held."""

    name: str
    pose: Pose
    type: str | None = None
    attached_to: tuple[str, str | None] | None = None


class InMemoryWorld:
    """A :class:`executive.ProjectionWorld` in plain Python.

    Events: ``ObjectAttached``/``ObjectDetached`` set/clear ``attached_to`` (an attached
    object's pose follows nothing, unless it is attached to a link given in ``links``: then
    it keeps its pose relative to that link); ``ContainerOpened``/
    ``ContainerClosed`` add/subtract ``distance`` to ``joint_states[container]``;
    ``ObjectPerceived`` appends to ``perceived``; ``RobotStateChanged`` bumps
    ``robot_state_changes``. Every event is appended to ``events``.
    Unknown objects raise :class:`executive.PerceptionObjectNotInWorld`.

    Frames: ``map`` and, with a ``robot`` description, the robot's base frame
    (:attr:`executive.RobotDescription.base_frame`), which moves with the robot pose.
    Without a description only ``map`` is known (asking for another frame: ValueError
    naming the fix). Links: ``links`` maps link names to poses in ``map`` or the base frame
    (a base-frame link moves with the robot); :meth:`set_link_pose` changes one.
    Extents: ``aabbs`` maps link or object names to ``(min, max)`` boxes in ``map``;
    :meth:`link_aabb` / :meth:`object_aabb` raise ``LookupError`` for any other name (a
    plan then falls back as it would for a world without that knowledge).

    Probes (every call is recorded in ``probe_calls[kind]``, kinds :data:`PROBES`): a probe
    fails when its 1-based call number is a key of ``fail_probe[kind]`` (the value: a failure
    instance or class, ``True`` for the default failure, or a whole :class:`ProbeResult`),
    when the base pose is within 1 mm of one of ``blocked_poses``, when a waypoint
    (compared in the frame it is given in) is within 1 mm of one of
    ``unreachable_waypoints`` (``index`` = the first such waypoint), or when a placing pose
    is within 1 mm of one of ``unstable_poses``. Default failures:
    ``NavigationPoseUnreachable``, ``ManipulationPoseUnreachable``, ``HighLevelFailure``.
    """

    def __init__(
        self,
        objects: Mapping[str, Pose] | None = None,
        *,
        robot_pose: Pose | None = None,
        types: Mapping[str, str] | None = None,
        links: Mapping[str, Pose] | None = None,
        aabbs: Mapping[str, AABB] | None = None,
        fail_probe: Mapping[str, Mapping[int, Any]] | None = None,
        blocked_poses: Collection[Pose] = (),
        unreachable_waypoints: Collection[Pose] = (),
        unstable_poses: Collection[Pose] = (),
        robot: RobotDescription | None = None,
        kitchen: KitchenDescription | None = None,
    ) -> None:
        #: The robot's description (:attr:`executive.WorldQueries.robot`); None: plans that
        #: need the robot's arms or frames raise :class:`executive.NoRobotDescription`.
        self.robot = robot
        #: The kitchen's description (:attr:`executive.WorldQueries.kitchen`); None: plans
        #: that need the kitchen's surfaces or floor raise
        #: :class:`executive.NoKitchenDescription`.
        self.kitchen = kitchen
        self.objects: dict[str, WorldObject] = {}
        for name, pose in (objects or {}).items():
            self.add_object(name, pose, type=(types or {}).get(name))
        self._robot_pose = robot_pose or Pose()
        self.joint_states: dict[str, float] = {}
        self.events: list[Event] = []
        self.perceived: list[Any] = []
        self.robot_state_changes = 0
        self.links: dict[str, Pose] = dict(links or {})
        self.aabbs: dict[str, AABB] = dict(aabbs or {})
        self._held: dict[str, Transform] = {}
        unknown = set(fail_probe or {}) - set(PROBES)
        if unknown:
            raise ValueError(f"fail_probe kinds are {', '.join(PROBES)}; got {sorted(unknown)}")
        self.fail_probe: dict[str, dict[int, Any]] = {
            kind: dict((fail_probe or {}).get(kind, {})) for kind in PROBES
        }
        self.blocked_poses: list[Pose] = list(blocked_poses)
        self.unreachable_waypoints: list[Pose] = list(unreachable_waypoints)
        self.unstable_poses: list[Pose] = list(unstable_poses)
        self.probe_calls: dict[str, list[Any]] = {kind: [] for kind in PROBES}

    def add_object(self, name: str, pose: Pose, *, type: str | None = None) -> WorldObject:
        if not isinstance(pose, Pose):
            raise TypeError(f"object {name!r}: pose must be an executive.Pose, got {pose!r}")
        obj = WorldObject(name, pose, type)
        self.objects[name] = obj
        return obj

    def _object(self, name: str) -> WorldObject:
        try:
            return self.objects[name]
        except KeyError:
            known = ", ".join(sorted(self.objects)) or "none"
            raise PerceptionObjectNotInWorld(
                f"no object {name!r} in the world (known: {known})", object=name
            ) from None

    # -- WorldModel -------------------------------------------------------------------
    def object_pose(self, name: str, frame: str = "map") -> Pose:
        obj = self._object(name)
        pose = obj.pose
        rel = self._held.get(name)
        if rel is not None and obj.attached_to is not None:
            link = self.link_pose(str(obj.attached_to[1]), "map").to_transform()
            pose = (link * rel).to_pose()
        return self._express(pose, frame)

    def _express(self, pose: Pose, frame: str) -> Pose:
        if frame == pose.frame:
            return pose
        other = frame if frame != "map" else pose.frame
        if self.robot is None:
            raise ValueError(
                f"InMemoryWorld without a robot description knows only the 'map' frame, "
                f"not {other!r}: build it with "
                "robot=<an executive.RobotDescription> to use the robot's base frame"
            )
        base_frame = self.robot.base_frame
        base = self._robot_pose.to_transform(base_frame)
        if frame == base_frame and pose.frame == "map":
            result: Pose = base.inverse() * pose
            return result
        if frame == "map" and pose.frame == base_frame:
            mapped: Pose = base * pose
            return mapped
        unknown = frame if frame not in ("map", base_frame) else pose.frame
        raise ValueError(f"InMemoryWorld knows frames 'map' and {base_frame!r}, not {unknown!r}")

    def robot_pose(self) -> Pose:
        return self._robot_pose

    def set_robot_pose(self, pose: Pose) -> None:
        self._robot_pose = pose

    def set_object_pose(self, name: str, pose: Pose) -> None:
        self._object(name).pose = pose

    # -- ProjectionWorld --------------------------------------------------------------
    def object_type(self, name: str) -> str:
        type_ = self._object(name).type
        if type_ is None:
            raise LookupError(f"object {name!r} was added without a type")
        return type_

    def object_in_hand(self, arm: str) -> str | None:
        held = self.attached(arm)
        return held[0] if held else None

    def gripper_opening(self, arm: str) -> float | None:
        """Unknown (None): an in-memory robot has no fingers. Tests replace it."""
        return None

    def link_pose(self, link: str, frame: str = "map") -> Pose:
        try:
            pose = self.links[link]
        except KeyError:
            known = ", ".join(sorted(self.links)) or "none"
            raise LookupError(f"unknown link {link!r} (known: {known})") from None
        return self._express(pose, frame)

    def link_aabb(self, link: str) -> AABB:
        return self._aabb(link, "link")

    def object_aabb(self, name: str) -> AABB:
        return self._aabb(name, "object")

    def _aabb(self, name: str, what: str) -> AABB:
        try:
            return self.aabbs[name]
        except KeyError:
            raise LookupError(f"no extent known for the {what} {name!r}") from None

    def set_link_pose(self, link: str, pose: Pose) -> None:
        """Move a link (objects attached to it follow)."""
        if not isinstance(pose, Pose):
            raise TypeError(f"link {link!r}: pose must be an executive.Pose, got {pose!r}")
        self.links[link] = pose

    def _probe_failure(self, kind: str, default: Any) -> ProbeResult | None:
        spec = self.fail_probe[kind].get(len(self.probe_calls[kind]))
        if spec is None:
            return None
        if isinstance(spec, ProbeResult):
            return spec
        if spec is True:
            spec = default
        return ProbeResult(False, spec() if isinstance(spec, type) else spec)

    @staticmethod
    def _near(pose: Pose, poses: Collection[Pose]) -> bool:
        return any(
            p.frame == pose.frame and p.distance_to(pose) <= 1e-3 and p.angle_to(pose) <= 1e-3
            for p in poses
        )

    def probe_base_pose(self, pose: Pose) -> ProbeResult:
        self.probe_calls["base"].append(pose)
        scripted = self._probe_failure("base", NavigationPoseUnreachable)
        if scripted is not None:
            return scripted
        blocked = [self._express(p, "map") for p in self.blocked_poses]
        if self._near(self._express(pose, "map"), blocked):
            return ProbeResult(False, NavigationPoseUnreachable(location=pose))
        return ProbeResult(True)

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
        self.probe_calls["arm"].append((arm, tuple(waypoints)))
        scripted = self._probe_failure("arm", ManipulationPoseUnreachable)
        if scripted is not None:
            return scripted
        for i, waypoint in enumerate(waypoints):
            if self._near(waypoint, self.unreachable_waypoints):
                return ProbeResult(False, ManipulationPoseUnreachable(), index=i)
        return ProbeResult(True)

    def probe_placing_stability(self, object_type: str, pose: Pose) -> ProbeResult:
        self.probe_calls["stability"].append((object_type, pose))
        scripted = self._probe_failure("stability", HighLevelFailure)
        if scripted is not None:
            return scripted
        unstable = [self._express(p, "map") for p in self.unstable_poses]
        if self._near(self._express(pose, "map"), unstable):
            return ProbeResult(False, HighLevelFailure("Pose unstable"))
        return ProbeResult(True)

    def handle_event(self, event: Event) -> None:
        self.events.append(event)
        if isinstance(event, ObjectAttached):
            name = object_name(event.object)
            obj = self._object(name)
            if event.link in self.links:
                link = self.link_pose(event.link, "map").to_transform()
                self._held[name] = link.inverse() * self.object_pose(name, "map").to_transform()
            obj.attached_to = (event.arm, event.link)
        elif isinstance(event, ObjectDetached):
            name = object_name(event.object)
            obj = self._object(name)
            if name in self._held:
                obj.pose = self.object_pose(name, "map")
                del self._held[name]
            obj.attached_to = None
        elif isinstance(event, ContainerOpened):
            name = object_name(event.container)
            self.joint_states[name] = self.joint_states.get(name, 0.0) + event.distance
        elif isinstance(event, ContainerClosed):
            name = object_name(event.container)
            self.joint_states[name] = self.joint_states.get(name, 0.0) - event.distance
        elif isinstance(event, ObjectPerceived):
            self.perceived.append(event.designator)
        elif isinstance(event, RobotStateChanged):
            self.robot_state_changes += 1

    def attached(self, arm: str | None = None) -> list[str]:
        """Names of the objects held (by ``arm``, or by any arm)."""
        return [
            o.name
            for o in self.objects.values()
            if o.attached_to is not None and (arm is None or o.attached_to[0] == arm)
        ]


AcceptSpec = str | Collection[str] | Callable[[Designator], bool] | None


class FakeProcessModule(ProcessModule):
    """A process module that records its goals and fails on cue.

    - ``accepts``: ``None`` (every motion), a motion type, a collection of types, or a
      predicate on the motion;
    - ``fail_on={n: failure}``: the n-th goal (1-based, counting every goal that started)
      raises ``failure`` (an instance, raised as is, or a class, instantiated without
      arguments);
    - ``result``: the value of each goal, or a callable ``result(motion)``;
    - ``delay``: seconds each goal takes, via ``cpl.sleep`` (the loop clock, or the current
      :class:`cpl.Timeline` inside a projection).
    - ``resources``: the robot parts it drives (:class:`executive.Resource`; the
      environment's parts are its modules', see :attr:`executive.Environment.resources`).

    ``calls`` lists the motions of started goals, ``cancelled`` the motions given to
    ``on_cancel``, ``completed`` the motions that finished successfully. ``history=n``
    keeps only (at least) the newest ``n`` motions in each list, for a module that runs
    all day (a soak test); ``goals`` counts every goal that started either way.
    """

    def __init__(
        self,
        name: str = "fake",
        *,
        accepts: AcceptSpec = None,
        fail_on: Mapping[int, BaseException | type[BaseException]] | None = None,
        result: Any = None,
        delay: float = 0.0,
        cancel_delay: float = 0.0,
        resources: Collection[Resource] = (),
        history: int | None = None,
    ) -> None:
        super().__init__(name)
        if history is not None and (type(history) is not int or history < 1):
            raise ValueError(f"history must be an int >= 1 or None (keep all), got {history!r}")
        parts = frozenset(resources)
        for part in parts:
            if not isinstance(part, Resource):
                raise TypeError(f"resources are executive.Resource values, got {part!r}")
        self.resources = parts
        self._accepts = _accept_predicate(accepts)
        self.fail_on: dict[int, BaseException | type[BaseException]] = dict(fail_on or {})
        for n in self.fail_on:
            if not isinstance(n, int) or n < 1:
                raise ValueError(f"fail_on keys are 1-based call numbers, got {n!r}")
        self.result = result
        self.delay = float(delay)
        self.cancel_delay = float(cancel_delay)
        self.calls: list[Designator] = []
        self.completed: list[Designator] = []
        self.cancelled: list[Designator] = []
        self.history = history  # None: the lists keep every motion
        self.goals = 0  # goals started (fail_on numbers them), whatever history keeps

    def _trim(self, motions: list[Designator]) -> None:
        # amortised: cut back to `history` once the list holds twice as many
        if self.history is not None and len(motions) >= 2 * self.history:
            del motions[: -self.history]

    def accepts(self, motion: Designator) -> bool:
        return self._accepts(motion)

    async def execute(self, motion: Designator) -> Any:
        self.calls.append(motion)
        self._trim(self.calls)
        self.goals += 1
        n = self.goals
        if self.delay > 0:
            await cpl.sleep(self.delay)
        failure = self.fail_on.get(n)
        if failure is not None:
            raise failure() if isinstance(failure, type) else failure
        self.completed.append(motion)
        self._trim(self.completed)
        return self.result(motion) if callable(self.result) else self.result

    async def on_cancel(self, motion: Designator) -> None:
        self.cancelled.append(motion)
        self._trim(self.cancelled)
        if self.cancel_delay > 0:
            await cpl.sleep(self.cancel_delay)


def _accept_predicate(spec: AcceptSpec) -> Callable[[Designator], bool]:
    if spec is None:
        return lambda motion: True
    if isinstance(spec, str):
        return lambda motion: motion.type == spec
    if callable(spec):
        return spec
    types = frozenset(spec)
    if not all(isinstance(t, str) for t in types):
        raise TypeError(f"accepts: expected motion type names, got {spec!r}")
    return lambda motion: motion.type in types
