"""Which grasps hold a toppled object (plans.toppled, executive.knowledge): from above,
across no more than the gripper opens; a box on its broad face has none, and fetching it
fails at once with a typed, counted failure naming why (issue 26)."""

from __future__ import annotations

import logging
import math
from typing import Any

import pytest
from conftest import KITCHEN, PR2, hand_links, make_robot

import plans  # noqa: F401 - the action rules
from executive import ObjectUnfetchable, Pose, an, knowledge, perform
from executive.testing import InMemoryWorld
from plans import retry_ledger
from plans.toppled import ObjectToppledUngraspable
from projection._objects import OBJECT_TYPES

#: Lying with its x axis vertical (turned about y).
X_UP = (0.0, math.sqrt(0.5), 0.0, math.sqrt(0.5))
#: Lying with its y axis vertical (turned about x): a box on its x-z face.
Y_UP = (math.sqrt(0.5), 0.0, 0.0, math.sqrt(0.5))


def test_the_knowledge_sizes_are_the_projection_models_sizes() -> None:
    for name, model in OBJECT_TYPES.items():
        assert knowledge.object_knowledge(name).size == pytest.approx(model.size)


def test_a_carton_on_its_broad_face_is_held_from_above_across_its_width() -> None:
    milk = Pose((0.6, 0.0, 0.88), X_UP, frame="base_footprint")
    assert knowledge.is_lying(milk)
    fits = [g for g in knowledge.grasps("milk") if knowledge.fits_lying("milk", g, milk, 0.10)]
    assert fits == ["back"]  # approaches along the carton's x, now down; across 0.095 m
    assert knowledge.closing_width("milk", "back") == pytest.approx(0.095)
    # a gripper that opens 0.08 m (a Panda's) holds it on no side as it lies
    assert not [g for g in knowledge.grasps("milk") if knowledge.fits_lying("milk", g, milk, 0.08)]
    # on its narrow face: the side grasps from above, across its 0.06 m depth
    narrow = Pose((0.6, 0.0, 0.9), Y_UP, frame="base_footprint")
    assert [
        g for g in knowledge.grasps("milk") if knowledge.fits_lying("milk", g, narrow, 0.08)
    ] == ["left-side"]


def test_a_cereal_box_on_its_broad_face_has_no_grasp_that_fits() -> None:
    flat = Pose((0.6, 0.0, 0.885), Y_UP, frame="base_footprint")
    on_side = Pose((0.6, 0.0, 0.945), X_UP, frame="base_footprint")
    grasps = knowledge.grasps("breakfast-cereal")
    assert not [g for g in grasps if knowledge.fits_lying("breakfast-cereal", g, flat, 0.10)]
    # on its narrow side: the back grasp from above, across the 0.07 m thickness
    assert [g for g in grasps if knowledge.fits_lying("breakfast-cereal", g, on_side, 0.10)] == [
        "back"
    ]


def _flat_cereal_world() -> InMemoryWorld:
    return InMemoryWorld(
        objects={"breakfast-cereal-1": Pose((1.4, 0.6, 0.885), Y_UP)},
        types={"breakfast-cereal-1": "breakfast-cereal"},
        links=hand_links(PR2),
        robot=PR2,
        kitchen=KITCHEN,
    )


def test_fetching_a_box_on_its_broad_face_fails_at_once_naming_why(
    caplog: pytest.LogCaptureFixture,
) -> None:
    world = _flat_cereal_world()
    robot = make_robot(world)
    counts: dict[str, int] = {}
    name = "breakfast-cereal-1"

    async def go() -> None:
        with retry_ledger() as ledger:
            try:
                await perform(
                    an.action(
                        type="fetching",
                        object=an.object(
                            type="breakfast-cereal",
                            name=name,
                            pose=world.object_pose(name),
                            transform=world.object_pose(name, "base_footprint").to_transform(name),
                        ),
                    )
                )
            finally:
                counts.update(ledger)

    with caplog.at_level(logging.WARNING, logger="plans.toppled"):
        with pytest.raises(ObjectToppledUngraspable) as caught:
            robot.run(go)
    assert isinstance(caught.value, ObjectUnfetchable)  # CRAM's failure, more precisely
    message = str(caught.value)
    assert "0.19 x 0.29 m face" in message and "0.190 and 0.290 m across" in message
    assert "right 0.100 m" in message
    assert counts == {"toppled-ungraspable": 1}  # no relocation spent on it
    assert any("cannot be picked as it lies" in r.getMessage() for r in caplog.records)
    # as the search perceived it, before anything moved
    assert robot.calls("arms") == [] and robot.calls("grippers") == []
    assert robot.calls("navigation") == []


def test_picking_up_a_lying_carton_offers_only_the_grasps_that_fit() -> None:
    world = InMemoryWorld(
        objects={"milk-1": Pose((1.4, 0.6, 0.88), X_UP)},
        types={"milk-1": "milk"},
        links=hand_links(PR2),
        robot=PR2,
        kitchen=KITCHEN,
    )
    robot = make_robot(world)
    seen: list[Any] = []

    async def go() -> None:
        world.set_robot_pose(Pose((0.8, 0.6, 0.0)))
        milk = an.object(
            type="milk",
            name="milk-1",
            transform=world.object_pose("milk-1", "base_footprint").to_transform("milk-1"),
        )
        for _plan, arguments in an.action(type="picking-up", object=milk).solutions():
            seen.append((arguments["arm"], arguments["grasp"]))

    robot.run(go)
    assert {g for _a, g in seen} == {"back"} and {a for a, _g in seen} == {"right", "left"}


def test_a_leaning_box_keeps_every_grasp() -> None:
    """Tilted 30 degrees (leaning against a counter) or upside down: not toppled, every
    grasp is tried, as before; toppled past 45 degrees: only the grasps from above."""
    leaning = Pose((0.6, 0.0, 0.9), (0.0, math.sin(0.26), 0.0, math.cos(0.26)))
    assert not knowledge.is_lying(leaning)
    toppled = Pose((0.6, 0.0, 0.9), (0.0, math.sin(0.4), 0.0, math.cos(0.4)))
    assert knowledge.is_lying(toppled)
    upside_down = Pose((0.6, 0.0, 0.9), (1.0, 0.0, 0.0, 0.0))  # a spoon on its back
    assert not knowledge.is_lying(upside_down)
