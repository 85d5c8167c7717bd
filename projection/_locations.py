"""Location designators resolved by costmaps in a projection :class:`World` (CRAM's
``location-costmap-generator`` and its validators).

``location_rules(world)`` returns a child of :data:`executive.static_rules` holding:

- a costmap generator (priority 20, after the pose/of generator at 10) for designators with
  any of ``reachable-for``, ``visible-for``, ``on``, ``in``, ``near``, ``far-from``,
  ``left-of``, ``right-of``, ``in-front-of``, ``behind``, ``context`` (modified by
  ``side``, ``range``, ``range-invert``, ``for``, ``object-count``, ``arm``);
- CRAM's validators: robot-location-on-floor (1), reachable-location and
  visible-location (5), potential-field threshold with ``for`` (5), collision of the
  ``for`` object with other items (6), costmap value / max > 0.10 with a generated height
  (20); and, unlike CRAM, a robot-collision check for robot locations (7, see
  :class:`LocationCostmaps`).

The executive pipeline ends a chain after 30 rejections in a row. A costmap is built once
per designator chain (cached, weakly, on the designator whose stream the pipeline runs,
i.e. the chain's first designator) so ``next_solution()`` is one draw plus the validators.

Values: ``on``/``in`` take CRAM's object designator (``an.object(type="counter-top",
urdf_name="sink_area_surface", part_of="kitchen")``), a link name, or an item (by name);
``for`` an object designator with a type (and optional name) or a type name: an existing
item of that type, else just the type's size; ``reachable-for``/``visible-for`` a robot
name, with ``location`` (a location designator), ``object`` (an object designator or item
name) or ``pose`` as the target; ``near``/``far-from``/``left-of``/... an object designator
(an item) or a location designator. Anything unresolvable raises
:class:`executive.DesignatorError` on ``reference()`` naming the designator and the reason
(unknown names with close matches; an empty costmap with the factor that emptied it); the
world is left unchanged.
"""

from __future__ import annotations

import difflib
import math
import weakref
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import Any, Final

import numpy as np

from executive import (
    DesignatorError,
    DesignatorInputError,
    Key,
    RuleDoc,
    RuleSet,
    current_environment,
    static_rules,
)
from executive._designator import Designator
from executive._pose import Pose
from executive.failures import NavigationPoseUnreachable
from projection import _costmaps as cm
from projection._objects import OBJECT_TYPES
from projection._world import KITCHEN, World

__all__ = [
    "COSTMAP_KEYS",
    "PRECISE_TYPES",
    "LocationCostmaps",
    "costmaps_of",
    "location_rules",
]

#: Keys that make a location designator a costmap designator.
COSTMAP_KEYS: Final = frozenset(
    {"reachable-for", "visible-for", "on", "in", "near", "far-from", "context", *cm.RELATIONS}
)
_MODIFIERS: Final = frozenset(
    {"side", "range", "range-invert", "for", "object-count", "arm", "experience"}
)
#: The floor of the learned base density factor: it reweights, never empties, a costmap.
LEARNED_FLOOR: Final = 0.2
#: ``for`` types whose potential-field threshold is 0.8 (others 0.2).
PRECISE_TYPES: Final = frozenset({"plate", "fork", "spoon", "knife", "cup"})
_ROBOT_KEYS: Final = ("reachable-for", "visible-for")
_REF_SIZE: Final = 0.1  # size and padding of a location-designator reference / no ``for``
_FLOOR_Z: Final = 0.05
_YAW_TOLERANCE: Final = 0.1
_MIN_VALUE: Final = 0.10
#: Clearance (m) between a ``for`` object placed by a spatial relation and its support's
#: edge (see :func:`projection._costmaps.add_relation`).
_SUPPORT_CLEARANCE: Final = 0.03


_SURFACE = "object designator with urdf-name (a kitchen link), a link name, or an item name"
_ITEM_OR_LOCATION = "object designator (an item) or location designator"

#: The costmap generator's documentation: its keys are the keys it declares (the
#: generated designator reference is built from it).
COSTMAP_DOC: Final = RuleDoc(
    "Costmap locations (CRAM's location-costmap-generator): an endless stream of samples "
    "drawn from the product of the keys' costmaps, filtered by the validators; the "
    "stream ends after 30 rejections in a row.",
    keys=(
        Key(
            "reachable-for",
            "robot name ('pr2')",
            "base poses from which the robot reaches the target: 0.2-0.7 m away, facing "
            "it (into an open drawer: from the reaching arm's shoulder)",
            default="-",
        ),
        Key(
            "visible-for",
            "robot name ('pr2')",
            "base poses from which the camera sees the target (ray casts), within 2 m, facing it",
            default="-",
        ),
        Key("location", "location designator", "the target of reachable-for / visible-for"),
        Key("object", "object designator or item name", "the target (its pose now)"),
        Key("pose", "executive.Pose", "the target of reachable-for / visible-for"),
        Key(
            "arm",
            "'left' | 'right'",
            "with reachable-for: the arm that reaches (drawers)",
            default="either",
        ),
        Key(
            "experience",
            "(action, object type)",
            "with reachable-for: weight the base poses by where the environment's "
            "preferences (learned priors) say that action on that type succeeded",
            default="not weighted",
        ),
        Key("on", _SURFACE, "on top of the surface (repeatable)", default="-"),
        Key("in", _SURFACE, "inside the container (a drawer)", default="-"),
        Key(
            "side",
            "'left' | 'right' | 'front' | 'back'",
            "with on/in: that half of the surface, in map axes around its origin "
            "(repeatable; front is -x)",
            default="whole surface",
        ),
        Key(
            "range",
            "number (m)",
            "with on/in: within this distance of the surface's origin",
            default="-",
        ),
        Key(
            "range-invert",
            "number (m)",
            "with on/in: farther than this from the surface's origin",
            default="-",
        ),
        Key(
            "for",
            "object designator with a type, or a type name",
            "the object to be put there: its size keeps it on the surface, and it must "
            "not collide with other items",
            default="a 0.1 m point",
        ),
        Key(
            "context",
            "'table-setting'",
            "table-setting slots along the surface's edge (needs on, for, object-count)",
            default="-",
        ),
        Key("object-count", "int >= 1", "with context: how many slots", default="-"),
        Key(
            "near",
            _ITEM_OR_LOCATION,
            "next to it, not touching (a ring and a Gaussian)",
            default="-",
        ),
        Key("far-from", _ITEM_OR_LOCATION, "a ring farther away from it", default="-"),
        Key(
            "left-of",
            _ITEM_OR_LOCATION,
            "to its left, seen from the nearest edge of the surface",
            default="-",
        ),
        Key(
            "right-of",
            _ITEM_OR_LOCATION,
            "to its right, seen from the nearest edge of the surface",
            default="-",
        ),
        Key(
            "in-front-of",
            _ITEM_OR_LOCATION,
            "in front of it, seen from the nearest edge of the surface",
            default="-",
        ),
        Key(
            "behind",
            _ITEM_OR_LOCATION,
            "behind it, seen from the nearest edge of the surface",
            default="-",
        ),
    ),
    raises=(DesignatorError,),
    note="DesignatorError on reference(), naming the designator and the reason: an unknown "
    "surface or item (with close matches), a bad value, or an empty costmap (with the "
    "factor that emptied it). A location with none of the costmap keys is left to the "
    "other generators. "
    "Costmap samples carry no orientation except reachable-for/visible-for (facing the "
    "target); delivering to a costmap target keeps the held yaw (free-yaw).",
)


@dataclass
class _Plan:
    """A designator's costmap and what its validators need."""

    costmap: cm.Costmap
    rng: np.random.Generator
    robot_key: str | None = None
    target: tuple[float, float] | None = None
    for_type: str | None = None
    for_item: str | None = None
    #: reachable-for into an open drawer: the fixed base yaw and the arms whose shoulder
    #: the reach distance is measured from (None: the usual facing / base-origin check).
    drawer_yaw: float | None = None
    drawer_arms: tuple[str, ...] = ()
    #: reachable-for: (minimal, in-reach) distance of the robot's arm(s), from their
    #: descriptions' :class:`executive.Reach`
    reach: tuple[float, float] = (cm.REACH_MINIMAL_DISTANCE, cm.IN_REACH_DISTANCE)


@dataclass(frozen=True)
class _Region:
    label: str
    lo: tuple[float, float, float]
    hi: tuple[float, float, float]
    origin: tuple[float, float, float]
    yaw: float


def _fmt(v: Any) -> str:
    if isinstance(v, Designator):
        for key in ("urdf-name", "name", "type"):
            if isinstance(v.get(key), str):
                return str(v.get(key))
        return v.short()
    if isinstance(v, Pose):
        return "pose({:.3g}, {:.3g}, {:.3g})".format(*v.position)
    if isinstance(v, float):
        return f"{v:g}"
    return str(v)


def _describe(d: Designator) -> str:
    return f"{d.kind} " + " ".join(f"({k} {_fmt(v)})" for k, v in d.properties)


def _yaw_of(q: Sequence[float]) -> float:
    x, y, z, w = q
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def _angle_diff(a: float, b: float) -> float:
    return abs((a - b + math.pi) % (2.0 * math.pi) - math.pi)


class LocationCostmaps:
    """The costmap generator and validators bound to one :class:`World`.

    ``rules`` is the child rule set to pass to ``executive.environment(rules=...)``;
    ``builds`` counts costmaps built (one per designator chain). ``spec`` sets the grid;
    ``robot_collision_check`` (default True) adds a validator (priority 7) rejecting
    ``reachable-for``/``visible-for`` poses where the robot, as it is now (arms, carried
    objects), would collide: CRAM leaves that to ``check-navigating-collisions``, but in
    this kitchen the 0.3 m free-space padding is less than the PR2 base's half width, so
    unchecked samples would put the base into the counter. ``demo_areas`` replaces the
    restricted-area rectangles (``None``: no restricted area).
    """

    def __init__(
        self,
        world: World,
        *,
        spec: cm.CostmapSpec | None = None,
        parent: RuleSet | None = None,
        robot_collision_check: bool = True,
        demo_areas: Sequence[tuple[float, float, float, float]] | None = cm.DEMO_AREAS,
    ) -> None:
        if not isinstance(world, World):
            raise TypeError(f"LocationCostmaps needs a projection World, got {world!r}")
        self.world = world
        self.spec = spec or cm.CostmapSpec()
        self.demo_areas = None if demo_areas is None else tuple(demo_areas)
        self.builds = 0
        self._plans: weakref.WeakKeyDictionary[Designator, _Plan] = weakref.WeakKeyDictionary()
        rules = (parent if parent is not None else static_rules).child("projection-locations")
        rules.register_location_generator(self.generate, 20, doc=COSTMAP_DOC)
        rules.register_location_validator(self.validate_on_floor, 1)
        rules.register_location_validator(self.validate_reachable, 5)
        rules.register_location_validator(self.validate_visible, 5)
        rules.register_location_validator(self.validate_potential_field, 5)
        rules.register_location_validator(self.validate_for_collision, 6)
        if robot_collision_check:
            rules.register_location_validator(self.validate_robot_collision, 7)
        rules.register_location_validator(self.validate_costmap, 20)
        self.rules = rules

    # ------------------------------------------------------------------ public
    @staticmethod
    def applies(d: Designator) -> bool:
        """Whether ``d`` is a costmap designator."""
        return d.kind == "location" and any(k in COSTMAP_KEYS for k, _ in d.properties)

    def costmap(self, d: Designator) -> cm.Costmap:
        """``d``'s costmap (built and cached on first use). DesignatorError if ``d`` cannot
        have one."""
        return self._plan(d).costmap

    def generate(self, d: Designator) -> Iterator[Pose] | None:
        """The costmap generator: an infinite stream of samples, or None for designators
        without costmap keys. DesignatorError for an empty costmap."""
        if not self.applies(d):
            self._check_modifiers(d)
            return None
        plan = self._plan(d)
        if plan.costmap.empty:
            raise DesignatorError(
                f"{_describe(d)}: the costmap is empty: {plan.costmap.empty_reason}", d
            )
        return plan.costmap.poses(plan.rng)

    # ------------------------------------------------------------------ validators
    def _map_pose(self, pose: Pose) -> Pose:
        if pose.frame == "map":
            return pose
        if pose.frame == "base_footprint":
            return self.world.robot_pose().to_transform() * pose  # type: ignore[no-any-return]
        raise DesignatorError(f"a location pose in frame {pose.frame!r}; use map or base_footprint")

    def validate_on_floor(self, d: Designator, pose: Pose) -> str:
        """robot-location-on-floor: z < 0.05 for reachable-for / visible-for."""
        if not any(k in d for k in _ROBOT_KEYS):
            return "unknown"
        return "accept" if self._map_pose(pose).position[2] < _FLOOR_Z else "reject"

    def _distance_and_yaw(self, d: Designator, pose: Pose, key: str, lo: float, hi: float) -> str:
        if key not in d:
            return "unknown"
        plan = self._plan(d)
        assert plan.target is not None
        p = self._map_pose(pose)
        dx, dy = plan.target[0] - p.position[0], plan.target[1] - p.position[1]
        dist = math.hypot(dx, dy)
        if not lo < dist < hi:
            return "reject"
        yaw_ok = _angle_diff(_yaw_of(p.orientation), math.atan2(dy, dx)) <= _YAW_TOLERANCE
        return "accept" if yaw_ok else "reject"

    def validate_reachable(self, d: Designator, pose: Pose) -> str:
        """reachable-location: the arm's minimal < d < in-reach distance
        (the arm description's Reach) to the reach point, yaw within 0.1 rad. For a
        reach point in an open drawer (see :func:`projection._costmaps.add_reachable_in_drawer`):
        d measured from the reaching arm's shoulder, yaw within 0.1 rad of the drawer
        axis."""
        plan = self._plan(d) if "reachable-for" in d else None
        lo, hi = plan.reach if plan is not None else (0.0, 0.0)
        if plan is not None and plan.drawer_yaw is not None:
            assert plan.target is not None
            p = self._map_pose(pose)
            yaw = _yaw_of(p.orientation)
            if _angle_diff(yaw, plan.drawer_yaw) > _YAW_TOLERANCE:
                return "reject"
            shoulders = self._shoulders()
            for arm in plan.drawer_arms:
                sx, sy = cm.drawer_shoulder(p.position[0], p.position[1], yaw, arm, shoulders)
                dist = math.hypot(plan.target[0] - sx, plan.target[1] - sy)
                if lo < dist < hi:
                    return "accept"
            return "reject"
        return self._distance_and_yaw(d, pose, "reachable-for", lo, hi)

    def _shoulders(self) -> dict[str, tuple[float, float]]:
        """The robot's arms' shoulders in ``base_footprint`` (left before right)."""
        return {a: self.world.shoulder_xy(a) for a in self.world.arms}

    def validate_visible(self, d: Designator, pose: Pose) -> str:
        """visible-location: d < 2 m to the target, yaw within 0.1 rad."""
        return self._distance_and_yaw(d, pose, "visible-for", -1.0, cm.VISIBILITY_SIZE)

    def validate_potential_field(self, d: Designator, pose: Pose) -> str:
        """With ``for``: costmap value / max above 0.8 (plate, fork, spoon, knife, cup)
        or 0.2."""
        if "for" not in d or not self.applies(d):
            return "unknown"
        plan = self._plan(d)
        threshold = 0.8 if plan.for_type in PRECISE_TYPES else 0.2
        p = self._map_pose(pose).position
        return "accept" if plan.costmap.value(p[0], p[1]) > threshold else "reject"

    def validate_for_collision(self, d: Designator, pose: Pose) -> str:
        """With ``for``: the object (the item, or a temporary one of the type) placed at
        ``pose`` must not touch another item. Runs between snapshot and restore."""
        if "for" not in d or not self.applies(d):
            return "unknown"
        plan = self._plan(d)
        if plan.for_type is None:
            return "unknown"
        world = self.world
        p = self._map_pose(pose)
        snap = world.snapshot()
        try:
            name = plan.for_item
            if name is None:
                name = "__costmap_probe__"
                while name in world.objects:
                    name += "_"
                world.spawn_object(name, plan.for_type, p, allow_overlap=True)
            else:
                world.set_object_pose(name, p, allow_overlap=True)
            hits = [
                c for c in world.contacts(name) if c.body_b not in (world.robot.name, KITCHEN, name)
            ]
        finally:
            world.restore(snap)
        return "reject" if hits else "unknown"

    def validate_robot_collision(self, d: Designator, pose: Pose) -> str:
        """For reachable-for / visible-for: the robot driven to ``pose`` must not collide
        (``World.drive`` between snapshot and restore)."""
        if not any(k in d for k in _ROBOT_KEYS):
            return "unknown"
        world = self.world
        snap = world.snapshot()
        try:
            world.drive(self._map_pose(pose))
        except NavigationPoseUnreachable:
            return "reject"
        finally:
            world.restore(snap)
        return "unknown"

    def validate_costmap(self, d: Designator, pose: Pose) -> str:
        """Costmap value / max > 0.10 and z one of the generated heights (within 1e-3)."""
        if not self.applies(d):
            return "unknown"
        costmap = self._plan(d).costmap
        x, y, z = self._map_pose(pose).position
        if costmap.value(x, y) <= _MIN_VALUE:
            return "reject"
        if not any(abs(z - h) <= 1e-3 for h in costmap.heights_at(x, y)):
            return "reject"
        return "unknown"

    # ------------------------------------------------------------------ building
    def _plan(self, d: Designator) -> _Plan:
        plan = self._plans.get(d)
        if plan is None:
            plan = self._build(d)
            self._plans[d] = plan
            self.builds += 1
        return plan

    def _error(self, d: Designator, message: str) -> DesignatorError:
        # callers report a malformed designator (a bad key, name or value), which no other
        # solution cures: not translated or retried by plans
        return DesignatorInputError(f"{_describe(d)}: {message}", d)

    def _check_modifiers(self, d: Designator) -> None:
        mods = sorted({k for k, _ in d.properties if k in _MODIFIERS} - {"arm"})
        if mods and "pose" not in d and "of" not in d and "of-item-object" not in d:
            raise self._error(
                d,
                f"({mods[0]} ...) only modifies a costmap key; add one of "
                f"{', '.join(sorted(COSTMAP_KEYS))}",
            )

    def _build(self, d: Designator) -> _Plan:
        world = self.world
        costmap = cm.Costmap(self.spec)
        rng = np.random.default_rng(int(world.rng.integers(2**63)))
        plan = _Plan(costmap, rng)
        for_type, for_item, for_size = self._for(d)
        plan.for_type, plan.for_item = for_type, for_item
        for_h = for_size[2] if for_size is not None else None

        robot_key = next((k for k in _ROBOT_KEYS if k in d), None)
        if robot_key is not None:
            robot = d[robot_key]
            if not isinstance(robot, str) or not robot:
                raise self._error(
                    d,
                    f"({robot_key} ...) takes a robot name such as {world.robot.name!r}, "
                    f"got {robot!r}",
                )
            arm = d.get("arm")
            if arm is not None and arm not in world.arms:
                raise self._error(d, f"unknown arm {arm!r}; known arms: {', '.join(world.arms)}")
            plan.reach = world.reach(arm)
            minimal, in_reach = plan.reach
            target, exclude = self._target(d, robot_key)
            plan.robot_key = robot_key
            plan.target = (target[0], target[1])
            drawer = self._open_drawer_at(target) if robot_key == "reachable-for" else None
            if drawer is not None:
                lo, hi, outward = drawer
                plan.drawer_yaw = cm.add_reachable_in_drawer(
                    costmap,
                    target,
                    lo,
                    hi,
                    outward,
                    arm,
                    shoulders=self._shoulders(),
                    in_reach=in_reach,
                    minimal=minimal,
                )
                plan.drawer_arms = (arm,) if arm is not None else world.arms
            elif robot_key == "reachable-for":
                cm.add_reachable_for(costmap, [target], in_reach, minimal)
                if "experience" in d:
                    self._learned(d, costmap, target, in_reach)
            else:
                bodies = {world.robot_body}
                bodies |= {
                    world.body_of(n)
                    for n in world.attachments
                    if world.attachments[n] not in cm.KITCHEN_LINKS
                }
                if exclude is not None:
                    bodies.add(world.body_of(exclude))
                cm.add_visible_for(
                    costmap, world.client, target, frozenset(bodies), world.camera_heights()
                )
            boxes = [world.link_aabb(link) for link in cm.KITCHEN_LINKS]
            cm.add_free_space(costmap, [((lo[0], lo[1]), (hi[0], hi[1])) for lo, hi in boxes])
            if self.demo_areas is not None:
                cm.add_demo_area(costmap, self.demo_areas)

        region = self._regions(d, costmap, for_h)
        self._sides(d, costmap, region)
        self._context(d, costmap, region, for_type)
        self._relations(d, costmap, for_type, for_size)
        return plan

    def _learned(
        self,
        d: Designator,
        costmap: cm.Costmap,
        target: Sequence[float],
        in_reach: float,
    ) -> None:
        """``(experience (action type))``: the environment's learned base density, in the
        target's frame (its yaw: the target pose's), facing the target as
        ``reachable-for`` does, floored at :data:`LEARNED_FLOOR` (it reweights, it never
        empties). Nothing without preferences or without anything learned for the type.

        Deliberate difference from CRAM: its reachability costmap is the same Gaussian for
        every robot, object and run; here experience may sharpen it (default off)."""
        value = d["experience"]
        if not (
            isinstance(value, tuple | list)
            and len(value) == 2
            and all(isinstance(v, str) and v for v in value)
        ):
            raise self._error(
                d,
                f"(experience ...) takes (action, object type), e.g. ('picking-up', 'cup'), "
                f"got {value!r}",
            )
        preferences = current_environment().preferences
        density = None if preferences is None else preferences.base_density(*value)
        if density is None:
            return
        loc, pose = d.get("location"), d.get("pose")
        ref = loc.current().reference() if isinstance(loc, Designator) else pose
        oyaw = _yaw_of(self._map_pose(ref).orientation) if isinstance(ref, Pose) else 0.0
        tx, ty = float(target[0]), float(target[1])
        c, s = math.cos(oyaw), math.sin(oyaw)

        def f(x: Any, y: Any) -> Any:
            dx, dy = x - tx, y - ty
            facing = np.arctan2(-dy, -dx)
            weight = np.asarray(density(c * dx + s * dy, -s * dx + c * dy, facing - oyaw))
            peak = float(weight.max()) if weight.size else 0.0
            if peak > 0.0:  # relative to the best cell here: the best gets weight 1
                weight = weight / peak
            return LEARNED_FLOOR + (1.0 - LEARNED_FLOOR) * np.clip(weight, 0.0, 1.0)

        costmap.add(
            "learned-base-density",
            f,
            4,
            bounds=(
                tx - in_reach,
                tx + in_reach,
                ty - in_reach,
                ty + in_reach,
            ),
        )

    # ------------------------------------------------------------------ values
    def _names(self) -> list[str]:
        return [*self.world.link_names, *self.world.objects]

    def _unknown(self, d: Designator, key: str, name: Any) -> DesignatorError:
        close = difflib.get_close_matches(str(name), self._names(), n=5, cutoff=0.5)
        hint = f"; did you mean {', '.join(close)}?" if close else ""
        return self._error(d, f"({key} ...): no link or object {name!r} in the world{hint}")

    def _named(self, d: Designator, key: str, name: Any) -> _Region:
        world = self.world
        if not isinstance(name, str):
            raise self._error(
                d, f"({key} ...) takes a link or object name or an object designator, got {name!r}"
            )
        candidates = [name, name.replace("-", "_")]
        for n in candidates:
            if n in world.objects:
                lo, hi = world.object_aabb(n)
                pose = world.object_pose(n)
                return _Region(n, lo, hi, pose.position, _yaw_of(pose.orientation))
        links = set(world.link_names)
        for n in candidates:
            if n in links:
                lo, hi = world.link_aabb(n)
                pose = world.link_pose(n)
                return _Region(n, lo, hi, pose.position, _yaw_of(pose.orientation))
        raise self._unknown(d, key, name)

    def _region_of(self, d: Designator, key: str, value: Any) -> _Region:
        if isinstance(value, Designator):
            if value.kind != "object":
                raise self._error(
                    d, f"({key} ...) takes an object designator or a name, got {value.short()}"
                )
            obj = value.current()
            name = obj.get("urdf-name") or obj.get("name")
            if name is None:
                raise self._error(
                    d, f"({key} {obj.short()}) needs urdf_name= (a kitchen link) or name= (an item)"
                )
            return self._named(d, key, name)
        return self._named(d, key, value)

    def _regions(self, d: Designator, costmap: cm.Costmap, for_h: float | None) -> _Region | None:
        region = None
        for key in ("on", "in"):
            for value in d.get_all(key):
                r = self._region_of(d, key, value)
                if key == "on":
                    cm.add_on_box(costmap, r.label, r.lo, r.hi, for_h)
                else:
                    cm.add_in_box(costmap, r.label, r.lo, r.hi)
                region = region or r
        return region

    def _sides(self, d: Designator, costmap: cm.Costmap, region: _Region | None) -> None:
        sides = d.get_all("side")
        ranges = [(r, False) for r in d.get_all("range")]
        ranges += [(r, True) for r in d.get_all("range-invert")]
        if (sides or ranges) and region is None:
            raise self._error(
                d, "(side ...), (range ...) and (range-invert ...) need (on ...) or (in ...)"
            )
        if region is None:
            return
        for s in sides:
            if s not in ("left", "right", "front", "back"):
                raise self._error(d, f"unknown side {s!r}; known sides: left, right, front, back")
        for a, b in (("left", "right"), ("front", "back")):
            if a in sides and b in sides:
                raise self._error(
                    d, f"the costmap is empty: (side {a}) and (side {b}) contradict each other"
                )
        for s in sides:
            cm.add_side(costmap, s, region.origin)
        for r, invert in ranges:
            if isinstance(r, bool) or not isinstance(r, (int, float)) or r < 0:
                raise self._error(d, f"(range ...) takes a distance >= 0 in metres, got {r!r}")
            cm.add_range(costmap, region.origin, float(r), invert)

    def _context(
        self, d: Designator, costmap: cm.Costmap, region: _Region | None, for_type: str | None
    ) -> None:
        context = d.get("context")
        if context is None:
            return
        if context != "table-setting":
            raise self._error(d, f"unknown context {context!r}; known contexts: table-setting")
        count = d.get("object-count")
        if region is None or for_type is None or count is None:
            raise self._error(
                d, "(context table-setting) needs (on ...), (for ...) and (object-count n)"
            )
        if isinstance(count, bool) or not isinstance(count, int) or count < 1:
            raise self._error(d, f"(object-count ...) takes an integer >= 1, got {count!r}")
        cm.add_slots(costmap, region.label, region.lo, region.hi, for_type, count, region.yaw)

    def _for(self, d: Designator) -> tuple[str | None, str | None, tuple[float, ...] | None]:
        value = d.get("for")
        if value is None:
            return None, None, None
        world = self.world
        if isinstance(value, Designator):
            obj = value.current()
            otype, name = obj.get("type"), obj.get("name")
        else:
            otype, name = value, None
        if isinstance(name, str) and name in world.objects:
            otype = world.objects[name]
        if not isinstance(otype, str) or otype not in OBJECT_TYPES:
            close = difflib.get_close_matches(str(otype), OBJECT_TYPES, n=3, cutoff=0.5)
            hint = f" (did you mean {', '.join(close)}?)" if close else ""
            raise self._error(
                d,
                f"(for ...) needs an object type; unknown type {otype!r}"
                f"{hint}; known types: {', '.join(sorted(OBJECT_TYPES))}",
            )
        if not (isinstance(name, str) and name in world.objects):
            items = sorted(n for n, t in world.objects.items() if t == otype)
            name = items[0] if items else None
        return otype, name, OBJECT_TYPES[otype].size

    def _to_map(self, pose: Pose) -> tuple[float, float, float]:
        return self._map_pose(pose).position

    def _object_point(
        self, d: Designator, key: str, value: Any
    ) -> tuple[tuple[float, float, float], str | None, str | None]:
        """An object designator / item name -> (map position, item name, type)."""
        world = self.world
        if isinstance(value, str):
            if value not in world.objects:
                raise self._unknown(d, key, value)
            return world.object_pose(value).position, value, world.objects[value]
        obj = value.current()
        name, otype = obj.get("name"), obj.get("type")
        if isinstance(name, str) and name in world.objects:
            return world.object_pose(name).position, name, world.objects[name]
        pose = obj.get("pose")
        if isinstance(pose, Pose):
            return self._to_map(pose), None, otype
        if isinstance(otype, str):
            items = sorted(n for n, t in world.objects.items() if t == otype)
            if items:
                return world.object_pose(items[0]).position, items[0], otype
        if isinstance(name, str):
            raise self._unknown(d, key, name)
        # the world's state, not a malformed designator: plans may translate it
        raise DesignatorError(
            f"{_describe(d)}: ({key} {obj.short()}): no item of type {otype!r} in the world "
            "and no pose",
            d,
        )

    def _target(self, d: Designator, key: str) -> tuple[tuple[float, float, float], str | None]:
        loc, obj, pose = d.get("location"), d.get("object"), d.get("pose")
        if isinstance(loc, Designator) and loc.kind == "location":
            return self._to_map(loc.current().reference()), None
        if loc is not None:
            raise self._error(d, f"(location ...) takes a location designator, got {loc!r}")
        if obj is not None:
            if not (isinstance(obj, str) or (isinstance(obj, Designator) and obj.kind == "object")):
                raise self._error(d, f"(object ...) takes an object designator, got {obj!r}")
            point, name, _ = self._object_point(d, "object", obj)
            return point, name
        if isinstance(pose, Pose):
            return self._to_map(pose), None
        raise self._error(d, f"({key} ...) needs a target: (location L), (object O) or (pose P)")

    def _open_drawer_at(
        self, point: Sequence[float]
    ) -> tuple[tuple[float, float, float], tuple[float, float, float], tuple[float, float]] | None:
        """The open drawer holding ``point`` (a kitchen link with a ``<link>_joint``
        whose AABB contains it, sticking out of its cabinet by > 0.05 m): its AABB and the
        horizontal axis it sticks out along (the opening direction); else None."""
        world = self.world
        for link in cm.KITCHEN_LINKS:
            if not world.has_joint(f"{link}_joint"):
                continue
            lo, hi = world.link_aabb(link)
            if not (lo[0] < point[0] < hi[0] and lo[1] < point[1] < hi[1]):
                continue
            if not lo[2] - 0.01 <= point[2] <= hi[2] + 0.05:
                continue
            best: tuple[float, tuple[float, float]] | None = None
            for other in cm.KITCHEN_LINKS:
                if other == link or other.startswith(link):
                    continue
                clo, chi = world.link_aabb(other)
                if not (
                    (clo[1] <= lo[1] + 1e-3 and hi[1] <= chi[1] + 1e-3)
                    or (clo[0] <= lo[0] + 1e-3 and hi[0] <= chi[0] + 1e-3)
                ):
                    continue
                if not (
                    lo[0] < chi[0]
                    and clo[0] < hi[0]
                    and lo[1] < chi[1]
                    and clo[1] < hi[1]
                    and lo[2] < chi[2]
                    and clo[2] < hi[2]
                ):
                    continue
                for amount, axis in (
                    (clo[0] - lo[0], (-1.0, 0.0)),
                    (hi[0] - chi[0], (1.0, 0.0)),
                    (clo[1] - lo[1], (0.0, -1.0)),
                    (hi[1] - chi[1], (0.0, 1.0)),
                ):
                    if best is None or amount > best[0]:
                        best = (amount, axis)
            if best is not None and best[0] > 0.05:
                return lo, hi, best[1]
        return None

    def _support(
        self, point: Sequence[float]
    ) -> tuple[tuple[float, float, float], tuple[float, float, float]] | None:
        """The highest kitchen link below ``point`` whose AABB contains its xy."""
        best = None
        for link in cm.KITCHEN_LINKS:
            lo, hi = self.world.link_aabb(link)
            if (
                lo[0] <= point[0] <= hi[0]
                and lo[1] <= point[1] <= hi[1]
                and (hi[2] <= point[2] + 0.05)
                and (best is None or hi[2] > best[1][2])
            ):
                best = (lo, hi)
        return best

    def _relations(
        self,
        d: Designator,
        costmap: cm.Costmap,
        for_type: str | None,
        for_size: tuple[float, ...] | None,
    ) -> None:
        s_for = cm.near_size(for_type, for_size) if for_size is not None else _REF_SIZE
        p_for = cm.near_padding(for_type) if for_size is not None else _REF_SIZE
        for_h = for_size[2] if for_size is not None else 0.0
        for key in ("near", "far-from", *cm.RELATIONS):
            for value in d.get_all(key):
                if isinstance(value, Designator) and value.kind == "location":
                    point = self._to_map(value.current().reference())
                    s_ref = p_ref = _REF_SIZE
                    is_object = False
                elif isinstance(value, str) or (
                    isinstance(value, Designator) and value.kind == "object"
                ):
                    point, _, rtype = self._object_point(d, key, value)
                    size = (
                        OBJECT_TYPES[rtype].size
                        if isinstance(rtype, str) and rtype in OBJECT_TYPES
                        else (_REF_SIZE,) * 3
                    )
                    s_ref, p_ref = cm.near_size(rtype, size), cm.near_padding(rtype)
                    is_object = True
                else:
                    raise self._error(
                        d, f"({key} ...) takes an object or location designator, got {value!r}"
                    )
                support = self._support(point)
                z = support[1][2] + for_h / 2.0 if support is not None else point[2]
                costmap.add_height(cm.constant_height(z))
                if key == "near":
                    cm.add_near(costmap, point, s_ref, p_ref, s_for, p_for)
                elif key == "far-from":
                    cm.add_far_from(costmap, point, s_ref, p_ref, s_for, p_for)
                else:
                    box = (
                        None
                        if support is None
                        else ((support[0][0], support[0][1]), (support[1][0], support[1][1]))
                    )
                    edge = "front"
                    if is_object and support is not None:
                        edge = cm.closest_edge(support[0], support[1], point)
                    margin = (
                        max(for_size[0], for_size[1]) / 2.0 + _SUPPORT_CLEARANCE
                        if for_size is not None
                        else 0.0
                    )
                    cm.add_relation(costmap, key, point, box, edge, margin=margin)


def location_rules(world: World, **options: Any) -> RuleSet:
    """A child of :data:`executive.static_rules` resolving location designators by
    costmaps in ``world`` (options: see :class:`LocationCostmaps`). Use it as
    ``executive.environment(rules=location_rules(world), world=...)``."""
    return LocationCostmaps(world, **options).rules


def costmaps_of(rules: RuleSet) -> LocationCostmaps | None:
    """The :class:`LocationCostmaps` whose generator is in ``rules`` (or its parents), or
    None."""
    for rule in rules.location_generators():
        owner = getattr(rule.fn, "__self__", None)
        if isinstance(owner, LocationCostmaps):
            return owner
    return None
