"""Rendering of task-tree snapshots (golden files), LiveTaskTree, dump_task_tree.

Regenerate the golden files with ``AIOCRAM_REGEN_GOLDEN=1 python -m pytest
tests/cpl/test_display.py`` and review the diff.
"""

from __future__ import annotations

import asyncio
import io
import os
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from rich.console import Console

import cpl
from cpl._status import Status
from cpl._tree import FailureInfo, TaskNode, snapshot
from cpl.display import STATUS_STYLES, LiveTaskTree, format_duration, render, render_text
from cpl.lowlevel import dump_task_tree
from tests.cpl.fake_tasks import FakeTask

GOLDEN_DIR = Path(__file__).parent / "golden"

S = Status


@pytest.fixture
def golden() -> Callable[[str, str], None]:
    """Compare text with ``golden/<name>``; rewrite the file if AIOCRAM_REGEN_GOLDEN=1."""

    def check(name: str, text: str) -> None:
        path = GOLDEN_DIR / name
        if os.environ.get("AIOCRAM_REGEN_GOLDEN") == "1":
            GOLDEN_DIR.mkdir(exist_ok=True)
            path.write_text(text, encoding="utf-8")
            return
        assert path.exists(), f"no golden file {path}: run with AIOCRAM_REGEN_GOLDEN=1"
        assert text == path.read_text(encoding="utf-8")

    return check


def node(path: str, status: Status, kind: str = "plan", *children: TaskNode, **kw: Any) -> TaskNode:
    parts = tuple(path.split("/"))
    return TaskNode(
        name=parts[-1].split("#")[0],
        path=parts,
        kind=kind,
        status=status,
        children=children,
        **kw,
    )


def fixed_tree() -> TaskNode:
    """A run in progress touching every status, kind label, and line decoration."""
    failure = FailureInfo(
        "executive.failures.NavigationPoseUnreachable",
        "navigation-pose-unreachable",
        "no base pose reaches (1.20, 0.40)",
        {"pose": "(1.2, 0.4)"},
    )
    return node(
        "demo",
        S.RUNNING,
        "top-level",
        node(
            "demo/setup",
            S.SUCCEEDED,
            "plan",
            node("demo/setup/park-arms", S.SUCCEEDED, start_time=0.0, end_time=0.0004),
            node("demo/setup/localize", S.SUCCEEDED, start_time=0.0004, end_time=0.0124),
            start_time=0.0,
            end_time=0.0124,
        ),
        node(
            "demo/transporting",
            S.RUNNING,
            "plan",
            node(
                "demo/transporting/fetching",
                S.FAILED,
                "plan",
                node(
                    "demo/transporting/fetching/navigating",
                    S.FAILED,
                    start_time=1.0,
                    end_time=3.5,
                    failure=failure,
                    annotations={"designator": "<a location (reachable-for pr2) (object cup)>"},
                ),
                start_time=1.0,
                end_time=3.5,
                failure=failure,
            ),
            node(
                "demo/transporting/fetching#2",
                S.RUNNING,
                "plan",
                node(
                    "demo/transporting/fetching#2/search",
                    S.RUNNING,
                    "pursue",
                    node(
                        "demo/transporting/fetching#2/search/look",
                        S.SUSPENDED,
                        "branch",
                        start_time=4.0,
                        waiting_on="suspended",
                    ),
                    node(
                        "demo/transporting/fetching#2/search/timeout",
                        S.EVAPORATED,
                        "branch",
                        start_time=4.0,
                        end_time=4.25,
                        evaporated_by=("demo", "transporting", "fetching#2", "search"),
                        evaporation_reason="pursue: another branch finished first",
                    ),
                    node(
                        "demo/transporting/fetching#2/search/wait-door",
                        S.RUNNING,
                        "branch",
                        start_time=4.0,
                        waiting_on="waiting for fluent door-open",
                    ),
                    start_time=4.0,
                    waiting_on="joining look",
                ),
                node("demo/transporting/fetching#2/grasp", S.CREATED, "tag"),
                start_time=4.0,
                annotations={"designator": "<an object (type cup) (color red)>", "n": 2},
                waiting_on="joining search",
            ),
            start_time=1.0,
            waiting_on="joining fetching#2",
        ),
        node(
            "demo/watchdog",
            S.EVAPORATED,
            "task",
            start_time=0.0,
            end_time=125.5,
            evaporation_reason="the caller of top_level was cancelled",
        ),
        start_time=0.0,
        waiting_on="joining transporting",
    )


def wide_tree() -> TaskNode:
    """A par-loop with many finished iterations, one failure and one running."""
    kids = [
        node(f"loop/it#{i}", S.SUCCEEDED, "branch", start_time=float(i), end_time=i + 0.5)
        for i in range(1, 40)
    ]
    kids[10] = node(
        "loop/it#11",
        S.FAILED,
        "branch",
        node("loop/it#11/ok", S.SUCCEEDED, start_time=10.0, end_time=10.1),
        node(
            "loop/it#11/bad",
            S.FAILED,
            start_time=10.1,
            end_time=10.5,
            failure=FailureInfo("cpl.PlanFailure", "PlanFailure", "dropped it"),
        ),
        start_time=10.0,
        end_time=10.5,
        failure=FailureInfo("cpl.PlanFailure", "PlanFailure", "dropped it"),
    )
    kids.append(node("loop/it#40", S.RUNNING, "branch", start_time=40.0, waiting_on="sleeping"))
    return node("loop", S.RUNNING, "par-loop", *kids, start_time=0.0)


# --------------------------------------------------------------------------- golden


@pytest.mark.parametrize("ascii", [False, True], ids=["unicode", "ascii"])
def test_golden_full(golden: Callable[[str, str], None], ascii: bool) -> None:
    text = render_text(fixed_tree(), ascii=ascii, width=110)
    golden(f"full_{'ascii' if ascii else 'unicode'}.txt", text)


def test_golden_narrow_ascii_wraps(golden: Callable[[str, str], None]) -> None:
    golden("narrow_ascii.txt", render_text(fixed_tree(), ascii=True, width=60))


def test_golden_without_times(golden: Callable[[str, str], None]) -> None:
    golden("no_times_ascii.txt", render_text(fixed_tree(), show_times=False))


@pytest.mark.parametrize("ascii", [False, True], ids=["unicode", "ascii"])
def test_golden_collapsed(golden: Callable[[str, str], None], ascii: bool) -> None:
    text = render_text(wide_tree(), ascii=ascii, collapse_finished=True)
    golden(f"collapsed_{'ascii' if ascii else 'unicode'}.txt", text)


@pytest.mark.parametrize("ascii", [False, True], ids=["unicode", "ascii"])
def test_golden_capped(golden: Callable[[str, str], None], ascii: bool) -> None:
    text = render_text(fixed_tree(), ascii=ascii, max_nodes=6)
    golden(f"capped_{'ascii' if ascii else 'unicode'}.txt", text)


# --------------------------------------------------------------------------- properties


def test_ascii_output_is_ascii() -> None:
    for tree in (fixed_tree(), wide_tree()):
        text = render_text(tree, ascii=True, max_nodes=20, collapse_finished=True)
        assert text.isascii()


def test_status_table_is_complete() -> None:
    assert set(STATUS_STYLES) == set(Status)
    for look in STATUS_STYLES.values():
        assert look.ascii.isascii() and len(look.ascii) == 1


def test_render_is_pure() -> None:
    tree = fixed_tree()
    before = tree.to_dict()
    assert render_text(tree) == render_text(tree)
    render(tree, collapse_finished=True, max_nodes=3)
    assert tree.to_dict() == before


def test_cap_counts_everything_left_out() -> None:
    text = render_text(wide_tree(), max_nodes=5)
    assert text.count("\n") == 5 + 1
    assert text.rstrip().endswith("... 38 more")
    with pytest.raises(ValueError):
        render(wide_tree(), max_nodes=0)


@pytest.mark.parametrize(
    ("seconds", "text"),
    [(0.0004, "0.4ms"), (0.5, "500.0ms"), (1.0, "1.00s"), (59.994, "59.99s"), (125.5, "2m05.5s")],
)
def test_format_duration(seconds: float, text: str) -> None:
    assert format_duration(seconds) == text


# --------------------------------------------------------------------------- snapshot side


_STATUSES = st.sampled_from(list(Status))


@st.composite
def fake_trees(draw: st.DrawFn) -> FakeTask:
    root = FakeTask("root", state=draw(_STATUSES))
    pending = [root]
    count = draw(st.integers(0, 25))
    for i in range(count):
        parent = pending[draw(st.integers(0, len(pending) - 1))]
        state = draw(_STATUSES)
        child = parent.add(
            FakeTask(f"t{i}", state=state, waiting_on="busy" if state.alive else None)
        )
        pending.append(child)
    return root


@settings(max_examples=150, deadline=None)
@given(fake_trees(), st.none() | st.integers(1, 12), st.booleans())
def test_collapsing_snapshot_renders_like_collapsing_render(
    root: FakeTask, cap: int | None, collapse: bool
) -> None:
    """Folding/capping while snapshotting draws the same as folding/capping the full one."""
    cheap = snapshot(root, max_nodes=cap, collapse_finished=collapse)
    full = snapshot(root)
    assert render_text(cheap, collapse_finished=collapse, max_nodes=cap) == render_text(
        full, collapse_finished=collapse, max_nodes=cap
    )


# --------------------------------------------------------------------------- live view


def test_live_task_tree_redraws_from_the_loop() -> None:
    root = FakeTask("root", state=Status.RUNNING, end_time=None)
    out = io.StringIO()
    console = Console(file=out, width=80, force_terminal=True, color_system=None)
    threads_before = threading.active_count()

    async def main() -> None:
        async with LiveTaskTree(root, refresh_per_second=100, console=console) as view:
            assert threading.active_count() == threads_before
            for i in range(5):
                root.add(FakeTask(f"step{i}", state=Status.RUNNING, end_time=None))
                await asyncio.sleep(0.02)
                root.children[-1].state = Status.SUCCEEDED
            view.refresh()
            assert "(+5 finished)" in out.getvalue()
            root.state = Status.SUCCEEDED

    asyncio.run(main())
    final = out.getvalue()
    assert "step4" in final  # the final draw is not folded
    assert "✔ root" in final


def test_live_task_tree_with_a_getter() -> None:
    holder: list[FakeTask] = []
    out = io.StringIO()
    console = Console(file=out, width=80, force_terminal=True, color_system=None)

    async def main() -> None:
        async with LiveTaskTree(
            lambda: holder[0] if holder else None, console=console, ascii=True
        ) as view:
            view.refresh()
            assert "(no task yet)" in out.getvalue()
            holder.append(FakeTask("late", state=Status.SUCCEEDED))

    asyncio.run(main())
    assert "+ late" in out.getvalue()
    with pytest.raises(ValueError):
        LiveTaskTree(lambda: None, refresh_per_second=0)


# --------------------------------------------------------------------------- dump


def test_dump_task_tree_of_a_task() -> None:
    root = FakeTask("root", state=Status.RUNNING, end_time=None, waiting_on="joining a")
    root.add(FakeTask("a", state=Status.RUNNING, end_time=None, waiting_on="sleeping until t=3"))
    out = io.StringIO()
    text = dump_task_tree(root, file=out)
    assert out.getvalue() == text
    assert text.isascii()
    assert "> root since t=0.00 - joining a" in text
    assert "`-- > a since t=0.00 - sleeping until t=3" in text


def test_dump_task_tree_without_runs() -> None:
    out = io.StringIO()
    assert dump_task_tree(file=out) == "(no cpl run in progress)\n"


def test_collapse_keeps_recovered_failures_visible(mrun: Any) -> None:
    """A subtree that succeeded after a retry is not folded away: the failure it recovered
    from stays visible, with the path to it; clean subtrees fold."""
    counter = cpl.RetryCounter(1)

    async def flaky() -> None:
        if counter.used == 0:
            cpl.fail("first try fails")

    async def clean() -> None:
        await cpl.sleep(1)

    async def recovering() -> None:
        def again(_f: Any) -> None:
            if counter.do_retry():
                cpl.retry()

        await cpl.with_failure_handling(
            lambda: cpl.with_task(flaky(), name="flaky"), {cpl.PlanFailure: again}
        )

    async def main() -> Any:
        await cpl.with_task(clean(), name="clean")
        await cpl.with_task(recovering(), name="recovering")
        return cpl.current_task()

    root = mrun(main, name="collapse")
    node = snapshot(root, collapse_finished=True)
    names = [n.name for n in node.walk()]
    assert "clean" not in names and node.collapsed == 1
    assert "recovering" in names and "flaky" in names
    text = render_text(node, ascii=True, width=100)
    assert "first try fails" in text
