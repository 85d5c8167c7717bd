"""The truth observer: what the demo really achieved, measured on the *true* world.

A plan reports what it believes (``ObjectOutcome.success``: "I placed it"); the robot's
belief world says where it thinks things are. Neither is a measurement. The
:class:`TruthObserver` watches one demo run from outside the robot and, after the run,
lets the true world settle and measures:

- per object (:class:`ObjectTruth`): where it really is (``island``, ``sink``,
  ``drawer``, ``hand``, ``floor``, ``elsewhere``, ``gone``), how far it is tilted from
  upright, and how far it lies from the pose the plan placed it at (the belief's pose of
  the object when it was last released, recorded from ``ObjectDetached``). It is
  **delivered** when it rests on the island surface, tilted less than
  :data:`UPRIGHT_DEG`, within :data:`NEAR_TARGET` of that placing pose. What the plan
  claimed is kept beside it; a **phantom** is an object the plan claims placed that was
  not delivered;
- the invariants (:data:`INVARIANTS`), each able to fail:

  - ``no_task_leaked``: no task is alive when the demo plan's body returns, except the
    body's own task and its ancestors (anything else would only be evaporated by the top
    level), and no plain asyncio task created during the run is still pending (cpl
    would not even evaporate it);
  - ``nothing_attached_before_cleanup`` / ``arms_at_rest_before_cleanup``: at the end of
    the plan, *before* the demo's final cleanup parks the arms, nothing is held in the
    true world and both arms are at a rest configuration (``carry`` or ``park``); a
    violation means the cleanup had to intervene, and the report says what it did;
  - ``no_object_lost``: every object is on the island, the sink counter, in the drawer,
    and none lies on the floor, elsewhere, or toppled (tilted beyond
    :data:`UPRIGHT_DEG`);
  - ``drawer_closed``; and after the cleanup ``held_safely`` and ``arms_parked``: the
    cleanup keeps holding what the robot still holds (an interrupted transport: Ctrl-C
    while carrying must not drop the object, see ``plans.demo._finalize``), so an object
    still attached is no violation as long as it is held *safely*, by an arm at ``carry``;
    every free arm is at ``park``. An object dropped on the way is ``no_object_lost``'s.

The observer never changes the physics during the run: it only reads the true world
(and subscribes to events, which it does not alter). The settle happens after the run.
"""

from __future__ import annotations

import asyncio
import math
from collections.abc import Callable, Iterable, Mapping
from dataclasses import asdict, dataclass, field
from typing import Any

import cpl
from cpl.lowlevel import stray_asyncio_tasks

__all__ = [
    "INVARIANTS",
    "NEAR_TARGET",
    "UPRIGHT_DEG",
    "ObjectTruth",
    "TruthObserver",
    "TruthReport",
    "leaked_tasks",
    "tilt_deg",
    "where_is",
]

#: Tilt (degrees from the object's upright) beyond which an object counts as toppled.
UPRIGHT_DEG = 15.0
#: Horizontal distance (m) between the true pose and the placing pose for "delivered".
NEAR_TARGET = 0.12
#: Settle steps (1/240 s) the true world gets after the run before it is measured.
SETTLE_STEPS = 240
#: Joint-space tolerance (rad) for "the arms are at a configuration".
ARM_TOLERANCE = 0.05
#: Configurations the arms may rest in at the end of the plan (``carry`` is where the
#: plans keep them between actions, ``park`` at the sides).
REST_CONFIGURATIONS = ("carry", "park")


INVARIANTS = (
    "no_task_leaked",
    "nothing_attached_before_cleanup",
    "arms_at_rest_before_cleanup",
    "no_object_lost",
    "drawer_closed",
    "held_safely",
    "arms_parked",
)


@dataclass
class ObjectTruth:
    """One object as the true world has it after the run. ``claimed``: the plan reported
    it placed; ``target``: xyz where the plan placed it (None: never released)."""

    name: str
    claimed: bool
    where: str
    tilt_deg: float
    position: tuple[float, float, float] | None
    target: tuple[float, float, float] | None
    target_distance: float | None
    delivered: bool

    @property
    def phantom(self) -> bool:
        """Claimed placed but not delivered."""
        return self.claimed and not self.delivered

    @property
    def toppled(self) -> bool:
        return self.where not in ("gone", "hand") and self.tilt_deg > UPRIGHT_DEG

    def to_json(self) -> dict[str, Any]:
        d = asdict(self)
        d["phantom"] = self.phantom
        d["toppled"] = self.toppled
        d["tilt_deg"] = round(self.tilt_deg, 1)
        for key in ("position", "target"):
            if d[key] is not None:
                d[key] = [round(v, 3) for v in d[key]]
        if d["target_distance"] is not None:
            d["target_distance"] = round(d["target_distance"], 3)
        return d


@dataclass
class TruthReport:
    """The run's truth: per object, the invariants and why each failed, and what the
    final cleanup had to do (empty: nothing)."""

    objects: dict[str, ObjectTruth]
    invariants: dict[str, bool]
    violations: dict[str, str]
    cleanup_intervened: list[str] = field(default_factory=list)

    @property
    def delivered(self) -> int:
        return sum(1 for o in self.objects.values() if o.delivered)

    @property
    def claimed(self) -> int:
        return sum(1 for o in self.objects.values() if o.claimed)

    @property
    def phantoms(self) -> int:
        return sum(1 for o in self.objects.values() if o.phantom)


def tilt_deg(pose: Any) -> float:
    """Angle (degrees) between the pose's z axis and the world's z axis."""
    zz = pose.as_rotation().as_matrix()[2, 2]
    return math.degrees(math.acos(max(-1.0, min(1.0, float(zz)))))


def _on_surface(world: Any, position: Any, link: str) -> bool:
    (x0, y0, _z0), (x1, y1, z1) = world.link_aabb(link)
    x, y, z = position
    return bool(x0 <= x <= x1 and y0 <= y <= y1 and z1 - 0.01 <= z <= z1 + 0.35)


def _in_drawer(world: Any, position: Any) -> bool:
    (x0, y0, z0), (x1, y1, z1) = world.link_aabb(world.kitchen.container.link)
    x, y, z = position
    return bool(x0 <= x <= x1 and y0 <= y <= y1 and z0 <= z <= z1 + 0.05)


def _robot_holds(world: Any) -> dict[str, str]:
    """Objects attached to a robot link (not to the kitchen, as the spoon to its drawer)."""
    return {n: link for n, link in world.attachments.items() if link in world.robot_links}


def where_is(world: Any, name: str) -> str:
    """Where object ``name`` is in ``world``: island, sink, drawer, hand, floor,
    elsewhere or gone."""
    if name not in world.objects:
        return "gone"
    if name in _robot_holds(world):
        return "hand"
    position = world.object_pose(name).position
    if _on_surface(world, position, world.kitchen.table_surface):
        return "island"
    if _in_drawer(world, position):
        return "drawer"
    if _on_surface(world, position, world.kitchen.start_surface):
        return "sink"
    if position[2] < world.kitchen.floor_height:
        return "floor"
    return "elsewhere"


def leaked_tasks(tasks: Iterable[cpl.Task], current: cpl.Task | None) -> list[cpl.Task]:
    """The tasks of ``tasks`` still alive, other than ``current`` and its ancestors."""
    keep: set[int] = set()
    t = current
    while t is not None:
        keep.add(id(t))
        t = t.parent
    return [t for t in tasks if t.alive and id(t) not in keep]


def _arm_links(robot: Any) -> dict[str, frozenset[str]]:
    """Per arm of ``robot`` (an :class:`executive.RobotDescription`), by arm name: the
    links that move with the arm, read from the robot's URDF: every link below the
    arm's first joint (its links, its hand, its gripper's fingers)."""
    from executive import KinematicTree

    tree = KinematicTree.from_urdf(robot.urdf())
    out = {}
    for arm in robot.arms:
        first = tree.joints[arm.joints[0]].child  # validate() checked the chain
        out[arm.name] = frozenset(link for link in tree.links if tree.is_below(link, first))
    return out


def _holding_arm(link: str, arms: Mapping[str, frozenset[str]]) -> str | None:
    """The arm whose links (:func:`_arm_links`) include ``link``, or None."""
    return next((arm for arm, links in arms.items() if link in links), None)


def _describe(atask: asyncio.Task[Any]) -> str:
    coro = atask.get_coro()
    what = getattr(coro, "__qualname__", type(coro).__name__)
    return f"asyncio task {atask.get_name()!r} ({what})"


def _arm_error(world: Any, configuration: str) -> dict[str, float]:
    """Per arm of the world's robot: the largest joint distance (rad) from its named
    configuration ``configuration`` (the description's ``arm.state``); a continuous joint
    (limits ``-inf, inf`` in ``world.arm_joint_limits``) by the shorter way round, whole
    turns apart being the same pose."""
    out = {}
    for arm in world.robot.arms:
        target = arm.state(configuration)
        limits = world.arm_joint_limits(arm.name)
        out[arm.name] = max(
            abs(math.remainder(a - b, 2.0 * math.pi))
            if math.isinf(lo) or math.isinf(hi)
            else abs(a - b)
            for a, b, (_joint, lo, hi) in zip(world.arm_joints(arm.name), target, limits)
        )
    return out


class TruthObserver:
    """Watches one demo run on ``true_world`` (see the module docstring). Call, in order:
    :meth:`subscribe` once the robot's environment is active; :meth:`body_returned` right
    after the demo plan's body returns (from inside it); :meth:`before_cleanup` just
    before the final cleanup; :meth:`measure` after the run. ``tasks`` returns every task
    of the run so far (e.g. an instrument's list)."""

    def __init__(
        self,
        true_world: Any,
        belief_world: Any,
        tasks: Callable[[], Iterable[cpl.Task]],
    ) -> None:
        self.true_world = true_world
        self.belief_world = belief_world
        self._tasks = tasks
        #: object name -> xyz of its last release, in the belief (where the plan put it)
        self.released_at: dict[str, tuple[float, float, float]] = {}
        self._leaked: list[str] | None = None  # None: body_returned not called
        self._held_before: dict[str, str] | None = None
        self._arms_before: dict[str, dict[str, float]] | None = None

    # -- during the run ----------------------------------------------------------
    def subscribe(self, env: Any) -> Callable[[], None]:
        """Record where the belief has each object when it is released, and annotate each
        real run of projection reasoning with the true robot's base pose at its pick and
        place (:func:`aiocram.fidelity.watch_bases`, for the projection fidelity)."""
        from executive.events import ObjectDetached, object_name

        def released(event: ObjectDetached) -> None:
            try:
                name = object_name(event.object)
                pose = self.belief_world.object_pose(name)
            except (LookupError, ValueError, TypeError, AttributeError):
                return  # an object the belief does not know: no placing pose
            self.released_at[name] = tuple(float(v) for v in pose.position)  # type: ignore[assignment]

        from .fidelity import watch_bases

        undo = [
            env.subscribe(ObjectDetached, released),
            # projection fidelity: where the *true* robot stood at each pick and place
            watch_bases(env, self.true_world.robot_pose),
        ]

        def unsubscribe() -> None:
            for u in undo:
                u()

        return unsubscribe

    def body_returned(self) -> None:
        """The demo plan's body has returned: record the tasks it leaked, cpl tasks and
        plain asyncio tasks created during the run and still pending (call it from inside
        the run)."""
        current = cpl.current_task()
        leaked = ["/".join(t.path) for t in leaked_tasks(self._tasks(), current)]
        root = current
        while root is not None and root.parent is not None:
            root = root.parent
        if root is not None:
            leaked += [_describe(t) for t in stray_asyncio_tasks(root)]
        self._leaked = leaked

    def before_cleanup(self) -> None:
        """The plan is over, the final cleanup has not run: record what is held and where
        the arms are in the true world."""
        self._held_before = _robot_holds(self.true_world)
        self._arms_before = {c: _arm_error(self.true_world, c) for c in REST_CONFIGURATIONS}

    # -- after the run -------------------------------------------------------------
    def measure(
        self,
        claimed: Mapping[str, bool],
        settle_steps: int = SETTLE_STEPS,
        *,
        interrupted: bool = False,
    ) -> TruthReport:
        """Settle the true world, then measure every object of ``claimed`` (name -> the
        plan reported it placed) and the invariants.

        A check whose moment never came (the body never returned, the final cleanup was
        never announced) fails, unless the run was ``interrupted`` (Ctrl-C evaporated the
        plan on purpose): then it is left out, and only what can be checked after the
        cleanup is."""
        from projection import settle

        world = self.true_world
        if settle_steps > 0:
            settle(world, settle_steps)
        ok: dict[str, bool] = {}
        why: dict[str, str] = {}

        def check(name: str, good: bool, detail: str) -> None:
            ok[name] = good
            if not good:
                why[name] = detail

        objects = {name: self._object(name, c) for name, c in claimed.items()}
        if self._leaked is None:
            if not interrupted:
                check("no_task_leaked", False, "not observed: body_returned() was never called")
        else:
            check("no_task_leaked", not self._leaked, "alive: " + ", ".join(self._leaked[:5]))
        cleanup: list[str] = []
        if self._held_before is None or self._arms_before is None:
            if not interrupted:
                for inv in ("nothing_attached_before_cleanup", "arms_at_rest_before_cleanup"):
                    check(inv, False, "not observed: before_cleanup() was never called")
        else:
            held = self._held_before
            check("nothing_attached_before_cleanup", not held, f"held: {sorted(held)}")
            kept = sorted(n for n in held if n in _robot_holds(world))
            released = sorted(n for n in held if n not in kept)
            if released:
                cleanup.append(f"released {', '.join(released)}")
            if kept:
                cleanup.append(f"kept holding {', '.join(kept)}")
            at_rest = any(max(err.values()) <= ARM_TOLERANCE for err in self._arms_before.values())
            detail = "; ".join(
                f"{arm} arm {min(errs[arm] for errs in self._arms_before.values()):.2f} rad"
                " from carry/park"
                for arm in self._arms_before[REST_CONFIGURATIONS[0]]
            )
            check("arms_at_rest_before_cleanup", at_rest, detail)
            if not at_rest:
                cleanup.append("parked the arms")
        lost = [
            f"{o.name} {o.where}" + (f" toppled {o.tilt_deg:.0f} deg" if o.toppled else "")
            for o in objects.values()
            if o.where in ("floor", "elsewhere", "gone") or o.toppled
        ]
        check("no_object_lost", not lost, "; ".join(lost))
        drawer = world.joint_position(world.kitchen.container.joint)
        check("drawer_closed", abs(drawer) < 0.01, f"drawer open {drawer:.3f} m")
        arms = _arm_links(world.robot)
        holding = {name: _holding_arm(link, arms) for name, link in _robot_holds(world).items()}
        carry = _arm_error(world, "carry")
        unsafe = [
            f"{name} held by {arm or 'no'} arm"
            + ("" if arm is None else f" {carry[arm]:.2f} rad from carry")
            for name, arm in sorted(holding.items())
            if arm is None or carry[arm] > ARM_TOLERANCE
        ]
        check("held_safely", not unsafe, "; ".join(unsafe))
        err = _arm_error(world, "park")
        off = [
            f"{arm} arm {e:.2f} rad from park"
            for arm, e in err.items()
            if e > ARM_TOLERANCE and arm not in holding.values()
        ]
        check("arms_parked", not off, "; ".join(off))
        return TruthReport(objects, ok, why, cleanup)

    def _object(self, name: str, claimed: bool) -> ObjectTruth:
        world = self.true_world
        where = where_is(world, name)
        target = self.released_at.get(name)
        if where == "gone":
            return ObjectTruth(name, claimed, where, 0.0, None, target, None, False)
        pose = world.object_pose(name)
        x, y, z = (float(v) for v in pose.position)
        position = (x, y, z)
        tilt = tilt_deg(pose)
        distance = None
        if target is not None:
            distance = math.hypot(position[0] - target[0], position[1] - target[1])
        delivered = (
            where == "island"
            and tilt <= UPRIGHT_DEG
            and distance is not None
            and distance <= NEAR_TARGET
            and _on_surface(world, target, world.kitchen.table_surface)
        )
        return ObjectTruth(
            name,
            claimed,
            where,
            tilt,
            position,
            target,
            distance,
            bool(delivered),
        )
