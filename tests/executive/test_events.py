"""Environments (isolation, derivation, world model) and events."""

from __future__ import annotations

from typing import Any

import pytest

import cpl
from executive import (
    Environment,
    NoWorldModel,
    PerceptionObjectNotInWorld,
    Pose,
    WorldModel,
    a,
    an,
    current_environment,
    emit,
    environment,
    events,
    perform,
    subscribe,
    with_process_modules,
)
from executive.events import (
    ContainerClosed,
    ContainerOpened,
    Event,
    ObjectAttached,
    ObjectDetached,
    ObjectPerceived,
    RobotStateChanged,
    object_name,
)
from executive.testing import FakeProcessModule, InMemoryWorld
from robots.pr2 import DESCRIPTION as PR2


def test_two_concurrent_environments_do_not_touch_each_other(mrun: Any) -> None:
    real_nav = FakeProcessModule("navigation", accepts="going", result="real", delay=1.0)
    proj_nav = FakeProcessModule("navigation", accepts="going", result="projected", delay=1.0)
    real_world = InMemoryWorld({"cup": Pose((1, 0, 0))})
    proj_world = InMemoryWorld({"cup": Pose((9, 0, 0))})
    seen: dict[str, list[Event]] = {"real": [], "projection": []}

    async def run_in(name: str, world: InMemoryWorld, pm: FakeProcessModule) -> tuple[Any, ...]:
        async with environment(name=name, world=world, process_modules=[pm]):
            subscribe(Event, seen[name].append)
            results = []
            for _ in range(3):
                results.append(await perform(a.motion(type="going", pose=Pose())))
                emit(RobotStateChanged(reason=name))
                await cpl.sleep(0.1)
            assert current_environment().name == name
            return (*results, current_environment().world.object_pose("cup").position[0])

    async def main() -> Any:
        return await cpl.par(
            run_in("real", real_world, real_nav), run_in("projection", proj_world, proj_nav)
        )

    real, projected = mrun(main, name="isolated")
    assert real == ("real", "real", "real", 1.0)
    assert projected == ("projected", "projected", "projected", 9.0)
    assert len(real_nav.calls) == 3 and len(proj_nav.calls) == 3
    assert [e.reason for e in seen["real"]] == ["real"] * 3  # type: ignore[attr-defined]
    assert [e.reason for e in seen["projection"]] == ["projection"] * 3  # type: ignore[attr-defined]
    assert real_world.robot_state_changes == 3 and proj_world.robot_state_changes == 3


def test_with_process_modules_derives_from_the_current_environment(mrun: Any) -> None:
    world = InMemoryWorld({"cup": Pose()})
    nav = FakeProcessModule("navigation", accepts="going")
    arms = FakeProcessModule("arms", accepts="moving-tcp")
    got: list[Event] = []

    async def main() -> None:
        async with environment(name="outer", world=world, process_modules=[nav]) as outer:
            subscribe(ObjectAttached, got.append)
            async with with_process_modules(arms) as inner:
                assert inner.parent is outer and inner.is_within(outer)
                assert [pm.name for pm in inner.process_modules] == ["navigation", "arms"]
                assert inner.world is world
                emit(ObjectAttached("cup", "left"))  # reaches the outer subscriber
                await perform(a.motion(type="moving-tcp", left_pose=Pose()))
                await perform(a.motion(type="going", pose=Pose()))
            assert not arms.running and nav.running
            assert current_environment() is outer

    mrun(main, name="derived")
    assert got == [ObjectAttached("cup", "left")]
    assert len(arms.calls) == 1 and len(nav.calls) == 1


def test_events_reach_the_world_model_first_then_subscribers(mrun: Any) -> None:
    world = InMemoryWorld({"cup-1": Pose((1, 0, 0.8))}, types={"cup-1": "cup"})
    order: list[str] = []
    cup = an.object(type="cup", name="cup-1")

    def on_attach(e: ObjectAttached) -> None:
        order.append(f"subscriber saw attached={world.attached('left')}")

    async def main() -> None:
        async with environment(world=world):
            events.subscribe(ObjectAttached, on_attach)
            unsubscribe = subscribe(Event, lambda e: order.append(type(e).__name__))
            events.emit(ObjectAttached(cup, "left", "l_wrist_roll_link"))
            emit(ContainerOpened("drawer", 0.3))
            emit(ContainerClosed(an.object(name="drawer"), 0.1))
            emit(ObjectPerceived(cup))
            unsubscribe()
            emit(ObjectDetached(cup, "left"))
            with pytest.raises(TypeError, match="Event"):
                emit("attached")  # type: ignore[arg-type]
            with pytest.raises(TypeError, match="event class"):
                subscribe("ObjectAttached", print)  # type: ignore[arg-type]

    mrun(main, name="events")
    assert order == [
        "subscriber saw attached=['cup-1']",
        "ObjectAttached",
        "ContainerOpened",
        "ContainerClosed",
        "ObjectPerceived",
    ]
    assert world.attached() == []
    assert world.objects["cup-1"].attached_to is None
    assert world.joint_states == {"drawer": pytest.approx(0.2)}
    assert world.perceived == [cup]
    assert [type(e).__name__ for e in world.events] == [
        "ObjectAttached",
        "ContainerOpened",
        "ContainerClosed",
        "ObjectPerceived",
        "ObjectDetached",
    ]


def test_events_are_frozen_records() -> None:
    e = ObjectAttached("cup", "left", "l_wrist_roll_link")
    with pytest.raises(AttributeError):
        e.arm = "right"  # type: ignore[misc]
    assert e == ObjectAttached("cup", "left", "l_wrist_roll_link")
    assert ContainerOpened.cram_name == "container-opening-event"


def test_outside_any_environment() -> None:
    emit(RobotStateChanged())  # nobody listens: nothing happens
    with pytest.raises(RuntimeError, match="no executive environment is active"):
        subscribe(Event, print)
    with pytest.raises(NoWorldModel, match="world="):
        current_environment().world  # noqa: B018


def test_in_memory_world_is_a_world_model() -> None:
    world = InMemoryWorld(
        {"cup": Pose((2, 1, 0))}, robot_pose=Pose.from_xyz_yaw(1, 1, 0), robot=PR2
    )
    assert isinstance(world, WorldModel)
    assert world.object_pose("cup").position == (2.0, 1.0, 0.0)
    in_base = world.object_pose("cup", frame="base_footprint")
    assert in_base.frame == "base_footprint"
    assert in_base.position == pytest.approx((1.0, 0.0, 0.0))
    with pytest.raises(PerceptionObjectNotInWorld, match=r"no object 'bowl'.*cup"):
        world.object_pose("bowl")
    with pytest.raises(ValueError, match="frames"):
        world.object_pose("cup", frame="camera")
    world.set_robot_pose(Pose((5, 0, 0)))
    assert world.robot_pose().position == (5.0, 0.0, 0.0)


def test_object_name() -> None:
    assert object_name("cup") == "cup"
    assert object_name(an.object(name="cup-1")) == "cup-1"
    assert object_name(an.object(urdf_name="drawer_1")) == "drawer_1"
    with pytest.raises(ValueError, match="names no object"):
        object_name(an.object(type="cup"))


def test_environment_construction_errors(mrun: Any) -> None:
    env = Environment("x")

    async def main() -> None:
        async with environment(env, world=InMemoryWorld()):
            pass

    with pytest.raises(TypeError, match="not both"):
        mrun(main, name="env-both")
    with pytest.raises(TypeError, match="RuleSet"):
        Environment(rules="static")  # type: ignore[arg-type]
    assert "x" in repr(env)
