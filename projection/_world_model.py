"""The belief state of a projected robot: :class:`ProjectedWorldModel` implements
:class:`executive.ProjectionWorld` on a :class:`~projection._world.World`.

In projection the belief *is* the world: queries read the PyBullet world, events change it
(CRAM's ``cram_bullet_reasoning_belief_state`` event handlers), and the probes imagine a
motion on it and put everything back (``World.snapshot``/``restore``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from cpl import PlanFailure as _PlanFailure
from executive import Pose, ProbeResult
from executive._kitchen import KitchenDescription
from executive._robot import RobotDescription
from executive.events import (
    ContainerClosed,
    ContainerOpened,
    Event,
    ObjectAttached,
    ObjectDetached,
    object_name,
)
from executive.failures import (
    HighLevelFailure,
    ManipulationGoalInCollision,
    PerceptionObjectNotInWorld,
)
from projection._arm_planner import touched_objects
from projection._objects import object_type as _object_type
from projection._swept_motions import arm_motion_sweep
from projection._world import KITCHEN, Contact, World

__all__ = ["DETACH_SETTLE_STEPS", "STABILITY_THRESHOLD", "ProjectedWorldModel"]

#: Physics steps an object settles for after it was released (CRAM: 10).
DETACH_SETTLE_STEPS = 10
#: How far (m) a placed object may move before the pose counts as unstable (CRAM: 0.2).
STABILITY_THRESHOLD = 0.2
#: How far (m) the footprints of a placed object and a neighbour may interpenetrate before
#: the placing pose counts as overlapping it.
OVERLAP_TOLERANCE = 0.005


def _arm(world: World, arm: Any) -> str:
    if not isinstance(arm, str) or arm not in world.arms:
        raise ValueError(f"unknown arm {arm!r}; known arms: {', '.join(world.arms)}")
    return arm


def _pose(pose: Any, what: str) -> Pose:
    if not isinstance(pose, Pose):
        raise TypeError(f"{what} must be an executive.Pose, got {pose!r}")
    return pose


class ProjectedWorldModel:
    """:class:`executive.ProjectionWorld` on a PyBullet :class:`World`.

    Unknown objects raise :class:`executive.PerceptionObjectNotInWorld`; unknown links and
    containers :class:`LookupError`; a wrong arm :class:`ValueError`. Events:

    - ``ObjectAttached``: the object is attached rigidly to ``event.link`` or, by default,
      to the arm's ``hand_link`` (CRAM's end-effector link; the PR2-like robot's
      ``?_wrist_roll_link``), replacing any
      attachment to the kitchen (the spoon in the drawer);
    - ``ObjectDetached``: released, then settles for :data:`DETACH_SETTLE_STEPS` steps; an
      object the robot does not hold is left alone;
    - ``ContainerOpened``/``ContainerClosed``: the container's joint (its ``urdf-name``,
      ``name``, or the name given) moves by ``distance``; beyond its limits raises
      :class:`executive.EnvironmentManipulationGoalNotReached`, world unchanged;
    - ``RobotStateChanged``, ``ObjectPerceived`` and others: nothing (the belief is the
      world).
    """

    def __init__(self, world: World, *, swept: bool = True) -> None:
        if not isinstance(world, World):
            raise TypeError(f"ProjectedWorldModel needs a projection.World, got {world!r}")
        if not isinstance(swept, bool):
            raise TypeError(f"swept must be True or False, got {swept!r}")
        self.world = world
        #: Whether :meth:`probe_arm_trajectory` also checks the path the arm sweeps
        #: between waypoints (the real controller's path), not the waypoints alone.
        self.swept = swept
        self._robot_links = world.robot_links

    @property
    def robot(self) -> RobotDescription:
        """The description of the robot the world holds."""
        return self.world.robot

    @property
    def kitchen(self) -> KitchenDescription:
        """The description of the kitchen the world holds."""
        return self.world.kitchen

    # ------------------------------------------------------------------ queries
    def _known(self, name: Any) -> str:
        if not isinstance(name, str) or name not in self.world.objects:
            known = ", ".join(self.world.objects) or "none"
            raise PerceptionObjectNotInWorld(
                f"no object {name!r} in the world (known: {known})", object=name
            )
        return name

    def object_pose(self, name: str, frame: str = "map") -> Pose:
        """The object's pose in ``map`` or ``base_footprint`` (another frame: ValueError)."""
        return self.world.object_pose(self._known(name), frame)

    def robot_pose(self) -> Pose:
        """``base_footprint`` in ``map``."""
        return self.world.robot_pose()

    def object_type(self, name: str) -> str:
        """The object's type."""
        return self.world.objects[self._known(name)]

    def object_in_hand(self, arm: str) -> str | None:
        """The first object attached to a link of ``arm`` (:meth:`World.arm_links`), or
        None."""
        links = self.world.arm_links(_arm(self.world, arm))
        for name, link in self.world.attachments.items():
            if link in links:
                return name
        return None

    def link_pose(self, link: str, frame: str = "map") -> Pose:
        """A robot or kitchen link's pose; unknown links raise LookupError."""
        return self.world.link_pose(link, frame)

    def container_state(self, link_or_joint: str) -> tuple[float, float, float]:
        """``(position, lower, upper)`` of a container joint (see ``World``;
        :class:`executive.ContainerStates`)."""
        return self.world.container_state(link_or_joint)

    def object_names(self) -> list[str]:
        """Every object of the world, by name (:class:`executive.ObjectInventory`)."""
        return list(self.world.objects)

    def spawn_object(self, name: str, type: str, pose: Pose) -> str:
        """Add an object to the projected world (:class:`executive.ObjectSpawning`: the
        stand-ins plans imagine with); refused with ``ValueError`` where it would reach
        into another object or the robot, the world unchanged."""
        return self.world.spawn_object(name, type, _pose(pose, "pose"))

    def remove_object(self, name: str) -> None:
        """Remove an object from the projected world (``LookupError`` if unknown)."""
        self.world.remove_object(name)

    def arm_joint_limits(self, arm: str) -> tuple[tuple[str, float, float], ...]:
        """``(joint, lower, upper)`` of ``arm``'s joints (see ``World``)."""
        return self.world.arm_joint_limits(arm)

    def gripper_opening(self, arm: str) -> float | None:
        """The distance (m) between the finger pads of ``arm``'s gripper (the robot's
        finger joints; a real robot's belief has them from its joint states)."""
        return self.world.gripper_opening(_arm(self.world, arm))

    def link_aabb(self, link: str) -> tuple[tuple[float, ...], tuple[float, ...]]:
        """A robot or kitchen link's axis-aligned bounding box in map, ``(min, max)``;
        unknown links raise LookupError."""
        lo, hi = self.world.link_aabb(link)
        return tuple(lo), tuple(hi)

    def object_aabb(self, name: str) -> tuple[tuple[float, ...], tuple[float, ...]]:
        """The object's axis-aligned bounding box in map, ``(min, max)``."""
        lo, hi = self.world.object_aabb(self._known(name))
        return tuple(lo), tuple(hi)

    # ------------------------------------------------------------------ events
    def handle_event(self, event: Event) -> None:
        """Apply an event to the world (see the class docstring). Not an Event:
        TypeError."""
        if not isinstance(event, Event):
            raise TypeError(f"handle_event() needs an executive.events.Event, got {event!r}")
        world = self.world
        if isinstance(event, ObjectAttached):
            name = self._known(object_name(event.object))
            link = event.link or world.robot.arm(_arm(world, event.arm)).hand_link
            world.attach(name, link)
        elif isinstance(event, ObjectDetached):
            name = self._known(object_name(event.object))
            _arm(world, event.arm)
            if world.attachments.get(name) in self._robot_links:
                world.detach(name, settle_steps=DETACH_SETTLE_STEPS)
        elif isinstance(event, ContainerOpened):
            world.open_container(self._container(event.container), event.distance)
        elif isinstance(event, ContainerClosed):
            world.close_container(self._container(event.container), event.distance)

    @staticmethod
    def _container(container: Any) -> str:
        if isinstance(container, str):
            return container
        get = getattr(container, "get", None)
        if get is not None:
            current = getattr(container, "current", None)
            desig = current() if current is not None else container
            name = desig.get("urdf-name")
            if isinstance(name, str):
                return name
        return object_name(container)

    # ------------------------------------------------------------------ probes
    def probe_base_pose(self, pose: Pose) -> ProbeResult:
        """Would the robot, with what it carries, stand collision-free at ``pose``? The
        failure is :class:`executive.NavigationPoseUnreachable`. World restored."""
        _pose(pose, "pose")
        world = self.world
        snap = world.snapshot()
        try:
            world.drive(pose)
        except _PlanFailure as failure:
            return ProbeResult(False, failure)
        finally:
            world.restore(snap)
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
        """Drive to ``robot_pose`` (if given; in collision -> ``NavigationPoseUnreachable``,
        index None), set the gripper opening (if given; out of range ->
        ``GripperGoalNotReached``, index None), then move ``arm``'s tool frame through
        ``waypoints`` with :meth:`World.move_tcp`. Waypoint ``i`` fails with
        ``ManipulationPoseUnreachable`` (no IK) or, where collisions are checked, with
        :class:`executive.ManipulationGoalInCollision` (``contacts=[...]``) when the robot
        or what it carries touches anything whose object, body or link name is not in
        ``allowed_contacts``. Where collisions are checked and ``swept`` is on (None:
        :attr:`swept`, on by default), the path the real arm controller follows *to* the waypoint
        (:func:`projection._arm_planner.controller_path`: the straight tool line, rerouted
        around free objects where it can be) must not sweep the robot or what it holds
        through a free object either (other than ``allowed_contacts`` and those it
        touches where that motion starts or ends): else
        :class:`executive.ManipulationGoalInCollision` (``swept=(names...)``). A waypoint
        not checked for collisions is exempt from kitchen contacts only (the put of a
        placing, where the object touches its support): there too the robot or what it
        holds must not touch a free object other than ``allowed_contacts``; else
        :class:`executive.ManipulationGoalInCollision` (``contacts=[...]``), e.g. a cereal
        box put down pressed into the bowl placed before it, or the elbow pressing
        the bowl as the hand goes down (seed 1 knocked the bowl so, three times).
        Deliberate addition: CRAM checked the waypoints only, and its arm moved between
        them wherever its controller took it; the simulated real arm follows that path
        and topples what it sweeps through. ``collision_modes`` (one per waypoint; None:
        not known): the collision mode of the motion to each waypoint; a free one (None:
        avoid all) is checked along the path the real controller plans for it
        (:func:`projection._arm_planner.controller_path`), not the straight tool line, so
        the probe accepts a reach the robot will plan around an object. The world is
        restored. Bad arguments raise TypeError/ValueError."""
        arm = _arm(self.world, arm)
        wps = [_pose(p, f"waypoint {i}") for i, p in enumerate(waypoints)]
        if robot_pose is not None:
            _pose(robot_pose, "robot_pose")
        if isinstance(check_collisions, bool):
            checks = [check_collisions] * len(wps)
        else:
            checks = [bool(c) for c in check_collisions]
            if len(checks) != len(wps):
                raise ValueError(
                    f"check_collisions has {len(checks)} entries for {len(wps)} waypoints"
                )
        if collision_modes is None:
            modes: list[dict[str, Any]] = [{} for _ in wps]
        else:
            modes = [{"collision_mode": m} for m in collision_modes]
            if len(modes) != len(wps) or any(
                m["collision_mode"] is not None and not isinstance(m["collision_mode"], str)
                for m in modes
            ):
                raise ValueError(
                    f"collision_modes needs one mode (a string or None) per waypoint: "
                    f"{len(wps)} waypoints, got {list(collision_modes)!r}"
                )
        if isinstance(allowed_contacts, str):
            raise TypeError("allowed_contacts is a sequence of names, not one string")
        allowed = frozenset(allowed_contacts)
        if swept is not None and not isinstance(swept, bool):
            raise TypeError(f"swept must be True, False or None, got {swept!r}")
        sweeps = self.swept if swept is None else swept
        world = self.world
        snap = world.snapshot()
        try:
            try:
                if robot_pose is not None:
                    world.drive(robot_pose)
                if gripper_opening is not None:
                    world.gripper(gripper_opening, arm)
            except _PlanFailure as failure:
                return ProbeResult(False, failure)
            for i, (wp, check, mode) in enumerate(zip(wps, checks, modes)):
                torso, start = world.torso_height, {arm: world.arm_joints(arm)}
                try:
                    world.move_tcp(**{arm: wp})
                except _PlanFailure as failure:
                    return ProbeResult(False, failure, i)
                collisions = world.robot_collisions()
                if check:
                    contacts = [c for c in collisions if not _allowed(c, allowed)]
                    if contacts:
                        return ProbeResult(False, _in_collision(arm, i, contacts), i)
                    if sweeps:
                        hits = self._swept(arm, wp, torso, start, allowed, mode)
                        if hits:
                            return ProbeResult(False, _swept_into(arm, i, hits), i)
                else:
                    # exempt from kitchen contacts only (the put of a placing): the robot
                    # and what it holds must not press into a free object other than the
                    # allowed ones (a box put down against a bowl placed before it). Not
                    # at checked waypoints: a contact of the robot is caught above, and
                    # the held object the probe keeps in the hand after a put is really
                    # left standing there (a retract).
                    free = {n for n in world.objects if n not in world.attachments} - allowed
                    pressed = [c for c in collisions if c.body_b in free]
                    if pressed:
                        return ProbeResult(False, _in_collision(arm, i, pressed), i)
            return ProbeResult(True)
        finally:
            world.restore(snap)

    def probe_arm_configuration(
        self,
        left: Sequence[float] | None = None,
        right: Sequence[float] | None = None,
        *,
        allowed_contacts: Sequence[str] = (),
    ) -> ProbeResult:
        """Would moving the arms to these joint values (``left``/``right``, one value per
        arm joint each; None: that arm stays) sweep the robot or what it holds through a
        free object (other than ``allowed_contacts`` and those it touches where the
        motion starts), or end pressing one it did not touch at the start (a failure
        too, ``swept=(names...)``; before, an object touched at the end was let pass,
        and the park that ended against the bowl pushed it)?
        The path is the real controller's for a configuration move
        (:func:`projection._arm_planner.controller_path`: straight in joint space, routed
        around free objects where it can be), in this world. The failure is
        :class:`executive.ManipulationGoalInCollision` (``swept=(names...)``). Also a
        failure: the arms would *end* inside a kitchen link they did not touch before
        (``swept=("kitchen/<link>", ...)``), e.g. the carry configuration next to the
        drawer the robot has just opened, which wedged the true robot's forearm in the
        drawer so that the base could not drive off. The world is restored. Wrong joint
        values: ValueError; allowed_contacts one string: TypeError. Deliberate addition:
        CRAM never checked a park (``position-arms``)."""
        goals = {a: q for a, q in (("left", left), ("right", right)) if q is not None}
        if isinstance(allowed_contacts, str):
            raise TypeError("allowed_contacts is a sequence of names, not one string")
        allowed = frozenset(allowed_contacts)
        world = self.world
        snap = world.snapshot()
        try:
            arms = sorted(goals)
            if not arms:
                return ProbeResult(True)
            torso = world.torso_height
            start = {a: world.arm_joints(a) for a in arms}
            free = {n for n in world.objects if n not in world.attachments} - allowed
            kitchen_before = {link for _a, link in _kitchen_contacts(world)}
            others = free - touched_objects(world, free)
            world.move_joints(**goals)  # ValueError for wrong values
            inside = sorted({link for _a, link in _kitchen_contacts(world)} - kitchen_before)
            if inside:
                return ProbeResult(
                    False,
                    ManipulationGoalInCollision(
                        f"the {' and '.join(arms)} arm(s) would end inside "
                        f"{', '.join(inside)} (e.g. an open drawer)",
                        arms=tuple(arms),
                        swept=tuple(f"{KITCHEN}/{link}" for link in inside),
                    ),
                )
            # an arm that ends against a free object it did not touch where it started
            # presses into it: the real arm pushes it (seed 8 without projection: the
            # park's upper arm ended against the bowl on the island and toppled it)
            pressed = sorted(touched_objects(world, others))
            if pressed:
                return ProbeResult(
                    False,
                    ManipulationGoalInCollision(
                        f"the {' and '.join(arms)} arm(s) would end pressing {', '.join(pressed)}",
                        arms=tuple(arms),
                        swept=tuple(pressed),
                    ),
                )
            if not others:
                return ProbeResult(True)
            # the world's answer (remembered: the arms module asks it again when the
            # motion is executed), restricted to the objects not allowed
            sweep = arm_motion_sweep(world, "move-joints", arms, goals, torso, start)
            hits = [n for n in sweep.swept if n in others]
        finally:
            world.restore(snap)
        if hits:
            return ProbeResult(
                False,
                ManipulationGoalInCollision(
                    f"moving the {' and '.join(arms)} arm(s) to "
                    f"{'their' if len(arms) > 1 else 'its'} configuration sweeps through "
                    f"{', '.join(hits)}",
                    arms=tuple(arms),
                    swept=tuple(hits),
                ),
            )
        return ProbeResult(True)

    def probe_container_opening(self, container: Any, distance: float, arm: str) -> ProbeResult:
        """Would opening ``container`` (its designator, link or joint) by ``distance`` push
        it into the robot: would the opened container touch a robot link (or something
        the robot holds) other than ``arm``'s gripper, which holds the handle, where it
        did not before? The failure is :class:`executive.ManipulationGoalInCollision`
        (``swept=("kitchen/<link>", ...)``). The world is restored. Unknown container:
        LookupError; a wrong arm: ValueError. Deliberate addition: CRAM checked only the
        opening arm's waypoints, and a drawer pulled open into the other forearm wedged
        the true robot there (no base motion was collision-free any more)."""
        gripper = self.world.gripper_links(_arm(self.world, arm))
        name = self._container(container)
        world = self.world
        snap = world.snapshot()
        try:
            before = _kitchen_contacts(world, gripper)
            world.open_container(name, distance)
            pushed = sorted({link for _a, link in _kitchen_contacts(world, gripper) - before})
        finally:
            world.restore(snap)
        if not pushed:
            return ProbeResult(True)
        return ProbeResult(
            False,
            ManipulationGoalInCollision(
                f"opening {name} by {distance:.2f} m would push {', '.join(pushed)} into the robot",
                arms=(arm,),
                swept=tuple(f"{KITCHEN}/{link}" for link in pushed),
            ),
        )

    def _swept(
        self,
        arm: str,
        waypoint: Pose,
        torso: float,
        start: dict[str, tuple[float, ...]],
        allowed: frozenset[str],
        mode: Mapping[str, Any] | None = None,
    ) -> list[str]:
        """With the robot at a waypoint's IK goal: the free objects (not ``allowed``, not
        touched where the motion starts or ends) that the real controller's path from
        ``torso``/``start`` to here sweeps the arm (or what it holds) through, sorted.
        The path is :func:`projection._arm_planner.controller_path` in this world, i.e.
        what the arms module will follow if the world is as believed; the answer is the
        world's (:func:`projection._swept_motions.arm_motion_sweep`, remembered in
        ``World.sweep_memo``), so executing the motion checked here costs a lookup.
        Leaves the robot at the goal configuration."""
        args = {arm: waypoint, **(mode or {})}  # with its collision mode where known
        sweep = arm_motion_sweep(self.world, "move-tcp", [arm], args, torso, start)
        return [n for n in sweep.swept if n not in allowed]

    def probe_placing_stability(self, object_type: str, pose: Pose) -> ProbeResult:
        """Would an object of ``object_type`` released at ``pose`` stay within
        :data:`STABILITY_THRESHOLD` of it (up to 600 steps, in a side world holding the
        kitchen only)? The failure is a :class:`executive.HighLevelFailure` "Pose
        unstable". The main world is not touched; unknown type: LookupError.

        Deliberate addition (CRAM's side world holds the kitchen only): the pose is also
        unstable when the object's box there overlaps a free object of the world (one
        the robot does not hold) by more than :data:`OVERLAP_TOLERANCE` (oriented
        footprints, by the separating-axis test, and heights); e.g. the cereal's fixed
        placing pose on the island would land on a bowl placed there before it."""
        _pose(pose, "pose")
        blocker = self._overlapping(object_type, pose)
        if blocker is not None:
            return ProbeResult(
                False,
                HighLevelFailure(
                    f"Pose unstable: a {object_type} at {pose!r} overlaps {blocker}",
                    object_type=object_type,
                    pose=pose,
                ),
            )
        if self.world.placing_pose_stable(object_type, pose, threshold=STABILITY_THRESHOLD):
            return ProbeResult(True)
        return ProbeResult(
            False,
            HighLevelFailure(
                f"Pose unstable: a {object_type} at {pose!r} moves more than "
                f"{STABILITY_THRESHOLD} m",
                object_type=object_type,
                pose=pose,
            ),
        )

    def _overlapping(self, object_type: str, pose: Pose) -> str | None:
        """The first free object whose box the object's box at ``pose`` (map or
        base_footprint) overlaps, or None."""
        world = self.world
        size = _object_type(object_type).size
        placed = _in_map(world, pose)
        held = {n for n, link in world.attachments.items() if link in self._robot_links}
        for name, otype in world.objects.items():
            if name in held:
                continue
            other = world.object_pose(name)
            if _boxes_overlap(placed, size, other, _object_type(otype).size):
                return name
        return None

    def __repr__(self) -> str:
        return f"<ProjectedWorldModel {self.world!r}>"


def _allowed(contact: Contact, allowed: frozenset[str]) -> bool:
    names = {contact.body_a, contact.link_a, contact.body_b, contact.link_b} - {"object"}
    return not names.isdisjoint(allowed)


def _kitchen_contacts(
    world: World, except_links: frozenset[str] = frozenset()
) -> set[tuple[str, str]]:
    """(robot link, kitchen link) pairs in contact now, but for robot links in
    ``except_links``."""
    return {
        (c.link_a or "", c.link_b or "")
        for c in world.robot_collisions()
        if c.body_b == KITCHEN and (c.link_a or "") not in except_links
    }


def _swept_into(arm: str, index: int, objects: list[str]) -> ManipulationGoalInCollision:
    return ManipulationGoalInCollision(
        f"{arm} arm on its way to waypoint {index} sweeps through {', '.join(objects)}",
        arm=arm,
        index=index,
        swept=tuple(objects),
    )


def _in_collision(arm: str, index: int, contacts: list[Contact]) -> ManipulationGoalInCollision:
    first = contacts[0]
    return ManipulationGoalInCollision(
        f"{arm} arm at waypoint {index}: {first.body_a}/{first.link_a} touches "
        f"{first.body_b}/{first.link_b} ({len(contacts)} contact(s))",
        arm=arm,
        index=index,
        contacts=tuple(contacts),
    )


def _in_map(world: World, pose: Pose) -> Pose:
    if pose.frame == "map":
        return pose
    if pose.frame == "base_footprint":
        tf = world.robot_pose().to_transform("base_footprint") * pose
        return tf if isinstance(tf, Pose) else tf.to_pose()
    raise ValueError(f"unsupported frame {pose.frame!r}; known: map, base_footprint")


def _boxes_overlap(a: Pose, size_a: Sequence[float], b: Pose, size_b: Sequence[float]) -> bool:
    """Whether two upright boxes (extents ``size``, centred at the poses, turned by their
    yaws) interpenetrate by more than :data:`OVERLAP_TOLERANCE`."""
    tol = OVERLAP_TOLERANCE
    if abs(a.position[2] - b.position[2]) >= (size_a[2] + size_b[2]) / 2.0 - tol:
        return False
    centre = (b.position[0] - a.position[0], b.position[1] - a.position[1])
    boxes = []
    for pose, size in ((a, size_a), (b, size_b)):
        c, s = math.cos(pose.yaw), math.sin(pose.yaw)
        boxes.append(((c, s), (-s, c), size[0] / 2.0, size[1] / 2.0))
    for axis in (boxes[0][0], boxes[0][1], boxes[1][0], boxes[1][1]):
        reach = sum(
            hx * abs(ux * axis[0] + uy * axis[1]) + hy * abs(vx * axis[0] + vy * axis[1])
            for (ux, uy), (vx, vy), hx, hy in boxes
        )
        if abs(centre[0] * axis[0] + centre[1] * axis[1]) >= reach - tol:
            return False
    return True
