"""``World(kitchen=...)`` (issue 25, item 2): a world carries its kitchen's description, the
projection's kitchen by default; one that does not fit the kitchen's URDF is refused before
anything is loaded, and the world model hands the description to plans."""

from __future__ import annotations

import dataclasses

import pybullet as pb
import pytest

from executive import KitchenDescriptionError
from kitchens import iai

projection = pytest.importorskip("projection")


def test_a_world_carries_the_projections_kitchen_by_default() -> None:
    with projection.World() as world:
        assert world.kitchen is iai.DESCRIPTION
        assert projection.ProjectedWorldModel(world).kitchen is iai.DESCRIPTION
        # every name the description gives is a link of the loaded kitchen
        for link in (world.kitchen.start_surface, world.kitchen.table_surface):
            assert world.link_aabb(link)[1][2] > 0.8
        assert world.container_state(world.kitchen.container.link)[0] == 0.0


def test_a_world_carries_the_kitchen_it_is_given() -> None:
    other = dataclasses.replace(iai.DESCRIPTION, floor_height=0.2)
    with projection.World(kitchen=other) as world:
        assert world.kitchen is other


def test_a_kitchen_that_does_not_fit_is_refused_before_anything_loads() -> None:
    misspelt = dataclasses.replace(iai.DESCRIPTION, table_surface="kitchen_island_top")
    before = _connections()
    with pytest.raises(
        KitchenDescriptionError,
        match=r"table_surface: no link 'kitchen_island_top'.*'kitchen_island_surface'",
    ):
        projection.World(kitchen=misspelt)
    assert _connections() == before  # no client was opened
    with pytest.raises(TypeError, match=r"executive\.KitchenDescription"):
        projection.World(kitchen="kitchen")


def test_the_real_robots_world_model_hands_out_the_beliefs_kitchen() -> None:
    true, belief = projection.make_world_pair(seed=0, objects={})
    try:
        model = projection.RealWorldModel(true, belief)
        assert model.kitchen is belief.kitchen is iai.DESCRIPTION
    finally:
        true.close()
        belief.close()


def _connections() -> int:
    """How many PyBullet clients are open (ids are handed out lowest first)."""
    probe = pb.connect(pb.DIRECT)
    pb.disconnect(probe)
    return probe
