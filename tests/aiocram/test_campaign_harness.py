"""The campaign harness keeps every finished run: records appended as runs end, a killed
worker recorded (exit 3) while the campaign goes on, Ctrl-C writing a partial summary
(exit 130), bad --objects rejected before any job starts (exit 2)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from aiocram.campaign import INVARIANTS, main

ROOT = Path(__file__).resolve().parents[2]


def fake_record(seed, fault_rate, projection, **_):
    return {
        "seed": seed,
        "fault_rate": fault_rate,
        "projection": projection,
        "objects": {"bowl": {"claimed": True, "delivered": True, "where": "island"}},
        "distance_driven": 1.0,
        "real_time_s": 10.0,
        "invariants": {name: True for name in INVARIANTS},
        "violations": {},
    }


def _lines(path):
    return [json.loads(line) for line in path.read_text().splitlines()]


def test_each_record_is_on_disk_as_its_run_ends(tmp_path, monkeypatch):
    import aiocram.demo

    out = tmp_path / "c"
    seen_on_disk = []

    def run(*, seed, **kwargs):
        seen_on_disk.append(len(_lines(out / "runs.jsonl")))
        return fake_record(seed, **kwargs)

    monkeypatch.setattr(aiocram.demo, "run_demo_once", run)
    args = ["campaign", "--seeds", "3", "--faults", "0", "--no-projection", "--workers", "1"]
    assert main([*args, "--out", str(out)]) == 0
    assert seen_on_disk == [0, 1, 2]  # each run saw every earlier run's record on disk
    assert [r["seed"] for r in _lines(out / "runs.jsonl")] == [1, 2, 3]


def test_a_killed_worker_is_recorded_and_the_campaign_goes_on(tmp_path, monkeypatch, capsys):
    """Seed 2's worker process is killed with SIGKILL for real (workers are forked, so
    the patched job runs in them)."""
    import aiocram.demo

    def run(*, seed, **kwargs):
        if seed == 2:
            os.kill(os.getpid(), signal.SIGKILL)
        return fake_record(seed, **kwargs)

    monkeypatch.setattr(aiocram.demo, "run_demo_once", run)
    out = tmp_path / "k"
    args = ["campaign", "--seeds", "5", "--faults", "0", "--no-projection", "--workers", "2"]
    assert main([*args, "--out", str(out)]) == 3
    records = {r["seed"]: r for r in _lines(out / "runs.jsonl")}
    assert sorted(records) == [1, 2, 3, 4, 5]
    assert "SIGKILL" in records[2]["error"]
    assert all("error" not in records[s] for s in (1, 3, 4, 5))
    data = json.loads((out / "campaign.json").read_text())
    assert len(data["runs"]) == 5
    (row,) = data["summary"]["rows"]
    assert row["invariant_violations"] == [
        {"seed": 2, "invariant": "harness", "detail": records[2]["error"]}
    ]
    assert "1 run crashed in the harness" in capsys.readouterr().err


_INTERRUPTIBLE = textwrap.dedent(
    """
    import sys, time
    sys.path.insert(0, {root!r})
    sys.path.insert(0, {tests!r})
    import aiocram.demo
    from test_campaign_harness import fake_record

    def run(*, seed, **kwargs):
        if seed > 2:
            time.sleep(600)  # a long run, interrupted by Ctrl-C
        return fake_record(seed, **kwargs)

    aiocram.demo.run_demo_once = run
    from aiocram.campaign import main
    sys.exit(main(["campaign", "--seeds", "6", "--faults", "0", "--no-projection",
                   "--workers", {workers!r}, "--out", {out!r}]))
    """
)


def _ignore_sigint() -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)


@pytest.mark.parametrize(
    ("workers", "inherited"),
    [("1", "default"), ("2", "default"), ("1", "ignored"), ("2", "ignored")],
)
def test_ctrl_c_writes_the_partial_summary_and_exits_130(tmp_path, workers, inherited):
    """``inherited="ignored"``: started as a non-interactive shell starts a background job
    (``aiocram campaign ... &``), with SIGINT ignored; one SIGINT must stop it all the
    same."""
    out = tmp_path / "i"
    script = _INTERRUPTIBLE.format(
        root=str(ROOT), tests=str(Path(__file__).parent), workers=workers, out=str(out)
    )
    proc = subprocess.Popen(
        [sys.executable, "-c", script],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
        preexec_fn=_ignore_sigint if inherited == "ignored" else None,
    )
    try:
        deadline = time.monotonic() + 60
        runs = out / "runs.jsonl"
        while time.monotonic() < deadline:
            if runs.exists() and len(runs.read_text().splitlines()) >= 2:
                break
            assert proc.poll() is None, proc.communicate()
            time.sleep(0.05)
        else:
            pytest.fail("the first two runs never reached runs.jsonl")
        time.sleep(0.3)  # let the long runs start
        proc.send_signal(signal.SIGINT)
        stdout, stderr = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 130, stderr
    assert "interrupted; partial summary of 2 of 6 runs" in stderr
    assert "robustness campaign" in stdout
    data = json.loads((out / "campaign.json").read_text())
    assert data["summary"]["partial"] is True
    assert data["summary"]["runs_finished"] == 2
    assert sorted(r["seed"] for r in data["runs"]) == [1, 2]
    assert len(_lines(out / "runs.jsonl")) == 2


@pytest.mark.parametrize(
    ("objects", "message"),
    [
        (["bowl", "plate"], "unknown plate"),
        (["bowl", "bowl"], "bowl given more than once"),
    ],
)
def test_bad_objects_rejected_before_any_job(tmp_path, monkeypatch, capsys, objects, message):
    import aiocram.demo

    def run(**kwargs):
        raise AssertionError("a job started")

    monkeypatch.setattr(aiocram.demo, "run_demo_once", run)
    out = tmp_path / "previous"
    out.mkdir()
    (out / "campaign.json").write_text("previous run")
    code = main(["campaign", "--seeds", "1", "--objects", *objects, "--out", str(out)])
    assert code == 2
    assert message in capsys.readouterr().err
    assert (out / "campaign.json").read_text() == "previous run"
    assert not (out / "runs.jsonl").exists()


def test_bad_workers_rejected(tmp_path, capsys):
    assert main(["campaign", "--workers", "0", "--out", str(tmp_path / "w")]) == 2
    assert "argument --workers: must be a whole number >= 1" in capsys.readouterr().err
    assert not (tmp_path / "w").exists()
