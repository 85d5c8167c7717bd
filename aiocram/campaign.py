"""The robustness campaign: the table-setting demo on the simulated real robot for every
(seed, fault rate), with and without projection reasoning.

Each job is independent and seeded (:func:`aiocram.demo.run_demo_once`), so jobs can run
anywhere: the ``local`` backend uses a process pool on this machine; the ``dask`` backend
sends the very same jobs to a ``dask.distributed`` cluster (a ``LocalCluster`` by default,
or the scheduler at ``--scheduler ADDRESS``), so a user who outgrows one machine adds
workers, not code.

Per fault rate it reports object success rate, retries used by kind, base distance driven,
time, and the invariants that must hold in every run (no task alive after the run, no
object lost or left attached, the drawer closed, the arms parked). Results go to
``OUT/campaign.json`` and PNG plots (success rate and distance against fault rate, with and
without projection).

Exit status: 0 when every invariant held in every run, 1 when some run violated one (the
violations are in the report), 2 for bad arguments, 3 when the harness itself crashed in
some run.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import sys
import time
from collections import defaultdict
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

__all__ = ["Job", "main", "run_campaign", "summarise"]


@dataclass(frozen=True)
class Job:
    """One demo run: a seed, a uniform fault rate, projection reasoning on or off."""

    seed: int
    fault_rate: float
    projection: bool
    objects: tuple[str, ...] = ("bowl", "cup", "spoon", "milk", "breakfast-cereal")
    runs: int = 3


def run_job(job: Job) -> dict[str, Any]:
    """Run one job in this process (picklable entry point for both backends). A crash of the
    demo itself is recorded as a result with ``error`` set, never lost."""
    from aiocram.demo import run_demo_once

    t0 = time.perf_counter()
    try:
        result = run_demo_once(
            seed=job.seed,
            fault_rate=job.fault_rate,
            projection=job.projection,
            objects=job.objects,
            runs=job.runs,
        )
    except Exception as exc:  # the campaign records every failure of the harness itself
        result = {
            "seed": job.seed,
            "fault_rate": job.fault_rate,
            "projection": job.projection,
            "error": f"{type(exc).__name__}: {exc}",
            "objects": {},
            "invariants": {},
        }
    result["wall_time_s"] = time.perf_counter() - t0
    return result


def _jobs(
    seeds: int,
    faults: Sequence[float],
    modes: Sequence[bool],
    first_seed: int,
    objects: tuple[str, ...],
) -> list[Job]:
    return [
        Job(seed=first_seed + s, fault_rate=f, projection=p, objects=objects)
        for p in modes
        for f in faults
        for s in range(seeds)
    ]


def _run_local(
    jobs: list[Job], workers: int, progress: Callable[[int, int], None]
) -> list[dict[str, Any]]:
    if workers <= 1:
        out = []
        for i, job in enumerate(jobs):
            out.append(run_job(job))
            progress(i + 1, len(jobs))
        return out
    results: list[dict[str, Any]] = []
    with ProcessPoolExecutor(max_workers=workers) as pool:
        for i, res in enumerate(pool.map(run_job, jobs, chunksize=1)):
            results.append(res)
            progress(i + 1, len(jobs))
    return results


def _run_dask(
    jobs: list[Job], workers: int, scheduler: str | None, progress: Callable[[int, int], None]
) -> list[dict[str, Any]]:
    try:
        from dask.distributed import Client, LocalCluster, as_completed
    except ImportError as exc:  # pragma: no cover - depends on the installation
        raise SystemExit(
            "the dask backend needs dask.distributed: pip install 'aiocram[dask]'"
        ) from exc
    cluster = None
    if scheduler is None:
        cluster = LocalCluster(
            n_workers=max(1, workers), threads_per_worker=1, processes=True, dashboard_address=None
        )
        client = Client(cluster)
    else:
        client = Client(scheduler)
    try:
        futures = client.map(run_job, jobs, pure=False)
        index = {f.key: i for i, f in enumerate(futures)}
        results: list[dict[str, Any] | None] = [None] * len(jobs)
        for done, fut in enumerate(as_completed(futures), start=1):
            results[index[fut.key]] = fut.result()
            progress(done, len(jobs))
        return [r for r in results if r is not None]
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def run_campaign(
    *,
    seeds: int,
    faults: Sequence[float],
    projection_modes: Sequence[bool] = (True, False),
    workers: int = 1,
    backend: str = "local",
    scheduler: str | None = None,
    first_seed: int = 1,
    objects: Sequence[str] = Job.objects,
    progress: Callable[[int, int], None] | None = None,
) -> list[dict[str, Any]]:
    """Run every (seed, fault rate, projection mode) job and return the raw results."""
    if seeds < 1:
        raise ValueError(f"--seeds must be at least 1, got {seeds}")
    bad = [f for f in faults if not (0.0 <= f <= 1.0) or math.isnan(f)]
    if bad:
        raise ValueError(f"fault rates are probabilities in [0, 1], got {bad}")
    jobs = _jobs(seeds, faults, projection_modes, first_seed, tuple(objects))
    report = progress or (lambda done, total: None)
    if backend == "local":
        return _run_local(jobs, workers, report)
    if backend == "dask":
        return _run_dask(jobs, workers, scheduler, report)
    raise ValueError(f"unknown backend {backend!r}: use 'local' or 'dask'")


INVARIANTS = ("no_task_alive", "no_object_lost", "nothing_attached", "drawer_closed", "arms_parked")


def summarise(results: Iterable[dict[str, Any]]) -> dict[str, Any]:
    """Aggregate per (projection mode, fault rate): success rate, retries by kind, distance,
    time, and invariant violations (each listed with its seed)."""
    groups: dict[tuple[bool, float], list[dict[str, Any]]] = defaultdict(list)
    for r in results:
        groups[(bool(r["projection"]), float(r["fault_rate"]))].append(r)
    rows = []
    for (proj, rate), runs in sorted(groups.items()):
        objects = [o for r in runs for o in r.get("objects", {}).values()]
        delivered = sum(1 for o in objects if o.get("success"))
        retries: dict[str, int] = defaultdict(int)
        for o in objects:
            for kind, n in (o.get("retries") or {}).items():
                retries[kind] += int(n)
        distances = [r.get("distance_driven", 0.0) for r in runs if "error" not in r]
        sim_times = [r.get("real_time_s", 0.0) for r in runs if "error" not in r]
        violations = []
        for r in runs:
            if "error" in r:
                violations.append({"seed": r["seed"], "invariant": "harness", "detail": r["error"]})
                continue
            for name in INVARIANTS:
                if not r["invariants"].get(name, False):
                    violations.append(
                        {
                            "seed": r["seed"],
                            "invariant": name,
                            "detail": r.get("violations", {}).get(name, ""),
                        }
                    )
        rows.append(
            {
                "projection": proj,
                "fault_rate": rate,
                "runs": len(runs),
                "objects": len(objects),
                "success_rate": delivered / len(objects) if objects else 0.0,
                "retries": dict(sorted(retries.items())),
                "mean_distance_m": statistics.fmean(distances) if distances else 0.0,
                "mean_sim_time_s": statistics.fmean(sim_times) if sim_times else 0.0,
                "mean_wall_time_s": statistics.fmean(r.get("wall_time_s", 0.0) for r in runs),
                "invariant_violations": violations,
            }
        )
    return {"rows": rows}


def _plot(summary: dict[str, Any], out: Path) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    paths = []
    for key, label, fname in (
        ("success_rate", "object success rate", "success_rate.png"),
        ("mean_distance_m", "mean base distance driven (m)", "distance.png"),
    ):
        fig, ax = plt.subplots(figsize=(6, 4), dpi=100)
        for proj in (True, False):
            rows = [r for r in summary["rows"] if r["projection"] is proj]
            if not rows:
                continue
            ax.plot(
                [r["fault_rate"] for r in rows],
                [r[key] for r in rows],
                marker="o",
                label="with projection" if proj else "without projection",
            )
        ax.set_xlabel("low-level fault rate")
        ax.set_ylabel(label)
        ax.set_ylim(0.0, 1.02 if key == "success_rate" else None)
        ax.grid(True, alpha=0.3)
        ax.legend()
        fig.tight_layout()
        path = out / fname
        fig.savefig(path)
        plt.close(fig)
        paths.append(path)
    return paths


def _print_summary(summary: dict[str, Any]) -> None:
    from rich.console import Console
    from rich.table import Table

    table = Table(title="robustness campaign")
    for col in (
        "projection",
        "fault rate",
        "runs",
        "success",
        "distance (m)",
        "sim time (s)",
        "retries",
        "violations",
    ):
        table.add_column(col)
    for r in summary["rows"]:
        table.add_row(
            "yes" if r["projection"] else "no",
            f"{r['fault_rate']:.2f}",
            str(r["runs"]),
            f"{100 * r['success_rate']:.1f} %",
            f"{r['mean_distance_m']:.2f}",
            f"{r['mean_sim_time_s']:.1f}",
            ", ".join(f"{k} {v}" for k, v in r["retries"].items()) or "-",
            str(len(r["invariant_violations"])),
        )
    Console().print(table)


def add_parser(subparsers: Any) -> None:
    p = subparsers.add_parser("campaign", help="run the robustness campaign")
    p.add_argument("--seeds", type=int, default=20, help="seeds per fault rate (default 20)")
    p.add_argument("--first-seed", type=int, default=1)
    p.add_argument(
        "--objects",
        nargs="+",
        default=list(Job.objects),
        help="objects to set in every run (default: all five)",
    )
    p.add_argument(
        "--faults",
        default="0,0.05,0.1,0.2",
        help="comma-separated uniform fault rates (default 0,0.05,0.1,0.2)",
    )
    p.add_argument(
        "--no-projection",
        action="store_true",
        help="only run without projection reasoning (default: both modes)",
    )
    p.add_argument("--only-projection", action="store_true", help=argparse.SUPPRESS)
    p.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    p.add_argument("--backend", choices=("local", "dask"), default="local")
    p.add_argument("--scheduler", help="dask scheduler address (default: a LocalCluster)")
    p.add_argument("--out", default="out/campaign", help="output directory")
    p.set_defaults(handler=_command)


def _command(args: argparse.Namespace) -> int:
    try:
        faults = [float(x) for x in args.faults.split(",") if x.strip()]
    except ValueError:
        print(
            f"aiocram campaign: --faults takes numbers like 0,0.05,0.1, got {args.faults!r}",
            file=sys.stderr,
        )
        return 2
    modes: tuple[bool, ...] = (False,) if args.no_projection else (True, False)
    if args.only_projection:
        modes = (True,)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()

    def progress(done: int, total: int) -> None:
        print(f"\r{done}/{total} runs", end="", file=sys.stderr, flush=True)

    try:
        results = run_campaign(
            seeds=args.seeds,
            faults=faults,
            projection_modes=modes,
            workers=args.workers,
            backend=args.backend,
            scheduler=args.scheduler,
            first_seed=args.first_seed,
            objects=args.objects,
            progress=progress,
        )
    except ValueError as exc:
        print(f"\naiocram campaign: {exc}", file=sys.stderr)
        return 2
    print(file=sys.stderr)
    summary = summarise(results)
    summary["command"] = " ".join(["aiocram", *sys.argv[1:]])
    summary["backend"] = args.backend
    summary["workers"] = args.workers
    summary["wall_time_s"] = time.perf_counter() - t0
    (out / "campaign.json").write_text(json.dumps({"summary": summary, "runs": results}, indent=2))
    plots = _plot(summary, out)
    _print_summary(summary)
    print(f"wrote {out / 'campaign.json'} and {', '.join(str(p) for p in plots)}")
    errors = sum(1 for r in results if "error" in r)
    if errors:
        print(
            f"{errors} runs crashed in the harness (see 'error' in campaign.json)", file=sys.stderr
        )
        return 3
    violated = sum(len(r["invariant_violations"]) for r in summary["rows"])
    return 1 if violated else 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="aiocram")
    sub = parser.add_subparsers(dest="command", required=True)
    add_parser(sub)
    args = parser.parse_args(argv)
    handler: Callable[[argparse.Namespace], int] = args.handler
    return handler(args)
