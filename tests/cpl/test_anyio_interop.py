"""The anyio / asyncio interop contract of docs/async_interop.md, case by case.

Every scenario runs through a hang guard (``cpl_run``, ``run_app_guarded`` or
``call_guarded``): a cleanup that spins or livelocks fails the test with the task
tree instead of freezing the suite. Each contract point is tested in both directions where
it has two (anyio inside cpl, cpl inside anyio).
"""

from __future__ import annotations

import asyncio
import functools
import math
import threading
from typing import Any

import anyio
import pytest

import cpl
from cpl.testing import MockClock, TransitionChecker, call_guarded, run_app_guarded


def children(task: cpl.Task) -> dict[str, cpl.Status]:
    return {c.path_entry: c.state for c in task.children}


# ------------------------------------------------------------ cancel scopes inside plans
def test_move_on_after_inside_a_branch_is_not_a_failure(cpl_run: Any) -> None:
    log: list[Any] = []

    async def careful() -> str:
        with anyio.move_on_after(1.0) as scope:
            await cpl.sleep(5.0)
        log.append(("scope cancelled", scope.cancelled_caught, anyio.current_time()))
        await cpl.sleep(0.5)  # the task goes on after its scope
        return "careful done"

    async def sibling() -> str:
        await cpl.sleep(2.0)
        return "sibling done"

    assert cpl_run(cpl.par, careful, sibling) == ["careful done", "sibling done"]
    assert log == [("scope cancelled", True, 1.0)]


def test_explicit_cancel_scope_cancel_is_not_a_failure(cpl_run: Any) -> None:
    async def branch() -> str:
        with anyio.CancelScope() as scope:
            scope.cancel()
            await cpl.sleep(1.0)  # a cpl checkpoint raises the scope's cancellation
            raise AssertionError("not reached")
        return "left the scope"

    async def main() -> Any:
        me = cpl.current_task()
        assert me is not None
        res = await cpl.par(cpl.tag("b", branch), cpl.tag("s", cpl.sleep(1.0)))
        return res, children(me.children[0])

    res, states = cpl_run(main)
    assert res == ["left the scope", None]
    assert states == {"b": cpl.Status.SUCCEEDED, "s": cpl.Status.SUCCEEDED}


def test_fail_after_timeout_is_an_ordinary_failure_that_evaporates_siblings(
    cpl_run: Any,
) -> None:
    """A scope's cancellation that *escapes* the task (``fail_after`` turns it into
    ``TimeoutError``) is a failure like any other: ``par`` evaporates the siblings."""
    cleaned: list[str] = []

    async def sibling() -> None:
        try:
            await cpl.sleep(10.0)
        finally:
            cleaned.append("sibling finally")

    async def timed() -> None:
        with anyio.fail_after(1.0):
            await cpl.sleep(5.0)

    async def main() -> Any:
        me = cpl.current_task()
        assert me is not None
        with pytest.raises(TimeoutError):
            await cpl.par(cpl.tag("timed", timed), cpl.tag("sibling", sibling))
        return children(me.children[0])

    assert cpl_run(main) == {"timed": cpl.Status.FAILED, "sibling": cpl.Status.EVAPORATED}
    assert cleaned == ["sibling finally"]


@pytest.mark.parametrize("clock", ["mock", "system"])
def test_move_on_after_around_a_form_evaporates_its_branches(clock: str, cpl_run: Any) -> None:
    """A scope around a whole form (in the parent's task): the branches are evaporated and
    their finally blocks run; the parent leaves the scope and goes on, not failed."""
    cleaned: list[str] = []

    async def branch(name: str) -> None:
        try:
            await cpl.sleep(10.0)
        finally:
            cleaned.append(name)

    async def main() -> Any:
        with anyio.move_on_after(0.05) as scope:
            await cpl.par(cpl.tag("a", branch("a")), cpl.tag("b", branch("b")))
        await cpl.sleep(0.01)
        me = cpl.current_task()
        assert me is not None
        return scope.cancelled_caught, children(me.children[0])

    caught, states = cpl_run(main, clock=None if clock == "mock" else cpl.SystemClock())
    assert caught is True
    assert states == {"a": cpl.Status.EVAPORATED, "b": cpl.Status.EVAPORATED}
    assert sorted(cleaned) == ["a", "b"]


@pytest.mark.parametrize("clock", ["mock", "system"])
def test_move_on_after_around_a_form_whose_branch_cleans_up_awaiting(
    clock: str, cpl_run: Any
) -> None:
    """Issue 18's case: the branch's cleanup awaits (shielded) while the scope is cancelled.
    It must run once, fully, and the run must end on both clocks."""
    log: list[str] = []

    async def branch() -> None:
        try:
            await cpl.sleep(10.0)
        finally:
            log.append("cleanup start")
            await cpl.shielded(cpl.sleep(0.5))
            log.append("cleanup end")

    async def main() -> bool:
        with anyio.move_on_after(0.05) as scope:
            await cpl.par(branch, cpl.sleep(10.0))
        return scope.cancelled_caught

    c = MockClock() if clock == "mock" else cpl.SystemClock()
    assert cpl_run(main, clock=c, deadline=8.0) is True
    assert log == ["cleanup start", "cleanup end"]


# ------------------------------------------------- evaporation reaches anyio constructs
def test_evaporation_passes_through_an_uncancelled_scope_and_runs_finally(
    cpl_run: Any,
) -> None:
    """An anyio scope that was not cancelled itself does not swallow an evaporation: the
    task ends EVAPORATED (not SUCCEEDED after the scope), and its finally blocks run."""
    log: list[str] = []

    async def victim() -> None:
        try:
            with anyio.move_on_after(100.0):
                with anyio.CancelScope():
                    await anyio.sleep(50.0)
            log.append("after the scopes")  # must not happen
        finally:
            log.append("victim finally")

    async def main() -> cpl.Status:
        t = cpl.spawn(victim, "victim")
        await cpl.sleep(1.0)
        t.evaporate("test")
        await t.join()
        return t.state

    assert cpl_run(main) is cpl.Status.EVAPORATED
    assert log == ["victim finally"]


def test_evaporation_cancels_an_anyio_task_group_inside_the_task(cpl_run: Any) -> None:
    log: list[str] = []

    async def worker(name: str) -> None:
        try:
            await anyio.sleep(100.0)
        finally:
            log.append(f"{name} finally")

    async def branch() -> None:
        try:
            async with anyio.create_task_group() as tg:
                tg.start_soon(worker, "w1")
                tg.start_soon(worker, "w2")
        finally:
            log.append("branch finally")

    async def main() -> Any:
        # pursue: the short branch wins, the task-group branch is evaporated
        res = await cpl.pursue(cpl.tag("tg", branch), cpl.tag("short", cpl.sleep(1.0)))
        me = cpl.current_task()
        assert me is not None
        return res, children(me.children[0])

    res, states = cpl_run(main)
    assert res is None
    assert states == {"tg": cpl.Status.EVAPORATED, "short": cpl.Status.SUCCEEDED}
    assert sorted(log[:2]) == ["w1 finally", "w2 finally"]
    assert log[2] == "branch finally"  # the task group waited for its children first


# ----------------------------------- issue 18's decision: shields and threads under evaporation
def test_evaporation_goes_through_an_anyio_shield(cpl_run: Any) -> None:
    """Decision (docs/async_interop.md): evaporation is asyncio cancellation, which anyio
    does not shield against; ``anyio.CancelScope(shield=True)`` protects from anyio scopes
    only. Cleanup that must finish uses ``cpl.shielded``."""
    log: list[str] = []

    async def victim() -> None:
        try:
            with anyio.CancelScope(shield=True):
                await anyio.sleep(5.0)
                log.append("shielded body done")
        finally:
            log.append("finally")

    async def main() -> cpl.Status:
        t = cpl.spawn(victim, "victim")
        await cpl.sleep(1.0)
        t.evaporate("test")
        await t.join()
        return t.state

    assert cpl_run(main) is cpl.Status.EVAPORATED
    assert log == ["finally"]


def test_anyio_shield_does_protect_from_an_anyio_scope_inside_a_plan(cpl_run: Any) -> None:
    log: list[str] = []

    async def main() -> None:
        with anyio.move_on_after(1.0):
            with anyio.CancelScope(shield=True):
                await cpl.sleep(3.0)
                log.append(f"shielded body done at {anyio.current_time()}")

    cpl_run(main)
    assert log == ["shielded body done at 3.0"]


def test_cpl_shielded_cleanup_survives_evaporation(cpl_run: Any) -> None:
    log: list[str] = []

    async def park() -> None:
        await anyio.sleep(2.0)
        log.append("parked")

    async def victim() -> None:
        try:
            await cpl.sleep(10.0)
        finally:
            await cpl.shielded(park())

    async def main() -> cpl.Status:
        t = cpl.spawn(victim, "victim")
        await cpl.sleep(1.0)
        t.evaporate("test")
        await t.join()
        log.append(f"joined at {anyio.current_time()}")
        return t.state

    assert cpl_run(main) is cpl.Status.EVAPORATED
    assert log == ["parked", "joined at 3.0"]


def test_evaporation_detaches_to_thread_run_sync_without_abandon(cpl_run: Any) -> None:
    """Decision: evaporation does not wait for ``anyio.to_thread.run_sync`` (even with
    ``abandon_on_cancel=False``): the task ends at once and the thread runs on, its result
    lost. To wait for the thread, await it inside ``cpl.shielded`` (next test) or use a
    blocking process module, which also asks the driver to stop."""
    release = threading.Event()
    log: list[str] = []

    def blocking() -> str:
        log.append("thread started")
        release.wait(10.0)
        log.append("thread ended")
        return "result"

    async def victim() -> None:
        await anyio.to_thread.run_sync(blocking, abandon_on_cancel=False)
        log.append("not reached")

    async def main() -> cpl.Status:
        t = cpl.spawn(victim, "victim")
        while not log:
            await anyio.sleep(0.01)
        t.evaporate("test")
        await t.join()
        log.append("victim dead")
        release.set()
        return t.state

    assert cpl_run(main, clock=cpl.SystemClock()) is cpl.Status.EVAPORATED
    assert log[:2] == ["thread started", "victim dead"]
    # the thread ends once released (bounded wait: never hangs the test)
    release.set()
    for _ in range(500):
        if "thread ended" in log:
            break
        threading.Event().wait(0.01)
    assert log[2:] == ["thread ended"]


def test_cpl_shielded_waits_for_a_worker_thread_under_evaporation(cpl_run: Any) -> None:
    release = threading.Event()
    log: list[str] = []

    def blocking() -> str:
        log.append("thread started")
        release.wait(10.0)
        log.append("thread ended")
        return "result"

    async def victim() -> None:
        await cpl.shielded(anyio.to_thread.run_sync(blocking))

    async def main() -> cpl.Status:
        t = cpl.spawn(victim, "victim")
        while not log:
            await anyio.sleep(0.01)
        t.evaporate("test")
        await anyio.sleep(0.05)
        log.append("victim still alive" if t.alive else "victim dead early")
        release.set()
        await t.join()
        log.append("victim dead")
        return t.state

    assert cpl_run(main, clock=cpl.SystemClock()) is cpl.Status.EVAPORATED
    assert log == ["thread started", "victim still alive", "thread ended", "victim dead"]


# --------------------------------------------------------------------------- task groups
def test_anyio_task_group_inside_a_cpl_task(cpl_run: Any) -> None:
    order: list[str] = []

    async def worker(name: str, delay: float) -> None:
        await cpl.sleep(delay)  # cpl waits work in anyio child tasks
        order.append(name)

    async def main() -> list[str]:
        async with anyio.create_task_group() as tg:
            tg.start_soon(worker, "slow", 2.0)
            tg.start_soon(worker, "fast", 1.0)
        return order

    assert cpl_run(main) == ["fast", "slow"]


def test_cpl_forms_inside_anyio_task_group_children(cpl_run: Any) -> None:
    async def child(tag: str, out: dict[str, Any]) -> None:
        out[tag] = await cpl.par(cpl.sleep(1.0), cpl.tag(f"{tag}-value", _value(tag)))

    async def main() -> Any:
        out: dict[str, Any] = {}
        async with anyio.create_task_group() as tg:
            tg.start_soon(child, "x", out)
            tg.start_soon(child, "y", out)
        me = cpl.current_task()
        assert me is not None
        return out, sorted(c.path_entry for c in cpl.walk(me) if c.kind == "tag")

    out, tags = cpl_run(main)
    assert out == {"x": [None, "x"], "y": [None, "y"]}
    assert tags == ["x-value", "y-value"]  # the branches are in the cpl task tree


async def _value(v: str) -> str:
    await cpl.sleep(0.5)
    return v


def test_a_failure_in_a_task_group_child_evaporates_cpl_branches_inside_its_sibling(
    cpl_run: Any,
) -> None:
    cleaned: list[str] = []

    async def branch() -> None:
        try:
            await cpl.sleep(10.0)
        finally:
            cleaned.append("branch finally")

    async def forms() -> None:
        await cpl.par(cpl.tag("long", branch))

    async def boom() -> None:
        await cpl.sleep(1.0)
        raise cpl.PlanFailure("boom")

    async def main() -> None:
        async with anyio.create_task_group() as tg:
            tg.start_soon(forms)
            tg.start_soon(boom)

    with pytest.raises(ExceptionGroup) as info:
        cpl_run(main)
    assert [str(e) for e in info.value.exceptions] == ["boom"]
    assert cleaned == ["branch finally"]


def test_top_levels_inside_an_anyio_task_group(cpl_run: Any) -> None:
    """cpl forms inside anyio: top levels as task-group children of a plain anyio program,
    cancelled by the group's scope: the plans are evaporated and clean up."""
    cleaned: list[str] = []

    async def plan(name: str) -> None:
        try:
            await cpl.sleep(100.0)
        finally:
            cleaned.append(name)

    async def app() -> list[str]:
        async with anyio.create_task_group() as tg:
            tg.start_soon(cpl.top_level, plan, "p1")
            tg.start_soon(cpl.top_level, plan, "p2")
            await anyio.sleep(1.0)
            tg.cancel_scope.cancel()
        return sorted(cleaned)

    assert run_app_guarded(app, clock=MockClock()) == ["p1", "p2"]


# ---------------------------------------------------------------------------- embedding
def test_top_level_embedded_in_a_running_asyncio_application() -> None:
    """Two plans and a plain asyncio 'server' task share one loop; cancelling the asyncio
    task that awaits a top level evaporates that plan (its finally runs) and nothing else."""
    log: list[str] = []

    async def plan(name: str, n: int) -> str:
        try:
            for _ in range(n):
                await cpl.sleep(1.0)
            return f"{name} done"
        finally:
            log.append(f"{name} finally")

    async def server(stop: asyncio.Event) -> int:
        ticks = 0
        while not stop.is_set():
            await asyncio.sleep(0.5)
            ticks += 1
        return ticks

    async def app() -> Any:
        stop = asyncio.Event()
        srv = asyncio.create_task(server(stop))
        short = asyncio.create_task(cpl.top_level(plan, "short", 2, instruments=[checker]))
        long = asyncio.create_task(cpl.top_level(plan, "long", 100, instruments=[checker]))
        res = await short
        long.cancel()
        with pytest.raises(asyncio.CancelledError):
            await long
        stop.set()
        return res, await srv

    checker = TransitionChecker()
    res, ticks = run_app_guarded(app, clock=MockClock())
    assert res == "short done"
    assert ticks >= 4  # the server ran while the plan did (2 s of plan time)
    assert sorted(log) == ["long finally", "short finally"]
    assert len(checker.tasks) == 2
    checker.assert_clean()  # both plans dead, every transition legal


def test_top_level_inside_anyio_run_on_asyncio() -> None:
    async def plan() -> Any:
        return await cpl.par(_value("a"), _value("b"))

    async def main() -> Any:
        return await cpl.top_level(plan)

    assert call_guarded(anyio.run, main, wall_timeout=20.0) == ["a", "b"]


def test_trio_backend_is_refused_with_a_clear_error() -> None:
    pytest.importorskip("trio")

    async def plan() -> None:
        await cpl.sleep(0.0)

    async def main() -> None:
        await cpl.top_level(plan())  # a coroutine: closed by the refusal, no warning

    with pytest.raises(RuntimeError, match=r"asyncio only.*trio.*backend='asyncio'"):
        call_guarded(functools.partial(anyio.run, main, backend="trio"), wall_timeout=20.0)


def test_cpl_run_inside_a_running_loop_tells_to_await_top_level() -> None:
    async def plan() -> None:
        pass

    async def main() -> None:
        cpl.run(plan())

    with pytest.raises(RuntimeError, match=r"await cpl.top_level"):
        call_guarded(anyio.run, main, wall_timeout=20.0)


# ------------------------------------------------------ anyio primitives feeding fluents
def test_anyio_event_sets_a_fluent(cpl_run: Any) -> None:
    async def main() -> Any:
        door_open = cpl.Fluent(False, name="door-open")
        ev = anyio.Event()

        async def bridge() -> None:  # anyio -> fluent
            await ev.wait()
            door_open.value = True

        async def opener() -> None:
            await cpl.sleep(2.0)
            ev.set()

        async def waiter() -> float:
            await cpl.wait_for(door_open)
            return anyio.current_time()

        res = await cpl.par(bridge, opener, waiter)
        return res[2]

    assert cpl_run(main) == 2.0


def test_memory_object_stream_feeds_a_fluent_and_evaporation_stops_the_pump(
    cpl_run: Any,
) -> None:
    seen: list[float] = []
    closed: list[str] = []

    async def main() -> Any:
        send, receive = anyio.create_memory_object_stream[int](max_buffer_size=4)
        distance: cpl.Fluent[float] = cpl.Fluent(math.inf, name="distance")

        async def pump() -> None:  # stream -> fluent, forever
            try:
                async with receive:
                    async for d in receive:
                        distance.value = d
            finally:
                closed.append("pump finally")

        async def sensor() -> None:
            async with send:
                for d in (9, 7, 4, 2, 1):
                    await cpl.sleep(1.0)
                    await send.send(d)
                await cpl.sleep(100.0)  # keeps the stream open

        async def approach() -> float:
            async for _ in cpl.whenever(cpl.pulsed(distance)):
                seen.append(distance.value)
                if distance.value < 3:
                    return anyio.current_time()
            raise AssertionError("unreachable")

        # pursue: approach ends first; pump and sensor are evaporated
        return await cpl.pursue(pump, sensor, approach)

    assert cpl_run(main) == 4.0
    assert seen[-1] == 2 and seen == sorted(seen, reverse=True)
    assert closed == ["pump finally"]


def test_fluent_updated_from_a_worker_thread_through_anyio_from_thread(cpl_run: Any) -> None:
    async def main() -> list[int]:
        progress = cpl.Fluent(0, name="progress")
        seen: list[int] = []

        def driver() -> None:  # blocking code in a worker thread
            for k in range(1, 4):
                anyio.from_thread.run_sync(setattr, progress, "value", k)

        async def watch() -> None:
            async for _ in cpl.whenever(cpl.pulsed(progress, handle_missed="always")):
                seen.append(progress.value)
                if progress.value == 3:
                    return

        await cpl.par(watch, anyio.to_thread.run_sync(driver))
        return seen

    seen = cpl_run(main, clock=cpl.SystemClock())
    # Sets from the thread may land between two wake-ups of the watcher (it then reads the
    # latest value): what it sees only grows, and it ends at the last value.
    assert seen == sorted(seen) and seen[-1] == 3 and set(seen) <= {1, 2, 3}


def test_fluents_feed_anyio_code_outside_any_plan() -> None:
    """The other direction: plain anyio tasks of the application (outside every cpl task)
    wait on a fluent a plan sets, and receive its changes through a memory object stream."""

    async def app() -> Any:
        arrived = cpl.Fluent(False, name="arrived")
        position = cpl.Fluent(0, name="position")
        send, receive = anyio.create_memory_object_stream[int](max_buffer_size=10)
        got: list[int] = []
        waited: list[float] = []

        async def plan() -> None:
            for x in (1, 2, 3):
                await cpl.sleep(1.0)
                position.value = x
            arrived.value = True

        async def forward() -> None:  # fluent -> stream, in a cpl branch
            async with send:
                async for _ in cpl.whenever(cpl.pulsed(position, handle_missed="always")):
                    await send.send(position.value)
                    if position.value == 3:
                        return

        async def consumer() -> None:  # plain anyio code
            async with receive:
                async for x in receive:
                    got.append(x)

        async def waiter() -> None:  # plain anyio code waiting on a fluent
            await cpl.wait_for(arrived)
            waited.append(anyio.current_time())

        async with anyio.create_task_group() as tg:
            tg.start_soon(consumer)
            tg.start_soon(waiter)
            await cpl.top_level(cpl.par(plan(), forward()), name="producer")
        return got, waited

    assert run_app_guarded(app, clock=MockClock()) == ([1, 2, 3], [3.0])
