"""The robustness campaign: the table-setting demo on the simulated real robot for every
(seed, fault rate), with and without projection reasoning.

Each job is independent and seeded (:func:`aiocram.demo.run_demo_once`), so jobs can run
anywhere: the ``local`` backend runs them on worker processes of this machine; the
``dask`` backend sends the very same jobs to a ``dask.distributed`` cluster (a
``LocalCluster`` by default, or the scheduler at ``--scheduler ADDRESS``), so a user who
outgrows one machine adds workers, not code.

Every figure is measured on the true world (:mod:`aiocram.truth`): per fault rate, the
objects *delivered* (upright on the island near where the plan placed them), what the
plans *claimed*, the *phantoms* (claimed, not delivered), where the others ended up,
retries by kind, base distance, time, and the invariants that must hold in every run
(:data:`aiocram.truth.INVARIANTS`), each violation with its seed and why.

The harness keeps every finished run: each run's record is appended to ``OUT/runs.jsonl``
as it ends; a local worker that dies (killed, crashed) is recorded as an ``error`` run of
its job, replaced, and the campaign goes on; Ctrl-C stops the workers, writes the partial
summary (``"partial": true``) and says so. All arguments are checked before any job starts
or any file is written. The summary goes to ``OUT/campaign.json`` with PNG plots, and to
the console as a table that fits 80 columns (the retries are in the JSON).

Exit status: 0 when every invariant held in every run, 1 when some run violated one (the
violations are in the report), 2 for bad arguments, 3 when the harness itself failed in
some run (a crash or a dead worker), 130 when interrupted.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import signal
import statistics
import sys
import time
from collections import defaultdict
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from aiocram.foresight import fidelity_lines, fidelity_summary
from aiocram.truth import INVARIANTS

__all__ = [
    "INVARIANTS",
    "Job",
    "check_objects",
    "main",
    "plan_campaign",
    "run_campaign",
    "summarise",
    "summary_table",
]


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
    # Seed-major: every prefix of the job list covers each (mode, fault rate) cell evenly,
    # so a campaign stopped early (Ctrl-C, a deadline) still compares like with like.
    return [
        Job(seed=first_seed + s, fault_rate=f, projection=p, objects=objects)
        for s in range(seeds)
        for p in modes
        for f in faults
    ]


def _start_method() -> str:
    import multiprocessing

    return "fork" if "fork" in multiprocessing.get_all_start_methods() else "spawn"


def _worker_main(conn: Any) -> None:
    """A local worker: run the jobs it is sent until it is sent ``None``. Ctrl-C is the
    parent's to handle (a terminal sends SIGINT to the whole process group)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    from aiocram.demo import frozen_imports

    with frozen_imports():
        while True:
            try:
                job = conn.recv()
            except EOFError:
                return
            if job is None:
                return
            conn.send(run_job(job))


class _Worker:
    """One local worker process and the job it is running (None: idle)."""

    def __init__(self, ctx: Any) -> None:
        parent, child = ctx.Pipe()
        self.conn = parent
        self.proc = ctx.Process(target=_worker_main, args=(child,), daemon=True)
        self.proc.start()
        child.close()
        self.job: Job | None = None  # invariant: not None while a job is in flight
        self.t0 = 0.0

    def send(self, job: Job) -> None:
        self.job, self.t0 = job, time.perf_counter()
        self.conn.send(job)

    def stop(self, kill: bool = False) -> None:
        if kill:
            self.proc.kill()
        else:
            try:
                self.conn.send(None)
            except OSError:
                pass
        self.proc.join(timeout=5)
        if self.proc.is_alive():
            self.proc.kill()
            self.proc.join()
        self.conn.close()


def _died(job: Job, exitcode: int | None, wall: float) -> dict[str, Any]:
    """The record of a job whose worker process died (killed, or crashed the interpreter)."""
    how = (
        f"killed by {signal.Signals(-exitcode).name}"
        if exitcode is not None and exitcode < 0
        else f"exited with status {exitcode}"
    )
    return {
        "seed": job.seed,
        "fault_rate": job.fault_rate,
        "projection": job.projection,
        "error": f"WorkerDied: the worker process running this job was {how}",
        "objects": {},
        "invariants": {},
        "wall_time_s": wall,
    }


def _run_local(jobs: list[Job], workers: int, done: Callable[[dict[str, Any]], None]) -> None:
    """Run ``jobs`` on ``workers`` worker processes (in this process when ``workers`` <= 1),
    calling ``done(record)`` as each ends. A worker that dies (killed, segfault) is
    recorded as an ``error`` run of its job and replaced; the other jobs go on. On
    KeyboardInterrupt the workers are killed and the interrupt propagates."""
    if workers <= 1:
        from aiocram.demo import frozen_imports

        with frozen_imports():
            for job in jobs:
                done(run_job(job))
        return
    import multiprocessing
    from multiprocessing.connection import wait

    ctx = multiprocessing.get_context(_start_method())
    queue = list(reversed(jobs))
    pool: list[_Worker] = []
    try:
        pool = [_Worker(ctx) for _ in range(min(workers, len(jobs)))]
        while True:
            for i, w in enumerate(pool):
                while w.job is None and queue:
                    job = queue.pop()
                    try:
                        w.send(job)
                    except OSError:  # died while idle: replace it, resend the job
                        queue.append(job)
                        w.stop(kill=True)
                        w = pool[i] = _Worker(ctx)
            busy = [w for w in pool if w.job is not None]
            if not busy:
                return
            ready = set(wait([w.conn for w in busy] + [w.proc.sentinel for w in busy]))
            for i, w in enumerate(pool):
                if w.job is None or (w.conn not in ready and w.proc.sentinel not in ready):
                    continue
                record = None
                try:
                    if w.conn.poll():
                        record = w.conn.recv()
                except (EOFError, OSError):
                    record = None
                if record is not None:
                    w.job = None
                    done(record)
                    continue
                if w.proc.is_alive():
                    continue  # the sentinel fired spuriously; the result is still coming
                w.proc.join()
                job, wall = w.job, time.perf_counter() - w.t0
                w.job = None
                exitcode = w.proc.exitcode
                w.stop(kill=True)
                pool[i] = _Worker(ctx)
                done(_died(job, exitcode, wall))
    finally:
        for w in pool:
            w.stop(kill=w.job is not None)


def _run_dask(
    jobs: list[Job], workers: int, scheduler: str | None, done: Callable[[dict[str, Any]], None]
) -> None:
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
        for fut in as_completed(futures):
            try:
                done(fut.result())
            except Exception as exc:  # a worker died (KilledWorker) or the cluster failed
                job = jobs[index[fut.key]]
                done(
                    {
                        "seed": job.seed,
                        "fault_rate": job.fault_rate,
                        "projection": job.projection,
                        "error": f"{type(exc).__name__}: {exc}",
                        "objects": {},
                        "invariants": {},
                        "wall_time_s": 0.0,
                    }
                )
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def check_objects(objects: Sequence[str]) -> tuple[str, ...]:
    """The demo objects as a tuple; unknown or repeated names, or none: ValueError saying
    which names the demo knows."""
    from aiocram.demo import DEFAULT_OBJECTS

    objects = tuple(objects)
    if not objects:
        raise ValueError(f"--objects needs at least one of {' '.join(DEFAULT_OBJECTS)}")
    unknown = [o for o in objects if o not in DEFAULT_OBJECTS]
    if unknown:
        raise ValueError(
            f"--objects: unknown {' '.join(unknown)}; the demo knows {' '.join(DEFAULT_OBJECTS)}"
        )
    repeated = sorted({o for o in objects if objects.count(o) > 1})
    if repeated:
        raise ValueError(f"--objects: {' '.join(repeated)} given more than once")
    return objects


def plan_campaign(
    *,
    seeds: int,
    faults: Sequence[float],
    projection_modes: Sequence[bool] = (True, False),
    backend: str = "local",
    first_seed: int = 1,
    objects: Sequence[str] = Job.objects,
) -> list[Job]:
    """Check every argument and return the jobs; nothing runs. Bad arguments:
    ValueError naming what to fix."""
    if seeds < 1:
        raise ValueError(f"--seeds must be at least 1, got {seeds}")
    bad = [f for f in faults if math.isnan(f) or not (0.0 <= f <= 1.0)]
    if bad:
        raise ValueError(f"fault rates are probabilities in [0, 1], got {bad}")
    if not faults:
        raise ValueError("--faults needs at least one rate, e.g. 0,0.1")
    if backend not in ("local", "dask"):
        raise ValueError(f"unknown backend {backend!r}: use 'local' or 'dask'")
    return _jobs(seeds, faults, projection_modes, first_seed, check_objects(objects))


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
    on_result: Callable[[dict[str, Any]], None] | None = None,
    results: list[dict[str, Any]] | None = None,
) -> list[dict[str, Any]]:
    """Run every (seed, fault rate, projection mode) job and return the raw results, in
    the order they ended. ``on_result(record)`` is called as each run ends (the command
    appends it to ``runs.jsonl``); ``results``, if given, is the list they are appended
    to, so a caller interrupted by Ctrl-C still holds every finished run. Arguments are
    all checked before any job starts (ValueError)."""
    jobs = plan_campaign(
        seeds=seeds,
        faults=faults,
        projection_modes=projection_modes,
        backend=backend,
        first_seed=first_seed,
        objects=objects,
    )
    out: list[dict[str, Any]] = [] if results is None else results
    report = progress or (lambda done, total: None)

    def done(record: dict[str, Any]) -> None:
        out.append(record)
        if on_result is not None:
            on_result(record)
        report(len(out), len(jobs))

    if backend == "local":
        _run_local(jobs, workers, done)
    else:
        _run_dask(jobs, workers, scheduler, done)
    return out


def summarise(results: Iterable[dict[str, Any]]) -> dict[str, Any]:
    """Aggregate per (projection mode, fault rate): objects delivered (measured on the true
    world), claimed by the plan, phantoms (claimed, not delivered), objects toppled or on
    the floor, retries by kind, distance, time, and invariant violations (each listed with
    its seed and why). ``success_rate`` is the delivered rate."""
    groups: dict[tuple[bool, float], list[dict[str, Any]]] = defaultdict(list)
    for r in results:
        groups[(bool(r["projection"]), float(r["fault_rate"]))].append(r)
    rows = []
    for (proj, rate), runs in sorted(groups.items()):
        objects = [o for r in runs for o in r.get("objects", {}).values()]
        delivered = sum(1 for o in objects if o.get("delivered"))
        claimed = sum(1 for o in objects if o.get("claimed"))
        phantoms = sum(1 for o in objects if o.get("claimed") and not o.get("delivered"))
        where: dict[str, int] = defaultdict(int)
        for o in objects:
            if not o.get("delivered"):
                where[str(o.get("where", "?")) + (" toppled" if o.get("toppled") else "")] += 1
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
        total = len(objects)
        rows.append(
            {
                "projection": proj,
                "fault_rate": rate,
                "runs": len(runs),
                "objects": total,
                "delivered": delivered,
                "claimed": claimed,
                "phantoms": phantoms,
                "delivered_rate": delivered / total if total else 0.0,
                "claimed_rate": claimed / total if total else 0.0,
                "success_rate": delivered / total if total else 0.0,
                "not_delivered_where": dict(sorted(where.items())),
                "cleanup_intervened": sum(1 for r in runs if r.get("cleanup_intervened")),
                "retries": dict(sorted(retries.items())),
                "mean_distance_m": statistics.fmean(distances) if distances else 0.0,
                "mean_sim_time_s": statistics.fmean(sim_times) if sim_times else 0.0,
                "mean_wall_time_s": statistics.fmean(r.get("wall_time_s", 0.0) for r in runs),
                "runs_violating": len({v["seed"] for v in violations}),
                "fidelity": fidelity_summary(runs),  # issue 14: projection fidelity
                "invariant_violations": violations,
            }
        )
    return {"rows": rows}


def _wilson(successes: int, total: int, z: float = 1.96) -> tuple[float, float]:
    """The Wilson score interval (95 % by default) of a success rate."""
    if total <= 0:
        return 0.0, 0.0
    p = successes / total
    centre = (p + z * z / (2 * total)) / (1 + z * z / total)
    half = z * ((p * (1 - p) / total + z * z / (4 * total * total)) ** 0.5) / (1 + z * z / total)
    return max(0.0, centre - half), min(1.0, centre + half)


def _plot(summary: dict[str, Any], out: Path) -> list[Path]:
    """The success-rate and distance plots: per fault rate, with and without projection;
    the title says how many runs (seeds) each point rests on, each point is labelled
    with its run count when they differ, and the success rate has its 95 % interval."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows_all = summary["rows"]
    runs = sorted({int(r["runs"]) for r in rows_all})
    objects = sorted({int(r["objects"]) for r in rows_all})
    if len(runs) == 1:
        basis = f"{runs[0]} seeds per point"
        if len(objects) == 1:
            basis += f" ({objects[0]} objects)"
    else:
        basis = f"{runs[0]}-{runs[-1]} seeds per point (n at each point)"
    paths = []
    for key, label, fname in (
        ("success_rate", "object success rate", "success_rate.png"),
        ("mean_distance_m", "mean base distance driven (m)", "distance.png"),
    ):
        fig, ax = plt.subplots(figsize=(6.4, 4.4), dpi=100)
        for proj in (True, False):
            rows = [r for r in rows_all if r["projection"] is proj]
            if not rows:
                continue
            xs = [r["fault_rate"] for r in rows]
            ys = [r[key] for r in rows]
            name = "with projection" if proj else "without projection"
            if key == "success_rate":
                bounds = [_wilson(int(r["delivered"]), int(r["objects"])) for r in rows]
                err = [
                    [y - lo for y, (lo, _) in zip(ys, bounds, strict=True)],
                    [hi - y for y, (_, hi) in zip(ys, bounds, strict=True)],
                ]
                ax.errorbar(
                    xs, ys, yerr=err, marker="o", capsize=3, label=f"{name} (95 % interval)"
                )
            else:
                ax.plot(xs, ys, marker="o", label=name)
            if len(runs) > 1:
                for x, y, r in zip(xs, ys, rows, strict=True):
                    ax.annotate(
                        f"n={r['runs']}",
                        (x, y),
                        xytext=(4, 4),
                        textcoords="offset points",
                        fontsize=7,
                    )
        ax.set_xticks(sorted({r["fault_rate"] for r in rows_all}))
        ax.set_xlabel("low-level fault rate (each motion fails with this probability)")
        ax.set_ylabel(label)
        if key == "success_rate":
            ax.set_ylim(0.0, 1.02)
        else:
            ax.set_ylim(0.0, None)
        ax.set_title(f"{label.split(' (')[0]}: {basis}", fontsize=10)
        ax.grid(True, alpha=0.3)
        ax.legend(loc="lower left")
        fig.tight_layout()
        path = out / fname
        fig.savefig(path)
        plt.close(fig)
        paths.append(path)
    return paths


def summary_table(summary: dict[str, Any]) -> Any:
    """The summary as a rich table that fits 80 columns (retries and violation details
    are in ``campaign.json``)."""
    from rich import box
    from rich.table import Table

    table = Table(
        title="robustness campaign (true world)",
        box=box.SIMPLE_HEAD,
        padding=(0, 1),
        collapse_padding=True,
    )
    for col, justify in (
        ("proj", "left"),
        ("faults", "right"),
        ("runs", "right"),
        ("delivered", "right"),
        ("claimed", "right"),
        ("phantoms", "right"),
        ("dist m", "right"),
        ("sim s", "right"),
        ("bad runs", "right"),
    ):
        table.add_column(col, justify=justify, no_wrap=True)  # type: ignore[arg-type]
    for r in summary["rows"]:
        table.add_row(
            "yes" if r["projection"] else "no",
            f"{r['fault_rate']:.2f}",
            str(r["runs"]),
            f"{100 * r.get('delivered_rate', r['success_rate']):.1f} %",
            f"{100 * r.get('claimed_rate', 0.0):.1f} %",
            str(r.get("phantoms", 0)),
            f"{r['mean_distance_m']:.2f}",
            f"{r['mean_sim_time_s']:.0f}",
            str(r.get("runs_violating", len(r["invariant_violations"]))),
        )
    return table


def _print_summary(summary: dict[str, Any]) -> None:
    from rich.console import Console

    console = Console()
    console.print(summary_table(summary))
    for line in fidelity_lines(summary["rows"]):
        console.print(line)
    kinds: dict[str, int] = defaultdict(int)
    for r in summary["rows"]:
        for v in r["invariant_violations"]:
            kinds[v["invariant"]] += 1
    if kinds:
        console.print(
            "violations by kind: " + ", ".join(f"{k} {n}" for k, n in sorted(kinds.items()))
        )


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


def _own_sigint() -> Callable[[], None]:
    """Make Ctrl-C (SIGINT) raise KeyboardInterrupt here while the campaign runs, and
    return the function that puts the previous handler back.

    A shell starts a background job (``cmd &``) of a non-interactive script with SIGINT
    ignored, and Python keeps an ignored SIGINT ignored, so without this ``kill -INT``
    would never stop a background campaign. Only the main thread can install handlers;
    elsewhere (a campaign run from a thread) SIGINT stays as it is."""
    import threading

    if threading.current_thread() is not threading.main_thread():
        return lambda: None
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)

    def restore() -> None:
        if previous is not None:  # None: a handler not installed from Python, left alone
            signal.signal(signal.SIGINT, previous)

    return restore


def _command(args: argparse.Namespace) -> int:
    """Check every argument, then run; each run's record is appended to
    ``OUT/runs.jsonl`` as it ends; the summary goes to ``OUT/campaign.json`` and the
    console. Ctrl-C: the partial summary of the finished runs is written and printed,
    exit 130."""
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
    settings = dict(
        seeds=args.seeds,
        faults=faults,
        projection_modes=modes,
        backend=args.backend,
        first_seed=args.first_seed,
        objects=args.objects,
    )
    try:
        jobs = plan_campaign(**settings)
        if args.workers < 1:
            raise ValueError(f"--workers must be at least 1, got {args.workers}")
    except ValueError as exc:
        print(f"aiocram campaign: {exc}", file=sys.stderr)
        return 2
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    runs_path = out / "runs.jsonl"
    runs_file = runs_path.open("w")

    def append(record: dict[str, Any]) -> None:
        runs_file.write(json.dumps(record) + "\n")
        runs_file.flush()

    def progress(done: int, total: int) -> None:
        print(f"\r{done}/{total} runs", end="", file=sys.stderr, flush=True)

    results: list[dict[str, Any]] = []
    interrupted = False
    restore_sigint = _own_sigint()
    try:
        run_campaign(
            **settings,
            workers=args.workers,
            scheduler=args.scheduler,
            progress=progress,
            on_result=append,
            results=results,
        )
    except KeyboardInterrupt:
        interrupted = True
    finally:
        restore_sigint()
        runs_file.close()
    print(file=sys.stderr)
    summary = summarise(results)
    summary["command"] = " ".join(["aiocram", *sys.argv[1:]])
    summary["backend"] = args.backend
    summary["workers"] = args.workers
    summary["wall_time_s"] = time.perf_counter() - t0
    summary["runs_finished"] = len(results)
    summary["runs_planned"] = len(jobs)
    summary["partial"] = interrupted
    (out / "campaign.json").write_text(json.dumps({"summary": summary, "runs": results}, indent=2))
    plots = _plot(summary, out)
    _print_summary(summary)
    print(f"wrote {runs_path}, {out / 'campaign.json'} and {', '.join(str(p) for p in plots)}")
    if interrupted:
        print(
            f"aiocram campaign: interrupted; partial summary of {len(results)} of {len(jobs)} runs",
            file=sys.stderr,
        )
        return 130
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
