"""Retention policies of the recorded task tree (issue 28): what a run keeps in memory."""

from __future__ import annotations

import gc
import io
import weakref
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from rich.console import Console

import cpl
from cpl._eventlog import load_events
from cpl.display import LiveTaskTree, render_text


async def leaf() -> str:
    await cpl.sleep(0)
    return "done"


async def step(i: int) -> str:
    """One top-level child with a grandchild: what a perform leaves (plan + goal)."""
    return await cpl.with_task(leaf(), name="leaf")


async def broken() -> None:
    await cpl.sleep(0)
    cpl.fail("the gripper slipped")


async def service(n: int, *, fail_at: int | None = None) -> cpl.Task:
    """A service loop in one top level: n steps, one of them failing (caught)."""
    for i in range(n):
        if i == fail_at:
            with pytest.raises(cpl.PlanFailure):
                await cpl.with_task(broken(), name="step", arguments={"i": i})
            continue
        await cpl.with_task(step(i), name="step", arguments={"i": i})
    root = cpl.current_task()
    assert root is not None
    while root.parent is not None:
        root = root.parent
    return root


def policies(tmp_path: Path) -> Iterator[cpl.Retention]:
    yield cpl.KeepAll()
    yield cpl.KeepRecent(3)
    yield cpl.KeepRecent(3, records=2, freeze=True)
    yield cpl.StreamFinished(tmp_path / "stream.jsonl", full=3)
    yield cpl.KeepRecent(0, records=10_000, freeze=True)  # the long-running default


def policy_ids() -> list[str]:
    return ["keep-all", "keep-recent", "keep-recent-bounded", "stream", "long-running"]


@pytest.fixture(params=range(5), ids=policy_ids())
def policy(request: pytest.FixtureRequest, tmp_path: Path) -> cpl.Retention:
    return list(policies(tmp_path))[request.param]


# ------------------------------------------------------------------ bounded tree


def test_node_count_stays_bounded_over_5000_steps() -> None:
    counts: list[int] = []

    async def main() -> None:
        root = cpl.current_task()
        assert root is not None
        for i in range(5000):
            await cpl.with_task(step(i), name="step")
            if i % 1000 == 999:
                counts.append(sum(1 for _ in cpl.walk(root)))

    cpl.run(main, name="soak", retention=cpl.KeepRecent(10, records=100))
    # the root, 10 steps kept whole with their leaf each: the same at 1000 and at 5000
    assert counts == [21] * 5


def test_keep_all_keeps_every_task() -> None:
    async def main() -> int:
        root = await service(50)
        return sum(1 for _ in cpl.walk(root))

    assert cpl.run(main) == 1 + 50 * 2


# ------------------------------------------------------------------ every policy


def test_queries_snapshot_and_live_view_under_each_policy(policy: cpl.Retention) -> None:
    seen: dict[str, Any] = {}

    async def main() -> None:
        root = await service(10, fail_at=8)
        seen["live steps"] = [t.arguments for t in cpl.find_tasks(root, name="step")]
        seen["failed"] = cpl.find_tasks(root, state=cpl.Status.FAILED)
        snap = root.snapshot()
        seen["snap steps"] = [n.arguments["i"] for n in snap.find_all("step")]
        seen["snap failed"] = [n.path for n in snap.find_all(lambda n: n.failed)]
        seen["size"] = sum(1 + n.collapsed for n in snap.walk())
        live = LiveTaskTree(root, max_nodes=6)
        seen["view"] = render_text(
            root.snapshot(max_nodes=6, collapse_finished=True), ascii=True, width=100
        )
        console = Console(file=io.StringIO(), width=100, color_system=None)
        console.print(live.renderable())
        seen["live view"] = console.file.getvalue()  # type: ignore[attr-defined]
        seen["summary"] = cpl.retention_summary(root)
        seen["retired"] = cpl.retired(root)

    cpl.run(main, name="svc", retention=policy)
    # the failure is visible in the live view and in the snapshot under every policy
    assert "step#9" in seen["view"] and "the gripper slipped" in seen["view"]
    assert "step#9" in seen["live view"] and "the gripper slipped" in seen["live view"]
    assert seen["snap failed"] == [("svc", "step#9")]
    summary = seen["summary"]
    if isinstance(policy, cpl.KeepAll):
        assert seen["snap steps"] == [repr(i) for i in range(10)]
        assert len(seen["live steps"]) == 10
        assert summary.retired == 0 and seen["retired"] == []
        assert seen["size"] == 1 + 9 * 2 + 1
        return
    assert seen["size"] == 1 + 9 * 2 + 1  # nothing is lost: every task shown or counted
    if isinstance(policy, cpl.KeepRecent) and policy.full == 0:
        # each step is retired as it ends: the live queries see none, the records all
        assert seen["live steps"] == [] and seen["failed"] == []
        assert seen["snap steps"] == [repr(i) for i in range(10)]
        assert summary.retired == 10 and summary.tasks == 19
        assert summary.by_status == {"succeeded": 9, "failed": 1}
        return
    # the newest 3 finished steps stay whole (the live queries see them); 7 were retired
    assert [a["i"] for a in seen["live steps"]] == [7, 8, 9]
    assert summary.retired == 7 and summary.by_status == {"succeeded": 7}
    assert summary.tasks == 14
    if isinstance(policy, cpl.KeepRecent) and policy.records is None:
        assert seen["snap steps"] == [repr(i) for i in range(10)]
        assert [n.collapsed for n in seen["retired"]] == [1] * 7
        assert summary.records == 7 and summary.dropped == 0
    elif isinstance(policy, cpl.KeepRecent):
        assert seen["snap steps"] == [repr(i) for i in (5, 6, 7, 8, 9)]
        assert summary.records == 2 and summary.dropped == 5
    else:
        assert seen["snap steps"] == [repr(i) for i in (7, 8, 9)]
        assert summary.streamed == 7 and summary.records == 0


def test_aiocram_show_under_each_policy(
    policy: cpl.Retention, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from aiocram.cli import main

    log = tmp_path / "events.jsonl"
    instruments = [] if isinstance(policy, cpl.StreamFinished) else [cpl.EventLog(log)]

    async def plan() -> None:
        await service(10, fail_at=8)

    cpl.run(plan, name="svc", instruments=instruments, retention=policy)
    path = Path(policy.target) if isinstance(policy, cpl.StreamFinished) else log  # type: ignore[arg-type]
    tree = cpl.tree_from_log(path)
    # the log holds the whole tree, whatever the policy kept in memory
    assert [n.arguments["i"] for n in tree.find_all("step")] == [repr(i) for i in range(10)]
    assert len(tree) == 1 + 9 * 2 + 1
    assert tree.by_path("svc/step#9").failure is not None
    assert main(["show", str(path), "--ascii"]) == 0
    out = capsys.readouterr().out
    assert "step#10" in out and "the gripper slipped" in out


def test_stream_writes_one_event_per_retired_subtree(tmp_path: Path) -> None:
    out = io.StringIO()

    async def plan() -> None:
        await service(6)

    cpl.run(plan, name="svc", retention=cpl.StreamFinished(out, full=2))
    kinds = [e["event"] for e in load_events_from_text(out.getvalue())]
    assert kinds == ["run-started", *["subtree"] * 6, "run-finished"]


def load_events_from_text(text: str) -> list[dict[str, Any]]:
    import json

    return [json.loads(line) for line in text.splitlines() if line.strip()]


def test_stream_log_of_a_killed_run_shows_what_was_retired(tmp_path: Path) -> None:
    path = tmp_path / "s.jsonl"

    async def plan() -> None:
        await service(6)

    cpl.run(plan, name="svc", retention=cpl.StreamFinished(path, full=2))
    events = load_events(path)
    # as if the process died before the end: only the retired subtrees are there
    cut = [e for e in events if e["event"] != "run-finished"][:5]
    tree = cpl.tree_from_log(cut)
    assert [c.name for c in tree.children] == ["step"] * 4


# ------------------------------------------------------------------ memory


def test_a_retired_subtree_is_freed_without_the_cyclic_collector() -> None:
    refs: list[weakref.ref[cpl.Task]] = []

    async def main() -> None:
        for _ in range(20):
            t = cpl.Task(step(0), name="step")
            refs.append(weakref.ref(t))
            await cpl.with_task(leaf(), name="other")  # creates some unrelated garbage
            t.start()
            await t.join()
            del t

    gc.disable()
    try:
        cpl.run(main, name="soak", retention=cpl.KeepRecent(5, records=0))
        alive_after = [r() is not None for r in refs]
    finally:
        gc.enable()
    # the 15 retired first steps (and their leaves) went with their last reference
    assert alive_after[:10] == [False] * 10


def test_a_held_retired_task_keeps_its_own_fields() -> None:
    async def main() -> cpl.Task:
        first = cpl.Task(step(0), name="first")
        first.start()
        await first.join()
        await service(5)
        return first

    first = cpl.run(main, name="svc", retention=cpl.KeepRecent(2))
    assert first.state is cpl.Status.SUCCEEDED and first.result == "done"
    assert first.path == ("svc", "first")
    assert first.children == []  # retired: the record counts them


def test_records_keep_failures_and_evaporations_as_text() -> None:
    async def main() -> list[cpl.TaskNode]:
        slow = cpl.Task(cpl.sleep(10), name="slow")
        slow.start()
        await cpl.sleep(0)
        slow.evaporate("not needed any more")
        await cpl.wait_for(cpl.task_dead(slow))
        with pytest.raises(cpl.PlanFailure):
            await cpl.with_task(broken(), name="grasp", arguments={"arm": "left"})
        await service(3)
        root = cpl.current_task()
        assert root is not None
        return cpl.retired(root)

    records = cpl.run(main, name="svc", retention=cpl.KeepRecent(1))
    slow, grasp = records[0], records[1]
    assert slow.evaporated and slow.evaporation_reason == "not needed any more"
    assert grasp.failed and grasp.arguments == {"arm": "'left'"}
    assert grasp.failure is not None and grasp.failure.message == "the gripper slipped"


def test_a_cleanup_failure_of_a_retired_subtree_is_logged(
    caplog: pytest.LogCaptureFixture,
) -> None:
    async def quick() -> None:
        await cpl.sleep(0)

    async def parks_badly() -> None:
        try:
            await cpl.sleep(10)
        finally:
            raise RuntimeError("the arm did not park")

    async def main() -> None:
        await cpl.pursue(quick(), parks_badly())
        await service(3)

    with caplog.at_level("ERROR", logger="cpl.cleanup"):
        cpl.run(main, name="svc", retention=cpl.KeepRecent(0))
    logged = [r.getMessage() for r in caplog.records if r.name == "cpl.cleanup"]
    assert len(logged) == 1 and "the arm did not park" in logged[0]


def test_a_collapsing_view_shows_failed_records_until_they_are_dropped() -> None:
    async def main() -> list[int]:
        root = cpl.current_task()
        assert root is not None
        shown = []
        with pytest.raises(cpl.PlanFailure):
            await cpl.with_task(broken(), name="grasp")
        for _ in range(3):
            snap = root.snapshot(collapse_finished=True)
            shown.append(len(snap.find_all("grasp")))
            await cpl.with_task(step(0), name="step")
        return shown

    # the failed record is shown while it is among the 2 records kept, then only counted
    assert cpl.run(main, retention=cpl.KeepRecent(0, records=2)) == [1, 1, 0]


def test_freeze_is_undone_at_the_end() -> None:
    assert gc.get_freeze_count() == 0
    frozen: list[int] = []

    async def main() -> None:
        frozen.append(gc.get_freeze_count())

    cpl.run(main, retention=cpl.KeepRecent(freeze=True))
    assert frozen[0] > 0
    assert gc.get_freeze_count() == 0


# ------------------------------------------------------------------ bad input


@pytest.mark.parametrize(
    ("make", "needle"),
    [
        (lambda: cpl.KeepRecent(-1), "full"),
        (lambda: cpl.KeepRecent(1.5), "full"),  # type: ignore[arg-type]
        (lambda: cpl.KeepRecent(3, records=-2), "records"),
        (lambda: cpl.KeepRecent(3, freeze=1), "freeze"),  # type: ignore[arg-type]
        (lambda: cpl.StreamFinished(42), "path or a text stream"),  # type: ignore[arg-type]
    ],
)
def test_bad_policies_are_named(make: Any, needle: str) -> None:
    with pytest.raises(TypeError, match=needle):
        make()


def test_a_run_rejects_a_non_policy_before_starting() -> None:
    started: list[bool] = []

    async def main() -> None:
        started.append(True)

    with pytest.raises(TypeError, match=r"cpl\.Retention"):
        cpl.run(main, retention="keep-recent")  # type: ignore[arg-type]
    assert started == []
