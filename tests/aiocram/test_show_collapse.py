"""``aiocram show --collapse LOG`` prints the compact tree the demo printed at its end,
read back from the event log (issue 27, item 5)."""

from __future__ import annotations

import io

from rich.console import Console

import cpl
from aiocram._views import final_tree
from aiocram.cli import main
from cpl.testing import MockClock
from executive import an


class NotSeen(cpl.PlanFailure):
    pass


@cpl.plan(name="perception")
async def _perception(fail: bool) -> str:
    await cpl.sleep(0.5)
    if fail:
        raise NotSeen("no visible spoon", object=an.object(type="spoon"))
    return "spoon-1"


@cpl.plan(name="transport")
async def _transport(fails: int) -> None:
    spoon = an.object(type="spoon", name="spoon-1")
    for _ in range(fails):
        try:
            await _perception(True).annotate(designator=an.action(type="detecting", object=spoon))
        except NotSeen:
            pass
    try:  # imagined (by its mark, whatever its name): its failures are not counted
        await cpl.tag("what-if-1", _perception(True), subtree=cpl.Subtree.IMAGINED)
    except NotSeen:
        pass


@cpl.plan(name="park")
async def _park() -> None:
    await cpl.sleep(0.1)


def _record(path) -> cpl.Task:
    box: list[cpl.Task] = []

    async def demo() -> None:
        root = cpl.current_task()
        assert root is not None
        box.append(root)
        await _park()
        await _park()
        for name, fails in (("bowl", 0), ("spoon", 3), ("cup", 1)):
            await _transport(fails).annotate(
                designator=an.action(type="transporting", object=an.object(type=name))
            )
        await _park()

    cpl.run(demo, name="demo", clock=MockClock(), instruments=[cpl.EventLog(path)])
    return box[0]


def _text(renderable) -> str:
    buffer = io.StringIO()
    Console(file=buffer, width=80, color_system=None, highlight=False, _environ={}).print(
        renderable
    )
    return buffer.getvalue()


def test_show_collapse_prints_the_tree_the_demo_printed(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("COLUMNS", "80")
    log = tmp_path / "log.jsonl"
    root = _record(log)
    shown_by_the_demo = _text(final_tree(root))
    assert main(["show", "--collapse", str(log)]) == 0
    out = capsys.readouterr().out
    assert out == shown_by_the_demo
    lines = out.splitlines()
    assert lines[1] == "├── (+2 finished)"
    assert "transport#2 transporting spoon" in out and "— 3 failed tasks" in out
    assert "✘ perception ×3 — last: NotSeen: no visible spoon (object=" in out
    assert "— 1 failed task\n" in out
    assert len(lines) <= 10


def test_show_collapse_ascii_is_ascii(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("COLUMNS", "80")
    log = tmp_path / "log.jsonl"
    _record(log)
    assert main(["show", "--collapse", "--ascii", str(log)]) == 0
    out = capsys.readouterr().out
    assert out.isascii()
    assert "x perception x3 - last: NotSeen: no visible spoon" in out
