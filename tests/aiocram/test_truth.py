"""The truth observer: every invariant fails when the true world breaks it, and
"delivered" is measured on the true world, not taken from the plan or the belief."""

from __future__ import annotations

import math

import pytest

import cpl
from aiocram.truth import (
    NEAR_TARGET,
    TruthObserver,
    leaked_tasks,
    tilt_deg,
    where_is,
)
from executive import Pose


@pytest.fixture
def worlds():
    from projection import make_world_pair

    true_world, belief_world = make_world_pair(1, objects={})
    yield true_world, belief_world
    true_world.close()
    belief_world.close()


def _island_pose(world, dx=0.0, dy=0.0, half_height=0.03, roll=0.0):
    (x0, y0, _), (x1, y1, z1) = world.link_aabb("kitchen_island_surface")
    from scipy.spatial.transform import Rotation

    q = Rotation.from_euler("x", roll).as_quat()
    return Pose(((x0 + x1) / 2 + dx, (y0 + y1) / 2 + dy, z1 + half_height + 0.002), tuple(q))


def _observed(true_world, belief_world, tasks=()):
    """An observer that saw a clean end of the plan (no tasks, nothing held)."""
    obs = TruthObserver(true_world, belief_world, lambda: tasks)

    async def body():
        obs.body_returned()

    cpl.run(body, name="body")
    true_world.park_arms("park")
    obs.before_cleanup()
    return obs


def test_clean_end_holds_every_invariant(worlds):
    true_world, belief_world = worlds
    obs = _observed(true_world, belief_world)
    pose = _island_pose(true_world)
    true_world.spawn_object("bowl-1", "bowl", pose)
    obs.released_at["bowl-1"] = pose.position
    report = obs.measure({"bowl-1": True})
    assert all(report.invariants.values()), report.violations
    (truth,) = report.objects.values()
    assert truth.where == "island" and truth.delivered and not truth.phantom
    assert report.delivered == 1 and report.phantoms == 0 and report.cleanup_intervened == []


def test_leaked_task_fails_no_task_leaked(worlds):
    true_world, belief_world = worlds
    tasks: list[cpl.Task] = []
    obs = TruthObserver(true_world, belief_world, lambda: tasks)

    async def body():
        tasks.append(cpl.spawn(cpl.sleep(1000.0), name="forgotten"))
        obs.body_returned()  # the body returns with its child still running

    from cpl.testing import MockClock

    cpl.run(body, name="body", clock=MockClock())
    true_world.park_arms("park")
    obs.before_cleanup()
    report = obs.measure({})
    assert not report.invariants["no_task_leaked"]
    assert "forgotten" in report.violations["no_task_leaked"]


def test_leaked_asyncio_task_fails_no_task_leaked(worlds):
    """A plain asyncio task the plan started and left running: cpl would not even
    evaporate it. Before, the invariant saw only cpl tasks and passed."""
    import asyncio

    true_world, belief_world = worlds
    tasks: list[cpl.Task] = []
    obs = TruthObserver(true_world, belief_world, lambda: tasks)

    async def poller():
        await asyncio.sleep(1000.0)

    async def body():
        asyncio.get_running_loop().create_task(poller(), name="forgotten-poller")
        await cpl.sleep(0.1)
        obs.body_returned()

    from cpl.testing import MockClock

    cpl.run(body, name="body", clock=MockClock(), cleanup_timeout=1.0)
    true_world.park_arms("park")
    obs.before_cleanup()
    report = obs.measure({})
    assert not report.invariants["no_task_leaked"]
    assert "forgotten-poller" in report.violations["no_task_leaked"]


def test_leaked_tasks_keeps_the_current_task_and_its_ancestors():
    seen = []

    async def body():
        async def inner():
            me = cpl.current_task()
            assert me is not None and me.parent is not None
            seen.append(leaked_tasks([me, me.parent], me))

        await cpl.with_task(inner, name="inner")

    cpl.run(body, name="body")
    assert seen == [[]]


def test_unobserved_run_fails_rather_than_passes(worlds):
    true_world, belief_world = worlds
    obs = TruthObserver(true_world, belief_world, lambda: ())
    report = obs.measure({})
    for name in (
        "no_task_leaked",
        "nothing_attached_before_cleanup",
        "arms_at_rest_before_cleanup",
    ):
        assert not report.invariants[name]
        assert "never called" in report.violations[name]


def test_an_interrupted_run_checks_only_what_the_cleanup_left(worlds):
    """Ctrl-C evaporates the plan on purpose: the moments before the cleanup never come,
    so those checks are left out; the after-cleanup ones still run (and can fail)."""
    true_world, belief_world = worlds
    obs = TruthObserver(true_world, belief_world, lambda: ())
    report = obs.measure({}, interrupted=True)
    assert "no_task_leaked" not in report.invariants
    assert "nothing_attached_before_cleanup" not in report.invariants
    assert {"drawer_closed", "held_safely", "arms_parked"} <= set(report.invariants)


def test_held_object_and_unparked_arms_before_cleanup_are_reported(worlds):
    true_world, belief_world = worlds
    obs = TruthObserver(true_world, belief_world, lambda: ())

    async def body():
        obs.body_returned()

    cpl.run(body, name="body")
    true_world.spawn_object("cup-1", "cup", _island_pose(true_world, half_height=0.05))
    true_world.attach("cup-1", "r_wrist_roll_link")
    true_world.move_joints(right=[-1.0, 0.5, -1.0, -1.0, 0.0, -0.5, 0.0])
    obs.before_cleanup()
    # the cleanup releases and parks
    true_world.detach("cup-1")
    true_world.park_arms("park")
    report = obs.measure({"cup-1": False})
    assert not report.invariants["nothing_attached_before_cleanup"]
    assert "cup-1" in report.violations["nothing_attached_before_cleanup"]
    assert not report.invariants["arms_at_rest_before_cleanup"]
    assert report.cleanup_intervened == ["released cup-1", "parked the arms"]
    assert report.invariants["held_safely"] and report.invariants["arms_parked"]


def test_held_in_carry_after_cleanup_is_safe_but_a_free_arm_must_park(worlds):
    """The cleanup keeps holding what it holds, in ``carry``: that holds ``held_safely``;
    the other (free) arm at ``carry`` instead of ``park`` fails ``arms_parked``."""
    true_world, belief_world = worlds
    obs = _observed(true_world, belief_world)
    true_world.spawn_object("cup-1", "cup", _island_pose(true_world, half_height=0.05))
    true_world.attach("cup-1", "l_wrist_roll_link")
    true_world.park_arms("carry")
    report = obs.measure({"cup-1": True})
    assert report.invariants["held_safely"], report.violations
    assert not report.invariants["arms_parked"]
    assert report.violations["arms_parked"].startswith("right arm")
    assert report.objects["cup-1"].where == "hand" and report.objects["cup-1"].phantom
    assert report.invariants["no_object_lost"]  # in the hand is not lost


def test_held_by_an_arm_out_of_carry_is_not_held_safely(worlds):
    true_world, belief_world = worlds
    obs = _observed(true_world, belief_world)
    true_world.spawn_object("cup-1", "cup", _island_pose(true_world, half_height=0.05))
    true_world.attach("cup-1", "r_wrist_roll_link")
    true_world.move_joints(right=[-1.0, 0.5, -1.0, -1.0, 0.0, -0.5, 0.0])
    report = obs.measure({"cup-1": False}, settle_steps=0)
    assert not report.invariants["held_safely"]
    assert "cup-1 held by right arm" in report.violations["held_safely"]
    assert report.invariants["arms_parked"]  # the left arm, the only free one, is parked


def test_object_on_the_floor_is_lost_and_a_claimed_one_a_phantom(worlds):
    true_world, belief_world = worlds
    obs = _observed(true_world, belief_world)
    true_world.spawn_object("milk-1", "milk", Pose((0.0, 1.5, 0.2)))
    obs.released_at["milk-1"] = _island_pose(true_world).position  # the plan "placed" it
    report = obs.measure({"milk-1": True})
    truth = report.objects["milk-1"]
    assert truth.where == "floor" and not truth.delivered and truth.phantom
    assert not report.invariants["no_object_lost"]
    assert "milk-1 floor" in report.violations["no_object_lost"]
    assert report.phantoms == 1 and report.claimed == 1 and report.delivered == 0


def test_toppled_object_on_the_island_is_lost_not_delivered(worlds):
    true_world, belief_world = worlds
    obs = _observed(true_world, belief_world)
    pose = _island_pose(true_world, half_height=0.04, roll=math.pi / 2)
    true_world.spawn_object("breakfast-cereal-1", "breakfast-cereal", pose)
    obs.released_at["breakfast-cereal-1"] = pose.position
    report = obs.measure({"breakfast-cereal-1": True})
    truth = report.objects["breakfast-cereal-1"]
    assert truth.where == "island" and truth.toppled and truth.tilt_deg > 60
    assert not truth.delivered and truth.phantom
    assert not report.invariants["no_object_lost"]
    assert "toppled" in report.violations["no_object_lost"]


def test_upright_on_the_island_but_far_from_the_placing_pose_is_not_delivered(worlds):
    true_world, belief_world = worlds
    obs = _observed(true_world, belief_world)
    pose = _island_pose(true_world)
    true_world.spawn_object("bowl-1", "bowl", pose)
    obs.released_at["bowl-1"] = _island_pose(true_world, dy=NEAR_TARGET + 0.1).position
    report = obs.measure({"bowl-1": True})
    truth = report.objects["bowl-1"]
    assert truth.where == "island" and not truth.toppled
    assert not truth.delivered and truth.target_distance > NEAR_TARGET
    assert report.invariants["no_object_lost"]  # not lost: only misplaced


def test_never_released_object_is_not_delivered_even_on_the_island(worlds):
    true_world, belief_world = worlds
    obs = _observed(true_world, belief_world)
    true_world.spawn_object("bowl-1", "bowl", _island_pose(true_world))
    report = obs.measure({"bowl-1": False})
    assert not report.objects["bowl-1"].delivered and not report.objects["bowl-1"].phantom


def test_open_drawer_fails_drawer_closed(worlds):
    true_world, belief_world = worlds
    obs = _observed(true_world, belief_world)
    true_world.set_container(true_world.kitchen.container.joint, 0.2)
    report = obs.measure({})
    assert not report.invariants["drawer_closed"]
    assert "0.200" in report.violations["drawer_closed"]


def test_where_and_tilt(worlds):
    true_world, _ = worlds
    assert where_is(true_world, "nothing-1") == "gone"
    assert tilt_deg(Pose((0, 0, 0))) == pytest.approx(0.0)
    assert tilt_deg(Pose.from_xyz_yaw(0, 0, 0, 2.0)) == pytest.approx(0.0, abs=1e-6)


# ------------------------------------------------------------------ through the demo
def _one_bowl(**plan):
    from aiocram.demo import DemoConfig, run_demo

    return run_demo(DemoConfig(objects=("bowl",), seed=1, live=False), **plan)


def test_demo_reports_a_task_the_plan_leaked():
    from aiocram.demo import table_setting

    async def leaky(world, config):
        result = await table_setting(world, config)
        cpl.spawn(cpl.sleep(1e6), name="leaked-monitor")  # never joined
        return result

    report = _one_bowl(plan=leaky)
    assert not report.invariants["no_task_leaked"]
    assert "leaked-monitor" in report.violations["no_task_leaked"]


def test_demo_reports_a_cleanup_that_had_to_park(monkeypatch):
    import plans.demo

    real = vars(plans.demo)["park_arms"]
    skipped: list[str] = []

    async def forgetful(configuration="carry"):
        if configuration == "park" and not skipped:  # the plan's own final park
            skipped.append(configuration)
            return
        await real(configuration)

    async def no_table_check(*_args):  # it parks the arms to look: not the final park
        return None

    monkeypatch.setattr(plans.demo, "park_arms", forgetful)
    monkeypatch.setattr(plans.demo, "recheck_table", no_table_check)
    report = _one_bowl()
    assert skipped == ["park"]
    assert not report.invariants["arms_at_rest_before_cleanup"]
    assert report.truth.cleanup_intervened == ["parked the arms"]
    assert report.invariants["arms_parked"]  # the cleanup did park them
    record = report.to_json()
    assert record["cleanup_intervened"] == ["parked the arms"]
    assert record["objects"]["bowl"]["claimed"] is True


def test_demo_delivered_comes_from_the_true_world():
    """The plan claims the bowl placed; the true bowl is then knocked to the floor before
    the measurement: delivered 0, one phantom."""
    from aiocram.demo import table_setting

    async def knocked(world, config):
        result = await table_setting(world, config)
        world.set_object_pose("bowl-1", Pose((0.0, 1.6, 0.1)))
        return result

    report = _one_bowl(plan=knocked)
    assert report.claimed == 1
    assert report.delivered == 0
    assert report.truth.phantoms == 1
    assert not report.invariants["no_object_lost"]
