"""Projected time: projected motions take their modelled duration on the projection's own
timeline, monitors and time-outs count projected seconds, and no loop time passes.

``mrun`` runs on a MockClock: loop time would jump if a projected wait used it, so
``loop_elapsed == 0`` shows that imagined time is not loop time.
"""

from __future__ import annotations

import asyncio
import itertools
import math
from typing import Any

import pytest

import cpl
from executive import Pose, a, an, perform

projection = pytest.importorskip("projection")

from projection._real_body import (  # noqa: E402
    BASE_ANGULAR_VELOCITY,
    DETECTION_TIME,
    TORSO_VELOCITY,
)

#: a turn on the spot by pi: the longest part of this drive (3.14 s at 1 rad/s)
TURN = Pose.from_xyz_yaw(0.0, 0.0, 0.0, math.pi)
TURN_SECONDS = math.pi / BASE_ANGULAR_VELOCITY


@pytest.fixture(scope="module")
def world() -> Any:
    w = projection.World(seed=1)
    yield w
    w.close()


@pytest.fixture(autouse=True)
def _home(world: Any) -> None:
    world.drive(Pose())
    world.move_torso(0.1)


def loop_time() -> float:
    return asyncio.get_running_loop().time()


def test_a_projected_par_interleaves_motion_by_motion(mrun: Any, world: Any) -> None:
    order: list[str] = []

    async def branch(name: str) -> None:
        for i in range(5):
            await perform(an.motion(type="moving-torso", joint_angle=0.05 * i))
            order.append(name)

    async def main() -> None:
        async with projection.with_projected_robot(world):
            await cpl.par(branch("A"), branch("B"))

    mrun(main)
    assert "".join(order) == "ABABABABAB"


def test_a_pursue_watcher_sees_every_projected_motion(mrun: Any, world: Any) -> None:
    ticks = [0]
    seen: list[int] = []

    async def watcher() -> None:
        while True:
            ticks[0] += 1
            await cpl.sleep(0)

    async def ten() -> None:
        for i in range(10):
            await perform(an.motion(type="moving-torso", joint_angle=0.03 * (i % 3)))
            seen.append(ticks[0])

    async def main() -> None:
        async with projection.with_projected_robot(world):
            await cpl.pursue(watcher(), ten())

    mrun(main)
    assert len(seen) == 10
    assert all(later > earlier for earlier, later in itertools.pairwise(seen))  # ran between


def test_motions_take_their_modelled_duration(mrun: Any, world: Any) -> None:
    async def timed(motion: Any) -> float:
        start = cpl.current_time()
        await perform(motion)
        return cpl.current_time() - start

    async def detect_main() -> float:
        world.drive(Pose())
        world.spawn_object("cup-1", "cup", Pose((0.5, 0.3, 1.0)))  # the seed's scene
        try:
            async with projection.with_projected_robot(world):
                await perform(
                    a.motion(type="looking", pose=Pose((0.7, 0.5, 0.8), frame="base_footprint"))
                )
                start = cpl.current_time()
                await perform(an.motion(type="detecting", object=an.object(type="cup")))
                return cpl.current_time() - start
        finally:
            world.remove_object("cup-1")

    async def move_main() -> tuple[float, float, float]:
        start = loop_time()
        async with projection.with_projected_robot(world):
            torso = await timed(an.motion(type="moving-torso", joint_angle=0.2))
            turn = await timed(a.motion(type="going", pose=TURN))
        return torso, turn, loop_time() - start

    torso, turn, loop_elapsed = mrun(move_main)
    assert torso == pytest.approx(0.1 / TORSO_VELOCITY)
    assert turn == pytest.approx(TURN_SECONDS)
    assert loop_elapsed == 0.0
    assert mrun(detect_main) == pytest.approx(DETECTION_TIME)


def test_a_sleep_monitor_fires_after_projected_seconds_during_a_long_drive(
    mrun: Any, world: Any
) -> None:
    fired: list[float] = []

    async def monitor() -> None:
        await cpl.sleep(2)
        fired.append(cpl.current_time())

    async def drive_then_more() -> None:
        await perform(a.motion(type="going", pose=TURN))
        await perform(an.motion(type="moving-torso", joint_angle=0.3))  # never starts

    async def main() -> tuple[float, float]:
        start = loop_time()
        async with projection.with_projected_robot(world):
            t0 = cpl.current_time()
            await cpl.pursue(monitor(), drive_then_more())
            return t0, loop_time() - start

    t0, loop_elapsed = mrun(main)
    assert fired == [pytest.approx(t0 + 2.0)]
    assert loop_elapsed == 0.0
    assert world.torso_height == pytest.approx(0.1)  # evaporated before the next motion


def test_timeouts_in_projection_count_projected_seconds(mrun: Any, world: Any) -> None:
    async def main() -> tuple[float, Any, float, float]:
        start = loop_time()
        async with projection.with_projected_robot(world):
            t0 = cpl.current_time()
            with pytest.raises(cpl.PolicyTimeout):
                await cpl.with_policy(
                    cpl.timeout_policy(1.0), perform(a.motion(type="going", pose=TURN))
                )
            t1 = cpl.current_time()
            waited = await cpl.par(
                cpl.wait_for(cpl.Fluent(False), timeout=1.5),
                perform(an.motion(type="moving-torso", joint_angle=0.3)),  # 4 s
            )
            return t1 - t0, waited[0], cpl.current_time() - t1, loop_time() - start

    policy, waited, torso, loop_elapsed = mrun(main)
    assert policy == pytest.approx(1.0)
    assert waited is None and torso == pytest.approx(0.2 / TORSO_VELOCITY)
    assert loop_elapsed == 0.0


def test_imagined_tasks_are_stamped_in_projected_time(mrun: Any, world: Any) -> None:
    async def main() -> Any:
        async with projection.with_projected_robot(world):
            await perform(a.motion(type="going", pose=TURN))

    mrun(main, name="stamped")
    tree: Any = cpl.task_tree("stamped")
    goal: Any = next(n for n in cpl.walk(tree) if n.name == "navigation")
    assert goal.end_time - goal.start_time == pytest.approx(TURN_SECONDS)


def test_projection_takes_no_loop_time_on_a_real_time_loop(world: Any) -> None:
    # the demo's loop may run in real time (--speed 1); a minute of projected driving must
    # not take a minute: the run's 20 s timeout would fail the test
    async def main() -> float:
        async with projection.with_projected_robot(world):
            t0 = cpl.current_time()
            for _ in range(20):
                await perform(a.motion(type="going", pose=TURN))
                await perform(a.motion(type="going", pose=Pose()))
            return cpl.current_time() - t0

    assert cpl.run(main, clock=cpl.ScaledClock(1), timeout=20) == pytest.approx(40 * TURN_SECONDS)
