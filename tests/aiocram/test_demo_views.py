"""The demo's console views (golden files): the live view keeps the running path and the
object's name visible at 80 columns and folds repeated failures; the final tree has a
finished root and shows the failures, folded.

Regenerate with ``AIOCRAM_REGEN_GOLDEN=1 python -m pytest tests/aiocram/test_demo_views.py``
and read the diff.
"""

from __future__ import annotations

import io
import os
from pathlib import Path

import pytest
from rich.console import Console

import cpl
from aiocram._views import DemoView, Progress, final_tree, fold_failures
from cpl.testing import MockClock
from executive import an

GOLDEN = Path(__file__).parent / "golden"


def _text(renderable, width: int = 80) -> str:
    buffer = io.StringIO()
    console = Console(
        file=buffer,
        width=width,
        color_system=None,
        force_terminal=False,
        highlight=False,
        emoji=False,
        _environ={},
    )
    console.print(renderable)
    return "".join(line.rstrip() + "\n" for line in buffer.getvalue().splitlines())


def _check(name: str, text: str) -> None:
    path = GOLDEN / name
    if os.environ.get("AIOCRAM_REGEN_GOLDEN") == "1":
        GOLDEN.mkdir(exist_ok=True)
        path.write_text(text)
    assert path.exists(), f"no golden file {path}: run with AIOCRAM_REGEN_GOLDEN=1"
    assert text == path.read_text()


class NotSeen(cpl.PlanFailure):
    pass


@cpl.plan(name="perception")
async def _perception(fail: bool) -> str:
    await cpl.sleep(0.5)
    if fail:
        raise NotSeen("no visible spoon")
    return "spoon-1"


@cpl.plan(name="perceive")
async def _perceive(fails: int, frames: list[str], view: list[DemoView]) -> str:
    spoon = an.object(type="spoon", name="spoon-1")
    for _ in range(fails):
        try:
            await _perception(True).annotate(designator=an.action(type="detecting", object=spoon))
        except NotSeen:
            pass
    if view:
        frames.append(_text(view[0].renderable()))
    return await _perception(False).annotate(designator=an.action(type="detecting", object=spoon))


@cpl.plan(name="transport")
async def _transport(fails: int, frames: list[str], view: list[DemoView]) -> None:
    # a long designator: the live view must still show "spoon" at 80 columns
    obj = an.object(type="spoon")
    await _perceive(fails, frames, view).annotate(
        designator=an.action(
            type="searching",
            object=obj,
            location=an.object(type="drawer", urdf_name="sink_area_left_upper_drawer_main"),
        )
    )


def _run(fails: int) -> tuple[list[str], cpl.Task]:
    frames: list[str] = []
    view: list[DemoView] = []
    wall = iter(float(i) for i in range(1000))
    progress = Progress(["bowl", "spoon"], wall=lambda: next(wall))
    box: list[cpl.Task] = []

    async def demo() -> None:
        root = cpl.current_task()
        assert root is not None
        box.append(root)
        view.append(DemoView(root, progress))
        for name in ("bowl", "spoon"):
            await _transport(fails if name == "spoon" else 0, frames, view).annotate(
                designator=an.action(type="transporting", object=an.object(type=name))
            )

    cpl.run(demo, name="demo", clock=MockClock(), instruments=[progress])
    return frames, box[0]


def test_live_view_keeps_the_running_path_and_folds_failures():
    frames, _ = _run(fails=23)
    assert len(frames) == 2
    spoon = frames[1]
    assert spoon.splitlines()[0].startswith("object 2 of 2: spoon")
    assert "searching spoon" in spoon  # the object's name is not cut at 80 columns
    assert "perception ×23" in spoon  # 23 failures, one line
    assert spoon.count("\n") <= 8
    _check("live_view_80.txt", spoon)


def test_final_tree_has_a_finished_root_and_folded_failures():
    _, root = _run(fails=5)
    text = _text(final_tree(root, log="out/demo/log.jsonl"))
    first = text.splitlines()[0]
    assert first.startswith("✔ demo") and "running" not in text
    assert "perception ×5" in text
    assert "the whole tree: aiocram show out/demo/log.jsonl" in text
    _check("final_tree_80.txt", text)


def test_one_failed_task_is_singular():
    _, root = _run(fails=1)
    text = _text(final_tree(root))
    assert "— 1 failed task\n" in text and "1 failed tasks" not in text


def test_fold_failures_leaves_imagined_runs_out():
    """By the subtree's mark, not its name: a marked subtree with any name is left out,
    a subtree named like an imagined run but unmarked is counted."""

    class T:
        def __init__(self, name, parent=None, state=cpl.Status.FAILED, subtree=None):
            self.parent = parent
            self.path = (*parent.path, name) if parent is not None else (name,)
            self.path_entry = name
            self.state = state
            self.subtree = subtree
            self.failure = NotSeen("x")

    demo = T("demo", state=cpl.Status.RUNNING)
    transport = T("transport", demo, cpl.Status.RUNNING)
    perceive = T("perceive", transport, cpl.Status.SUCCEEDED)
    dream = T("what-if", transport, cpl.Status.FAILED, subtree=cpl.Subtree.IMAGINED)
    lookalike = T("projection-run-1", transport, cpl.Status.SUCCEEDED)
    tasks = [
        T("perception", perceive),
        T("perception#2", perceive),
        T("perception", T("perceive", dream, cpl.Status.SUCCEEDED)),
        T("perception", lookalike),
        perceive,
    ]
    assert [(n, k) for n, k, _ in fold_failures(tasks)] == [("perception", 3)]


@pytest.mark.parametrize("width", [60, 80, 120])
def test_live_view_lines_fit_the_width(width):
    frames: list[str] = []
    wall = iter(float(i) for i in range(1000))
    progress = Progress(["spoon"], wall=lambda: next(wall))

    async def demo() -> None:
        view = DemoView(cpl.current_task(), progress)

        async def grab() -> None:
            frames.append(_text(view.renderable(), width))

        @cpl.plan(name="transport")
        async def transport() -> None:
            await _perceive(3, [], [])
            await grab()

        await transport().annotate(
            designator=an.action(type="transporting", object=an.object(type="spoon"))
        )

    cpl.run(demo, name="demo", clock=MockClock(), instruments=[progress])
    assert all(len(line) <= width for line in frames[0].splitlines())
