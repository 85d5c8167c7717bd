"""``aiocram bench``: run every benchmark in ``bench/`` and write a markdown report
(``out/BENCHMARKS.md`` by default; the tracked ``BENCHMARKS.md`` at the repository root is
only replaced when asked for with ``--out BENCHMARKS.md``).

Each benchmark runs in its own Python process (no shared caches, garbage or loops) and
prints its figures beside a baseline measured in the same run, as ratios: these machines
are noisy, so absolute numbers alone mean little. ``BENCHMARKS.md`` records the machine,
the date, the command and every benchmark's output, and says how to reproduce it.

The benchmarks live in the source tree (``bench/`` next to ``pyproject.toml``); run the
command from a checkout (``pip install -e .``).
"""

from __future__ import annotations

import argparse
import datetime
import os
import platform
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

__all__ = ["BENCHMARKS", "add_parser", "run_benchmarks"]

#: (script, arguments, what it measures), in report order.
BENCHMARKS: tuple[tuple[str, tuple[str, ...], str], ...] = (
    (
        "cpl_overhead.py",
        (),
        "cpl forms vs asyncio.TaskGroup, memory per task, wait_for "
        "latency vs asyncio.Event, live-view cost",
    ),
    (
        "executive_perform.py",
        (),
        "perform of a motion and of an action vs asyncio tasks; flatness over 10k performs",
    ),
    (
        "blocking_driver.py",
        ("--rounds", "3"),
        "event-loop latency while a blocking driver runs in a worker thread vs on the loop",
    ),
    (
        "soak.py",
        ("--performs", "1000000"),
        "a robot running all day: 1 M action performs in one top level under the "
        "long-running retention policy (RSS, full-collection pauses, flatness) vs asyncio",
    ),
    (
        "soak_table.py",
        ("--hours", "1"),
        "a projected robot setting the table in a loop for an hour of simulated time in one "
        "top level (long-running retention): RSS, pauses, flatness",
    ),
    ("projection_ops.py", ("--reps", "1000"), "projection operations vs raw PyBullet"),
    ("projection_costmaps.py", (), "costmap sampling and building vs numpy / rayTestBatch"),
    ("projection_demo.py", ("--seeds", "5"), "bowl transport and five-object demo in projection"),
    (
        "real_robot_demo.py",
        ("--seeds", "3"),
        "projection-then-execute on the simulated real robot at maximum speed vs projection only",
    ),
)


def _bench_dir() -> Path:
    here = Path(__file__).resolve().parent.parent / "bench"
    if not here.is_dir():
        raise SystemExit(
            "aiocram bench: the benchmarks live in the source tree's bench/ folder; run it "
            "from a checkout installed with `pip install -e .`"
        )
    return here


def _machine() -> dict[str, str]:
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    mem = ""
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemTotal"):
                mem = f"{int(line.split()[1]) / 1024 / 1024:.1f} GiB"
                break
    except OSError:
        pass
    from importlib.metadata import PackageNotFoundError, version

    try:
        pybullet_version = version("pybullet")
    except PackageNotFoundError:
        pybullet_version = "unknown"
    return {
        "cpu": cpu,
        "cores": str(os.cpu_count()),
        "memory": mem,
        "os": platform.platform(),
        "python": platform.python_version(),
        "pybullet": pybullet_version,
    }


def run_benchmarks(
    names: list[str] | None = None,
    out: Path | None = None,
    quick: bool = False,
    campaign: Path | None = None,
) -> list[dict[str, Any]]:
    """Run the benchmarks (all, or those whose script name starts with one of ``names``);
    print each one's output as it finishes; write the markdown report to ``out``."""
    bench = _bench_dir()
    selected = [b for b in BENCHMARKS if not names or any(b[0].startswith(n) for n in names)]
    if not selected:
        known = ", ".join(b[0] for b in BENCHMARKS)
        raise ValueError(f"no benchmark matches {names}; known: {known}")
    results = []
    for script, args, what in selected:
        if quick:
            args = _quick_args(script)
        cmd = [sys.executable, str(bench / script), *args]
        print(f"== {script}: {what}", flush=True)
        t0 = time.perf_counter()
        proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
        elapsed = time.perf_counter() - t0
        text = proc.stdout.rstrip()
        print(text, flush=True)
        if proc.returncode != 0:
            print(proc.stderr.rstrip()[-2000:], file=sys.stderr)
        results.append(
            {
                "script": script,
                "args": list(args),
                "what": what,
                "output": text,
                "returncode": proc.returncode,
                "seconds": elapsed,
            }
        )
    if out is not None:
        text = _markdown(results)
        if campaign is not None:
            text += "\n" + _campaign_markdown(campaign)
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(text)
        print(f"wrote {out}")
    return results


def _campaign_markdown(directory: Path) -> str:
    """The robustness campaign's summary (``DIR/campaign.json`` from ``aiocram
    campaign``) as a markdown section; missing or malformed: ValueError naming the file."""
    import json

    path = directory / "campaign.json"
    try:
        summary = json.loads(path.read_text())["summary"]
    except (OSError, KeyError, ValueError) as exc:
        raise ValueError(f"no campaign summary in {path}: {exc}") from exc
    lines = [
        "## Robustness campaign",
        "",
        f"Command: `{summary.get('command', 'aiocram campaign')}` "
        f"({summary.get('backend', 'local')} backend, {summary.get('workers', '?')} workers, "
        f"{summary.get('wall_time_s', 0.0) / 60:.0f} min). The table-setting demo on the "
        "simulated real robot for every (seed, fault rate), with and without projection "
        "reasoning; plots: `success_rate.png`, `distance.png` next to the JSON.",
        "",
        "Objects *delivered* are measured on the true world after the run (upright on the "
        "island near where the plan placed them, see `aiocram.truth`); *claimed* is what the "
        "plan reported; a *phantom* was claimed but not delivered.",
        "",
        "| robot | projection | fault rate | runs | delivered | claimed | phantoms "
        "| mean distance (m) | mean sim time (s) | runs violating an invariant | retries used |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in summary["rows"]:
        bad_runs = len({v["seed"] for v in r["invariant_violations"]})
        retries = ", ".join(f"{k} {v}" for k, v in r["retries"].items()) or "-"
        lines.append(
            f"| {r.get('robot', 'pr2')} "  # a summary from before robots were a choice: pr2
            f"| {'yes' if r['projection'] else 'no'} | {r['fault_rate']:.2f} | {r['runs']} | "
            f"{100 * r.get('delivered_rate', r['success_rate']):.1f} % | "
            f"{100 * r.get('claimed_rate', 0.0):.1f} % | {r.get('phantoms', 0)} | "
            f"{r['mean_distance_m']:.2f} | "
            f"{r['mean_sim_time_s']:.1f} | {bad_runs} | {retries} |"
        )
    kinds: dict[str, int] = {}
    for r in summary["rows"]:
        for v in r["invariant_violations"]:
            kinds[v["invariant"]] = kinds.get(v["invariant"], 0) + 1
    if kinds:
        lines += [
            "",
            "Invariant violations by kind: "
            + ", ".join(f"{k} {n}" for k, n in sorted(kinds.items()))
            + ".",
        ]
    return "\n".join(lines) + "\n"


def _quick_args(script: str) -> tuple[str, ...]:
    return {
        "cpl_overhead.py": ("--sizes", "1000", "--repeat", "1", "--waiters", "1", "100"),
        "blocking_driver.py": ("--rounds", "1"),
        "executive_perform.py": ("2000",),
        "soak.py": ("--quick",),
        "soak_table.py": ("--quick",),
        "projection_ops.py": ("--reps", "50"),
        "projection_costmaps.py": ("--reps", "50"),
        "projection_demo.py": ("--seeds", "1"),
        "real_robot_demo.py": ("--seeds", "1"),
    }.get(script, ())


def _markdown(results: list[dict[str, Any]]) -> str:
    m = _machine()
    now = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
    lines = [
        "# Benchmarks",
        "",
        "Generated by `aiocram bench` (`python -m aiocram.bench` runs the same). Every",
        "figure is printed beside a baseline measured in the same run, as a ratio; the",
        "machines are noisy, so compare ratios rather than absolute times.",
        "",
        f"- date: {now}",
        f"- machine: {m['cpu']}, {m['cores']} cores, {m['memory']}; {m['os']}",
        f"- Python {m['python']}, pybullet {m['pybullet']}",
        "",
        "To reproduce: `pip install -e . && aiocram bench` (all, ~10 minutes; writes",
        "`out/BENCHMARKS.md`, `--out BENCHMARKS.md` updates this file), or",
        "`aiocram bench cpl_overhead` for one; each script also runs alone:",
        "`python bench/<script>.py --help`.",
        "",
    ]
    for r in results:
        args = " ".join(r["args"])
        lines += [
            f"## {r['script']}",
            "",
            f"{r['what']}. Command: `python bench/{r['script']}{' ' + args if args else ''}`"
            f" ({r['seconds']:.0f} s{'' if r['returncode'] == 0 else ', FAILED'}).",
            "",
            "```",
            r["output"],
            "```",
            "",
        ]
    return "\n".join(lines)


def add_parser(subparsers: Any) -> None:
    from aiocram._help import HelpFormatter

    p = subparsers.add_parser(
        "bench",
        help="run the benchmarks and write a markdown report",
        description="Run the benchmarks in bench/ (each in its own process) and write their "
        "output, with the machine and the date, as a markdown report.",
        formatter_class=HelpFormatter,
    )
    p.add_argument("names", nargs="*", help="only these benchmarks (script name prefixes)")
    p.add_argument(
        "--out",
        default="out/BENCHMARKS.md",
        metavar="FILE",
        help="the report (--out BENCHMARKS.md replaces the tracked one at the repository root)",
    )
    p.add_argument("--no-report", action="store_true", help="print only, write no report")
    p.add_argument("--quick", action="store_true", help="tiny sizes (a smoke test)")
    p.add_argument(
        "--campaign",
        help="also report this `aiocram campaign --out` directory's results in the report",
    )
    p.set_defaults(handler=_command)


def _check_report_path(out: Path) -> None:
    """ValueError naming ``--out`` unless a report can be written at ``out`` (checked
    before any benchmark runs, so a typo does not cost ten minutes)."""
    from aiocram._outputs import check_out_dir

    if out.is_dir():
        raise ValueError(f"--out {out}: is a directory; give a file name such as {out}/BENCH.md")
    check_out_dir(out.parent)
    if out.exists() and not os.access(out, os.W_OK):
        raise ValueError(f"--out {out}: is not writable")


def _command(args: argparse.Namespace) -> int:
    try:
        if not args.no_report:
            _check_report_path(Path(args.out))
        results = run_benchmarks(
            args.names or None,
            None if args.no_report else Path(args.out),
            quick=args.quick,
            campaign=Path(args.campaign) if args.campaign else None,
        )
    except ValueError as exc:
        print(f"aiocram bench: error: {exc}", file=sys.stderr)
        return 2
    return 0 if all(r["returncode"] == 0 for r in results) else 1


if __name__ == "__main__":
    parser = argparse.ArgumentParser(prog="aiocram bench")
    sub = parser.add_subparsers(dest="command")
    add_parser(sub)
    sys.exit(_command(parser.parse_args(["bench", *sys.argv[1:]])))
