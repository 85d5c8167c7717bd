"""The campaign guards its input and its results (issue 27, item 3): every flag is
checked before a run starts or a file is written (exit 2, the flag named, the previous
campaign untouched), a previous campaign is never wiped unasked, a dask scheduler that
does not answer is an error within seconds, a crashed run's objects stay in the
denominator, and a full disk keeps every run."""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from aiocram.campaign import INVARIANTS, main, summarise, summary_table

ROOT = Path(__file__).resolve().parents[2]
BASE = ["campaign", "--seeds", "2", "--faults", "0", "--no-projection", "--workers", "1"]


def record(seed, fault_rate, projection, objects=("bowl",), **_):
    return {
        "seed": seed,
        "fault_rate": fault_rate,
        "projection": projection,
        "objects": {o: {"claimed": True, "delivered": True, "where": "island"} for o in objects},
        "distance_driven": 1.0,
        "real_time_s": 10.0,
        "invariants": {name: True for name in INVARIANTS},
        "violations": {},
    }


@pytest.fixture
def no_runs(monkeypatch):
    import aiocram.demo

    def run(**kwargs):
        raise AssertionError("a run started")

    monkeypatch.setattr(aiocram.demo, "run_demo_once", run)


@pytest.fixture
def fake_runs(monkeypatch):
    import aiocram.demo

    monkeypatch.setattr(aiocram.demo, "run_demo_once", record)


def _previous(path: Path) -> dict[str, str]:
    """A finished campaign of 16 runs in ``path``; its files' contents."""
    path.mkdir(parents=True)
    (path / "runs.jsonl").write_text(
        "".join(json.dumps(record(s, 0.0, False)) + "\n" for s in range(16))
    )
    (path / "campaign.json").write_text('{"summary": "the previous campaign"}')
    (path / "success_rate.png").write_bytes(b"previous plot")
    return _contents(path)


def _contents(path: Path) -> dict[str, str]:
    """The files (not directories: a campaign's staging one) in ``path``, but for the
    experience store, which every campaign adds its runs to (issue 29)."""
    return {
        p.name: p.read_bytes().decode(errors="replace")
        for p in sorted(path.iterdir())
        if p.is_file() and not p.name.startswith("experience.sqlite")
    }


@pytest.mark.usefixtures("no_runs")
@pytest.mark.parametrize(
    ("flags", "flag", "words"),
    [
        (["--first-seed", "-1"], "--first-seed", "whole number >= 0"),
        (["--seeds", "0"], "--seeds", "whole number >= 1"),
        (["--seeds", "two"], "--seeds", "whole number"),
        (["--faults", "0,0.1,0.1"], "--faults", "0.1 given more than once"),
        (["--faults", "0.1,0.10"], "--faults", "given more than once"),
        (["--faults", "0,,0.1"], "--faults", "separated by commas"),
        (["--faults", "1.5"], "--faults", "probability from 0 to 1"),
        (["--workers", "0"], "--workers", "whole number >= 1"),
        (["--scheduler", "tcp://127.0.0.1:8786"], "--scheduler", "--backend dask"),
        (["--objects", "bowl", "plate"], "--objects", "unknown plate"),
    ],
)
def test_bad_flags_are_refused_before_anything_is_written(tmp_path, capsys, flags, flag, words):
    out = tmp_path / "previous"
    before = _previous(out)
    assert main([*BASE, "--out", str(out), "--overwrite", *flags]) == 2
    err = capsys.readouterr().err
    assert flag in err and words in err, err
    assert _contents(out) == before


@pytest.mark.usefixtures("no_runs")
def test_an_out_that_is_a_file_or_empty_is_refused(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    notes = tmp_path / "notes.txt"
    notes.write_text("mine")
    assert main([*BASE, "--out", str(notes)]) == 2
    assert "--out" in capsys.readouterr().err
    assert notes.read_text() == "mine"
    assert main([*BASE, "--out", ""]) == 2
    assert "--out" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.txt"]


def test_a_previous_campaign_is_refused_and_replaced_only_when_asked(tmp_path, capsys, monkeypatch):
    import aiocram.demo

    out = tmp_path / "c"
    before = _previous(out)
    monkeypatch.setattr(aiocram.demo, "run_demo_once", record)
    assert main([*BASE, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "--out" in err and "holds a campaign already" in err and "--overwrite" in err
    assert _contents(out) == before

    seen_during_the_run = []

    def run(**kwargs):
        seen_during_the_run.append(_contents(out))
        return record(**kwargs)

    monkeypatch.setattr(aiocram.demo, "run_demo_once", run)
    assert main([*BASE, "--out", str(out), "--overwrite"]) == 0
    # until the new campaign ended, the previous one stayed as it was
    assert all(seen == before for seen in seen_during_the_run) and len(seen_during_the_run) == 2
    runs = [json.loads(line) for line in (out / "runs.jsonl").read_text().splitlines()]
    assert [r["seed"] for r in runs] == [1, 2]
    assert json.loads((out / "campaign.json").read_text())["summary"]["runs_finished"] == 2
    assert (out / "success_rate.png").read_bytes() != b"previous plot"
    assert not list(out.glob(".partial-*"))


def _closed_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@pytest.mark.usefixtures("no_runs")
def test_a_scheduler_that_does_not_answer_is_a_usage_error(tmp_path, capsys):
    pytest.importorskip("dask.distributed")
    out = tmp_path / "d"
    address = f"tcp://127.0.0.1:{_closed_port()}"
    code = main([*BASE, "--backend", "dask", "--scheduler", address, "--out", str(out)])
    assert code == 2
    err = capsys.readouterr().err
    assert f"--scheduler {address}: no dask scheduler answered" in err
    assert not out.exists()


def test_a_crashed_run_counts_its_objects_as_not_delivered():
    objects = ("bowl", "cup", "spoon", "milk", "breakfast-cereal")
    fine = record(1, 0.1, True, objects=objects)
    crashed = {
        "seed": 2,
        "fault_rate": 0.1,
        "projection": True,
        "error": "WorkerDied: the worker process running this job was killed by SIGKILL",
        "objects": {},
        "planned": list(objects),
        "invariants": {},
    }
    old_style = {k: v for k, v in crashed.items() if k != "planned"} | {"seed": 3}
    (row,) = summarise([fine, crashed, old_style])["rows"]
    assert row["objects"] == 15 and row["delivered"] == 5
    assert row["delivered_rate"] == pytest.approx(1 / 3)
    assert row["runs_crashed"] == 2
    assert row["not_delivered_where"] == {"crashed run": 10}
    from rich.console import Console

    console = Console(width=80, record=True, color_system=None)
    console.print(summary_table(summarise([fine, crashed])))
    lines = console.export_text().splitlines()
    header = next(line for line in lines if "crash" in line.split())  # headers: 1-2 lines
    body = next(line for line in lines if line.startswith("yes"))
    end = header.index("crash") + len("crash")  # the column is right-justified
    assert body[:end].split()[-1] == "1"


_FULL_DISK = textwrap.dedent(
    """
    import json, resource, sys
    sys.path.insert(0, {tests!r})
    import aiocram.demo
    from test_campaign_guards import record

    aiocram.demo.run_demo_once = record
    from aiocram.campaign import main

    typical = record(3, 0.0, False, aiocram.demo.DEFAULT_OBJECTS)
    line = len(json.dumps({{**typical, "wall_time_s": 0.00012345678901234}})) + 1
    # the file system takes two and a half records per file: the third run finds it full
    resource.setrlimit(resource.RLIMIT_FSIZE, (int(2.5 * line), resource.RLIM_INFINITY))
    # --no-store: runs.jsonl's guard is under test (a store that cannot be written is
    # refused before the runs: test_experience.py)
    sys.exit(main(["campaign", "--seeds", "5", "--faults", "0", "--no-projection",
                   "--workers", {workers!r}, "--out", {out!r}, "--no-store"]))
    """
)


@pytest.mark.skipif(sys.platform == "win32", reason="needs RLIMIT_FSIZE")
@pytest.mark.parametrize("workers", ["1", "2"])
def test_a_full_disk_keeps_every_run_and_says_what_to_free(tmp_path, workers):
    """With 2 workers the run in flight when the disk filled up finishes and is kept."""
    out = tmp_path / "full"
    script = _FULL_DISK.format(tests=str(Path(__file__).parent), out=str(out), workers=workers)
    proc = subprocess.run(
        [sys.executable, "-c", script],
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONPATH": str(ROOT), "COLUMNS": "80"},
        timeout=300,
        check=False,
    )
    assert proc.returncode == 4, proc.stderr
    assert "Traceback" not in proc.stderr
    # runs.jsonl holds whole records only: the two written before the disk was full
    on_disk = [json.loads(line) for line in (out / "runs.jsonl").read_text().splitlines()]
    assert len(on_disk) == 2
    # the run that found the disk full is not lost (nor, with 2 workers, the one still in
    # flight then): each is printed as a JSON line
    printed = [json.loads(line) for line in proc.stdout.splitlines() if line.startswith("{")]
    finished = sorted(r["seed"] for r in on_disk + printed)
    assert finished == list(range(1, len(finished) + 1)) and 1 <= len(printed) <= int(workers)
    assert all("error" not in r for r in on_disk + printed)
    assert f"cannot write {out / 'runs.jsonl'}: File too large" in proc.stderr
    assert f"stopped after {len(finished)} of 5 runs" in proc.stderr
    assert "keeps the 2 runs written before" in proc.stderr
    assert f"Free space on the file system of {out}" in proc.stderr


def test_help_describes_the_command_and_every_flag():
    from aiocram.cli import build_parser

    parser = build_parser()
    (sub,) = [a for a in parser._actions if a.dest == "command"]
    campaign = sub.choices["campaign"]  # type: ignore[index]
    assert "Exit status" in (campaign.description or "")
    undocumented = [
        a.option_strings[0]
        for a in campaign._actions
        if a.option_strings and a.help != "==SUPPRESS==" and not (a.help or "").strip()
    ]
    assert undocumented == []


def test_overwrite_stopped_before_any_run_ended_leaves_the_previous_campaign(
    tmp_path, capsys, monkeypatch
):
    """Ctrl-C two seconds into a campaign started with --overwrite: nothing to replace
    the previous campaign with, so it stays."""
    import aiocram.demo

    out = tmp_path / "c"
    before = _previous(out)

    def run(**kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(aiocram.demo, "run_demo_once", run)
    assert main([*BASE, "--out", str(out), "--overwrite"]) == 130
    assert "the previous campaign in" in capsys.readouterr().err
    assert _contents(out) == before
    assert not list(out.glob(".partial-*"))
