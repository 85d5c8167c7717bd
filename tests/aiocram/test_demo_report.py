"""The demo's summary on the console (issue 27, item 5): the table never cuts a number
and wraps a long failure name rather than cutting it, at 60 columns as at 80; a run
stopped by Ctrl-C says "interrupted"; violated invariants are listed one per line."""

from __future__ import annotations

import io

import pytest
from rich.console import Console

import cpl
from aiocram.cli import main
from aiocram.demo import DemoConfig, DemoReport, outcome_table, print_report
from aiocram.truth import ObjectTruth, TruthReport
from executive import ObjectNowhereToBeFound
from plans.demo import ObjectOutcome


def _truth(name: str, delivered: bool, claimed: bool = True) -> ObjectTruth:
    return ObjectTruth(name, claimed, "island", 0.0, None, None, None, delivered)


def _report(**kw) -> DemoReport:
    outcomes = {
        "bowl": ObjectOutcome("bowl", "bowl-1", True, None, {"regrasps": 1, "relocations": 1}),
        "cup": ObjectOutcome(
            "cup", "cup-1", False, ObjectNowhereToBeFound("no cup"), {"detecting": 12}
        ),
        "milk": ObjectOutcome("milk", "milk-1", False, cpl.Evaporated("interrupted by Ctrl-C")),
        "breakfast-cereal": ObjectOutcome("breakfast-cereal", "breakfast-cereal-1", True),
    }
    truth = TruthReport(
        {
            "bowl-1": _truth("bowl-1", True),
            "cup-1": _truth("cup-1", False, claimed=False),
            "milk-1": _truth("milk-1", False, claimed=False),
            "breakfast-cereal-1": _truth("breakfast-cereal-1", True),
        },
        kw.pop("invariants", {}),
        kw.pop("violations", {}),
    )
    return DemoReport(
        DemoConfig(),
        outcomes,
        truth.invariants,
        truth.violations,
        1234.5,
        30.0,
        {"bowl": 0.73, "cup": 1.13},
        {"bowl": 100.7, "cup": 54.7, "breakfast-cereal": 1034.1},
        truth=truth,
        distances={"cup": 12.73},
    )


def _render(renderable, width: int) -> str:
    buffer = io.StringIO()
    Console(file=buffer, width=width, color_system=None, _environ={}).print(renderable)
    return buffer.getvalue()


@pytest.mark.parametrize("width", [60, 80, 120])
def test_the_table_never_cuts_a_number_nor_a_failure_name(width):
    text = _render(outcome_table(_report(), width), width)
    lines = text.splitlines()
    assert all(len(line) <= width for line in lines), text
    cells = [[c.strip() for c in line.split("│")[1:-1]] for line in lines if "│" in line]
    for number in ("12.73", "100.7", "54.7", "1034.1", "0.73", "1.13"):
        assert any(number in row for row in cells), (number, text)
    # the outcome column, read down: the failure name whole (wrapped where words join)
    outcomes = "".join(row[1] for row in cells)
    assert "ObjectNowhereToBeFound" in outcomes, text
    assert "breakfast-cereal" in "".join(row[0] for row in cells), text
    # each retries cell keeps its total
    assert any(row[2].startswith("12") for row in cells) and "…" not in "".join(
        row[2].split(":")[0] for row in cells
    )


def test_a_run_stopped_by_ctrl_c_says_interrupted():
    text = _render(outcome_table(_report(), 120), 120)
    milk = next(line for line in text.splitlines() if "milk" in line)
    assert "interrupted" in milk and "Evaporated" not in text


def test_violated_invariants_are_listed_one_per_line():
    report = _report(
        invariants={"no_object_lost": False, "drawer_closed": False, "arms_parked": True},
        violations={"no_object_lost": "cup-1 on the floor"},
    )
    buffer = io.StringIO()
    print_report(report, Console(file=buffer, width=80, color_system=None, _environ={}))
    lines = buffer.getvalue().splitlines()
    at = lines.index("invariants violated:")
    assert lines[at + 1 : at + 3] == [
        "  no_object_lost: cup-1 on the floor",
        "  drawer_closed: (no detail recorded)",
    ]
    assert "{" not in buffer.getvalue()


def test_an_empty_out_is_refused_before_anything_is_written(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["demo", "--no-live", "--out", ""]) == 2
    assert "--out" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_a_fault_kind_given_twice_is_refused(tmp_path, capsys):
    out = tmp_path / "demo"
    code = main(
        ["demo", "--no-live", "--faults", "navigation=0.1,navigation=0.2", "--out", str(out)]
    )
    assert code == 2
    err = capsys.readouterr().err
    assert "--faults" in err and "navigation given more than once" in err
    assert not out.exists()
