"""CRAM language features: policies, try_each_in_order, with_tags, task fluents,
handlers before unwinding, the CRAM `error` clause, and run timeouts."""

from __future__ import annotations

import asyncio
from typing import Any

import pytest

import cpl
from cpl.testing import MockClock, TransitionChecker, run_guarded


# ------------------------------------------------------------------------- policies
def test_timeout_policy_evaporates_an_overrunning_body_and_fails(mrun: Any) -> None:
    events: list[str] = []

    async def body() -> str:
        try:
            await cpl.sleep(10)
            return "finished"
        finally:
            events.append(f"body cleanup at {asyncio.get_running_loop().time():g}")

    async def main() -> Any:
        with pytest.raises(cpl.PolicyTimeout) as info:
            await cpl.with_policy(cpl.timeout_policy(2), body)
        return info.value

    failure = mrun(main)
    assert isinstance(failure, cpl.PolicyTimeout)
    policy: Any = failure.policy  # timeout_policy's class (and its seconds) is private
    assert policy is not None and policy.seconds == 2.0
    assert events == ["body cleanup at 2"]


def test_timeout_policy_returns_the_value_of_a_body_in_time(mrun: Any) -> None:
    async def body() -> str:
        await cpl.sleep(1)
        return "in time"

    async def main() -> Any:
        return await cpl.with_policy(cpl.timeout_policy(2), body)

    assert mrun(main) == "in time"


def test_policy_overrun_is_a_plan_failure_the_caller_can_retry(mrun: Any) -> None:
    durations = iter([5, 3, 1])
    attempts: list[int] = []

    async def body() -> str:
        d = next(durations)
        attempts.append(d)
        await cpl.sleep(d)
        return f"took {d}"

    async def main() -> Any:
        counter = cpl.RetryCounter(2)

        def again(_f: Any) -> None:
            if counter.do_retry():
                cpl.retry()

        return await cpl.with_failure_handling(
            lambda: cpl.with_policy(cpl.timeout_policy(2), body), {cpl.PolicyTimeout: again}
        )

    assert mrun(main) == "took 1"
    assert attempts == [5, 3, 1]


def test_policy_hooks_run_in_order_and_cleanup_survives_evaporation(mrun: Any) -> None:
    calls: list[str] = []
    trigger = cpl.Fluent(False)

    class Guard(cpl.Policy):
        name = "guard"

        def init(self) -> bool:
            calls.append("init")
            return True

        async def check(self) -> None:
            await cpl.wait_for(trigger)
            calls.append("check met")

        async def recover(self) -> None:
            await cpl.sleep(1)
            calls.append("recover")

        async def clean_up(self) -> None:
            await cpl.sleep(1)
            calls.append("clean_up")

    async def body() -> None:
        try:
            await cpl.sleep(100)
        finally:
            calls.append("body cleanup")

    async def main() -> None:
        async def flip() -> None:
            await cpl.sleep(3)
            trigger.value = True

        cpl.spawn(flip(), name="flip")
        with pytest.raises(cpl.PolicyConditionMet):
            await cpl.with_policy(Guard(), body)
        # evaporating the whole form: clean_up still runs, recover does not
        calls.append("--")
        trigger.value = False
        t = cpl.spawn(cpl.with_policy(Guard(), body), name="guarded")
        await cpl.sleep(1)
        t.evaporate("stop")
        await t.join()

    mrun(main)
    assert calls == [
        "init", "check met", "body cleanup", "recover", "clean_up",
        "--", "init", "body cleanup", "clean_up",
    ]  # fmt: skip


def test_policy_init_refusing_fails_without_running_the_body(mrun: Any) -> None:
    ran: list[str] = []

    class No(cpl.Policy):
        def init(self) -> bool:
            return False

    async def body() -> None:
        ran.append("body")

    async def main() -> None:
        with pytest.raises(cpl.PolicyInitFailed):
            await cpl.with_policy(No(), body)

    mrun(main)
    assert ran == []


def test_policy_misuse_errors_teach() -> None:
    with pytest.raises(ValueError, match="finite number of seconds"):
        cpl.timeout_policy(-1)

    async def main() -> None:
        await cpl.with_policy("5 seconds", lambda: cpl.sleep(1))  # type: ignore[arg-type]

    with pytest.raises(TypeError, match="timeout_policy"):
        cpl.run(main)


def test_with_policies_nests_first_outermost(mrun: Any) -> None:
    async def body() -> None:
        await cpl.sleep(10)

    async def main() -> Any:
        with pytest.raises(cpl.PolicyTimeout) as info:
            await cpl.with_policies([cpl.timeout_policy(5), cpl.timeout_policy(1)], body)
        policy: Any = info.value.policy  # timeout_policy's class is private
        return policy.seconds

    assert mrun(main) == 1.0


# ---------------------------------------------------------------- try_each_in_order
def test_try_each_in_order_over_values(mrun: Any) -> None:
    tried: list[str] = []

    async def grasp(kind: str) -> str:
        tried.append(kind)
        if kind != "top":
            cpl.fail(f"{kind} grasp failed")
        return kind

    async def main() -> Any:
        return await cpl.try_each_in_order(["front", "left", "top", "right"], grasp)

    assert mrun(main) == "top"
    assert tried == ["front", "left", "top"]  # "right" never tried


def test_try_each_in_order_all_fail_gives_composite_in_order(mrun: Any) -> None:
    async def grasp(kind: str) -> None:
        cpl.fail(kind)

    async def main() -> Any:
        with pytest.raises(cpl.CompositeFailure) as info:
            await cpl.try_each_in_order(iter(["a", "b"]), grasp)
        return [str(f) for f in info.value.failures]

    assert mrun(main) == ["a", "b"]


def test_try_each_in_order_lets_programming_errors_through(mrun: Any) -> None:
    async def broken(v: int) -> None:
        raise KeyError(v)

    async def main() -> None:
        with pytest.raises(KeyError):
            await cpl.try_each_in_order([1, 2], broken)
        assert await cpl.try_each_in_order([], broken) is None

    mrun(main)


# ------------------------------------------------------------------------ with_tags
def test_with_tags_can_be_referred_to_before_they_run(mrun: Any) -> None:
    seen: list[Any] = []

    async def grasp() -> str:
        await cpl.sleep(2)
        return "grasped"

    async def main() -> None:
        with cpl.with_tags("grasp", "watch") as tags:
            seen.append(tags["grasp"].state)

            async def watch() -> float:
                # waits on the tag's task before it started running
                await cpl.wait_for(cpl.task_dead(tags["grasp"]))
                return asyncio.get_running_loop().time()

            async def later_grasp() -> str:
                await cpl.sleep(1)
                return await tags.run("grasp", grasp())

            done_at, value = await cpl.par(tags.run("watch", watch()), later_grasp())
            seen.extend([done_at, value, tags["grasp"].state, tags["grasp"].result])

    mrun(main)
    assert seen == [cpl.Status.CREATED, 3.0, "grasped", cpl.Status.SUCCEEDED, "grasped"]


def test_a_tag_run_again_is_a_new_task_named_call_n(mrun: Any) -> None:
    async def main() -> list[str]:
        with cpl.with_tags("step") as tags:
            first = tags["step"]
            for i in range(3):
                await tags.run("step", cpl.sleep(i))
            return [first.path_entry, tags["step"].path_entry]

    assert mrun(main) == ["step", "step#3"]


def test_tags_never_run_are_evaporated_when_the_block_ends(mrun: Any) -> None:
    async def main() -> Any:
        with cpl.with_tags("never", "once") as tags:
            waiter = cpl.spawn(tags["never"].join(), name="waiter")
            await tags.run("once", cpl.sleep(1))
        await waiter.join()  # woken: the tag died without running
        with pytest.raises(KeyError, match="declared: \\['never', 'once'\\]"):
            tags["nope"]
        with pytest.raises(RuntimeError, match="after its with_tags block"):
            await tags.run("once", cpl.sleep(1))
        return tags["never"].state

    assert mrun(main) is cpl.Status.EVAPORATED


# ---------------------------------------------------------------------- task fluents
def test_task_fluents_follow_the_status_and_compose_in_nets(mrun: Any) -> None:
    async def work() -> None:
        await cpl.sleep(2)
        cpl.fail("no")

    async def main() -> list[Any]:
        t = cpl.Task(work(), name="work")
        alive, dead = cpl.task_alive(t), cpl.task_dead(t)
        failed, ok = cpl.task_failed(t), cpl.task_succeeded(t)
        out = [alive.value, dead.value]
        timeout = cpl.Fluent(False)
        t.start()
        await cpl.wait_for(cpl.fl_or(dead, timeout))
        out += [alive.value, dead.value, failed.value, ok.value]
        with pytest.raises(cpl.PlanFailure):
            await t.join()
        return out

    assert mrun(main) == [True, False, False, True, True, False]
    with pytest.raises(TypeError, match=r"cpl\.Task"):
        cpl.task_dead("work")  # type: ignore[arg-type]


# ------------------------------------------------------- handlers before unwinding
def test_before_unwinding_handler_sees_the_failing_state(mrun: Any) -> None:
    log: list[str] = []

    async def body() -> None:
        try:
            log.append("holding cup")
            cpl.fail("slipped")
        finally:
            log.append("cleanup: released cup")

    def handler(f: Any) -> None:
        log.append(f"handler: {f} (cup still held: {log[-1] == 'holding cup'})")

    async def main() -> None:
        for before in (True, False):
            log.append(f"-- before_unwinding={before}")
            with pytest.raises(cpl.PlanFailure):
                await cpl.with_failure_handling(
                    body, {cpl.PlanFailure: handler}, before_unwinding=before
                )

    mrun(main)
    assert log == [
        "-- before_unwinding=True",
        "holding cup",
        "handler: slipped (cup still held: True)",
        "cleanup: released cup",
        "-- before_unwinding=False",
        "holding cup",
        "cleanup: released cup",
        "handler: slipped (cup still held: False)",
    ]


def test_before_unwinding_retry_and_return_unwind_from_the_signal_point(mrun: Any) -> None:
    attempts: list[int] = []
    counter = cpl.RetryCounter(2)

    async def body() -> str:
        attempts.append(len(attempts))
        try:
            cpl.fail("again")
        finally:
            attempts.append(-1)  # cleanup runs after the handler chose retry

    def handler(_f: Any) -> None:
        if counter.do_retry():
            cpl.retry()
        cpl.return_("gave up")

    async def main() -> Any:
        return await cpl.with_failure_handling(
            body, [(cpl.PlanFailure, handler)], before_unwinding=True
        )

    assert mrun(main) == "gave up"
    assert attempts == [0, -1, 2, -1, 4, -1]


def test_before_unwinding_sees_a_child_failure_at_the_join_and_outer_retry_skips_inner(
    mrun: Any,
) -> None:
    order: list[str] = []
    outer_counter = cpl.RetryCounter(1)

    async def child() -> None:
        await cpl.sleep(1)
        cpl.fail("child failed")

    async def inner_body() -> None:
        try:
            await cpl.with_task(child(), name="child")
        finally:
            order.append("inner cleanup")

    def inner(_f: Any) -> None:
        order.append("inner declines")

    def outer(_f: Any) -> None:
        order.append("outer")
        if outer_counter.do_retry():
            cpl.retry()  # retries the OUTER form, through the inner one

    async def outer_body() -> None:
        order.append("outer body")
        await cpl.with_failure_handling(inner_body, {cpl.PlanFailure: inner}, before_unwinding=True)

    async def main() -> None:
        with pytest.raises(cpl.PlanFailure, match="child failed"):
            await cpl.with_failure_handling(
                outer_body, {cpl.PlanFailure: outer}, before_unwinding=True
            )

    mrun(main)
    assert order == [
        "outer body", "inner declines", "outer", "inner cleanup",
        "outer body", "inner declines", "outer", "inner cleanup",
    ]  # fmt: skip


def test_before_unwinding_handlers_must_be_sync() -> None:
    async def handler(_f: Any) -> None:
        pass

    async def main() -> None:
        await cpl.with_failure_handling(
            lambda: cpl.sleep(0), {cpl.PlanFailure: handler}, before_unwinding=True
        )

    with pytest.raises(TypeError, match="must be synchronous"):
        cpl.run(main)


def test_handlers_of_a_parent_never_run_in_a_child_task(mrun: Any) -> None:
    where: list[str | None] = []

    def handler(_f: Any) -> None:
        task = cpl.current_task()
        where.append(task.name if task else None)

    async def child() -> None:
        cpl.fail("x")

    async def body() -> None:
        await cpl.with_task(child(), name="child")

    async def main() -> None:
        with pytest.raises(cpl.PlanFailure):
            await cpl.with_failure_handling(body, {cpl.PlanFailure: handler}, before_unwinding=True)

    mrun(main)
    assert where == ["test"]  # the form's own task (the root), at the join


# ----------------------------------------------------------------- the error clause
def test_error_clause_is_cram_error_not_plan_failure(mrun: Any) -> None:
    caught: list[str] = []

    async def main() -> None:
        for exc in (KeyError("k"), cpl.PlanFailure("p")):

            async def body(exc: BaseException = exc) -> None:
                raise exc

            def on_error(f: Any) -> None:
                caught.append(type(f).__name__)
                cpl.return_()

            try:
                await cpl.with_failure_handling(body, {cpl.Error: on_error})
            except cpl.PlanFailure:
                caught.append("PlanFailure escaped")

    mrun(main)
    assert caught == ["KeyError", "PlanFailure escaped"]


# --------------------------------------------------------------------- run timeouts
def test_run_timeout_evaporates_and_raises_after_cleanup() -> None:
    cleaned: list[float] = []

    async def plan() -> None:
        try:
            await cpl.sleep(100)
        finally:
            await cpl.shielded(cpl.sleep(1))
            cleaned.append(asyncio.get_running_loop().time())

    checker = TransitionChecker()
    with pytest.raises(cpl.RunTimeout) as info:
        run_guarded(plan, clock=MockClock(), timeout=5, instruments=[checker])
    assert info.value.stuck == []
    assert cleaned == [6.0]
    checker.assert_clean()


def test_run_timeout_cannot_hang_on_a_cleanup_that_never_ends() -> None:
    async def plan() -> None:
        try:
            await cpl.sleep(100)
        finally:
            await cpl.shielded(asyncio.get_running_loop().create_future())  # never done

    with pytest.raises(cpl.RunTimeout, match="still alive") as info:
        run_guarded(plan, clock=MockClock(), timeout=5, cleanup_timeout=2, wall_timeout=20)
    assert [t.name for t in info.value.stuck] == ["plan"]


def test_top_level_timeout_and_bad_timeouts() -> None:
    async def app() -> Any:
        try:
            return await cpl.top_level(cpl.sleep, 10, timeout=1)
        except cpl.RunTimeout as exc:
            return type(exc).__name__

    def factory() -> asyncio.AbstractEventLoop:
        loop = asyncio.new_event_loop()
        MockClock().install(loop)
        return loop

    with asyncio.Runner(loop_factory=factory) as runner:  # embedded in a plain asyncio app
        assert runner.run(asyncio.wait_for(app(), 60)) == "RunTimeout"

    async def quick() -> str:
        return "done"

    assert cpl.run(quick, timeout=1) == "done"
    with pytest.raises(ValueError, match="timeout must be a finite"):
        cpl.run(quick, timeout=-1)
