"""The demo's scenes, beside the world they are built in: :func:`set_up_scene` places
CRAM's table-setting objects (the world's kitchen's demo scene,
:attr:`executive.KitchenDescription.demo_objects`) at seeded random poses in
their spawning regions (:data:`SPAWN_REGIONS`) or at CRAM's fixed poses, the spoon in the
drawer; :func:`make_world_pair` builds a true world and a belief world from the same
assets for the simulated real robot, the true one with CRAM's demo objects at their
fixed poses (:data:`DEMO_OBJECTS`) or the caller's.

Deliberate difference from CRAM: its demo plan spawned its own objects; here the plan only
acts, and whoever runs it sets the scene up first (``aiocram demo`` calls
:func:`set_up_scene` before it starts the robot)."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from types import MappingProxyType
from typing import Any, Literal

import numpy as np

import cpl
from executive import (
    Designator,
    DesignatorError,
    LocationDesignator,
    Pose,
    a,
    an,
    yaw_quaternion,
)
from executive._robot import RobotDescription
from kitchens import iai
from projection._objects import object_type
from projection._real_body import settle
from projection._world import World

__all__ = [
    "DEFAULT_SPAWN_REGION",
    "DEMO_OBJECTS",
    "SPAWN_REGIONS",
    "SceneObject",
    "SceneSetUpError",
    "make_world_pair",
    "set_up_scene",
    "spawn_region",
]

SceneObject = tuple[str, Pose] | tuple[str, Pose, str]

#: CRAM's demo objects (map; z is replaced by the resting height on the sink counter; the
#: spoon lies in the drawer, attached to it): name -> (type, pose[, attached link]).
DEMO_OBJECTS: Mapping[str, SceneObject] = {
    f"{t}-1": (
        (t, iai.DESCRIPTION.demo_poses[t])
        if t not in iai.DESCRIPTION.demo_attachments
        else (t, iai.DESCRIPTION.demo_poses[t], iai.DESCRIPTION.demo_attachments[t])
    )
    for t in iai.DESCRIPTION.demo_poses  # in CRAM's fixed scene's spawning order
}


def make_world_pair(
    seed: int | None = 0,
    *,
    objects: Mapping[str, SceneObject] | None = None,
    belief_objects: Literal["none", "exact", "noisy"] = "none",
    noise: tuple[float, float] = (0.02, 0.1),
    gui: bool = False,
    robot: RobotDescription | None = None,
) -> tuple[World, World]:
    """Two worlds from the same assets: ``(true_world, belief_world)``, robot and kitchen
    identical. ``objects`` (default :data:`DEMO_OBJECTS`; name -> (type, pose[, link to
    attach to])) are spawned in the true world (types that rest on a surface get their z
    from the counter below), which then settles for 100 physics steps. The belief knows
    them not at all (``"none"``: perception teaches it), exactly (``"exact"``), or with
    Gaussian ``noise`` = (x/y std m, yaw std rad) drawn from ``seed`` (``"noisy"``).
    ``gui=True`` shows the true world in a PyBullet window (needs a display). ``robot``:
    the robot both worlds hold (default: the PR2-like robot). The caller closes both
    worlds. Bad ``belief_objects``: ValueError."""
    if belief_objects not in ("none", "exact", "noisy"):
        raise ValueError(
            f"belief_objects must be 'none', 'exact' or 'noisy', got {belief_objects!r}"
        )
    true_world = World(seed=seed, gui=gui, robot=robot)
    belief_world = World(seed=seed, robot=robot)
    try:
        spec = DEMO_OBJECTS if objects is None else objects
        for name, entry in spec.items():
            otype, pose = entry[0], entry[1]
            if objects is None and len(entry) == 2:  # the demo: rest on the sink counter
                top = true_world.link_aabb(true_world.kitchen.start_surface)[1][2]
                z = top + object_type(otype).size[2] / 2.0 + 0.001
                pose = Pose((pose.position[0], pose.position[1], z), pose.orientation)
            true_world.spawn_object(name, otype, pose)
            if len(entry) == 3:
                true_world.attach(name, entry[2])
        settle(true_world, 100)
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


# --- the demo's scene set-up (issue 24: one module beside the world it builds) ---------

_SINK = an.object(
    type="counter-top", urdf_name=iai.DESCRIPTION.start_surface, part_of=iai.DESCRIPTION.name
)
_DRAWER = an.object(
    type="drawer", urdf_name=iai.DESCRIPTION.container.link, part_of=iai.DESCRIPTION.name
)
_LEFT, _FRONT = ("side", "left"), ("side", "front")

#: Where a random scene samples an object, as location properties (``(for <type>)`` is
#: added: the object's half height above the surface, no contact with the objects spawned
#: before it). CRAM's spawning region is the sink counter's left-front quarter
#: (:data:`DEFAULT_SPAWN_REGION`, for any type not listed here); each demo type's region is
#: that quarter narrowed to where the demo then looks for it (its fetch location in
#: ``plans.demo.fetch_location``; deliberate: CRAM spawned the bowl anywhere in the quarter
#: but searched it only >= 0.5 m from the counter's origin, so it was often never found).
#: The spoon lies in the drawer, within CRAM's ``(range 0.2)`` of its centre and
#: ``(range-invert 0.12)``. The order of the properties is the order they were sampled
#: with since the scene was first seeded: keep it, or the poses of every seed change.
SPAWN_REGIONS: Mapping[str, tuple[tuple[str, Any], ...]] = MappingProxyType(
    {
        "bowl": (_LEFT, _FRONT, ("on", _SINK), ("range-invert", 0.5)),
        "cup": (_LEFT, ("on", _SINK), _FRONT),
        "spoon": (_FRONT, ("in", _DRAWER), ("range", 0.2), ("range-invert", 0.12)),
        "milk": (_LEFT, _FRONT, ("on", _SINK), ("range", 0.5)),
        "breakfast-cereal": (_LEFT, _FRONT, ("on", _SINK), ("range", 0.5)),
    }
)
#: CRAM's spawning region, for a demo type without its own row in :data:`SPAWN_REGIONS`.
DEFAULT_SPAWN_REGION: tuple[tuple[str, Any], ...] = (_LEFT, _FRONT, ("on", _SINK))

#: Clearance (m) an object in the drawer keeps from the cabinet front once the drawer is
#: open by the transport's accessing distance (:attr:`executive.ContainerDescription.opening`):
#: nearer, the palm of a top grasp touches the counter top above the drawer.
SPOON_CLEARANCE = 0.1
#: How many samples of its region a random spawn tries for one the robot can reach.
REACH_TRIES = 30
#: How many random yaws a spawn tries at its sampled position before giving up.
SPAWN_YAW_TRIES = 24
#: Physics steps (1/240 s each) :func:`set_up_scene` lets the spawned objects come to
#: rest by default (what ``aiocram demo`` always did).
SETTLE_STEPS = 240


class SceneSetUpError(ValueError):
    """:func:`set_up_scene` was asked for a scene it cannot build (the message says what
    to fix); nothing was spawned."""


def set_up_scene(
    world: World,
    objects: Sequence[str] | None = None,
    *,
    random: bool = True,
    seed: int | None = None,
    settle_steps: int = SETTLE_STEPS,
) -> dict[str, Pose]:
    """Set up CRAM's table-setting scene in ``world``: the one call that builds the demo's
    scene, before the plan runs (the plan only acts: it never spawns).

    Spawns ``<type>-1`` for each type of ``objects`` (default: all of them; from the
    world's kitchen's :attr:`executive.KitchenDescription.demo_objects`, the one list of
    demo objects), replacing an
    object of that name: with ``random``, at a sample of its spawning region
    (:data:`SPAWN_REGIONS`) that the robot can reach, collision-free with the objects
    spawned before it, turned by a yaw drawn from ``seed``; otherwise at CRAM's fixed pose
    (``demo_poses``). An object listed in the kitchen's
    ``demo_attachments`` is attached to its link (the spoon to the
    drawer). Then the world settles for ``settle_steps`` physics steps (0: the objects
    stay exactly where they were put). Returns each object's pose, by name.

    Random samples are drawn with projection's location rules bound to ``world``, so the
    same world state and ``seed`` give the same poses: outside a running plan (the usual
    case: before ``cpl.run`` starts the robot) in a ``cpl.run`` of its own under
    :func:`projection.with_projected_robot`; inside one, in the current environment, which
    must then be ``with_projected_robot(world)`` (``RuntimeError`` otherwise: e.g. the
    simulated real robot's belief is not the true world the scene is built in).

    Bad input, before anything is spawned: an unknown type or one given twice,
    :class:`SceneSetUpError` naming the demo's types; not a World, ``TypeError``."""
    if not isinstance(world, World):
        raise TypeError(f"set_up_scene needs a projection.World, got {world!r}")
    kitchen = world.kitchen
    if objects is None:
        objects = kitchen.demo_objects
    if isinstance(objects, str):
        raise SceneSetUpError(f"objects is a sequence of types, e.g. ({objects!r},)")
    unknown = [t for t in objects if t not in kitchen.demo_poses]
    if unknown:
        raise SceneSetUpError(
            f"unknown object type{'s' if len(unknown) > 1 else ''} "
            f"{', '.join(map(repr, unknown))}; the demo's types: "
            f"{', '.join(kitchen.demo_objects)} (a new one is added in the kitchen's "
            "description, kitchens.<name>.DESCRIPTION)"
        )
    twice = sorted({t for t in objects if list(objects).count(t) > 1})
    if twice:
        raise SceneSetUpError(f"object types given more than once: {', '.join(twice)}")
    if not isinstance(settle_steps, int) or settle_steps < 0:
        raise SceneSetUpError(f"settle_steps must be a whole number >= 0, got {settle_steps!r}")
    rng = np.random.default_rng(seed)

    def spawn() -> None:
        for otype in objects:
            _spawn_one(world, otype, random, rng)

    if not random:  # fixed poses: no location to resolve
        spawn()
    elif cpl.current_task() is not None:
        from executive import current_environment
        from projection._world_model import ProjectedWorldModel

        model = current_environment().world
        if not (isinstance(model, ProjectedWorldModel) and model.world is world):
            raise RuntimeError(
                "set_up_scene inside a plan samples with the current environment's "
                "location rules, which must be with_projected_robot(world) on the world "
                "it builds; call it before cpl.run instead (it then runs its own)"
            )
        spawn()
    else:
        from projection._environment import with_projected_robot

        async def in_projection() -> None:
            async with with_projected_robot(world):
                spawn()

        cpl.run(in_projection, name="scene-setup")
    if settle_steps:
        settle(world, settle_steps)
    return {f"{t}-1": world.object_pose(f"{t}-1") for t in objects}


def spawn_region(object_type: str) -> LocationDesignator:
    """The location designator a random scene samples ``object_type`` from (see
    :data:`SPAWN_REGIONS`), with ``(for <type>)``."""
    region = SPAWN_REGIONS.get(object_type, DEFAULT_SPAWN_REGION)
    return a.location(*region, for_=an.object(type=object_type))


def _spawn_one(world: World, object_type: str, random: bool, rng: np.random.Generator) -> None:
    name = f"{object_type}-1"
    if name in world.objects:
        world.remove_object(name)
    if random:
        sample = _reachable_sample(
            spawn_region(object_type), _spawn_filter(world, object_type), world.robot.name
        )
        _spawn_at_free_yaw(world, name, object_type, sample, rng)
    else:
        world.spawn_object(name, object_type, world.kitchen.demo_poses[object_type])
    link = world.kitchen.demo_attachments.get(object_type)
    if link is not None:
        world.attach(name, link)


def _spawn_filter(world: World, object_type: str) -> Callable[[Pose], bool]:
    """Deliberate restriction of the drawer's spawning region (CRAM: ``(range 0.2)``
    around the drawer box's centre, i.e. up to 0.29 m deep in this 0.58 m drawer): only
    the part that comes out at least :data:`SPOON_CLEARANCE` beyond the cabinet front when
    the drawer is opened by the kitchen's container opening along -x (the sink-side
    drawer opens towards -x; its closed front is its box's -x face)."""
    container = world.kitchen.container
    if world.kitchen.demo_attachments.get(object_type) != container.link:
        return lambda _pose: True
    front = world.link_aabb(container.link)[0][0]
    opening = container.opening
    return lambda pose: pose.position[0] - opening <= front - SPOON_CLEARANCE


def _reachable_sample(
    location: LocationDesignator, accept: Callable[[Pose], bool], robot: str
) -> Pose:
    """The first sample of ``location`` that ``accept`` takes and a robot location
    ``(reachable-for <robot>)`` resolves for (deliberate: CRAM's spawning region reaches
    0.65 m deep into the counter, beyond the arm's reach from any collision-free base
    pose, so such objects were unfetchable); after :data:`REACH_TRIES` samples, the last
    one."""
    current: Designator = location
    sample: Pose = location.reference()
    for _ in range(REACH_TRIES):
        sample = current.reference()
        if accept(sample):
            reach = a.location(reachable_for=robot, location=a.location(pose=sample))
            try:
                reach.reference()
                return sample
            except DesignatorError:
                pass
        nxt = current.next_solution()
        if nxt is None:
            break
        current = nxt
    return sample


def _spawn_at_free_yaw(
    world: World, name: str, object_type: str, sample: Pose, rng: np.random.Generator
) -> None:
    """Spawn at ``sample``'s position with a random yaw; the sample is collision-free for
    the object's footprint as sampled, but a turned box may reach into a neighbour, which
    the world refuses (``ValueError``): then another yaw, up to :data:`SPAWN_YAW_TRIES`
    (deterministic under the seeded ``rng``); the last refusal propagates."""
    for attempt in range(SPAWN_YAW_TRIES):
        yaw = float(rng.uniform(-math.pi, math.pi))
        try:
            world.spawn_object(name, object_type, Pose(sample.position, yaw_quaternion(yaw)))
            return
        except ValueError:
            if attempt == SPAWN_YAW_TRIES - 1:
                raise
