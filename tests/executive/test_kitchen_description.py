"""executive.KitchenDescription (issue 25, item 2): the typed kitchen contract checks itself
when built and against the kitchen's URDF tree, and the environment hands it to plans."""

from __future__ import annotations

import dataclasses

import pytest

import cpl
import executive
from executive import (
    ContainerDescription,
    KinematicTree,
    KitchenDescription,
    KitchenDescriptionError,
    NoKitchenDescription,
    Pose,
)
from executive.testing import InMemoryWorld

URDF = """<robot name="k">
  <link name="root"/><link name="counter_top"/><link name="island_top"/>
  <link name="box_main"/><link name="box_handle"/>
  <joint name="counter_top_joint" type="fixed">
    <parent link="root"/><child link="counter_top"/></joint>
  <joint name="island_top_joint" type="fixed">
    <parent link="root"/><child link="island_top"/></joint>
  <joint name="box_main_joint" type="prismatic">
    <parent link="root"/><child link="box_main"/>
    <limit lower="0" upper="0.4" effort="1" velocity="1"/></joint>
  <joint name="box_handle_joint" type="fixed">
    <parent link="box_main"/><child link="box_handle"/></joint>
</robot>"""


def make(**changes: object) -> KitchenDescription:
    fields: dict[str, object] = dict(
        name="k",
        start_surface="counter_top",
        table_surface="island_top",
        container=ContainerDescription("box_main", "box_main_joint", "box_handle", 0.3),
        floor_height=0.3,
        demo_objects=("bowl", "spoon"),
        demo_poses={"bowl": Pose((1.0, 0.0, 0.9)), "spoon": Pose((1.0, 0.5, 0.7))},
        demo_attachments={"spoon": "box_main"},
    )
    fields.update(changes)
    return KitchenDescription(**fields)  # type: ignore[arg-type]


def test_a_well_formed_description_validates_and_is_read_only() -> None:
    kitchen = make()
    kitchen.validate(KinematicTree.from_urdf(URDF))
    with pytest.raises(TypeError):
        kitchen.demo_poses["cup"] = Pose()  # type: ignore[index]
    with pytest.raises(dataclasses.FrozenInstanceError):
        kitchen.start_surface = "x"  # type: ignore[misc]


@pytest.mark.parametrize(
    ("changes", "field", "says"),
    [
        ({"demo_objects": ("bowl", "spoon", "cup")}, "demo_poses", r"missing \['cup'\]"),
        ({"demo_attachments": {"fork": "box_main"}}, "demo_poses", r"extra \['fork'\]"),
        ({"demo_objects": ("bowl", "bowl")}, "demo_objects", "twice"),
        ({"start_surface": ""}, "start_surface", "non-empty"),
        (
            {"container": ContainerDescription("box_main", "box_main_joint", "box_handle", 0)},
            "container.opening",
            "> 0",
        ),
        ({"container": "box_main"}, "container", "ContainerDescription"),
        ({"floor_height": float("nan")}, "floor_height", "finite"),
        ({"demo_poses": {"bowl": (1, 0, 0), "spoon": Pose()}}, "demo_poses", "executive.Pose"),
    ],
)
def test_a_malformed_description_names_the_field(
    changes: dict[str, object], field: str, says: str
) -> None:
    with pytest.raises(KitchenDescriptionError, match=says) as e:
        make(**changes)
    assert e.value.field == field and e.value.kitchen == "k"
    assert isinstance(e.value, ValueError)


@pytest.mark.parametrize(
    ("changes", "field", "says"),
    [
        ({"table_surface": "island_tpo"}, "table_surface", "did you mean 'island_top'"),
        (
            {"container": ContainerDescription("box_main", "box_joint", "box_handle", 0.3)},
            "container.joint",
            "no joint 'box_joint'",
        ),
        (
            {"container": ContainerDescription("box_main", "box_handle_joint", "box_handle", 0.3)},
            "container.joint",
            "moves 'box_handle', not the container's link 'box_main'",
        ),
        ({"demo_attachments": {"spoon": "box"}}, "demo_attachments['spoon']", "no link 'box'"),
    ],
)
def test_a_description_that_does_not_fit_the_urdf_names_the_field(
    changes: dict[str, object], field: str, says: str
) -> None:
    kitchen = make(**changes)
    with pytest.raises(KitchenDescriptionError, match=says) as e:
        kitchen.validate(KinematicTree.from_urdf(URDF))
    assert e.value.field == field


def _kitchen_of(world: InMemoryWorld) -> KitchenDescription:
    async def read() -> KitchenDescription:
        async with executive.environment(executive.Environment("fake", world=world)):
            return executive.current_environment().kitchen

    return cpl.run(read)


def test_the_environment_hands_out_its_world_models_kitchen() -> None:
    kitchen = make()
    assert _kitchen_of(InMemoryWorld(kitchen=kitchen)) is kitchen
    with pytest.raises(NoKitchenDescription, match=r"InMemoryWorld.*kitchen=") as e:
        _kitchen_of(InMemoryWorld())
    assert executive.cram_name_of(e.value) == "no-kitchen-description"
