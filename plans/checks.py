"""CRAM's projection checks (``check-collisions.lisp``), on the world model only.

Each asks the current environment's world model (a :class:`executive.ProjectionWorld`)
to imagine a motion; the world is left as it was. The navigation and picking-up checks
inject their choice into the designator chain with ``next_solution`` (the caller re-reads
``current()``), as CRAM does. They are plain functions (no motion is performed), so
evaporation cannot interrupt them half-way.
"""

from __future__ import annotations

import logging
from typing import Any, cast

from executive import (
    ActionDesignator,
    ContainerOpeningProbe,
    Designator,
    DesignatorError,
    EnvironmentUnreachable,
    HighLevelFailure,
    LocationDesignator,
    ManipulationGoalInCollision,
    NavigationGoalInCollision,
    ObjectUnreachable,
    Pose,
    ProbeResult,
    ProjectionWorld,
    current_environment,
)
from executive.events import object_name
from plans.atomic import _COLLISION_MODES

__all__ = [
    "PICK_CHECKS",
    "PlacingPoseUnstable",
    "check_environment_manipulation_collisions",
    "check_navigating_collisions",
    "check_picking_up_collisions",
    "check_placing_collisions",
    "check_placing_pose_stability",
]

log = logging.getLogger("plans.checks")


class PlacingPoseUnstable(HighLevelFailure):
    """v0.8.1's "Pose unstable" high-level failure of ``check-placing-pose-stability``."""

    cram_name = "high-level-failure"
    default_message = "Pose unstable."


def _world() -> ProjectionWorld:
    world = current_environment().world
    if not isinstance(world, ProjectionWorld):
        raise TypeError(f"the projection checks need a ProjectionWorld, got {world!r}")
    return world


def _failure(result: ProbeResult) -> str:
    return f"{type(result.failure).__name__} at waypoint {result.index}: {result.failure}"


def check_navigating_collisions(location: LocationDesignator, samples: int = 30) -> Designator:
    """Probe the base poses of ``location``'s chain (from its newest member) until one is
    collision-free; returns that member (CRAM: up to 30 samples, ``next-solution``).

    Raises ``NavigationGoalInCollision`` when no sample is free within ``samples`` tries,
    the samples run out, or the designator cannot be resolved."""
    world = _world()
    current: Designator | None = location.current()
    tried = 0
    try:
        while current is not None:
            pose = current.reference()
            result = world.probe_base_pose(pose)
            if result.ok:
                return current
            tried += 1
            log.info("base pose %r in collision (%s)", pose, result.failure)
            if tried > samples:
                break
            current = current.next_solution()
    except DesignatorError as error:
        raise NavigationGoalInCollision(str(error)) from error
    raise NavigationGoalInCollision(f"no collision-free pose for {location.short()}")


def _pick_arguments(action: Designator) -> dict[str, Any]:
    return dict(cast(Any, action.reference()).arguments)


#: Picking-up solutions :func:`check_picking_up_collisions` probes (deliberate difference
#: from CRAM's 30: see there); the one name of this budget.
PICK_CHECKS = 60


def check_picking_up_collisions(action: ActionDesignator, retries: int = PICK_CHECKS) -> Designator:
    """Probe the ``picking-up`` solutions (arm, grasp), from the newest one, until the
    whole trajectory (reach, grasp, lift) is reachable and touches nothing but the target
    object, and the arm sweeps through no other object on its way (the world model's
    probe checks the controller's path); returns that member of the chain. Deliberate
    difference: CRAM probed 30 solutions; each of ours comes straight and from above
    (:func:`plans.pick_place._approaches`), so 60. No solution within ``retries`` next
    solutions, or a designator error -> ``ObjectUnreachable``."""
    world = _world()
    current: Designator | None = action.current()
    used = 0
    obj: Any = None
    try:
        while current is not None:
            args = _pick_arguments(current)
            obj = args["object_designator"]
            waypoints = [*args["reach_poses"], *args["grasp_poses"], *args["lift_poses"]]
            # the collision mode of each motion (plans.atomic): the probe checks the path
            # the robot will take, planned around objects for a free reach
            modes = [_COLLISION_MODES["reaching"]] * len(args["reach_poses"])
            modes += [_COLLISION_MODES["grasping"]] * len(args["grasp_poses"])
            modes += [_COLLISION_MODES["lifting"]] * len(args["lift_poses"])
            result = world.probe_arm_trajectory(
                args["arm"],
                waypoints,
                gripper_opening=args["opening"],
                allowed_contacts=(object_name(obj),),
                collision_modes=modes,
            )
            if result.ok:
                return current
            log.info("picking up with %s/%s: %s", args["arm"], args["grasp"], _failure(result))
            used += 1
            if used > retries:
                break
            current = current.next_solution()
    except DesignatorError as error:
        raise ObjectUnreachable(str(error), object=obj) from error
    raise ObjectUnreachable(f"no reachable picking-up solution for {action.short()}", object=obj)


#: Placing solutions :func:`check_placing_collisions` probes beyond the first: each yaw
#: variant comes straight and from above (:mod:`plans.pick_place`), so twice CRAM's 8.
PLACE_CHECKS = 16


def check_placing_collisions(
    action: ActionDesignator, retries: int = PLACE_CHECKS, *, take_swept: bool = True
) -> Designator:
    """Probe the ``placing`` trajectory: IK for every waypoint; collisions at the reach
    and retract waypoints (v0.8.1; HEAD only logged collisions, a quirk fixed here), the
    put waypoint is IK-only (the object touches its support there). Deliberate deviation
    from HEAD (which probed only the first grounding): up to ``retries`` further
    solutions of the grounding are probed (``next_solution``, as for picking up): the
    placing yaw variants of :mod:`plans.pick_place`; the deliver plan's target loop still
    retries other targets. Returns the first member of the chain that passes. No
    solution passes, or a designator error -> ``ObjectUnreachable`` (naming the first
    solution's failure).

    Deliberate addition: the path the arm sweeps between waypoints is checked too
    (``swept``), so a solution whose reach would sweep the held object through an
    object already placed is passed over for one that does not. When every probed
    solution failed *only* by such a sweep, the first of them is taken anyway (as
    before the sweep check): the cereal's two fixed placing poses among the objects
    placed before it are both swept over, and refusing them would leave the cereal
    undelivered. ``take_swept=False``: refused instead (``ObjectUnreachable``, logged):
    the deliver plan first looks for a target or a base pose from which nothing is swept
    (:data:`plans.deliver.STRICT_STANDS`)."""
    world = _world()
    current: Designator | None = action.current()
    obj: Any = None
    first: ProbeResult | None = None
    swept_only: list[Designator] = []
    used = 0
    try:
        while current is not None:
            args = dict(cast(Any, current.reference()).arguments)
            obj = args["object_designator"]
            result = _probe_placing(world, args)
            if result.ok:
                return current
            log.info("placing with %s: %s", args["arm"], _failure(result))
            if _only_swept(result):
                swept_only.append(current)
            first = first or result
            used += 1
            if used > retries:
                break
            current = current.next_solution()
    except DesignatorError as error:
        raise ObjectUnreachable(str(error), object=obj) from error
    if swept_only and not take_swept:
        log.info("placing: every solution sweeps through an object; not taking one here")
        assert first is not None
        raise ObjectUnreachable(f"placing: {_failure(first)}", object=obj) from first.failure
    for member in swept_only:
        args = dict(cast(Any, member.reference()).arguments)
        result = _probe_placing(world, args, swept=False)
        if result.ok:
            log.warning(
                "placing with %s: every solution sweeps through an object; taking one "
                "whose waypoints are clear",
                args["arm"],
            )
            return member
    assert first is not None
    raise ObjectUnreachable(f"placing: {_failure(first)}", object=obj) from first.failure


def _probe_placing(
    world: ProjectionWorld, args: dict[str, Any], swept: bool | None = None
) -> ProbeResult:
    """Probe a placing grounding's reach, put and retract waypoints (the put ones not for
    collisions: the object touches its support there), then, where the grounding names
    its ``release_opening``, the release: the reach and put again with the gripper opened
    that wide, where the robot must press no free object but the placed one (the fingers
    opening beside a neighbour push it). Deliberate addition: CRAM checked no release."""
    allowed = (object_name(args["object_designator"]),)
    reach_put = [*args["reach_poses"], *args["put_poses"]]
    checks = [True] * len(args["reach_poses"]) + [False] * len(args["put_poses"])
    checks += [True] * len(args["retract_poses"])
    modes = [_COLLISION_MODES["reaching"]] * len(args["reach_poses"])
    modes += [_COLLISION_MODES["putting"]] * len(args["put_poses"])
    modes += [_COLLISION_MODES["retracting"]] * len(args["retract_poses"])
    result = world.probe_arm_trajectory(
        args["arm"],
        [*reach_put, *args["retract_poses"]],
        allowed_contacts=allowed,
        check_collisions=checks,
        swept=swept,
        collision_modes=modes,
    )
    opening = args.get("release_opening")
    if not result.ok or opening is None:
        return result
    # unchecked waypoints: only pressing a free object fails them (kitchen contacts are
    # the put's own); the path was checked above, with the fingers as they hold
    return world.probe_arm_trajectory(
        args["arm"],
        reach_put,
        gripper_opening=opening,
        allowed_contacts=allowed,
        check_collisions=False,
        swept=False,
    )


def _only_swept(result: ProbeResult) -> bool:
    """Whether a probe failed by a sweep between waypoints (its waypoints were clear up
    to there)."""
    failure = result.failure
    details = getattr(failure, "details", None)
    return isinstance(failure, ManipulationGoalInCollision) and bool(
        isinstance(details, dict) and details.get("swept")
    )


def check_placing_pose_stability(object_type: str, pose: Pose) -> None:
    """v0.8.1's stability check: would an object of ``object_type`` stay at ``pose`` (in
    ``map``)? Unstable -> :class:`PlacingPoseUnstable` (a high-level failure)."""
    result = _world().probe_placing_stability(object_type, pose)
    if not result.ok:
        raise PlacingPoseUnstable(
            f"a {object_type} at {pose!r} is unstable: {result.failure}"
        ) from result.failure


def check_environment_manipulation_collisions(
    action: ActionDesignator, allowed_contacts: tuple[str, ...] = ()
) -> Designator:
    """Probe an ``opening``/``closing`` (container) trajectory: IK for every waypoint;
    for opening, collisions too (except with ``allowed_contacts``, e.g. the handle and
    drawer links), and, where the world model can tell (:class:`ContainerOpeningProbe`),
    whether the opened container would be pushed into the robot (the other forearm).
    Failure or designator error -> ``EnvironmentUnreachable``. Returns the
    newest member of the chain."""
    world = _world()
    current = action.current()
    try:
        args = dict(cast(Any, current.reference()).arguments)
        waypoints = args["waypoints"]
        result = world.probe_arm_trajectory(
            args["arm"],
            waypoints,
            allowed_contacts=allowed_contacts,
            check_collisions=args["opening"],
        )
    except DesignatorError as error:
        raise EnvironmentUnreachable(str(error)) from error
    if not result.ok:
        raise EnvironmentUnreachable(f"{current.short()}: {_failure(result)}") from result.failure
    if args["opening"] and isinstance(world, ContainerOpeningProbe):
        pushed = world.probe_container_opening(args["container"], args["distance"], args["arm"])
        if not pushed.ok:
            raise EnvironmentUnreachable(
                f"{current.short()}: {_failure(pushed)}"
            ) from pushed.failure
    return current
