"""bench/imagining.py's report (the bench standard): means and medians of both trees,
this tree's ratio to the other measured in the same run, and imagining's growth with the
run's length (per transport of a demo)."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType

BENCH = Path(__file__).resolve().parents[2] / "bench" / "imagining.py"


def _bench() -> ModuleType:
    spec = importlib.util.spec_from_file_location("bench_imagining", BENCH)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_report_gives_means_medians_ratios_and_growth() -> None:
    bench = _bench()
    rows = {
        ("this", "projected"): [
            {"wall": 1.0, "cpu": 0.9, "planning": True, "delivered": 5},
            {"wall": 2.0, "cpu": 1.5, "planning": True, "delivered": 5},
            {"wall": 1.2, "cpu": 1.2, "planning": True, "delivered": 5},
        ],
        ("other", "projected"): [{"wall": 0.8, "cpu": 0.7, "planning": False, "delivered": 5}],
        ("this", "imagining"): [
            {"wall": [0.5, 0.6, 1.0], "cpu": [0.4, 0.5, 0.9], "delivered": 3, "sim": 100.0},
            {"wall": [0.7, 0.8, 1.2], "cpu": [0.6, 0.7, 1.1], "delivered": 3, "sim": 90.0},
        ],
        ("other", "imagining"): [
            {"wall": [0.4, 0.5, 0.6], "cpu": [0.3, 0.4, 0.5], "delivered": 3, "sim": 80.0}
        ],
    }
    lines = bench.summary(rows, ["projected", "imagining"])
    text = "\n".join(lines)
    # projected: mean 1.4 s (GC included), median 1.2 s; ratios against the other's 0.8
    assert "projected demo      this  mean wall  1.400 s" in text
    assert "median wall  1.200 s" in text
    assert "projected demo      ratio this/other: mean wall  1.75x" in text
    assert "| median wall  1.50x" in text
    # imagining grows with the transport's index: means of the k-th transport
    assert "imagining by transport (this, mean cpu s): #1 0.500  #2 0.600  #3 1.000" in text
    assert "imagining by transport (other, mean cpu s): #1 0.300  #2 0.400  #3 0.500" in text


def test_a_missing_side_prints_no_ratio() -> None:
    bench = _bench()
    rows = {("this", "projected"): [{"wall": 1.0, "cpu": 0.9, "planning": True, "delivered": 5}]}
    lines = bench.summary(rows, ["projected"])
    assert any("ratio this/other: mean wall    -  " in line for line in lines)
