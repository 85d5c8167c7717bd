"""Projection-then-execute on the simulated real robot: the same plan in projection and
for real, the real run using the imagined run's choices, the belief world learning only
from real perception, and real faults recovered by the plans' own retries."""

from __future__ import annotations

from typing import Any

import pytest

import cpl
import executive
import plans
from executive import an, perform
from kitchens.iai import DESCRIPTION as KITCHEN
from plans.demo import fetch_location, place_location
from projection import (
    FaultProfile,
    ProjectionImagination,
    World,
    make_world_pair,
    settle,
    with_projected_robot,
    with_real_robot,
)

BOWL_START = executive.Pose.from_xyz_yaw(1.4, 0.8, 0.88, 0.4)


def transport_bowl() -> Any:
    return an.action(
        type="transporting",
        object=an.object(type="bowl"),
        location=fetch_location("bowl", KITCHEN),
        target=place_location("bowl", kitchen=KITCHEN),
    )


def on_island(world: World, name: str) -> bool:
    (lx, ly, _), (hx, hy, hz) = world.link_aabb("kitchen_island_surface")
    x, y, z = world.object_pose(name).position
    return lx < x < hx and ly < y < hy and hz < z < hz + 0.1


def real_pair() -> tuple[World, World]:
    true, belief = make_world_pair(0, objects={})
    true.spawn_object("bowl-1", "bowl", BOWL_START)
    settle(true, 240)
    return true, belief


def test_the_same_transport_plan_succeeds_in_projection_and_for_real(mrun):
    world = World(seed=0)
    world.spawn_object("bowl-1", "bowl", BOWL_START)
    true, belief = real_pair()
    try:

        async def projected() -> Any:
            async with with_projected_robot(world):
                return await perform(transport_bowl())

        async def real() -> Any:
            async with with_real_robot(true, belief, FaultProfile(seed=0)):
                return await perform(transport_bowl())

        assert mrun(projected) is not None
        assert on_island(world, "bowl-1")
        assert mrun(real) is not None
        assert on_island(true, "bowl-1") and on_island(belief, "bowl-1")
        assert true.attachments == {} and belief.attachments == {}
    finally:
        for w in (world, true, belief):
            w.close()


def test_the_real_run_uses_the_base_poses_chosen_in_projection(mrun, checker):
    true, belief = real_pair()
    try:

        async def real() -> Any:
            async with with_real_robot(true, belief, FaultProfile(seed=0)):
                return await perform(transport_bowl())

        assert mrun(real, name="ptx") is not None
        root = next(t for t in checker.tasks if t.kind == "top-level")
        (real_run,) = cpl.find_tasks(root, name="real-run")
        imagined = cpl.find_tasks(root, pred=lambda t: t.name.startswith("projection-run"))
        assert len(imagined) == 3
        assert real_run.annotations is not None
        chosen = real_run.annotations["projected"]
        assert chosen.fetch_robot_location is not None
        # the navigating performed right before the real picking-up went to the chosen pose
        (pick_task, _), *_ = executive.performed(real_run, "picking-up")
        nav = executive.previous_performed(pick_task, "navigating")
        assert nav is not None
        _, nav_action = nav
        assert nav_action.get("location").reference() == chosen.fetch_robot_location.reference()
        # and the tree shows the imagined runs beside the real one
        assert real_run.parent is not None
        names = [t.name for t in real_run.parent.children]
        assert names[-4:] == [
            "projection-run-1",
            "projection-run-2",
            "projection-run-3",
            "real-run",
        ]
    finally:
        true.close()
        belief.close()


def test_the_belief_learns_from_perception_never_from_imagination(mrun, monkeypatch):
    true, belief = real_pair()
    saved: list[Any] = []
    restored_equal: list[bool] = []
    original_snapshot = ProjectionImagination.snapshot
    original_restore = ProjectionImagination.restore

    def snapshot(self: ProjectionImagination) -> Any:
        snap = original_snapshot(self)
        saved.append(snap)
        return snap

    def restore(self: ProjectionImagination, snap: Any) -> None:
        original_restore(self, snap)
        restored_equal.append(belief.snapshot().isclose(snap))

    monkeypatch.setattr(ProjectionImagination, "snapshot", snapshot)
    monkeypatch.setattr(ProjectionImagination, "restore", restore)
    try:
        assert belief.objects == {}

        async def real() -> Any:
            async with with_real_robot(true, belief, FaultProfile(seed=0)):
                return await perform(transport_bowl())

        assert mrun(real) is not None
        # imagining started from a belief that already knew the bowl (real perception)...
        assert saved and all("bowl-1" in [o[0] for o in s.objects] for s in saved)
        # ...and every restore put the belief back exactly as it was saved
        assert restored_equal and all(restored_equal)
        assert belief.objects == {"bowl-1": "bowl"}
    finally:
        true.close()
        belief.close()


@pytest.mark.parametrize("seed", [3, 4])
def test_real_faults_are_recovered_by_the_plans_own_retries(mrun, seed):
    """With grip slips and perception misses injected, the transport still succeeds and
    the plan shows the retries it used."""
    true, belief = real_pair()
    faults = FaultProfile(grasp_slip=0.5, perception=0.3, seed=seed)
    try:

        async def real() -> Any:
            async with with_real_robot(true, belief, faults):
                with plans.retry_ledger() as ledger:
                    result = await perform(transport_bowl())
                return result, dict(ledger)

        result, retries = mrun(real)
        assert result is not None
        assert sum(retries.values()) > 0, retries
        assert on_island(true, "bowl-1")
        assert true.attachments == {}
    finally:
        true.close()
        belief.close()
