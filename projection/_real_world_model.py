"""The real robot's world model: queries and probes on the belief world, events applied
to both the belief and the true world."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import pybullet as pb

from executive import Pose, ProbeResult
from executive._kitchen import KitchenDescription
from executive._robot import RobotDescription
from executive.events import (
    ContainerClosed,
    ContainerOpened,
    Event,
    ObjectAttached,
    ObjectDetached,
    ObjectPerceived,
    RobotStateChanged,
    object_name,
)
from projection._real_body import sync_robot
from projection._world import World
from projection._world_model import DETACH_SETTLE_STEPS, ProjectedWorldModel

__all__ = ["RealWorldModel"]


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
        self._links = true_world.robot_links

    # -- queries and probes: the belief's -------------------------------------------
    @property
    def robot(self) -> RobotDescription:
        """The description of the robot (the belief's, the same robot as the true one's)."""
        return self.belief.robot

    @property
    def kitchen(self) -> KitchenDescription:
        """The description of the kitchen (the belief's, the same kitchen as the true one's)."""
        return self.belief.kitchen

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

    def container_state(self, link_or_joint: str) -> tuple[float, float, float]:
        return self.belief.container_state(link_or_joint)

    def object_names(self) -> list[str]:
        """The objects of the belief (:class:`executive.ObjectInventory`). Spawning is
        not offered (no :class:`executive.ObjectSpawning`): reality is not spawned into."""
        return self.belief.object_names()

    def arm_joint_limits(self, arm: str) -> tuple[tuple[str, float, float], ...]:
        return self.belief.arm_joint_limits(arm)

    def gripper_opening(self, arm: str) -> float | None:
        """The finger opening of ``arm``: the belief robot mirrors the true joint states
        (as a real robot's belief has them from its joint-state topic)."""
        return self.belief.gripper_opening(arm)

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
        swept: bool | None = None,
        collision_modes: Sequence[str | None] | None = None,
    ) -> ProbeResult:
        return self.belief.probe_arm_trajectory(
            arm,
            waypoints,
            robot_pose=robot_pose,
            gripper_opening=gripper_opening,
            allowed_contacts=allowed_contacts,
            check_collisions=check_collisions,
            swept=swept,
            collision_modes=collision_modes,
        )

    def probe_arm_configuration(
        self,
        left: Sequence[float] | None = None,
        right: Sequence[float] | None = None,
        *,
        allowed_contacts: Sequence[str] = (),
    ) -> ProbeResult:
        return self.belief.probe_arm_configuration(left, right, allowed_contacts=allowed_contacts)

    def probe_container_opening(self, container: Any, distance: float, arm: str) -> ProbeResult:
        return self.belief.probe_container_opening(container, distance, arm)

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
                true.attach(name, event.link or true.robot.arm(event.arm).hand_link)
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
            if n in world.gripper_links(arm)
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
                belief.set_object_pose(name, pose, allow_overlap=True)
        elif isinstance(otype, str):
            belief.spawn_object(name, otype, pose, allow_overlap=True)  # noisy percepts

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
