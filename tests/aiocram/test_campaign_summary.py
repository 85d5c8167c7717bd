"""The campaign's aggregation and argument checks (the real demo runs are in
test_campaign_runs.py)."""

from __future__ import annotations

import pytest

from aiocram.campaign import INVARIANTS, run_campaign, summarise


def _run(seed, rate, proj, delivered, distance, broken=(), phantoms=0):
    objects = {
        f"o{i}": {
            "claimed": i < delivered + phantoms,
            "delivered": i < delivered,
            "where": "island" if i < delivered else "floor",
            "retries": {"relocations": i},
        }
        for i in range(5)
    }
    return {
        "seed": seed,
        "fault_rate": rate,
        "projection": proj,
        "objects": objects,
        "distance_driven": distance,
        "real_time_s": 100.0,
        "wall_time_s": 2.0,
        "invariants": {name: name not in broken for name in INVARIANTS},
        "violations": {name: "broken on purpose" for name in broken},
    }


def test_summary_per_mode_and_rate():
    results = [
        _run(1, 0.0, True, 5, 10.0),
        _run(2, 0.0, True, 4, 12.0),
        _run(1, 0.1, True, 3, 20.0, broken=("drawer_closed",)),
        _run(1, 0.0, False, 5, 30.0),
    ]
    rows = {(r["projection"], r["fault_rate"]): r for r in summarise(results)["rows"]}
    assert rows[(True, 0.0)]["success_rate"] == pytest.approx(9 / 10)
    assert rows[(True, 0.0)]["delivered_rate"] == pytest.approx(9 / 10)
    assert rows[(True, 0.0)]["phantoms"] == 0
    assert rows[(True, 0.0)]["mean_distance_m"] == pytest.approx(11.0)
    assert rows[(True, 0.0)]["retries"] == {"relocations": 20}
    assert rows[(True, 0.1)]["invariant_violations"] == [
        {"seed": 1, "invariant": "drawer_closed", "detail": "broken on purpose"}
    ]
    assert rows[(False, 0.0)]["invariant_violations"] == []


def test_harness_errors_count_as_violations():
    results = [
        {
            "seed": 3,
            "fault_rate": 0.0,
            "projection": True,
            "error": "RuntimeError: x",
            "objects": {},
            "invariants": {},
            "wall_time_s": 0.1,
        }
    ]
    (row,) = summarise(results)["rows"]
    assert row["invariant_violations"][0]["invariant"] == "harness"


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"seeds": 0, "faults": [0.0]}, "at least 1"),
        ({"seeds": 1, "faults": [1.5]}, "probabilities"),
        ({"seeds": 1, "faults": [0.0], "backend": "ray"}, "unknown backend"),
    ],
)
def test_bad_arguments(kwargs, message):
    with pytest.raises(ValueError, match=message):
        run_campaign(**kwargs)


def test_campaign_section_of_the_benchmark_report(tmp_path):
    import json

    from aiocram.bench import _campaign_markdown

    summary = summarise(
        [_run(1, 0.0, True, 5, 10.0), _run(2, 0.1, False, 4, 12.0, broken=("arms_parked",))]
    )
    summary.update(
        command="aiocram campaign --seeds 2", backend="local", workers=2, wall_time_s=120.0
    )
    (tmp_path / "campaign.json").write_text(json.dumps({"summary": summary, "runs": []}))
    text = _campaign_markdown(tmp_path)
    assert "| yes | 0.00 | 1 | 100.0 % | 100.0 % | 0 | 10.00 |" in text
    assert "| no | 0.10 | 1 | 80.0 % | 80.0 % | 0 | 12.00 |" in text
    assert "arms_parked 1" in text
    with pytest.raises(ValueError, match="no campaign summary"):
        _campaign_markdown(tmp_path / "missing")


def test_phantoms_are_claimed_objects_not_delivered():
    (row,) = summarise([_run(1, 0.1, True, 2, 10.0, phantoms=2)])["rows"]
    assert row["delivered_rate"] == pytest.approx(2 / 5)
    assert row["claimed_rate"] == pytest.approx(4 / 5)
    assert row["phantoms"] == 2
    assert row["not_delivered_where"] == {"floor": 3}


def test_summary_table_fits_80_columns():
    from rich.console import Console

    from aiocram.campaign import summary_table

    rows = [
        _run(s, r, p, 3, 12.345, phantoms=1)
        for s in (1, 2)
        for r in (0.0, 0.05, 0.1, 0.2)
        for p in (True, False)
    ]
    for r in rows:  # two objects knocked in each run (aiocram.knocks)
        r["knocked"] = ["o3", "o4"]
    console = Console(width=80, record=True, color_system=None)
    console.print(summary_table(summarise(rows)))
    lines = console.export_text().splitlines()
    assert max(len(line) for line in lines) <= 80
    assert not any("…" in line for line in lines)  # nothing truncated
    body = [line for line in lines if line.strip().startswith(("yes", "no"))]
    assert len(body) == 8  # one line per row: nothing wrapped
    assert body[0].split() == [
        "no",
        "0.00",
        "2",
        "60.0",
        "%",
        "80.0",
        "%",
        "2",
        "4",
        "12.35",
        "100",
        "0",
        "0",
    ]
