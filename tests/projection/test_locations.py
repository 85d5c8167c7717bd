"""Location designators resolved by costmaps in a real PyBullet world: every key, the
validators, caching per chain, the 30-rejection cut-off, errors, CRAM's demo designators
(reference section 3.4) and the costmap picture."""

from __future__ import annotations

import asyncio
import math
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import executive
from executive import Pose, a, an
from executive.failures import NavigationPoseUnreachable
from projection import World
from projection._locations import LocationCostmaps, costmaps_of, location_rules
from projection._objects import OBJECT_TYPES

SINK = an.object(type="counter-top", urdf_name="sink_area_surface", part_of="kitchen")
ISLAND = an.object(type="counter-top", urdf_name="kitchen_island_surface", part_of="kitchen")
DRAWER = an.object(type="drawer", urdf_name="sink_area_left_upper_drawer_main", part_of="kitchen")


@pytest.fixture()
def world() -> Iterator[World]:
    with World(seed=0) as w:
        yield w


def run(world: World, fn: Callable[[], Any], rules: executive.RuleSet | None = None) -> Any:
    """Call ``fn`` inside an environment with the costmap rules of ``world``."""

    async def main() -> Any:
        async with executive.environment(rules=rules or location_rules(world)):
            return fn()

    return asyncio.run(main())


def solutions(d: executive.LocationDesignator, n: int) -> list[Pose]:
    out = [d.reference()]
    cur: Any = d
    while len(out) < n:
        cur = cur.next_solution()
        assert cur is not None
        out.append(cur.reference())
    return out


def state(world: World) -> tuple[Any, ...]:
    objs = tuple((n, world.object_pose(n).position) for n in world.objects)
    return world.robot_pose().position, world.robot_pose().orientation, objs


def spawn_on(world: World, name: str, type_: str, x: float, y: float, top: float = 0.85) -> None:
    world.spawn_object(name, type_, Pose((x, y, top + OBJECT_TYPES[type_].size[2] / 2)))


def inside(p: Pose, lo: Any, hi: Any) -> bool:
    return lo[0] < p.position[0] < hi[0] and lo[1] < p.position[1] < hi[1]


# ----------------------------------------------------------------------- on / in / side
def test_on_side_left(world: World) -> None:
    lo, hi = world.link_aabb("sink_area_surface")
    origin = world.link_pose("sink_area_surface").position
    d = a.location(("side", "left"), on=SINK)
    for p in run(world, lambda: solutions(d, 40)):
        assert p.position[1] > origin[1] and inside(p, lo, hi)
        assert p.position[2] == pytest.approx(0.85)
        assert p.orientation == (0.0, 0.0, 0.0, 1.0)


def test_side_front_range_and_range_invert(world: World) -> None:
    origin = world.link_pose("sink_area_surface").position
    near = a.location(("side", "left"), ("side", "front"), on=SINK, range=0.5)
    far = a.location(("side", "left"), ("side", "front"), on=SINK, range_invert=0.5)
    ps, qs = run(world, lambda: (solutions(near, 30), solutions(far, 30)))
    for p in ps:
        assert p.position[0] < origin[0] and p.position[1] > origin[1]
        assert math.dist(p.position[:2], origin[:2]) <= 0.5
    for q in qs:
        assert q.position[0] < origin[0]
        assert math.dist(q.position[:2], origin[:2]) >= 0.5


def test_plain_link_name_and_hyphenated_urdf_name(world: World) -> None:
    lo, hi = world.link_aabb("kitchen_island_surface")
    obj = an.object(type="counter-top", urdf_name="kitchen-island-surface", part_of="kitchen")
    p, q = run(
        world,
        lambda: (
            a.location(on="kitchen_island_surface").reference(),
            a.location(on=obj).reference(),
        ),
    )
    assert inside(p, lo, hi) and inside(q, lo, hi)


def test_in_drawer_front(world: World) -> None:
    lo, hi = world.link_aabb("sink_area_left_upper_drawer_main")
    origin = world.link_pose("sink_area_left_upper_drawer_main").position
    d = a.location(("side", "front"), in_=DRAWER)
    for p in run(world, lambda: solutions(d, 30)):
        assert inside(p, lo, hi) and p.position[0] < origin[0]
        assert p.position[2] == pytest.approx(lo[2] + 0.035)


# ------------------------------------------------------------------- robot locations
def test_reachable_for_samples(world: World) -> None:
    target = Pose((1.4, 0.8, 0.87))
    d = a.location(reachable_for="pr2", location=a.location(pose=target))
    before = state(world)
    poses = run(world, lambda: solutions(d, 25))
    assert state(world) == before
    for p in poses:
        dist = math.dist(p.position[:2], target.position[:2])
        assert 0.2 < dist < 0.7 and p.position[2] < 0.05
        facing = math.atan2(target.position[1] - p.position[1], target.position[0] - p.position[0])
        assert abs(math.remainder(p.yaw - facing, 2 * math.pi)) <= 0.1
        snap = world.snapshot()
        try:
            world.drive(p)  # raises NavigationPoseUnreachable on a collision
        finally:
            world.restore(snap)
    assert state(world) == before


def test_reachable_for_object_on_the_island(world: World) -> None:
    spawn_on(world, "bowl", "bowl", -0.76, 1.19)
    d = a.location(reachable_for="pr2", object=an.object(type="bowl", name="bowl"), arm="right")
    for p in run(world, lambda: solutions(d, 10)):
        assert 0.2 < math.dist(p.position[:2], (-0.76, 1.19)) < 0.7
        assert -1.0 < p.position[0] < 0.0  # in front of the island


def test_visible_for_samples(world: World) -> None:
    spawn_on(world, "cup", "cup", 1.3, 0.6)
    target = world.object_pose("cup").position
    d = a.location(visible_for="pr2", object=an.object(type="cup", name="cup"))
    for p in run(world, lambda: solutions(d, 15)):
        assert math.dist(p.position[:2], target[:2]) < 2.0 and p.position[2] == 0.0
        facing = math.atan2(target[1] - p.position[1], target[0] - p.position[0])
        assert abs(math.remainder(p.yaw - facing, 2 * math.pi)) <= 0.1
    cmap = costmaps_of_world(world, d)
    assert cmap.value(*[p for p in d.reference().position[:2]]) > 0.1


def costmaps_of_world(world: World, d: executive.LocationDesignator) -> Any:
    return LocationCostmaps(world).costmap(d)


def test_visibility_factor_sees_through_the_robot_but_not_the_counter(world: World) -> None:
    engine = LocationCostmaps(world)
    d = a.location(visible_for="pr2", location=a.location(pose=Pose((1.4, 0.4, 0.85))))
    cmap = run(world, lambda: engine.costmap(d), engine.rules)
    # the robot stands at the origin, between nothing and the target: irrelevant; a cell
    # under the counter's far side cannot see the top's near point at all
    assert cmap.value(0.76, 0.4) > 0.1
    assert cmap.value(1.6, 0.4) == 0.0


# ------------------------------------------------------------------ table setting, relations
def test_table_setting_slot_for_the_bowl(world: World) -> None:
    spawn_on(world, "bowl", "bowl", 1.4, 0.8)
    lo, hi = world.link_aabb("kitchen_island_surface")
    d = a.location(
        ("side", "back"),
        ("side", "right"),
        on=ISLAND,
        context="table-setting",
        for_=an.object(type="bowl"),
        object_count=3,
        range_invert=0.5,
    )
    for p in run(world, lambda: solutions(d, 20)):
        assert inside(p, lo, hi)
        # the slot (slot_centres: (-0.83, 0.72)) nearest the right (-y) end, pulled to the
        # back (+x) edge
        assert math.dist(p.position[:2], (-0.68, 0.72)) <= 0.1 + 1e-9
        assert p.position[2] == pytest.approx(0.85 + OBJECT_TYPES["bowl"].size[2] / 2)


def _bowl_on_island(world: World) -> tuple[float, float]:
    spawn_on(world, "bowl", "bowl", -0.68, 0.64)
    return -0.68, 0.64


def test_near_and_far_from_a_bowl(world: World) -> None:
    bx, by = _bowl_on_island(world)
    bowl = an.object(type="bowl", name="bowl")
    near = a.location(near=bowl, for_=an.object(type="cup"))
    far = a.location(far_from=bowl, for_=an.object(type="milk"))
    ps, qs = run(world, lambda: (solutions(near, 20), solutions(far, 20)))
    # near: ring from 0.08 + 0.03 + 0.1 + 0.04 = 0.25 of width (0.16 + 0.08) / 2 = 0.12
    for p in ps:
        assert 0.25 - 1e-9 <= math.dist(p.position[:2], (bx, by)) <= 0.37 + 1e-9
        assert p.position[2] == pytest.approx(0.85 + OBJECT_TYPES["cup"].size[2] / 2)
    # far-from: from 1.5*0.16 + 3*0.03 + 0.01 + 0.03 = 0.37, width (0.16 + 0.06) * 2.5
    for q in qs:
        assert 0.37 - 1e-9 <= math.dist(q.position[:2], (bx, by)) <= 0.37 + 0.55 + 1e-9


def test_left_of_and_right_of_a_bowl(world: World) -> None:
    bx, by = _bowl_on_island(world)
    lo, hi = world.link_aabb("kitchen_island_surface")
    bowl = an.object(type="bowl", name="bowl")
    # the bowl is nearest the island's +x edge ("back"): the robot faces -x there, so
    # right-of is +y and left-of is -y
    right = a.location(right_of=bowl, for_=an.object(type="cup"))
    left = a.location(left_of=bowl, for_=an.object(type="cup"))
    ps, qs = run(world, lambda: (solutions(right, 20), solutions(left, 20)))
    for p in ps:
        assert p.position[1] > by and inside(p, lo, hi)
        v = abs(p.position[1] - by) / math.dist(p.position[:2], (bx, by))
        assert v > 0.8  # the cup's potential-field threshold
    for q in qs:
        assert q.position[1] < by and inside(q, lo, hi)


# -------------------------------------------------------------------------- demo (3.4)
FETCHING = {
    "breakfast-cereal": a.location(("side", "left"), ("side", "front"), on=SINK, range=0.5),
    "cup": a.location(("side", "left"), on=SINK),
    "bowl": a.location(("side", "left"), ("side", "front"), on=SINK, range_invert=0.5),
    "milk": a.location(("side", "left"), ("side", "front"), on=SINK, range=0.5),
    "spoon": a.location(("side", "front"), in_=DRAWER),
}


@pytest.mark.parametrize("otype", list(FETCHING))
def test_demo_fetching_locations(world: World, otype: str) -> None:
    d = FETCHING[otype].copy()
    link = "sink_area_left_upper_drawer_main" if otype == "spoon" else "sink_area_surface"
    lo, hi = world.link_aabb(link)
    origin = world.link_pose(link).position
    p = run(world, d.reference)
    assert inside(p, lo, hi) and p.position[0] < origin[0]
    if otype != "spoon":
        assert p.position[1] > origin[1]
    # an object of the type stands there without touching another item (empty counter)
    z = p.position[2] + OBJECT_TYPES[otype].size[2] / 2
    world.spawn_object(otype, otype, Pose((p.position[0], p.position[1], z)))
    assert not [c for c in world.contacts(otype) if c.body_b not in ("kitchen", "pr2")]


def test_demo_placing_locations_are_collision_free(world: World) -> None:
    spawn_on(world, "bowl", "bowl", 1.4, 0.8)
    spawn_on(world, "cup", "cup", 1.3, 0.6)
    spawn_on(world, "spoon", "spoon", 1.25, 0.3)
    spawn_on(world, "milk", "milk", 1.4, 0.1)
    bowl = an.object(type="bowl", name="bowl")
    island_lo, island_hi = world.link_aabb("kitchen_island_surface")
    rules = location_rules(world)

    def place(name: str, d: executive.LocationDesignator) -> Pose:
        p = d.reference()
        world.set_object_pose(name, p)
        others = [c for c in world.contacts(name) if c.body_b not in ("kitchen", "pr2")]
        assert not others, (name, p, others)
        assert inside(p, island_lo, island_hi)
        return p

    def scenario() -> None:
        place(
            "bowl",
            a.location(
                ("side", "back"),
                ("side", "right"),
                on=ISLAND,
                context="table-setting",
                for_=bowl,
                object_count=3,
                range_invert=0.5,
            ),
        )
        by = world.object_pose("bowl").position[1]
        for name in ("cup", "spoon"):
            p = place(name, a.location(right_of=bowl, near=bowl, for_=an.object(type=name)))
            assert p.position[1] > by
        p = place("milk", a.location(left_of=bowl, far_from=bowl, for_=an.object(type="milk")))
        assert p.position[1] < by

    run(world, scenario, rules)


def test_for_collision_validator_avoids_an_item(world: World) -> None:
    _bowl_on_island(world)
    spawn_on(world, "cup", "cup", 1.3, 0.6)
    engine = LocationCostmaps(world)
    bowl = an.object(type="bowl", name="bowl")
    d = a.location(near=bowl, for_=an.object(type="cup", name="cup"))
    p = run(world, d.reference, engine.rules)
    # a cup-sized blocker at the sample makes that pose invalid, and the world is restored
    spawn_on(world, "blocker", "milk", p.position[0], p.position[1])
    before = state(world)
    assert engine.validate_for_collision(d, p) == "reject"
    assert state(world) == before


# ---------------------------------------------------------------- caching, cut-off, seeds
def test_next_solution_reuses_the_costmap(world: World) -> None:
    engine = LocationCostmaps(world)
    d = a.location(reachable_for="pr2", location=a.location(pose=Pose((1.4, 0.4, 0.9))))

    def walk() -> tuple[list[Pose], list[float]]:
        first = d.reference()
        times, out, cur = [], [first], d
        for _ in range(20):
            t0 = time.perf_counter()
            nxt = cur.next_solution()
            times.append(time.perf_counter() - t0)
            assert nxt is not None
            cur = nxt
            out.append(cur.reference())
        return out, times

    poses, times = run(world, walk, engine.rules)
    assert engine.builds == 1
    assert len({p.position for p in poses}) > 4  # the band in front of the counter is narrow
    assert sorted(times)[len(times) // 2] < 0.02  # one draw + validators, no rebuild


def test_next_different_solution(world: World) -> None:
    d = a.location(("side", "left"), on=SINK)

    def two() -> tuple[Pose, Pose]:
        nxt = d.next_different_solution(0.2)
        assert nxt is not None
        return d.reference(), nxt.reference()

    p, q = run(world, two)
    assert math.dist(p.position, q.position) > 0.2


def test_same_seed_same_samples() -> None:
    def draw() -> list[Pose]:
        with World(seed=7) as w:
            d = a.location(reachable_for="pr2", location=a.location(pose=Pose((1.4, 0.8, 0.9))))
            e = a.location(("side", "left"), on=SINK)
            return run(w, lambda: solutions(d, 5) + solutions(e, 5))

    assert draw() == draw()


def test_thirty_rejections_end_the_chain(world: World) -> None:
    rules = location_rules(world)
    calls: list[Pose] = []

    def reject_all(d: Any, pose: Pose) -> str:
        calls.append(pose)
        return "reject"

    rules.register_location_validator(reject_all, 0)
    d = a.location(on=SINK)
    with pytest.raises(executive.DesignatorError, match="cannot be resolved"):
        run(world, d.reference, rules)
    assert len(calls) == 30


def test_chain_ends_after_a_solution(world: World) -> None:
    rules = location_rules(world)
    seen: list[Pose] = []

    def first_only(d: Any, pose: Pose) -> str:
        seen.append(pose)
        return "accept" if len(seen) == 1 else "reject"

    rules.register_location_validator(first_only, 0)
    d = a.location(on=SINK)
    assert run(world, lambda: (d.reference(), d.next_solution()), rules)[1] is None
    assert len(seen) == 31


# ----------------------------------------------------------------------------- errors
@pytest.mark.parametrize(
    ("designator", "message"),
    [
        (
            a.location(("side", "left"), ("side", "right"), on=ISLAND),
            r"location \(side left\) \(side right\) \(on kitchen_island_surface\): the "
            r"costmap is empty: \(side left\) and \(side right\) contradict",
        ),
        (
            a.location(("side", "left"), on=ISLAND, range_invert=5.0),
            r"the costmap is empty: factor 'range-invert' leaves no cell",
        ),
        (
            a.location(on="kitchen_iland_surface"),
            r"no link or object 'kitchen_iland_surface'.*did you mean kitchen_island_surface",
        ),
        (
            a.location(on=an.object(type="counter-top", urdf_name="sink_surface")),
            r"did you mean sink_area_surface",
        ),
        (a.location(("side", "up"), on=SINK), r"unknown side 'up'"),
        (a.location(("side", "left")), r"\(side \.\.\.\) only modifies a costmap key"),
        (a.location(reachable_for="pr2"), r"needs a target"),
        (a.location(on=SINK, for_="spon"), r"unknown type 'spon'.*did you mean spoon"),
        (
            a.location(reachable_for="pr2", location=a.location(pose=(math.nan, 0.0, 0.0))),
            r"non-finite",
        ),
        (
            a.location(on=ISLAND, context="table-setting", for_="bowl"),
            r"needs \(on \.\.\.\), \(for \.\.\.\) and \(object-count n\)",
        ),
    ],
)
def test_errors_name_the_problem(
    world: World, designator: executive.LocationDesignator, message: str
) -> None:
    before = state(world)
    with pytest.raises(executive.DesignatorError, match=message):
        run(world, designator.copy().reference)
    assert state(world) == before


def test_unknown_object_target(world: World) -> None:
    d = a.location(reachable_for="pr2", object=an.object(type="cup", name="mug1"))
    with pytest.raises(executive.DesignatorError, match="mug1"):
        run(world, d.reference)


def test_pose_and_of_stay_with_the_builtin_generator(world: World) -> None:
    p = Pose((1.0, 2.0, 0.0))
    engine = LocationCostmaps(world)
    assert run(world, a.location(pose=p).reference, engine.rules) == p
    assert engine.builds == 0
    assert costmaps_of(engine.rules) is engine


# ----------------------------------------------------------------------------- picture
def test_costmap_png(world: World, tmp_path: Path) -> None:
    from PIL import Image

    from projection.render import costmap

    rules = location_rules(world)
    d = a.location(reachable_for="pr2", location=a.location(pose=Pose((1.4, 0.8, 0.9))))

    def draw() -> Path:
        solutions(d, 3)
        return costmap(d, tmp_path / "reach.png", samples=20)

    out = run(world, draw, rules)
    with Image.open(out) as img:
        assert img.format == "PNG" and img.width > 200 and img.height > 200
    out2 = costmap(a.location(on=SINK), tmp_path / "on.png", world=world, samples=5)
    assert out2.stat().st_size > 0
    with pytest.raises(TypeError):
        costmap(d, tmp_path / "x.png")


def test_navigation_error_is_not_swallowed(world: World) -> None:
    # the robot-collision validator treats only NavigationPoseUnreachable as a rejection
    engine = LocationCostmaps(world)
    d = a.location(reachable_for="pr2", location=a.location(pose=Pose((1.4, 0.8, 0.9))))
    assert engine.validate_robot_collision(d, Pose((1.5, 0.5, 0.0))) == "reject"
    assert engine.validate_robot_collision(d, Pose((0.6, 0.5, 0.0))) == "unknown"
    assert issubclass(NavigationPoseUnreachable, Exception)


# ------------------------------------------------------------ learned base density
class _Peaked:
    """Preferences whose learned base density peaks at ``at`` (x, y in the target's frame)."""

    def __init__(self, at: tuple[float, float] | None) -> None:
        self.at = at
        self.asked: list[tuple[str, str]] = []

    def order_choices(self, action: str, obj: str, choices: Any) -> list[Any]:
        return list(choices)

    def base_density(self, action: str, obj: str) -> Any:
        self.asked.append((action, obj))
        if self.at is None:
            return None
        ax, ay = self.at
        return lambda x, y, yaw: np.exp(-((x - ax) ** 2 + (y - ay) ** 2) / (2 * 0.05**2))


def _samples_with(preferences: Any, n: int = 30) -> list[Pose]:
    target = Pose((1.4, 0.8, 0.87))
    d = a.location(
        reachable_for="pr2", location=a.location(pose=target), experience=("picking-up", "cup")
    )
    with World(seed=0) as world:

        async def main() -> list[Pose]:
            env = executive.Environment(rules=location_rules(world), preferences=preferences)
            async with executive.environment(env):
                return solutions(d, n)

        return asyncio.run(main())


def test_a_learned_base_density_draws_the_samples_to_where_experience_stood() -> None:
    # in the target's frame (its yaw is 0: the map's axes): 0.12 m left of where the
    # rules' Gaussian peaks, at the edge of the free space in front of the counter
    peak = (-0.68, 0.12)
    learned = _Peaked(peak)
    plain = _samples_with(None)
    drawn = _samples_with(learned)
    assert learned.asked == [("picking-up", "cup")]
    where = (1.4 + peak[0], 0.8 + peak[1])

    def mean_distance(poses: list[Pose]) -> float:
        return sum(math.dist(p.position[:2], where) for p in poses) / len(poses)

    # the floor (LEARNED_FLOOR) bounds the reweighting to 5x: a clear shift, not a collapse
    assert mean_distance(drawn) < 0.75 * mean_distance(plain)
    for p in drawn:  # still reachable-for poses: reweighted, nothing added
        assert 0.2 < math.dist(p.position[:2], (1.4, 0.8)) < 0.7


def test_nothing_learned_for_the_type_leaves_the_costmap_as_it_was() -> None:
    assert [p.position for p in _samples_with(_Peaked(None))] == [
        p.position for p in _samples_with(None)
    ]


def test_a_malformed_experience_key_is_an_input_error(world: World) -> None:
    d = a.location(
        reachable_for="pr2", location=a.location(pose=Pose((1.4, 0.8, 0.87))), experience="cup"
    )
    with pytest.raises(executive.DesignatorInputError, match=r"\(experience ...\) takes"):
        run(world, d.reference)
