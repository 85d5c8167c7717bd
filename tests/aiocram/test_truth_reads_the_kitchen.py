"""The truth measures the measured world's kitchen (issue 25, item 2): where an object is
("island", "sink", "floor") follows ``world.kitchen``'s roles, not link names of its own."""

from __future__ import annotations

import dataclasses

import pytest

from aiocram.truth import where_is
from executive import Pose
from kitchens import iai

projection = pytest.importorskip("projection")


def test_where_an_object_is_follows_the_worlds_kitchen() -> None:
    k = iai.DESCRIPTION
    swapped = dataclasses.replace(
        k, start_surface=k.table_surface, table_surface=k.start_surface, floor_height=0.01
    )
    cup = k.demo_poses["cup"]
    for kitchen, expected in ((k, "sink"), (swapped, "island")):
        with projection.World(kitchen=kitchen) as world:
            world.spawn_object("cup-1", "cup", cup)
            assert where_is(world, "cup-1") == expected
            world.remove_object("cup-1")
            world.spawn_object("cup-1", "cup", Pose((0.5, -1.0, 0.04)))
            # below the projection kitchen's 0.3 m floor height; above the swapped 0.01 m
            assert where_is(world, "cup-1") == ("floor" if kitchen is k else "elsewhere")
