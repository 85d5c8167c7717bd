"""Plans read the kitchen from the environment (issue 25, item 2): the demo's surfaces, its
container, the floor height and the demo's objects are those of the current environment's
:class:`executive.KitchenDescription`, never names spelt in ``plans``; a world model
without one is a typed error before anything moves."""

from __future__ import annotations

import dataclasses
from typing import Any

import pytest
from conftest import KITCHEN, PR2, hand_links, make_robot

import cpl
import executive
import plans  # noqa: F401 - registers the action rules
from executive import (
    ContainerDescription,
    KitchenDescription,
    NoKitchenDescription,
    Pose,
    an,
    perform,
)
from executive.testing import InMemoryWorld
from plans import demo
from plans.environment import DEFAULT_DISTANCE
from plans.fetch import floor_height

#: The same kitchen with every name the plans use changed: a plan that spelt one of the
#: projection kitchen's names would still say the old one.
RENAMED = dataclasses.replace(
    KITCHEN,
    name="galley",
    start_surface="galley_counter_top",
    table_surface="galley_table_top",
    container=ContainerDescription("galley_box", "galley_box_joint", "galley_box_knob", 0.25),
    floor_height=0.2,
    demo_objects=("cup", "bowl"),
    demo_poses={"cup": Pose((1.0, 0.0, 0.9)), "bowl": Pose((1.0, 0.3, 0.9))},
    demo_attachments={},
)


def _in(kitchen: KitchenDescription | None, read: Any) -> Any:
    world = InMemoryWorld(robot=PR2, kitchen=kitchen)

    async def main() -> Any:
        async with executive.environment(executive.Environment("fake", world=world)):
            return read()

    return cpl.run(main)


def _names(location: executive.LocationDesignator) -> set[tuple[str, str, str]]:
    """(key, urdf-name, part-of) of the location's object-valued keys."""
    return {
        (key, value.get("urdf-name"), value.get("part-of"))
        for key, value in location.properties
        if isinstance(value, executive.ObjectDesignator) and value.get("urdf-name")
    }


def test_the_demos_locations_name_the_environments_kitchen() -> None:
    def read() -> dict[str, Any]:
        return {
            "cup": _names(demo.fetch_location("cup")),
            "spoon": _names(demo.fetch_location("spoon")),
            "bowl-target": _names(demo.place_location("bowl")),
            "cup-target": _names(demo.place_location("cup", bowl_placed=False)),
            "objects": demo.demo_objects(),
            "floor": floor_height(),
        }

    got = _in(RENAMED, read)
    assert got["cup"] == {("on", "galley_counter_top", "galley")}
    assert got["spoon"] == {("in", "galley_box", "galley")}
    assert got["bowl-target"] == {("on", "galley_table_top", "galley")}
    assert got["cup-target"] == {("on", "galley_table_top", "galley")}
    assert got["objects"] == ("cup", "bowl")
    assert got["floor"] == 0.2
    # the projection's kitchen, the same way
    assert _in(KITCHEN, lambda: _names(demo.fetch_location("cup"))) == {
        ("on", "sink_area_surface", "kitchen")
    }


def test_a_kitchen_given_explicitly_needs_no_environment() -> None:
    assert _names(demo.fetch_location("bowl", RENAMED)) == {("on", "galley_counter_top", "galley")}
    assert _names(demo.place_location("milk", bowl_placed=False, kitchen=RENAMED)) == {
        ("on", "galley_table_top", "galley")
    }
    with pytest.raises(TypeError, match=r"executive\.KitchenDescription"):
        demo.start_surface("sink_area_surface")  # type: ignore[arg-type]


def test_the_demo_needs_a_kitchen_description() -> None:
    with pytest.raises(NoKitchenDescription, match=r"InMemoryWorld.*kitchen="):
        _in(None, lambda: demo.fetch_location("cup"))


def test_fetching_without_a_kitchen_description_names_the_fix_before_anything_moves() -> None:
    world = InMemoryWorld(
        objects={"cup-1": Pose((1.3, 0.6, 0.9))},
        types={"cup-1": "cup"},
        links=hand_links(PR2),
        robot=PR2,
    )
    robot = make_robot(world)
    cup = an.object(type="cup", name="cup-1")
    with pytest.raises(NoKitchenDescription, match="kitchen="):
        robot.run(perform, an.action(type="fetching", object=cup))
    assert all(pm.calls == [] for pm in robot.pms.values())  # nothing moved


def test_the_plans_accessing_distance_is_the_projection_kitchens_opening() -> None:
    """The scene places the spoon where it is reachable once the drawer is open by the
    kitchen's ``container.opening``; the transports open it by ``DEFAULT_DISTANCE``."""
    assert DEFAULT_DISTANCE == KITCHEN.container.opening


def test_the_drawers_handle_is_the_kitchens() -> None:
    from plans.environment import handle_link

    described = an.object(type="drawer", urdf_name="galley_box", part_of="galley")
    other = an.object(type="drawer", urdf_name="galley_shelf_main", part_of="galley")
    assert _in(RENAMED, lambda: handle_link(described)) == "galley_box_knob"
    # a container the kitchen does not describe: CRAM's naming
    assert _in(RENAMED, lambda: handle_link(other)) == "galley_shelf_handle"
