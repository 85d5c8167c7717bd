"""The overhang grasp (issue 26): a cereal box lying on its broad face (wider than the
gripper on every side that faces up) is pushed over the counter's edge by the hand and
grasped by the end that sticks out, from the side. The geometry on its own; the recovery
on the simulated real robot, measured in the TRUE world (PyBullet's contacts and friction
move the box: the plans never set an object's pose)."""

from __future__ import annotations

import math
from typing import Any

import pytest
from conftest import ON_ITS_BROAD_FACE, stage_lying_box, tilt, transport_counted

import plans  # noqa: F401 - the action rules
from executive import Pose, knowledge
from plans import retry_ledger
from projection import make_world_pair, settle

#: A counter 1 m square from (0, 0).
COUNTER = (0.0, 0.0, 1.0, 1.0)
CEREAL = "breakfast-cereal"


def test_the_side_grasps_fit_a_box_on_its_broad_face_only_across_its_thickness() -> None:
    assert hasattr(knowledge, "fits_overhanging")
    lying = Pose((0.0, 0.0, 0.0), ON_ITS_BROAD_FACE)
    upright = Pose((0.0, 0.0, 0.0))
    for grasp in ("back", "front"):
        assert knowledge.fits_overhanging(CEREAL, grasp, lying, 0.10)  # 0.07 m across
        assert not knowledge.fits_overhanging(CEREAL, grasp, lying, 0.06)  # narrower
        assert not knowledge.fits_overhanging(CEREAL, grasp, upright, 0.10)  # fingers level
        assert not knowledge.fits_lying(CEREAL, grasp, lying, 0.10)  # never from above


def test_the_overhang_is_measured_against_the_edge_the_grasp_approaches() -> None:
    from plans.overhang import (
        OVERHANG_ACROSS,
        OVERHANG_HOLD,
        OVERHANG_KEEP,
        OVERHANG_MARGIN,
        OVERHANG_SLACK,
        overhang_geometry,
    )

    needed = OVERHANG_HOLD + OVERHANG_MARGIN
    # the back grasp approaches along the box's +x: the gripper comes from -x, so the
    # box's -x end (0.095 m from its centre) must stick out over the x = 0 edge
    box = Pose((0.3, 0.5, 0.9), ON_ITS_BROAD_FACE)
    fit = overhang_geometry(CEREAL, "back", box, COUNTER)
    u, out, push, inset = fit.direction, fit.overhang, fit.push, fit.inset
    assert u == pytest.approx((-1.0, 0.0))
    assert out == pytest.approx(-(0.3 - 0.095))  # 0.205 m short of the edge
    assert push == pytest.approx(0.205 + needed + OVERHANG_SLACK)
    assert inset == pytest.approx(0.095 - needed - OVERHANG_SLACK)
    assert inset >= OVERHANG_KEEP  # fits: its centre stays on the counter
    # the front grasp: towards the x = 1 edge
    fit = overhang_geometry(CEREAL, "front", box, COUNTER)
    u, out = fit.direction, fit.overhang
    assert u == pytest.approx((1.0, 0.0)) and out == pytest.approx(-(1.0 - 0.3 - 0.095))
    # sticking out enough already: no push
    ready = Pose((0.095 - needed - 0.005, 0.5, 0.9), ON_ITS_BROAD_FACE)
    fit = overhang_geometry(CEREAL, "back", ready, COUNTER)
    out, push = fit.overhang, fit.push
    assert out == pytest.approx(needed + 0.005) and push == 0.0
    # turned 40 degrees: one corner of the end sticks out farther; it is held there,
    # OVERHANG_ACROSS from the middle of the end, and pushed less far than the box's
    # middle would need
    yaw = math.radians(40)
    turned = Pose((0.3, 0.5, 0.9), ON_ITS_BROAD_FACE).to_transform()
    turned = Pose.from_xyz_yaw(0.0, 0.0, 0.0, yaw).to_transform() * turned
    m = turned.matrix()
    m[:3, 3] = (0.3, 0.5, 0.9)
    from executive import Transform

    fit = overhang_geometry(CEREAL, "back", Transform.from_matrix(m).to_pose(), COUNTER)
    middle = (0.3 - 0.095 * math.cos(yaw)) / math.cos(yaw)  # along the push, to the edge
    assert fit.across == pytest.approx(-OVERHANG_ACROSS)
    assert 0.0 < fit.push < middle + needed and fit.inset >= OVERHANG_KEEP
    with pytest.raises(ValueError, match="not over the footprint"):
        overhang_geometry(CEREAL, "back", Pose((1.5, 0.5, 0.9), ON_ITS_BROAD_FACE), COUNTER)


def test_a_cereal_box_on_its_broad_face_is_pushed_over_the_edge_and_delivered(
    mrun: Any,
) -> None:
    """Before, the transport failed at once with ``ObjectToppledUngraspable`` and the box
    never moved. Now the hand pushes it towards the sink counter's front edge until its
    end sticks out, grasps that end from the side and delivers it: measured in the true
    world, the box left the sink counter and stands on the island."""
    true, belief = make_world_pair(0, belief_objects="exact")
    name = "breakfast-cereal-1"
    try:
        before = stage_lying_box(true, name)
        counts: dict[str, int] = {}
        transport_counted(mrun, true, belief, CEREAL, name, counts)
        assert counts.get("overhang-pushes", 0) >= 1
        assert "toppled-ungraspable" not in counts
        settle(true, 240)
        after = true.object_pose(name)
        (lx, ly, _), (hx, hy, hz) = true.link_aabb("kitchen_island_surface")
        x, y, z = after.position
        assert math.dist(after.position, before.position) > 0.5  # it left the sink
        assert lx < x < hx and ly < y < hy and hz < z < hz + 0.3  # on the island
        assert name not in true.attachments
        assert tilt(after) < math.radians(15)  # standing: "delivered" in the true world
    finally:
        true.close()
        belief.close()


def test_imagined_the_push_leaves_the_box_overhanging_and_the_transport_goes_on(
    mrun: Any,
) -> None:
    """In projection no contact moves a pushed object: the imagination puts the box where
    the push was planned to leave it (sticking out over the edge), so the imagined
    transport picks it by that end and delivers it, as the real one does. Before, the
    imagined transport failed with ``ObjectToppledUngraspable``."""
    from executive import an, perform
    from plans.demo import fetch_location, place_location
    from projection import with_projected_robot

    true, belief = make_world_pair(0, belief_objects="exact")
    true.close()
    name = "breakfast-cereal-1"
    try:
        stage_lying_box(belief, name)
        counts: dict[str, int] = {}

        async def main() -> Any:
            with retry_ledger() as ledger:
                try:
                    async with with_projected_robot(belief):
                        return await perform(
                            an.action(
                                type="transporting",
                                object=an.object(type=CEREAL, name=name),
                                location=fetch_location(CEREAL),
                                target=place_location(CEREAL, bowl_placed=False),
                                projection_reasoning=False,
                            )
                        )
                finally:
                    counts.update(ledger)

        mrun(main)
        assert counts.get("overhang-pushes", 0) >= 1
        (lx, ly, _), (hx, hy, hz) = belief.link_aabb("kitchen_island_surface")
        x, y, z = belief.object_pose(name).position
        assert lx < x < hx and ly < y < hy and hz < z < hz + 0.3  # imagined on the island
    finally:
        belief.close()


def test_bad_overhang_inputs_are_typed_errors_naming_what_to_fix() -> None:
    from executive import GripperDescription

    with pytest.raises(ValueError, match="finger_reach must be a finite distance >= 0"):
        GripperDescription(("f",), 0.1, 0.05, 0.0, 10.0, finger_reach=-0.01)
    lying = Pose((0.0, 0.0, 0.0), ON_ITS_BROAD_FACE)
    identity = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
    with pytest.raises(ValueError, match=r"grasp depth must be 0 to 0\.190 m"):
        knowledge.grasp_poses(CEREAL, "back", lying, identity, depth=0.3)
    with pytest.raises(ValueError, match="grasp across must be a finite distance"):
        knowledge.grasp_poses(CEREAL, "back", lying, identity, across=math.nan)
    # the depth and the place across move the tool frame in the object frame only so
    grasp = knowledge.grasp_poses(CEREAL, "back", Pose(), identity, depth=0.01, across=-0.07)[2]
    assert grasp.position == pytest.approx((-0.095 + 0.01, 0.0, -0.07))
