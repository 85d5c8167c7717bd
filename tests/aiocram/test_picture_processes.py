"""The demo draws every other costmap figure in a forked process: the two halves are the
whole set, the child really is another process, and a child that fails is reported while
the parent's pictures are drawn all the same."""

from __future__ import annotations

import os
import sys
from pathlib import Path
from typing import Any

import pytest

from aiocram import _figures, demo
from aiocram._costmap_figure import _Use
from aiocram._figures import CostmapRecorder
from aiocram.demo import _outputs as demo_outputs

pytestmark = pytest.mark.skipif(not hasattr(os, "fork"), reason="needs os.fork")


def _use(obj: str, step: str, failed: bool = False) -> _Use:
    use = _Use(None, obj, "reachable", step, (0.0, 0.0, 0.0), {})
    use.tries.append(((1.0, 1.0, 0.0), not failed))
    return use


def test_the_two_parts_are_the_whole_set(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    drawn: list[str] = []

    def figure(engine: Any, use: Any, path: Path, **_: Any) -> Path:
        drawn.append(path.name)
        return path

    monkeypatch.setattr(_figures, "costmap_figure", figure)
    recorder = CostmapRecorder(world=None)
    recorder.uses = [
        _use("bowl", "search-for-object"),
        _use("bowl", "fetch", failed=True),
        _use("bowl", "deliver"),
        _use("cup", "search-for-object"),
        _use("cup", "fetch"),
    ]
    recorder.figures(None, tmp_path)
    whole = list(drawn)
    drawn.clear()
    recorder.figures(None, tmp_path, part=(0, 2))
    first = list(drawn)
    drawn.clear()
    recorder.figures(None, tmp_path, part=(1, 2))
    assert len(whole) == 5
    assert sorted(first + drawn) == sorted(whole)
    assert first and drawn and not set(first) & set(drawn)


@pytest.fixture
def single_threaded(monkeypatch: pytest.MonkeyPatch) -> None:
    """Threads another test left behind must not turn the fork off here."""
    import threading

    monkeypatch.setattr(threading, "active_count", lambda: 1)


@pytest.mark.usefixtures("single_threaded")
def test_the_child_is_another_process_and_leaves_nothing_to_clean_up(tmp_path: Path) -> None:
    mark = tmp_path / "child"
    pid = demo_outputs._fork(lambda: mark.write_text(str(os.getpid())))
    assert pid is not None
    _, status = os.waitpid(pid, 0)
    assert status == 0
    assert int(mark.read_text()) == pid != os.getpid()


class _Outputs:
    def __init__(self, root: Path) -> None:
        self.staging = root

    def path(self, name: str) -> Path:
        return self.staging / name


class _Camera:
    def write(self, path: Path) -> Path:
        path.write_text("camera")
        return path


class _Costmaps:
    """Draws its part as files; the child's part fails."""

    uses = (1, 2, 3)

    def figures(self, engine: Any, out_dir: Path, part: tuple[int, int] = (0, 1)) -> list[Path]:
        if part == (1, 2):
            raise RuntimeError("the child's figure failed")
        (out_dir / f"costmap-part-{part[0]}-of-{part[1]}.png").write_text("figure")
        return []


@pytest.mark.usefixtures("single_threaded")
def test_a_failed_child_is_reported_and_the_parent_draws_its_pictures(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path, capfd: pytest.CaptureFixture[str]
) -> None:
    from projection import render

    monkeypatch.setattr(render, "camera_showing", lambda world: None)
    monkeypatch.setattr(
        _figures, "write_scene", lambda world, path, camera, caption: path.write_text("scene")
    )
    demo_outputs.write_pictures(_Outputs(tmp_path), None, _Camera(), _Costmaps(), [object()])
    sys.stderr.flush()
    err = capfd.readouterr().err
    assert "the child's figure failed" in err  # the child's traceback
    assert "some costmap pictures not drawn" in err
    names = sorted(p.name for p in tmp_path.iterdir())
    assert names == ["costmap-part-0-of-2.png", "final_scene.png", "robot_view.png"]


def test_the_import_freeze_is_undone_when_the_runs_end() -> None:
    """``frozen_imports`` hides objects from ``gc.get_referrers`` while it lasts; it must
    not outlive the runs (a test process goes on after ``aiocram demo``)."""
    import gc

    before = gc.get_freeze_count()
    with demo.frozen_imports():
        assert gc.get_freeze_count() > before
    assert gc.get_freeze_count() == before


def test_no_fork_while_other_threads_run(tmp_path: Path) -> None:
    """A forked child would hold only the forking thread (``--gui`` runs others): then the
    caller draws everything itself."""
    import threading

    stop = threading.Event()
    other = threading.Thread(target=stop.wait)
    other.start()
    try:
        assert demo_outputs._fork(lambda: None) is None
    finally:
        stop.set()
        other.join()
