"""The aiocram commands end to end: demo, show, campaign (both backends), bench."""

from __future__ import annotations

import json
import logging

import pytest

import cpl
from aiocram.cli import main


@pytest.fixture(autouse=True)
def _keep_logging():
    """The demo routes plan logging to a file and restores it; check it did."""
    before = {
        n: (logging.getLogger(n).propagate, list(logging.getLogger(n).handlers))
        for n in ("plans", "executive", "projection")
    }
    yield
    after = {
        n: (logging.getLogger(n).propagate, list(logging.getLogger(n).handlers)) for n in before
    }
    assert after == before


def test_demo_writes_log_pictures_and_summary(tmp_path, capsys):
    out = tmp_path / "demo"
    code = main(["demo", "--objects", "bowl", "--seed", "1", "--no-live", "--out", str(out)])
    text = capsys.readouterr().out
    assert code in (0, 1)  # 1 = an invariant violated: reported, not a crash
    assert "bowl" in text and "objects delivered (true world" in text
    for name in ("log.jsonl", "final_scene.png", "robot_view.png"):
        assert (out / name).stat().st_size > 0, name
    assert (out / "plans.log").exists()  # empty when nothing was retried
    tree = cpl.tree_from_log(out / "log.jsonl")
    assert tree.find("transport") is not None
    # the imagined runs and the real one are named subtrees of the recorded tree
    names = {n.name for n in tree.walk()}
    assert {"projection-run-1", "real-run"} <= names
    assert main(["show", str(out / "log.jsonl"), "--ascii", "--max-nodes", "20"]) == 0


def test_demo_bad_arguments(capsys):
    assert main(["demo", "--objects", "teapot", "--no-live", "--out", "/tmp/x"]) == 2
    assert "unknown objects" in capsys.readouterr().err
    assert main(["demo", "--speed", "-3", "--no-live"]) == 2
    assert "--speed" in capsys.readouterr().err


def test_tiny_campaign(tmp_path):
    # one backend here; .ci/run runs a campaign on each backend (local and dask)
    backend = "local"
    out = tmp_path / backend
    code = main(
        [
            "campaign",
            "--seeds",
            "1",
            "--faults",
            "0,0.2",
            "--objects",
            "bowl",
            "--backend",
            backend,
            "--workers",
            "2",
            "--out",
            str(out),
        ]
    )
    assert code in (0, 1)
    data = json.loads((out / "campaign.json").read_text())
    runs = data["runs"]
    assert len(runs) == 4  # 1 seed x 2 fault rates x (with, without projection)
    assert all("error" not in r for r in runs), [r.get("error") for r in runs]
    assert {(r["projection"], r["fault_rate"]) for r in runs} == {
        (True, 0.0),
        (True, 0.2),
        (False, 0.0),
        (False, 0.2),
    }
    assert all(set(r["invariants"]) >= {"no_task_leaked", "no_object_lost"} for r in runs)
    assert (out / "success_rate.png").stat().st_size > 0
    assert (out / "distance.png").stat().st_size > 0
    assert code == (1 if any(r["invariant_violations"] for r in data["summary"]["rows"]) else 0)


def test_campaign_rejects_bad_fault_rates(tmp_path, capsys):
    assert main(["campaign", "--faults", "0,x", "--out", str(tmp_path)]) == 2
    assert main(["campaign", "--faults", "2", "--out", str(tmp_path)]) == 2


def test_campaign_reports_harness_crashes(tmp_path, monkeypatch, capsys):
    import aiocram.demo

    def broken(**kwargs):
        raise RuntimeError("the simulator is on fire")

    monkeypatch.setattr(aiocram.demo, "run_demo_once", broken)
    out = tmp_path / "crash"
    code = main(
        [
            "campaign",
            "--seeds",
            "1",
            "--faults",
            "0",
            "--workers",
            "1",
            "--no-projection",
            "--out",
            str(out),
        ]
    )
    assert code == 3
    runs = json.loads((out / "campaign.json").read_text())["runs"]
    assert runs[0]["error"] == "RuntimeError: the simulator is on fire"
    assert "crashed in the harness" in capsys.readouterr().err
