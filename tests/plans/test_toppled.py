"""A milk carton knocked over on the sink counter is picked up from above and delivered
standing (issue 13: "a toppled box can still be picked, or set upright"; no CRAM plan
does this). The grasp is the carton's side grasp whose approach now points down
(:func:`executive.knowledge.grasp_poses`); the placing holds it by that grasp, now
horizontal, and puts the carton down upright. Measured in the true world."""

from __future__ import annotations

import math
from typing import Any

import pytest
from conftest import stage_lying_box, transport_counted, transport_for_real

import plans  # noqa: F401 - the action rules
from executive import Pose, knowledge
from projection import make_world_pair, settle

#: The carton on its side: its x axis (0.06 m) vertical, lying on its 0.095 x 0.20 face.
ON_ITS_SIDE = (0.0, math.sqrt(0.5), 0.0, math.sqrt(0.5))


def _tilt(pose: Pose) -> float:
    """Angle (rad) between the object's z axis and the vertical."""
    return math.acos(max(-1.0, min(1.0, float(pose.matrix()[2, 2]))))


def _transport_lying_milk(mrun: Any, monkeypatch: pytest.MonkeyPatch, lying_tilt: float) -> Any:
    monkeypatch.setattr(knowledge, "LYING_TILT", lying_tilt)
    true, belief = make_world_pair(0, belief_objects="exact")
    try:
        x, y, z = true.object_pose("milk-1").position
        true.set_object_pose("milk-1", Pose((x, y, z - 0.03), ON_ITS_SIDE))
        settle(true, 240)
        assert _tilt(true.object_pose("milk-1")) > math.radians(80)

        async def main() -> Any:
            return await transport_for_real(true, belief, "milk", "milk-1")

        try:
            mrun(main)
        except Exception as exc:  # the old grasps: the plan's typed failure
            outcome: Any = exc
        else:
            outcome = None
        settle(true, 240)
        return outcome, true.object_pose("milk-1"), true.link_aabb("kitchen_island_surface")
    finally:
        true.close()
        belief.close()


def test_a_milk_carton_lying_on_the_counter_is_delivered_standing(
    mrun: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    outcome, end, ((lx, ly, _), (hx, hy, hz)) = _transport_lying_milk(
        mrun, monkeypatch, knowledge.LYING_TILT
    )
    assert outcome is None
    x, y, z = end.position
    assert lx < x < hx and ly < y < hy and hz < z < hz + 0.15  # on the island
    assert _tilt(end) < math.radians(15)  # standing: "delivered" in the true world


def test_with_grasps_for_upright_objects_only_the_lying_carton_is_lost(
    mrun: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The same scene with every object treated as upright (the offsets along the lying
    carton's axis, as before): no pick succeeds and the carton stays on its side."""
    outcome, end, _island = _transport_lying_milk(mrun, monkeypatch, math.pi)
    assert outcome is not None and type(outcome).__name__ == "ObjectUnfetchable"
    assert _tilt(end) > math.radians(80)


def test_a_cereal_box_on_its_broad_face_fails_typed_and_counted_untouched(
    mrun: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Issue 26: a box lying on its broad face is wider than the gripper on every side
    that faces up. Where no end of it can be pushed over the counter's edge either (here:
    its centre must stay farther inside the edge than the box is long, so no push
    qualifies; see tests/plans/test_overhang.py for the push that works), the transport
    fails with :class:`plans.toppled.ObjectToppledUngraspable` naming both whys,
    counted, and the arm never touched the box (measured in the true world). Before,
    every relocation and pick check was spent on it (``ObjectUnfetchable``)."""
    import plans.overhang
    from plans.toppled import ObjectToppledUngraspable

    monkeypatch.setattr(plans.overhang, "OVERHANG_KEEP", 0.2)

    true, belief = make_world_pair(0, belief_objects="exact")
    name = "breakfast-cereal-1"
    try:
        before = stage_lying_box(true, name)
        counts: dict[str, int] = {}
        with pytest.raises(ObjectToppledUngraspable, match=r"0\.190 and 0\.290 m across") as info:
            transport_counted(mrun, true, belief, "breakfast-cereal", name, counts)
        assert "its centre would be" in str(info.value)
        assert "pushing" not in counts and "overhang-pushes" not in counts
        assert counts.get("toppled-ungraspable") == 1
        assert "relocations" not in counts  # no base pose was spent on it
        settle(true, 240)
        after = true.object_pose(name)
        assert math.dist(after.position, before.position) < 0.01  # never touched
    finally:
        true.close()
        belief.close()
