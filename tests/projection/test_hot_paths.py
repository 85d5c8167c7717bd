"""The second performance round's hot paths keep their behaviour: lazy "did you mean"
hints, ``World.has_joint``, costmap factor bounds (the windowed product equals the whole
grid's, empty reasons included) and the positive-cells cdf (the same samples)."""

from __future__ import annotations

import difflib
import pickle
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
import pytest

from projection import World
from projection import _costmaps as cm
from projection._names import UnknownName


@pytest.fixture(scope="module")
def world() -> Iterator[World]:
    w = World(seed=0)
    yield w
    w.close()


def test_unknown_joint_and_link_hints_are_built_only_when_read(
    world: World, monkeypatch: pytest.MonkeyPatch
) -> None:
    calls = []
    real = difflib.get_close_matches

    def counting(*args: Any, **kw: Any) -> list[str]:
        calls.append(args)
        return real(*args, **kw)

    monkeypatch.setattr(difflib, "get_close_matches", counting)
    for _ in range(50):  # a hot loop that expects misses pays no hint
        with pytest.raises(LookupError):
            world.joint_position("torso_lift_joit")
        with pytest.raises(LookupError):
            world.link_aabb("kitchen_island_surfac")
    assert calls == []
    with pytest.raises(LookupError, match="close matches: torso_lift_joint") as joint:
        world.joint_position("torso_lift_joit")
    with pytest.raises(LookupError, match="did you mean kitchen_island_surface") as link:
        world.link_aabb("kitchen_island_surfac")
    assert isinstance(joint.value, UnknownName) and joint.value.name == "torso_lift_joit"
    assert "unknown link 'kitchen_island_surfac'" in str(link.value)
    # the message survives pickling (campaign workers), hint included
    again = pickle.loads(pickle.dumps(link.value))
    assert str(again) == str(link.value)
    assert str(UnknownName("joint", "zzz", ["a"])) == "unknown joint 'zzz'"


def test_has_joint(world: World) -> None:
    assert world.has_joint("torso_lift_joint")
    drawers = [link for link in cm.KITCHEN_LINKS if world.has_joint(f"{link}_joint")]
    assert drawers, "the kitchen has drawers"
    for link in drawers:
        world.joint_position(f"{link}_joint")  # agrees with joint_position
    assert not world.has_joint("kitchen_island_surface_joint")
    with pytest.raises(LookupError):
        world.joint_position("kitchen_island_surface_joint")


def _pair(build: Callable[[cm.Costmap], None]) -> tuple[cm.Costmap, cm.Costmap]:
    """The same factors with their bounds and with every bound dropped."""
    bounded = cm.Costmap()
    build(bounded)
    unbounded = cm.Costmap()
    build(unbounded)
    unbounded.factors = [
        cm.Factor(f.name, f.fn, f.score, f.expensive, None) for f in unbounded.factors
    ]
    return bounded, unbounded


def _reachable(c: cm.Costmap) -> None:
    cm.add_reachable_for(c, [(1.0, 0.5, 0.9)])


def _slots_on_table(c: cm.Costmap) -> None:
    cm.add_on_box(c, "table", (-1.2, 0.2, 0.0), (-0.55, 2.4, 0.9))
    cm.add_slots(c, "table", (-1.2, 0.2, 0.0), (-0.55, 2.4, 0.9), "bowl", 2)


def _range_in_demo_area(c: cm.Costmap) -> None:
    cm.add_range(c, (0.3, 0.3), 1.5, False)
    cm.add_demo_area(c)


def _near(c: cm.Costmap) -> None:
    cm.add_near(c, (2.0, -1.0), 0.2, 0.03, 0.1, 0.01)


def _left_of(c: cm.Costmap) -> None:
    cm.add_relation(c, "left-of", (1.0, 1.0), ((0.5, 0.0), (2.0, 2.0)), "front")


@pytest.mark.parametrize(
    "build", [_reachable, _slots_on_table, _range_in_demo_area, _near, _left_of]
)
def test_bounded_factors_give_the_whole_grids_values_and_samples(
    build: Callable[[cm.Costmap], None],
) -> None:
    bounded, unbounded = _pair(build)
    assert any(f.bounds is not None for f in bounded.factors)
    np.testing.assert_array_equal(bounded.values(), unbounded.values())
    assert bounded.max == unbounded.max and bounded.empty_reason == unbounded.empty_reason
    r1, r2 = np.random.default_rng(7), np.random.default_rng(7)
    for _ in range(300):
        assert bounded.sample_xy(r1) == unbounded.sample_xy(r2)


def test_an_empty_windowed_map_names_the_same_factor() -> None:
    def build(c: cm.Costmap) -> None:
        cm.add_on_box(c, "a", (0.0, 0.0, 0.0), (1.0, 1.0, 0.5))
        cm.add_on_box(c, "b", (3.0, 3.0, 0.0), (4.0, 4.0, 0.5))  # disjoint: empty

    bounded, unbounded = _pair(build)
    assert bounded.empty and unbounded.empty
    assert bounded.empty_reason == unbounded.empty_reason
    assert "on-bounding-box-b" in str(bounded.empty_reason)
    with pytest.raises(ValueError, match="empty"):
        bounded.sample_xy(np.random.default_rng(0))
