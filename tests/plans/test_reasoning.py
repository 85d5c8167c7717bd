"""Projection reasoning (``with_projected_task_tree``, ``pick_best_parameters_by_distance``)
against the fakes and in real PyBullet projection.

Fakes: the "real" robot and its imagination are two sets of fake process modules
(:func:`conftest.make_robot`) on the same :class:`InMemoryWorld`; :class:`FakeImagination`
snapshots / restores that world's state by copying it. Projection: the "real" environment
runs the projection process modules on a PyBullet world and imagines on the same world
(``ProjectionImagination(world)``), so imagined runs and the real one act on one world,
separated by snapshot / restore.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import AsyncIterator, Iterator
from contextlib import asynccontextmanager
from typing import Any

import pytest
from conftest import KITCHEN, PR2, base_poses, hand_links, location_generator, make_robot

import cpl
import executive
import plans
from cpl.testing import MockClock
from executive import (
    ObjectUnfetchable,
    PerceptionObjectNotFound,
    Pose,
    a,
    an,
    newest_effective,
    perform,
    performed,
    previous_performed,
)
from executive.testing import InMemoryWorld
from plans.reasoning import (
    ProjectedParameters,
    pick_best_parameters_by_distance,
    projected_parameters,
    route_cost,
    with_projected_task_tree,
)

CUP = Pose((1.3, 0.6, 0.9))
RUN_NAMES = ["projection-run-1", "projection-run-2", "projection-run-3"]


# ------------------------------------------------------------------------------- fakes
def projected(task: cpl.Task) -> Any:
    """The projected parameters annotated on a real run."""
    assert task.annotations is not None
    return task.annotations["projected"]


def world_state(world: InMemoryWorld) -> tuple[Any, ...]:
    """Everything of the in-memory world that plans change (poses are immutable)."""
    return (
        {n: dataclasses.replace(o) for n, o in world.objects.items()},
        world.robot_pose(),
        dict(world.links),
        dict(world._held),
        dict(world.joint_states),
    )


class FakeImagination:
    """An :class:`executive.Imagination` over an InMemoryWorld: snapshots copy its state;
    ``projection()`` runs ``robot``'s fake modules on it, marked ``projecting``."""

    def __init__(self, world: InMemoryWorld, robot: Any) -> None:
        self.world = world
        self.robot = robot
        self.taken: list[tuple[Any, ...]] = []
        self.restored: list[tuple[Any, ...]] = []

    def snapshot(self) -> tuple[Any, ...]:
        snap = world_state(self.world)
        self.taken.append(snap)
        return snap

    def restore(self, snapshot: tuple[Any, ...]) -> None:
        objects, robot, links, held, joints = snapshot
        w = self.world
        w.objects = {n: dataclasses.replace(o) for n, o in objects.items()}
        w.set_robot_pose(robot)
        w.links, w._held, w.joint_states = dict(links), dict(held), dict(joints)
        self.restored.append(world_state(w))

    @asynccontextmanager
    async def projection(self) -> AsyncIterator[executive.Environment]:
        env = executive.Environment(
            "imagination",
            process_modules=self.robot.pms.values(),
            world=self.world,
            rules=self.robot.rules,
            projecting=True,
        )
        async with executive.environment(env):
            yield env


def shifted_generator(offsets: list[float]) -> Any:
    """``reachable-for`` streams whose n-th created stream is :func:`base_poses` moved
    back by ``offsets[n]`` (0 once the list is used up): the imagined runs differ."""
    counter = itertools.count()

    def generate(d: executive.Designator) -> Iterator[Pose] | None:
        if "reachable-for" not in d:
            return location_generator(d)
        n = next(counter)
        back = offsets[n] if n < len(offsets) else 0.0
        target = d.get("location").reference()
        return (Pose((p.position[0] - back, p.position[1], 0.0)) for p in base_poses(target))

    return generate


def setup(offsets: list[float] | None = None, **imagination_fail_on: Any) -> Any:
    world = InMemoryWorld(
        objects={"cup-1": CUP},
        types={"cup-1": "cup"},
        links=hand_links(PR2),
        robot=PR2,
        kitchen=KITCHEN,
    )
    real = make_robot(world)
    dream = make_robot(world, **imagination_fail_on)
    if offsets is not None:
        generate = shifted_generator(offsets)  # one counter for both robots
        for robot in (real, dream):
            robot.rules = executive.static_rules.child("shifted")
            robot.rules.register_location_generator(generate, 15)
    return world, real, dream, FakeImagination(world, dream)


def run_real(robot: Any, imagination: Any, fn: Any, *, projecting: bool = False) -> Any:
    """Run ``fn()`` in the fake real environment; returns ``(root task, value)``."""

    async def main() -> Any:
        env = executive.Environment(
            "real",
            process_modules=robot.pms.values(),
            world=robot.world,
            rules=robot.rules,
            imagination=imagination,
            projecting=projecting,
        )
        async with executive.environment(env):
            return cpl.current_task(), await fn()

    return cpl.run(main, clock=MockClock())


def transporting(**props: Any) -> executive.ActionDesignator:
    return an.action(
        type="transporting",
        object=an.object(type="cup"),
        location=a.location(spots=1),
        target=a.location(spots=5),
        **props,
    )


def child(root: cpl.Task, name: str) -> cpl.Task:
    found = [t for t in cpl_walk(root) if t.name == name]
    assert len(found) == 1, (name, found)
    return found[0]


def cpl_walk(root: cpl.Task) -> Iterator[cpl.Task]:
    yield root
    for c in root.children:
        yield from cpl_walk(c)


def nav_pose_before(run: cpl.Task, outer: str, inner: str) -> Pose:
    """The pose the ``navigating`` before the run's successful ``inner`` went to."""
    (outer_task, _), *_ = performed(run, outer)
    inner_task, _ = performed(outer_task, inner)[-1]
    found = previous_performed(inner_task, "navigating")
    assert found is not None
    location = newest_effective(found[1].get("location"))
    assert location is not None
    pose: Pose = location.reference()
    return pose


# ------------------------------------------------------------------- fakes: behaviour
def test_the_real_run_uses_the_cheapest_imagined_base_poses():
    # Stream order: run-1 fetch, run-1 deliver, run-2 fetch, ... Run 2 places closest.
    world, real, _dream, imagination = setup(offsets=[0.0, 2.0, 0.0, 0.0, 0.0, 1.0])
    root, result = run_real(real, imagination, lambda: perform(transporting()))
    assert result is not None and world.attached() == []
    runs = [child(root, n) for n in RUN_NAMES]
    assert all(r.state is cpl.Status.SUCCEEDED for r in runs)
    real_run = child(root, "real-run")
    # the runs sit side by side under the transport task, the real run last
    parent = runs[0].parent
    assert parent is not None
    assert [t.name for t in parent.children][-4:] == [*RUN_NAMES, "real-run"]
    place_poses = [nav_pose_before(r, "delivering", "placing") for r in runs]
    # all runs clean: the cheapest route wins (run 1's deliver stream is moved back 2 m)
    assert all(r.annotations is not None for r in runs) and real_run.annotations is not None
    costs = [r.annotations["assessment"].cost for r in runs if r.annotations is not None]
    assert all(c is not None for c in costs) and len(set(costs)) == 3
    best = costs.index(min(costs))
    assert costs[0] > min(costs)
    assert real_run.annotations["chosen"] == RUN_NAMES[best]
    chosen = projected(real_run)
    assert chosen == projected_parameters(runs[best])
    assert nav_pose_before(real_run, "fetching", "picking-up") == nav_pose_before(
        runs[best], "fetching", "picking-up"
    )
    assert nav_pose_before(real_run, "delivering", "placing") == place_poses[best]
    # the real robot drove there (fake navigation: the last drives, each followed by a
    # back-off of the base before the arms are parked)
    drives = [m.reference().arguments["pose"] for m in real.calls("navigation", "going")]
    assert drives[-4] == nav_pose_before(runs[best], "fetching", "picking-up")
    assert drives[-2] == place_poses[best]
    backs = [round(d.distance_to(g), 3) for d, g in zip(drives[-4::2], drives[-3::2])]
    assert backs == [0.25, 0.25]
    # injection: the fetching got the location designator and the pick-up action
    (_, fetching), *_ = performed(real_run, "fetching")
    assert fetching.get("robot-location") is chosen.fetch_robot_location
    assert fetching.get("pick-up-action") is chosen.pick_up_action
    (_pick_task, picking), *_ = performed(real_run, "picking-up")
    grounded = chosen.pick_up_action.reference().arguments
    assert (picking.get("arm"), picking.get("grasp")) == (grounded["arm"], grounded["grasp"])
    (_, delivering), *_ = performed(real_run, "delivering")
    assert delivering.get("place-action") is chosen.place_action
    (_, placing), *_ = performed(real_run, "placing")
    # the robot stands where projection put it, so the re-anchored target is the same pose
    injected = chosen.place_action.get("target").reference()
    assert placing.get("target").reference().isclose(injected, 1e-9, 1e-9)


def test_injected_placing_target_is_anchored_in_the_map():
    """A real robot that stopped short of the projected base pose still places the object
    where projection meant it (in the map), not at the same offset from where it stands."""
    from executive import Pose
    from plans.deliver import _injected_spot

    projected_base = Pose.from_xyz_yaw(-0.2, 1.5, 0.0, math.pi)
    target = Pose((0.55, 0.1, 0.85), frame="base_footprint")
    place = an.action(type="placing", target=a.location(pose=target))
    spot = _injected_spot(place, a.location(pose=projected_base))
    assert spot is not None and spot.frame == "map"
    assert spot.position == pytest.approx((-0.75, 1.4, 0.85))
    assert _injected_spot(None, a.location(pose=projected_base)) is None
    map_target = Pose((-0.8, 1.2, 0.9))
    assert (
        _injected_spot(an.action(type="placing", target=a.location(pose=map_target)), None)
        == map_target
    )


def test_imagined_runs_leave_the_belief_world_unchanged():
    _world, real, _dream, imagination = setup()
    run_real(real, imagination, lambda: perform(transporting()))
    before = imagination.taken[0]
    assert len(imagination.restored) == 4  # before each of the 3 runs and after the last
    assert all(state == before for state in imagination.restored)


def test_an_imagined_failure_does_not_fail_the_real_run():
    # Run 1: every picking-up probe (2 arms x the cup's 5 grasps x straight/from above)
    # fails at each of the 11 base poses it tries (the 4 of its region, then the plan's
    # own, until fetching's 10 relocations run out) -> object-unfetchable.
    world, real, _dream, imagination = setup()
    world.fail_probe["arm"] = {n: True for n in range(1, 20 * 11 + 1)}
    root, result = run_real(real, imagination, lambda: perform(transporting()))
    run1, run2, _ = (child(root, n) for n in RUN_NAMES)
    assert run1.state is cpl.Status.FAILED and isinstance(run1.failure, ObjectUnfetchable)
    assert run2.state is cpl.Status.SUCCEEDED
    assert result is not None and world.attached() == []
    assert projected(child(root, "real-run")) == projected_parameters(run2)


def test_without_a_successful_run_nothing_is_injected():
    # The imagination never perceives the cup; the real robot does.
    fail = {n: PerceptionObjectNotFound for n in range(1, 10_000)}
    world, real, _dream, imagination = setup(perception=fail)
    root, result = run_real(real, imagination, lambda: perform(transporting()))
    runs = [child(root, n) for n in RUN_NAMES]
    assert all(r.state is cpl.Status.FAILED for r in runs)
    assert pick_best_parameters_by_distance(runs, Pose()) is None
    real_run = child(root, "real-run")
    assert "projected" not in (real_run.annotations or {})
    (_, fetching), *_ = performed(real_run, "fetching")
    assert "robot-location" not in fetching and "pick-up-action" not in fetching
    assert result is not None and world.attached() == []


@pytest.mark.parametrize("how", ["projecting", "disabled", "no-imagination"])
def test_pass_through(how):
    world, real, _dream, imagination = setup()
    props = {"projection_reasoning": False} if how == "disabled" else {}
    root, result = run_real(
        real,
        None if how == "no-imagination" else imagination,
        lambda: perform(transporting(**props)),
        projecting=how == "projecting",
    )
    assert result is not None and world.attached() == []
    names = {t.name for t in cpl_walk(root)}
    assert not names & {*RUN_NAMES, "real-run"}
    assert imagination.taken == []


def test_evaporation_during_imagination_restores_the_belief_world():
    world, real, dream, imagination = setup()
    dream.pms["perception"].delay = 5.0  # imagined detections take a while
    seen: list[Any] = []

    async def go() -> None:
        transport = cpl.spawn(perform(transporting()), name="transport")
        while not dream.pms["perception"].calls:
            await cpl.sleep(0.5)
        await cpl.sleep(1.0)  # the imagined robot has moved (and is perceiving)
        seen.append(world_state(world))
        transport.evaporate()
        assert await transport.join() is None

    run_real(real, imagination, go)
    before = imagination.taken[0]
    assert seen[0] != before  # imagination had changed the world
    assert world_state(world) == before
    assert imagination.restored[-1] == before


def test_a_body_failure_outside_the_plan_failures_propagates_after_restoring():
    world, real, _dream, imagination = setup()

    async def body(_params: ProjectedParameters) -> None:
        world.set_robot_pose(Pose((5.0, 5.0, 0.0)))
        raise RuntimeError("bug")

    with pytest.raises(RuntimeError, match="bug"):
        run_real(real, imagination, lambda: with_projected_task_tree(body))
    assert world.robot_pose() == Pose()


def test_pick_sees_each_run_and_the_start_pose():
    world, real, _dream, imagination = setup()
    world.set_robot_pose(Pose((0.1, 0.2, 0.0)))
    seen: list[Any] = []

    def pick(runs, start):
        seen.append(([r.name for r in runs], start))
        return ProjectedParameters()

    async def body(params: ProjectedParameters) -> str:
        if executive.current_environment().projecting:
            raise executive.ObjectUnfetchable()
        return "real"

    _root, result = run_real(real, imagination, lambda: with_projected_task_tree(body, 2, pick))
    assert result == "real"
    assert seen == [(["projection-run-1", "projection-run-2"], Pose((0.1, 0.2, 0.0)))]


def test_route_cost_is_distance_plus_angle():
    start = Pose()
    there = Pose.from_xyz_yaw(3.0, 4.0, 0.0, 0.5)
    back = Pose.from_xyz_yaw(3.0, 0.0, 0.0, -0.5)
    assert route_cost([start, there, back]) == pytest.approx(5.0 + 0.5 + 4.0 + 1.0)
    assert route_cost([start]) == 0


# ---------------------------------------------------------------------- real projection
projection = pytest.importorskip("projection")


class RecordingImagination:
    """ProjectionImagination that records the belief world after each restore."""

    def __init__(self, world: Any) -> None:
        from projection._imagination import ProjectionImagination

        self.inner = ProjectionImagination(world)
        self.world = world
        self.taken: list[Any] = []
        self.restored: list[Any] = []
        self.inside: list[Any] = []

    def snapshot(self) -> Any:
        self.taken.append(self.inner.snapshot())
        return self.taken[-1]

    def restore(self, snapshot: Any) -> None:
        if self.restored:
            self.inside.append(self.world.snapshot())  # what the last run left
        self.inner.restore(snapshot)
        self.restored.append(self.world.snapshot())

    def projection(self) -> Any:
        return self.inner.projection()


def projected_real_run(mrun, world, imagination, fn, *args):
    from projection._locations import location_rules
    from projection._process_modules import projection_process_modules
    from projection._world_model import ProjectedWorldModel

    async def main():
        env = executive.Environment(
            "real",
            process_modules=projection_process_modules(world),
            world=ProjectedWorldModel(world),
            rules=location_rules(world),
            imagination=imagination,
        )
        async with executive.environment(env):
            return cpl.current_task(), await fn(*args)

    return mrun(main)


def test_projection_imagination_is_an_imagination():
    from projection._imagination import ProjectionImagination

    world = projection.World(seed=1)
    try:
        imagination: executive.Imagination = ProjectionImagination(world)
        snap = imagination.snapshot()
        world.drive(Pose((0.3, 0.0, 0.0)))
        imagination.restore(snap)
        assert world.snapshot() == snap
        with pytest.raises(TypeError):
            ProjectionImagination(InMemoryWorld())  # type: ignore[arg-type]
    finally:
        world.close()


def test_one_bowl_with_projection_reasoning(mrun):
    world = projection.World(seed=1)
    imagination = RecordingImagination(world)
    try:
        projection.set_up_scene(world, ("bowl",), seed=1, settle_steps=0)
        root, outcome = projected_real_run(mrun, world, imagination, plans.table_setting, ("bowl",))
        assert outcome["bowl"].success
        (transport, _), *_ = performed(root, "transporting")
        names = [t.name for t in transport.children]
        assert names[-4:] == [*RUN_NAMES, "real-run"]
        runs = [child(transport, n) for n in RUN_NAMES]
        real_run = child(transport, "real-run")
        assert all(r.state is cpl.Status.SUCCEEDED for r in runs)
        picked = projected(real_run)
        assert picked in [projected_parameters(r) for r in runs]
        fetch_base = newest_effective(picked.fetch_robot_location)
        deliver_base = newest_effective(picked.deliver_robot_location)
        assert fetch_base is not None and deliver_base is not None
        assert nav_pose_before(real_run, "fetching", "picking-up") == fetch_base.reference()
        assert nav_pose_before(real_run, "delivering", "placing") == deliver_base.reference()
        # the imagined runs changed the world, and each restore put it back exactly (the
        # transport's projection is the last snapshot: before it, the search imagined its
        # viewpoints, each restore back to its own snapshot)
        before = imagination.taken[-1]
        assert imagination.restored[-4:] == [before] * 4
        assert set(imagination.restored) <= set(imagination.taken)
        assert any(state != before for state in imagination.inside)
        assert world.attachments == {}
    finally:
        world.close()


def test_reasoning_inside_projection_is_a_pass_through(mrun):
    world = projection.World(seed=1)
    try:

        async def main():
            async with projection.with_projected_robot(world) as env:
                assert env.projecting
                return cpl.current_task(), await plans.table_setting(("bowl",))

        projection.set_up_scene(world, ("bowl",), seed=1, settle_steps=0)
        root, outcome = mrun(main)
        assert outcome["bowl"].success
        assert not {t.name for t in cpl_walk(root)} & {*RUN_NAMES, "real-run"}
    finally:
        world.close()
