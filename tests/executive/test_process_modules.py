"""Process modules: exclusivity, status, cancellation cleanup, lifecycle, pm_execute."""

from __future__ import annotations

from typing import Any

import pytest

import cpl
from executive import (
    NavigationPoseUnreachable,
    NoProcessModule,
    PMStatus,
    Pose,
    ProcessModule,
    ProcessModuleGoalEvaporated,
    a,
    current_environment,
    environment,
    perform,
    pm_execute,
    with_process_modules,
)
from executive.testing import FakeProcessModule

HOME = Pose()


def going(x: float = 0.0) -> Any:
    return a.motion(type="going", pose=Pose((x, 0.0, 0.0)))


def test_two_concurrent_goals_run_one_after_the_other(mrun: Any) -> None:
    log: list[tuple[str, float, str]] = []

    class Logging(ProcessModule):
        motion_types = frozenset({"going"})

        async def execute(self, motion: Any) -> float:
            loop = __import__("asyncio").get_running_loop()
            x = motion.reference().arguments["pose"].position[0]
            log.append(("start", loop.time(), f"{x}"))
            await cpl.sleep(1.0)
            log.append(("end", loop.time(), f"{x}"))
            return float(x)

    pm = Logging()

    async def main() -> Any:
        async with with_process_modules(pm):
            return await cpl.par(perform(going(1)), perform(going(2)), perform(going(3)))

    mrun(main, name="exclusive")
    assert [(e, x) for e, _, x in log] == [
        ("start", "1.0"),
        ("end", "1.0"),
        ("start", "2.0"),
        ("end", "2.0"),
        ("start", "3.0"),
        ("end", "3.0"),
    ]
    starts = [t for e, t, _ in log if e == "start"]
    assert starts == sorted(starts) and starts[1] - starts[0] >= 1.0  # simulated clock
    assert pm.name == "logging"


def test_status_fluent_follows_the_goals(mrun: Any) -> None:
    pm = FakeProcessModule(
        "nav", accepts="going", delay=1.0, fail_on={2: NavigationPoseUnreachable}
    )
    seen: list[PMStatus] = []
    pm.status.on_update(seen.append)

    def status() -> PMStatus:
        return pm.status.value

    async def main() -> None:
        assert status() is PMStatus.OFFLINE
        async with with_process_modules(pm):
            assert pm.running and status() is PMStatus.IDLE
            await perform(going())
            with pytest.raises(NavigationPoseUnreachable):
                await perform(going())
            assert status() is PMStatus.FAILED
        assert not pm.running

    mrun(main, name="status")
    assert seen == [
        PMStatus.IDLE,
        PMStatus.RUNNING,
        PMStatus.IDLE,
        PMStatus.RUNNING,
        PMStatus.FAILED,
        PMStatus.OFFLINE,
    ]


def test_fifo_order_survives_a_failing_and_an_evaporated_goal(mrun: Any) -> None:
    pm = FakeProcessModule(
        "nav", accepts="going", delay=1.0, fail_on={1: NavigationPoseUnreachable}
    )

    async def main() -> None:
        async with with_process_modules(pm):
            t1 = cpl.spawn(perform(going(1)), name="g1")
            t2 = cpl.spawn(perform(going(2)), name="g2")
            t3 = cpl.spawn(perform(going(3)), name="g3")
            await cpl.sleep(0.5)
            t2.evaporate("not needed")  # still waiting its turn: it never runs
            with pytest.raises(NavigationPoseUnreachable):
                await t1.join()
            await t3.join()
            assert pm.pending == 0

    mrun(main, name="fifo")
    xs = [m.reference().arguments["pose"].position[0] for m in pm.calls]
    assert xs == [1.0, 3.0]
    assert pm.cancelled == []  # g2 never started, so no cleanup


def test_evaporating_a_running_goal_runs_on_cancel_once_shielded(mrun: Any) -> None:
    pm = FakeProcessModule("nav", accepts="going", delay=10.0, cancel_delay=0.5)

    async def main() -> None:
        async with with_process_modules(pm):
            caller = cpl.spawn(perform(going(1)), name="caller")
            await cpl.sleep(1.0)
            caller.evaporate("changed my mind")
            await caller.join()
            assert caller.state is cpl.Status.EVAPORATED

    mrun(main, name="cancel")
    assert len(pm.cancelled) == 1  # the hook ran once, and its 0.5 s sleep finished
    assert pm.completed == []
    tree = cpl.task_tree("cancel")
    assert tree is not None
    goal = tree.find("nav")
    assert goal is not None and goal.evaporated


def test_evaporating_only_the_goal_fails_the_caller(mrun: Any) -> None:
    pm = FakeProcessModule("nav", accepts="going", delay=10.0)

    async def main() -> None:
        async with with_process_modules(pm):
            caller = cpl.spawn(perform(going(1)), name="caller")
            await cpl.sleep(1.0)
            goal = next(c for c in caller.children if c.name == "nav")
            goal.evaporate("operator stop")
            with pytest.raises(ProcessModuleGoalEvaporated, match="operator stop"):
                await caller.join()

    mrun(main, name="goal-only")
    assert len(pm.cancelled) == 1


def test_a_slow_on_cancel_is_abandoned_after_its_timeout(mrun: Any) -> None:
    class Stuck(FakeProcessModule):
        cancel_timeout = 0.5

    pm = Stuck("nav", accepts="going", delay=10.0, cancel_delay=100.0)

    async def main() -> float:
        loop = __import__("asyncio").get_running_loop()
        async with with_process_modules(pm):
            caller = cpl.spawn(perform(going(1)), name="caller")
            await cpl.sleep(1.0)
            caller.evaporate()
            await caller.join()
            return float(loop.time())

    assert mrun(main, name="stuck") < 10.0
    assert len(pm.cancelled) == 1


def test_leaving_the_block_leaves_no_goal_running(mrun: Any) -> None:
    pm = FakeProcessModule("nav", accepts="going", delay=100.0)

    async def main() -> None:
        async with with_process_modules(pm):
            orphan = cpl.spawn(perform(going(1)), name="orphan")
            await cpl.sleep(1.0)
            assert pm.pending == 1
        assert pm.pending == 0
        assert pm.status.value is PMStatus.OFFLINE
        with pytest.raises(ProcessModuleGoalEvaporated, match="block"):
            await orphan.join()

    mrun(main, name="leave")
    assert len(pm.cancelled) == 1


def test_pm_execute_calls_one_module_by_name(mrun: Any) -> None:
    pm = FakeProcessModule("nav", accepts="going", result="done")

    async def main() -> Any:
        async with with_process_modules(pm):
            # pm-execute does not check matching, as in CRAM
            result = await pm_execute("nav", a.motion(type="moving-torso", joint_angle=0.1))
            with pytest.raises(NoProcessModule, match=r"no running process module named 'arms'"):
                await pm_execute("arms", going())
            return result

    assert mrun(main, name="pm-execute") == "done"


def test_goal_on_a_module_whose_block_was_left(mrun: Any) -> None:
    pm = FakeProcessModule("nav", accepts="going")

    async def main() -> None:
        async with with_process_modules(pm):
            env = current_environment()
        with pytest.raises(NoProcessModule, match="not running"):
            await pm._submit(going(), env)

    mrun(main, name="stale")


def test_process_module_needs_execute_and_a_good_name() -> None:
    with pytest.raises(TypeError):
        ProcessModule()  # type: ignore[abstract]
    with pytest.raises(TypeError, match="non-empty string"):
        FakeProcessModule("")
    with pytest.raises(ValueError, match="1-based"):
        FakeProcessModule("x", fail_on={0: NavigationPoseUnreachable})


def test_environment_rejects_non_modules(mrun: Any) -> None:
    async def main() -> None:
        async with environment(process_modules=["nav"]):  # type: ignore[list-item]
            pass

    with pytest.raises(TypeError, match="ProcessModule"):
        mrun(main, name="bad-env")


# -- every goal is a scheduling point ------------------------------------------------


def test_par_branches_interleave_motion_by_motion(mrun: Any) -> None:
    # an instantaneous module (its execute never awaits) still yields once per goal
    order: list[str] = []

    async def branch(name: str) -> None:
        for i in range(5):
            await perform(going(i))
            order.append(name)

    async def main() -> None:
        async with with_process_modules(FakeProcessModule(accepts="going")):
            await cpl.par(branch("A"), branch("B"))

    mrun(main)
    assert "".join(order) == "ABABABABAB"


def test_a_pursue_watcher_sees_every_motion(mrun: Any) -> None:
    ticks = [0]

    async def watcher() -> None:
        while True:
            ticks[0] += 1
            await cpl.sleep(0)

    async def ten() -> None:
        for i in range(10):
            await perform(going(i))

    async def main() -> None:
        async with with_process_modules(FakeProcessModule(accepts="going")):
            await cpl.pursue(watcher(), ten())

    mrun(main)
    assert ticks[0] >= 10


def test_an_evaporation_takes_effect_at_the_next_motion(mrun: Any) -> None:
    # a monitor fires during the third motion: the fourth never starts
    pm = FakeProcessModule(accepts="going")
    third = cpl.Fluent(False, name="third-motion")

    class Signalling(FakeProcessModule):
        async def execute(self, motion: Any) -> Any:
            if len(pm.calls) == 2:
                third.value = True
            return await pm.execute(motion)

    async def ten() -> None:
        for i in range(10):
            await perform(going(i))

    async def main() -> None:
        async with with_process_modules(Signalling(accepts="going")):
            await cpl.pursue(cpl.wait_for(third), ten())

    mrun(main)
    assert len(pm.calls) == 3 and len(pm.completed) == 3
