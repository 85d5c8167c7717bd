"""End to end in projection (real PyBullet): the pick-and-place walkthrough, one bowl
transport, and the table-setting demo."""

from __future__ import annotations

from typing import Any

import pytest

import cpl
import plans
from executive import Pose, a, an, current_environment, knowledge, perform
from executive.events import ContainerOpened, ObjectAttached
from kitchens.iai import DESCRIPTION as KITCHEN
from robots.pr2 import DESCRIPTION as PR2

projection = pytest.importorskip("projection")

ISLAND = "kitchen_island_surface"


def on_island(world, name: str) -> bool:
    (lx, ly, _), (hx, hy, hz) = world.link_aabb(ISLAND)
    x, y, z = world.object_pose(name).position
    return lx < x < hx and ly < y < hy and hz - 0.01 < z < hz + 0.3


def in_hand(world):
    wrist = world.link_pose("l_wrist_roll_link").to_transform()
    return (wrist.inverse() * world.object_pose("cup-1").to_transform()).matrix()


def run_projected(mrun, world, fn, *args):
    async def main():
        async with projection.with_projected_robot(world):
            return await fn(*args)

    return mrun(main)


def test_the_seeds_pick_and_place_with_the_seeds_numbers(mrun):
    # the seed's REPL: a cup at (0.5, 0.3, 1.0) picked from the origin with the left arm
    # and grasp top, carried to (-0.5, 0, 0) (clear of the island) and put down again
    world = projection.World(seed=1)
    world.spawn_object("cup-1", "cup", Pose((0.5, 0.3, 1.0)))
    look = Pose((0.7, 0.5, 0.8), frame="base_footprint")

    async def seed():
        await perform(an.action(type="going", target=a.location(pose=Pose())))
        await perform(an.action(type="looking", target=a.location(pose=look)))
        cup = await perform(an.action(type="detecting", object=an.object(type="cup")))
        await perform(an.action(type="picking-up", object=cup, arm="left", grasp="top"))
        assert world.object_pose("cup-1").position[2] > 1.05  # lifted
        before = in_hand(world)
        await perform(an.action(type="going", target=a.location(pose=Pose((-0.5, 0.0, 0.0)))))
        assert world.robot_pose().isclose(Pose((-0.5, 0.0, 0.0)), 1e-6, 1e-6)
        assert in_hand(world) == pytest.approx(before, abs=1e-3)
        await perform(an.action(type="placing", arm="left"))
        assert world.attachments == {}
        # put back down where the hand lifted it from, now in front of the moved robot
        assert world.object_pose("cup-1").position == pytest.approx((0.0, 0.3, 1.0), abs=0.02)

    run_projected(mrun, world, seed)


def test_pick_and_place_walkthrough(mrun):
    world = projection.World(seed=3)
    world.spawn_object("cup-1", "cup", Pose((1.3, 0.6, 0.9)))

    async def walkthrough():
        spot = a.location(pose=Pose((1.3, 0.6, 0.9)))
        await perform(an.action(type="navigating", location=Pose((0.75, 0.6, 0.0))))
        await perform(an.action(type="looking", target=spot))
        cup = await perform(an.action(type="detecting", object=an.object(type="cup")))
        picking = plans.check_picking_up_collisions(
            an.action(type="picking-up", object=cup, arm="left")
        )
        assert picking.reference().arguments["grasp"] in knowledge.grasps("cup")
        await perform(picking)
        before = in_hand(world)
        await perform(an.action(type="navigating", location=Pose((0.55, 0.6, 0.0))))
        assert world.robot_pose().isclose(Pose((0.55, 0.6, 0.0)), 1e-6, 1e-6)
        assert in_hand(world) == pytest.approx(before, abs=1e-3)  # the cup followed the hand
        target = Pose((1.25, 0.4, 0.9))
        await perform(
            plans.check_placing_collisions(
                an.action(type="placing", arm="left", target=a.location(pose=target))
            )
        )

    run_projected(mrun, world, walkthrough)
    assert world.attachments == {}
    assert world.object_pose("cup-1").distance_to(Pose((1.25, 0.4, 0.9))) < 0.05


def test_one_bowl_transport(mrun):
    """The plan returns its outcomes and tells an observer as it goes (issue 24): one
    transport of the bowl between ``TransportStarted`` and ``TransportEnded`` (the same
    outcome record, final by then), then ``TransportsOver`` before its final cleanup."""
    from plans.demo import TransportEnded, TransportsOver, TransportStarted

    world = projection.World(seed=1)
    seen: list[tuple[str, Any]] = []

    async def observed():
        env = current_environment()
        for kind in (TransportStarted, TransportEnded, TransportsOver):
            env.subscribe(kind, lambda e: seen.append((type(e).__name__, e)))
        return await plans.table_setting(("bowl",))

    projection.set_up_scene(world, ("bowl",), seed=1, settle_steps=0)
    outcome = run_projected(mrun, world, observed)
    assert outcome["bowl"].success
    assert on_island(world, "bowl-1") and world.attachments == {}
    assert [kind for kind, _ in seen] == ["TransportStarted", "TransportEnded", "TransportsOver"]
    assert seen[0][1].outcome is seen[1][1].outcome is outcome["bowl"]


def settled_moves(world, names, steps: int = 300) -> dict[str, float]:
    """How far (m) each object moves in ``steps`` more physics steps of the whole world."""
    import pybullet as pb

    before = {n: world.object_pose(n) for n in names}
    for _ in range(steps):
        pb.stepSimulation(physicsClientId=world.client)
    return {n: world.object_pose(n).distance_to(p) for n, p in before.items()}


@pytest.mark.slow
@pytest.mark.parametrize(
    "seed",
    [
        1,
        2,
        # seed 3: the cereal's fixed CRAM placing pose overlaps an object placed before it;
        # the stability check sees neighbours now and the cereal takes a fallback pose
        3,
    ],
)
def test_table_setting(mrun, seed):
    world = projection.World(seed=seed)
    projection.set_up_scene(world, KITCHEN.demo_objects, seed=seed, settle_steps=0)
    outcomes = run_projected(
        mrun, world, plans.table_setting, KITCHEN.demo_objects
    )  # mrun: no task alive, every transition legal
    assert list(outcomes) == list(KITCHEN.demo_objects)
    failed = {t: o.failure for t, o in outcomes.items() if not o.success}
    assert failed == {}
    for object_type, outcome in outcomes.items():
        assert on_island(world, outcome.name), object_type
    assert world.attachments == {}  # nothing held, the spoon no longer in the drawer
    assert world.joint_position("sink_area_left_upper_drawer_main_joint") == pytest.approx(
        0, abs=1e-6
    )
    for arm in PR2.arm_names:
        assert world.arm_joints(arm) == pytest.approx(PR2.arm(arm).state("park"), abs=1e-3)
    moves = settled_moves(world, [o.name for o in outcomes.values()])
    assert max(moves.values()) < 0.02, moves


def test_a_grasp_monitor_stops_a_projected_transport_at_the_next_motion(mrun):
    # a monitor in pursue that fires when the spoon is grasped: the transport's next
    # motion never starts (the spoon is not lifted, carried or placed), and its cleanup
    # still runs (the drawer is closed, nothing is held)
    world = projection.World(seed=1)
    fired = []

    async def main():
        async with projection.with_projected_robot(world):
            grasped = cpl.Fluent(False, name="spoon-grasped")
            current_environment().subscribe(
                ObjectAttached, lambda _e: setattr(grasped, "value", True)
            )

            async def monitor():
                await cpl.wait_for(grasped)
                fired.append(cpl.current_time())

            await cpl.pursue(monitor(), plans.table_setting(("spoon",)))

    projection.set_up_scene(world, ("spoon",), seed=1, settle_steps=0)
    mrun(main, name="grasp-monitor")
    assert len(fired) == 1
    at = fired[0]
    tree: Any = cpl.task_tree("grasp-monitor")
    goals: list[Any] = [
        n
        for n in cpl.walk(tree)
        if n.kind == "task" and n.start_time is not None and n.start_time >= at
    ]
    # every motion the plan itself would have gone on with was evaporated before it started
    # (or never reached a process module: an action yields between claiming its parts and
    # starting its plan, so the evaporation may land there, before the next motion exists)
    planned = [n for n in goals if any(p in ("fetch", "deliver") for p in n.path)]
    assert all(n.status is cpl.Status.EVAPORATED for n in planned)
    assert all(n.status is not cpl.Status.EVAPORATED for n in goals if n not in planned)
    assert not any(n.name.startswith("deliver") for n in cpl.walk(tree))
    assert not on_island(world, "spoon-1")
    # the demo's cleanup keeps holding what the robot holds (never drops it): the spoon is
    # in the hand it was grasped with, or was never taken out of the drawer
    assert set(world.attachments) <= {"spoon-1"}
    assert world.object_pose("spoon-1").position[2] > 0.5
    assert world.joint_position("sink_area_left_upper_drawer_main_joint") == pytest.approx(
        0, abs=1e-6
    )


def test_a_transport_evaporated_while_opening_the_drawer_closes_it(mrun):
    # the monitor fires when the drawer is open, in the middle of accessing: the
    # transport stops there (the spoon is not fetched) and its cleanup closes the drawer
    world = projection.World(seed=1)

    async def main():
        async with projection.with_projected_robot(world):
            opened = cpl.Fluent(False, name="drawer-opened")
            current_environment().subscribe(
                ContainerOpened, lambda _e: setattr(opened, "value", True)
            )
            await cpl.pursue(cpl.wait_for(opened), plans.table_setting(("spoon",)))

    projection.set_up_scene(world, ("spoon",), seed=1, settle_steps=0)
    mrun(main, name="drawer-monitor")
    tree: Any = cpl.task_tree("drawer-monitor")
    assert not any(n.name.startswith(("fetch", "deliver")) for n in cpl.walk(tree))
    assert not on_island(world, "spoon-1")
    assert not any(link.startswith(("l_", "r_")) for link in world.attachments.values())
    assert world.joint_position("sink_area_left_upper_drawer_main_joint") == pytest.approx(
        0, abs=1e-6
    )
