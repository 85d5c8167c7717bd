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

from collections.abc import Callable, Collection, Mapping
from dataclasses import dataclass
from typing import Any

import cpl

from ._designator import Designator
from ._pose import Pose
from ._process_module import ProcessModule
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
from .failures import PerceptionObjectNotInWorld

__all__ = ["FakeProcessModule", "InMemoryWorld", "WorldObject"]


@dataclass
class WorldObject:
    """An object of the in-memory world. ``attached_to`` is ``(arm, link)`` while held."""

    name: str
    pose: Pose
    type: str | None = None
    attached_to: tuple[str, str | None] | None = None


class InMemoryWorld:
    """A :class:`executive.WorldModel` in plain Python.

    Events: ``ObjectAttached``/``ObjectDetached`` set/clear ``attached_to`` (an attached
    object's pose follows nothing: this world has no kinematics); ``ContainerOpened``/
    ``ContainerClosed`` add/subtract ``distance`` to ``joint_states[container]``;
    ``ObjectPerceived`` appends to ``perceived``; ``RobotStateChanged`` bumps
    ``robot_state_changes``. Every event is appended to ``events``.
    Unknown objects raise :class:`executive.PerceptionObjectNotInWorld`.
    """

    def __init__(
        self,
        objects: Mapping[str, Pose] | None = None,
        *,
        robot_pose: Pose | None = None,
        types: Mapping[str, str] | None = None,
    ) -> None:
        self.objects: dict[str, WorldObject] = {}
        for name, pose in (objects or {}).items():
            self.add_object(name, pose, type=(types or {}).get(name))
        self._robot_pose = robot_pose or Pose()
        self.joint_states: dict[str, float] = {}
        self.events: list[Event] = []
        self.perceived: list[Any] = []
        self.robot_state_changes = 0

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
        pose = self._object(name).pose
        if frame == pose.frame:
            return pose
        if frame == "base_footprint" and pose.frame == "map":
            base = self._robot_pose.to_transform("base_footprint")
            result: Pose = base.inverse() * pose
            return result
        raise ValueError(f"InMemoryWorld knows frames 'map' and 'base_footprint', not {frame!r}")

    def robot_pose(self) -> Pose:
        return self._robot_pose

    def set_robot_pose(self, pose: Pose) -> None:
        self._robot_pose = pose

    def set_object_pose(self, name: str, pose: Pose) -> None:
        self._object(name).pose = pose

    def handle_event(self, event: Event) -> None:
        self.events.append(event)
        if isinstance(event, ObjectAttached):
            self._object(object_name(event.object)).attached_to = (event.arm, event.link)
        elif isinstance(event, ObjectDetached):
            self._object(object_name(event.object)).attached_to = None
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
    - ``delay``: seconds of (loop clock) time each goal takes, via ``cpl.sleep``.

    ``calls`` lists the motions of started goals, ``cancelled`` the motions given to
    ``on_cancel``, ``completed`` the motions that finished successfully.
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
    ) -> None:
        super().__init__(name)
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

    def accepts(self, motion: Designator) -> bool:
        return self._accepts(motion)

    async def execute(self, motion: Designator) -> Any:
        self.calls.append(motion)
        n = len(self.calls)
        if self.delay > 0:
            await cpl.sleep(self.delay)
        failure = self.fail_on.get(n)
        if failure is not None:
            raise failure() if isinstance(failure, type) else failure
        self.completed.append(motion)
        return self.result(motion) if callable(self.result) else self.result

    async def on_cancel(self, motion: Designator) -> None:
        self.cancelled.append(motion)
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
