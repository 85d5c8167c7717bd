"""``aiocram demo``, ``show`` and ``bench`` as a new user runs them: the console script in
a subprocess (``python -m aiocram.cli``), careless input, Ctrl-C, the files and pictures.

Every subprocess has a deadline (``communicate(timeout=...)``), so a hang fails the test.
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

ROOT = Path(__file__).resolve().parents[2]
ENV = {**os.environ, "PYTHONPATH": str(ROOT), "COLUMNS": "80"}


def aiocram(
    *args: str, cwd: Path | None = None, timeout: float = 240
) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "aiocram.cli", *args],
        capture_output=True,
        text=True,
        env=ENV,
        cwd=cwd or ROOT,
        timeout=timeout,
        check=False,
    )


def _previous_run(out: Path) -> dict[str, bytes]:
    out.mkdir(parents=True)
    files = {
        "log.jsonl": b'{"previous": "run"}\n',
        "plans.log": b"previous plans.log\n",
        "robot_view.png": b"previous picture",
    }
    for name, data in files.items():
        (out / name).write_bytes(data)
    return files


@pytest.mark.parametrize(
    ("args", "flag"),
    [
        (["--seed", "-1"], "--seed"),
        (["--seed", "one"], "--seed"),
        (["--speed", "abc"], "--speed"),
        (["--speed", "0"], "--speed"),
        (["--faults", "2"], "--faults"),
        (["--faults", "navigation=x"], "--faults"),
        (["--runs", "0"], "--runs"),
        (["--objects", "teapot"], "--objects"),
        (["--objects", "cup", "cup"], "--objects"),
        (["--gui"], "--gui"),
    ],
)
def test_bad_arguments_name_the_flag_and_touch_nothing(tmp_path, args, flag):
    out = tmp_path / "demo"
    before = _previous_run(out)
    env = {k: v for k, v in ENV.items() if k != "DISPLAY"}
    proc = subprocess.run(
        [sys.executable, "-m", "aiocram.cli", "demo", "--no-live", "--out", str(out), *args],
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
        check=False,
    )
    assert proc.returncode == 2, proc.stderr
    assert flag in proc.stderr
    assert "Traceback" not in proc.stderr
    assert "pybullet build time" not in proc.stderr
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before


@pytest.mark.parametrize("kind", ["file", "proc", "file-parent"])
def test_unusable_out_is_a_usage_error(tmp_path, kind):
    target = tmp_path / "README.md"
    target.write_text("keep me\n")
    out = {
        "file": str(target),
        "proc": "/proc/aiocram-nowhere/x",
        "file-parent": str(target / "sub"),
    }[kind]
    proc = aiocram("demo", "--no-live", "--out", out, timeout=120)
    assert proc.returncode == 2, proc.stderr
    assert "--out" in proc.stderr and "Traceback" not in proc.stderr
    assert target.read_text() == "keep me\n"


def test_demo_with_one_object_writes_everything(tmp_path):
    """``--objects cup``: the cup's target must not need the bowl. The run replaces the
    previous run's files (stale costmaps too), prints a finished tree and lists every file."""
    out = tmp_path / "demo"
    _previous_run(out)
    (out / "costmap-9-old.png").write_bytes(b"stale")
    proc = aiocram("demo", "--objects", "cup", "--seed", "1", "--no-live", "--out", str(out))
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "pybullet build time" not in proc.stderr
    text = proc.stdout
    assert "1/1 objects delivered" in text
    assert re.search(r"^✔ demo \[top-level\]", text, re.M), text
    assert f"the whole tree: aiocram show {out}/log.jsonl\n" in text
    names = sorted(p.name for p in out.iterdir())
    assert "costmap-9-old.png" not in names
    assert not [n for n in names if n.startswith(".partial")]
    for name in ("log.jsonl", "plans.log", "final_scene.png", "robot_view.png"):
        assert f"wrote {out / name}" in text
        assert (out / name).stat().st_size > 100, name
    costmaps = [n for n in names if n.startswith("costmap-")]
    assert costmaps and all(
        re.fullmatch(r"costmap-\d+-(search|fetch|deliver|transport|check-table)-[a-z0-9-]+\.png", n)
        for n in costmaps
    ), costmaps
    # every line fits 80 columns, but for file paths (kept whole to be copied)
    assert max(len(line) for line in text.splitlines() if str(out) not in line) <= 80
    _check_robot_view(out / "robot_view.png")


def _check_robot_view(path: Path) -> None:
    """Not a flat grey wall: varied pixels, and the red outline of a detected object."""
    pixels = np.asarray(Image.open(path).convert("RGB"), dtype=int)
    assert pixels.std() > 20
    outline = (pixels[..., 0] == 255) & (pixels[..., 1] == 40) & (pixels[..., 2] == 40)
    assert outline.sum() > 200


def test_objects_in_any_order(tmp_path):
    """The cup before the bowl: both placed (the cup gets an island slot of its own)."""
    proc = aiocram(
        "demo", "--objects", "cup", "bowl", "--seed", "1", "--no-live", "--out", str(tmp_path)
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "2/2 objects delivered" in proc.stdout


def _start_demo(out: Path) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [
            sys.executable,
            "-m",
            "aiocram.cli",
            "demo",
            "--speed",
            "4",
            "--no-live",
            "--out",
            str(out),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=ENV,
    )


def _wait_for_the_robot(out: Path, proc: subprocess.Popen[str]) -> None:
    """Until the run's staged event log shows the first transport (the robot moves)."""
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        assert proc.poll() is None, proc.communicate()
        logs = list(out.glob(".partial-*/log.jsonl"))
        if logs and '"transport"' in logs[0].read_text(errors="replace"):
            return
        time.sleep(0.2)
    proc.kill()
    pytest.fail("the demo never started its first transport")


def test_ctrl_c_cleans_up_and_exits_130(tmp_path):
    out = tmp_path / "demo"
    proc = _start_demo(out)
    _wait_for_the_robot(out, proc)
    proc.send_signal(signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 130, stderr
    assert "interrupted, cleaning up (Ctrl-C again to abort)" in stderr
    assert "Traceback" not in stderr and "KeyboardInterrupt" not in stderr
    assert "interrupted by Ctrl-C" in stdout  # the summary of what was done
    assert "invariants hold" in stdout  # the cleanup parked the arms, closed the drawer
    assert "evaporated" in stdout and re.search(r"^~ demo", stdout, re.M)
    assert (out / "plans.log").exists()  # empty if nothing was retried before Ctrl-C
    for name in ("log.jsonl", "final_scene.png", "robot_view.png"):
        assert (out / name).stat().st_size > 0, name
    import cpl

    tree = cpl.tree_from_log(out / "log.jsonl")
    assert not [n for n in tree.walk() if n.status.alive]


def test_second_ctrl_c_aborts_at_once(tmp_path):
    out = tmp_path / "demo"
    proc = _start_demo(out)
    _wait_for_the_robot(out, proc)
    proc.send_signal(signal.SIGINT)
    time.sleep(0.2)
    proc.send_signal(signal.SIGINT)
    _, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 130
    assert "aborted" in stderr and "Traceback" not in stderr
    assert (out / "log.jsonl").stat().st_size > 0  # what was logged so far is kept


def test_show_renders_a_log_cut_mid_write(tmp_path):
    import cpl

    log = tmp_path / "log.jsonl"

    async def work() -> None:
        await cpl.sleep(1)

    cpl.run(work, name="work", instruments=[cpl.EventLog(log)])
    data = log.read_bytes()
    cut = tmp_path / "cut.jsonl"
    cut.write_bytes(data[: len(data) - 15])  # the last line loses its end
    proc = aiocram("show", "--ascii", str(cut), timeout=60)
    assert proc.returncode == 0, proc.stderr
    assert "work" in proc.stdout
    assert "cut mid-write" in proc.stderr and "Traceback" not in proc.stderr
    # a broken line in the middle is still an error, with the line number
    lines = data.decode().splitlines(keepends=True)
    broken = tmp_path / "broken.jsonl"
    broken.write_text(lines[0] + '{"event": \n' + "".join(lines[1:]))
    proc = aiocram("show", str(broken), timeout=60)
    assert proc.returncode == 2 and "broken.jsonl:2" in proc.stderr


def test_help_shows_defaults_and_text_for_every_option():
    for command in ("demo", "show", "bench"):
        proc = aiocram(command, "--help", timeout=60)
        assert proc.returncode == 0
        # every option line has some help text after it
        options = re.findall(r"^  (--[a-z-]+)(.*)$", proc.stdout, re.M)
        assert options
        for name, rest in options:
            after = proc.stdout.split(name, 1)[1].split("\n  -", 1)[0]
            assert len(after.split()) >= 3, (command, name, rest)
    demo = aiocram("demo", "--help", timeout=60).stdout
    for default in ("(default: 1)", "(default: 3)", "(default: max)", "(default: out/demo)"):
        assert default in " ".join(demo.split()), default
    assert "--no-live" in demo


def test_bench_writes_to_out_not_the_tracked_file(tmp_path):
    tracked = (ROOT / "BENCHMARKS.md").read_bytes()
    proc = aiocram("bench", "executive_perform", "--quick", cwd=tmp_path, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "out" / "BENCHMARKS.md").stat().st_size > 0
    assert (ROOT / "BENCHMARKS.md").read_bytes() == tracked
    bad = aiocram("bench", "executive_perform", "--out", str(tmp_path), cwd=tmp_path, timeout=60)
    assert bad.returncode == 2 and "--out" in bad.stderr


def _command_running(plan, monkeypatch):
    """``aiocram demo`` as the CLI runs it, with ``plan`` handed to its ``run_demo``."""
    from functools import partial

    from aiocram.demo import _cli, run_demo

    monkeypatch.setattr(_cli, "run_demo", partial(run_demo, plan=plan))
    return _cli


def test_internal_errors_are_not_usage_errors(tmp_path, monkeypatch, capsys):
    """A ValueError raised inside the run is a bug: exit 3 with the traceback, not 2."""
    from aiocram.cli import main

    async def broken(world, config):
        raise ValueError("a bug inside the plan")

    _command_running(broken, monkeypatch)
    code = main(["demo", "--objects", "cup", "--no-live", "--out", str(tmp_path)])
    err = capsys.readouterr().err
    assert code == 3
    assert "internal error" in err and "a bug inside the plan" in err
    assert (tmp_path / "log.jsonl").exists()  # the log so far is kept


def test_plans_log_has_every_retry_the_summary_counts(tmp_path):
    """The full seed-1 demo (the README's): each kind of retry in the summary appears at
    least as often in plans.log."""
    from aiocram.demo import DemoConfig, run_demo

    report = run_demo(DemoConfig(seed=1, out=tmp_path, live=False))
    log = (tmp_path / "plans.log").read_text()
    granted: dict[str, int] = {}
    for kind in re.findall(r"retry (\S+) granted", log):
        granted[kind] = granted.get(kind, 0) + 1
    totals: dict[str, int] = {}
    for outcome in report.outcomes.values():
        for kind, n in outcome.retries.items():
            totals[kind] = totals.get(kind, 0) + n
    assert sum(totals.values()) > 0  # seed 1 retries (else this test proves nothing)
    for kind, n in totals.items():
        assert granted.get(kind, 0) >= n, (kind, n, granted)


def test_cleanup_failures_are_in_the_summary_and_plans_log(tmp_path, monkeypatch, capsys):
    """A cleanup that raised in an evaporated branch is counted in the summary and logged
    (with its traceback) in plans.log."""
    import cpl
    from aiocram.cli import main

    class Boom(cpl.PlanFailure):
        pass

    async def slow() -> None:
        try:
            await cpl.sleep(10)
        finally:
            raise RuntimeError("cleanup broke")

    async def fail() -> None:
        await cpl.sleep(1)
        raise Boom("a branch failed")

    async def plan_with_broken_cleanup(world, config):
        try:
            await cpl.par(cpl.tag("slow", slow), cpl.tag("fail", fail))
        except Boom:
            pass
        return {}

    _command_running(plan_with_broken_cleanup, monkeypatch)
    code = main(["demo", "--objects", "cup", "--no-live", "--out", str(tmp_path)])
    out = capsys.readouterr().out
    assert code == 1  # the stand-in plan neither delivers the cup nor reaches the cleanup
    assert "1 cleanup failure(s)" in out
    log = (tmp_path / "plans.log").read_text()
    assert "the cleanup of evaporated task demo/par/slow raised RuntimeError" in log
    assert "Traceback" in log
