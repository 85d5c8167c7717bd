"""The JSON-lines event log: writing, loading, rebuilding trees; ``aiocram show``."""

from __future__ import annotations

import asyncio
import io
import json
import logging
from pathlib import Path
from typing import Any

import pytest
from rich.console import Console

from cpl._eventlog import EVENT_SCHEMA, EventLog, load_events, tree_from_log
from cpl._failures import Evaporated, PlanFailure
from cpl._status import Status
from cpl._tree import TaskNode, snapshot
from tests.cpl.fake_tasks import FakeTask

S = Status


class GraspFailure(PlanFailure):
    cram_name = "object-unreachable"


def fake_run() -> FakeTask:
    root = FakeTask("demo", kind="top-level", state=S.FAILED, end_time=9.0)
    root.failure = GraspFailure("out of reach", object="cup")
    p = root.add(FakeTask("par", kind="par", state=S.FAILED, end_time=9.0, failure=root.failure))
    go = p.add(FakeTask("go", arguments={"where": (1.0, 2.0)}, result=True))
    go.annotations = {"designator": object(), "n": 3}
    p.add(FakeTask("go", arguments={"where": "sink"}, state=S.FAILED, failure=root.failure))
    p.add(
        FakeTask(
            "watch",
            kind="branch",
            state=S.EVAPORATED,
            evaporation=Evaporated("par: a branch failed", by=("demo", "par")),
        )
    )
    root.add(FakeTask("later", kind="tag", state=S.CREATED, start_time=None, end_time=None))
    root.add(FakeTask("stuck", state=S.SUSPENDED, end_time=None))
    return root


def preorder(task: FakeTask) -> list[FakeTask]:
    out, stack = [], [task]
    while stack:
        t = stack.pop()
        out.append(t)
        stack.extend(reversed(t.children))
    return out


def drive(log: EventLog, root: FakeTask) -> None:
    """Call the instrument hooks in the order a run does."""
    log.run_started(root)  # type: ignore[arg-type]
    tasks = preorder(root)
    for t in tasks[1:]:
        log.task_spawned(t)  # type: ignore[arg-type]
    for t in tasks:
        if t.state is not S.CREATED:
            log.task_status_changed(t, S.CREATED, S.RUNNING)  # type: ignore[arg-type]
    for t in reversed(tasks):
        if t.state not in (S.CREATED, S.RUNNING):
            log.task_status_changed(t, S.RUNNING, t.state)  # type: ignore[arg-type]
    log.run_finished(root)  # type: ignore[arg-type]


def write_log(path: Path, *roots: FakeTask) -> None:
    for root in roots:
        drive(EventLog(path), root)


# --------------------------------------------------------------------------- round trip


def test_file_round_trip_gives_the_snapshot(tmp_path: Path) -> None:
    root = fake_run()
    path = tmp_path / "run.jsonl"
    write_log(path, root)
    events = load_events(path)
    assert {e["schema"] for e in events} == {EVENT_SCHEMA}
    assert [e["event"] for e in events][:2] == ["run-started", "task-started"]
    assert events[-1]["event"] == "run-finished"
    started = next(e for e in events if e["path"] == ["demo", "par", "go#2"])
    assert started["parent"] == ["demo", "par"] and started["arguments"] == {"where": "'sink'"}
    finished = next(e for e in events if e["event"] == "task-finished" and e["status"] == "failed")
    assert finished["failure"]["cram_name"] == "object-unreachable"
    evaporated = next(e for e in events if e.get("status") == "evaporated")
    assert evaporated["evaporated_by"] == ["demo", "par"]
    assert evaporated["reason"] == "par: a branch failed"
    rebuilt = tree_from_log(path)
    assert rebuilt == snapshot(root)
    assert tree_from_log(events) == rebuilt


def test_stream_and_many_runs(tmp_path: Path) -> None:
    first, second = fake_run(), FakeTask("other", kind="top-level")
    path = tmp_path / "runs.jsonl"
    write_log(path, first, second)
    assert tree_from_log(path).name == "other"
    assert tree_from_log(path, run=0) == snapshot(first)
    assert tree_from_log(path, run=-2) == snapshot(first)
    with pytest.raises(ValueError, match="holds 2 run"):
        tree_from_log(path, run=2)
    buf = io.StringIO()
    drive(EventLog(buf), second)
    assert not buf.closed
    assert buf.getvalue().count("\n") == len(load_events_from_text(buf.getvalue()))


def load_events_from_text(text: str) -> list[dict[str, Any]]:
    return [json.loads(line) for line in text.splitlines()]


def test_logger_target_with_a_prefixing_format(tmp_path: Path) -> None:
    path = tmp_path / "app.log"
    logger = logging.getLogger("aiocram.tests.events")
    logger.propagate = False
    logger.setLevel(logging.DEBUG)
    handler = logging.FileHandler(path, encoding="utf-8")
    handler.setFormatter(logging.Formatter("%(levelname)s %(name)s: %(message)s"))
    logger.addHandler(handler)
    try:
        logger.info("starting up, nothing to see")
        root = fake_run()
        drive(EventLog(logger, level=logging.DEBUG), root)
    finally:
        logger.removeHandler(handler)
        handler.close()
    assert path.read_text().splitlines()[1].startswith("DEBUG aiocram.tests.events: {")
    assert tree_from_log(path) == snapshot(root)


def test_moved_task_is_reparented(tmp_path: Path) -> None:
    root = FakeTask("demo", kind="top-level")
    tag = root.add(FakeTask("w1", kind="tag"))
    log = EventLog(tmp_path / "m.jsonl")
    log.run_started(root)  # type: ignore[arg-type]
    log.task_spawned(tag)  # type: ignore[arg-type]
    form = root.add(FakeTask("po", kind="partial-order"))
    log.task_spawned(form)  # type: ignore[arg-type]
    root.children.remove(tag)
    form.add(tag)
    log.task_spawned(tag)  # type: ignore[arg-type]
    for t in (tag, form, root):
        log.task_status_changed(t, S.RUNNING, S.SUCCEEDED)  # type: ignore[arg-type]
    log.run_finished(root)  # type: ignore[arg-type]
    events = load_events(tmp_path / "m.jsonl")
    assert events[3]["moved_from"] == ["demo", "w1"]
    tree = tree_from_log(events)
    assert tree == snapshot(root)
    assert [n.path for n in tree.walk()] == [("demo",), ("demo", "po"), ("demo", "po", "w1")]


def test_interrupted_run_shows_the_last_reported_state(tmp_path: Path) -> None:
    root = fake_run()
    path = tmp_path / "cut.jsonl"
    write_log(path, root)
    lines = path.read_text().splitlines()
    cut = [ln for ln in lines if '"task-finished"' not in ln and '"run-finished"' not in ln]
    path.write_text("\n".join(cut) + "\n")
    tree = tree_from_log(path)
    assert {n.status for n in tree.walk()} == {S.RUNNING, S.CREATED, S.SUSPENDED}


def test_fluent_events_only_when_asked() -> None:
    class Fl:
        name = "door-open"

    quiet, loud = io.StringIO(), io.StringIO()
    EventLog(quiet).fluent_changed(Fl(), True)  # type: ignore[arg-type]
    EventLog(loud, fluents=True).fluent_changed(Fl(), (1, object()))  # type: ignore[arg-type]
    assert quiet.getvalue() == ""
    event = json.loads(loud.getvalue())
    assert event["event"] == "fluent-changed" and event["fluent"] == "door-open"
    assert event["value"].startswith("(1, <object object at")


# --------------------------------------------------------------------------- errors


def test_unknown_schema_is_named(tmp_path: Path) -> None:
    path = tmp_path / "future.jsonl"
    path.write_text(json.dumps({"schema": "aiocram.events/2", "event": "run-started"}) + "\n")
    with pytest.raises(
        ValueError, match=r"future\.jsonl:1: .*'aiocram\.events/2'.*'aiocram\.events/1'"
    ):
        load_events(path)
    with pytest.raises(ValueError, match=r"'aiocram\.events/2'"):
        tree_from_log([{"schema": "aiocram.events/2"}])


def test_broken_logs(tmp_path: Path) -> None:
    path = tmp_path / "bad.jsonl"
    path.write_text('{"schema": "aiocram.events/1", "event": \n')
    with pytest.raises(ValueError, match=r"bad\.jsonl:1: not a JSON event line"):
        load_events(path)
    with pytest.raises(ValueError, match="no run"):
        tree_from_log([])
    orphan = [
        {"schema": EVENT_SCHEMA, "event": "run-started", "path": ["r"], "name": "r",
         "status": "running"},
        {"schema": EVENT_SCHEMA, "event": "task-started", "path": ["x", "y"], "parent": ["x"],
         "name": "y", "status": "created"},
    ]  # fmt: skip
    with pytest.raises(ValueError, match="unknown parent"):
        tree_from_log(orphan)


# --------------------------------------------------------------------------- CLI


def test_cli_show(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from aiocram.cli import main

    path = tmp_path / "run.jsonl"
    write_log(path, fake_run())
    assert main(["show", str(path), "--ascii"]) == 0
    out = capsys.readouterr().out
    assert out.isascii()
    assert "x demo [top-level] 9.00s - object-unreachable: out of reach" in out
    assert "+-- x go#2 1.00s - object-unreachable: out of reach" in out
    assert "evaporated by demo/par: par: a branch failed" in out
    assert main(["show", str(path), "--max-nodes", "2"]) == 0
    out = capsys.readouterr().out
    assert "✘ demo" in out and "… 5 more" in out


def test_cli_errors(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from aiocram.cli import main

    assert main(["show", str(tmp_path / "missing.jsonl")]) == 2
    assert "no such file" in capsys.readouterr().err
    bad = tmp_path / "bad.jsonl"
    bad.write_text('{"schema": "nope"}\n')
    assert main(["show", str(bad)]) == 2
    assert "unsupported event schema 'nope'" in capsys.readouterr().err
    # main() returns argparse's exit status instead of raising SystemExit
    assert main(["--version"]) == 0
    assert capsys.readouterr().out.startswith("aiocram ")
    assert main([]) == 2


# --------------------------------------------------------------------------- real runs


def test_real_run_log_live_view_and_dump(tmp_path: Path) -> None:
    cpl = pytest.importorskip("cpl")
    if not all(hasattr(cpl, n) for n in ("plan", "par", "sleep", "top_level", "task_tree")):
        pytest.skip("cpl runtime not complete yet")
    from cpl.display import LiveTaskTree, render_text
    from cpl.lowlevel import dump_task_tree
    from cpl.testing import MockClock

    dumps: list[str] = []
    roots: list[Any] = []

    @cpl.plan
    async def go(where: str) -> str:
        await cpl.sleep(1.0)
        return where

    @cpl.plan
    async def demo() -> list[str]:
        roots.append(cpl.current_task())
        result: list[str] = await cpl.par(go("table"), go("sink"), dump_later())
        return result

    async def dump_later() -> str:
        await cpl.sleep(0.5)
        dumps.append(dump_task_tree(file=io.StringIO()))
        return "dumped"

    log_path = tmp_path / "real.jsonl"
    out = io.StringIO()
    console = Console(file=out, width=100, force_terminal=True, color_system=None)

    async def main() -> Any:
        async with LiveTaskTree(lambda: roots[0] if roots else None, console=console):
            return await cpl.top_level(
                demo, name="aiocram-test-demo", instruments=[EventLog(log_path)]
            )

    loop = asyncio.new_event_loop()
    clock = MockClock()
    clock.install(loop)
    try:
        assert loop.run_until_complete(main()) == ["table", "sink", "dumped"]
    finally:
        clock.uninstall(loop)
        loop.close()

    snap = cpl.task_tree("aiocram-test-demo")
    assert isinstance(snap, TaskNode)
    assert tree_from_log(log_path) == snap
    par = snap.find(lambda n: n.kind == "par")
    assert par is not None and par.succeeded
    assert [c.path[-1] for c in par.children] == ["go", "go#2", "dump_later"]
    assert par.children[1].arguments == {"where": "'sink'"}
    assert "sleeping" in dumps[0] or "joining" in dumps[0]
    assert "> go#2" in dumps[0]
    assert "go#2" in out.getvalue()
    assert "+ go#2 1.00s" in render_text(snap)
