"""The robustness campaign: the table-setting demo on the simulated real robot for every
(robot, seed, fault rate), with and without projection reasoning.

Each job is independent and seeded (:func:`aiocram.demo.run_demo_once`), so jobs can run
anywhere: the ``local`` backend runs them on worker processes of this machine; the
``dask`` backend sends the very same jobs to a ``dask.distributed`` cluster (a
``LocalCluster`` by default, or the scheduler at ``--scheduler ADDRESS``), so a user who
outgrows one machine adds workers, not code.

Every figure is measured on the true world (:mod:`aiocram.truth`): per fault rate, the
objects *delivered* (upright on the island near where the plan placed them), what the
plans *claimed*, the *phantoms* (claimed, not delivered), where the others ended up,
retries by kind, base distance, time, the objects *knocked* (moved by a robot motion that
was not their own pick-up or placing, :mod:`aiocram.knocks`), and the invariants that must
hold in every run (:data:`aiocram.truth.INVARIANTS`), each violation with its seed and why.
With ``--robots pr2,panda`` every cell is run by each robot, and every figure is per robot
(a ``robot`` field in each row of the summary, a table per robot).

The harness keeps every finished run: each run's record is appended to ``OUT/runs.jsonl``
as it ends; a local worker that dies (killed, crashed) is recorded as an ``error`` run of
its job, replaced, and the campaign goes on (a crashed run's objects count as not
delivered: they stay in the denominator, and the table counts the crashed runs); Ctrl-C
stops the workers, writes the partial summary (``"partial": true``) and says so. A write
that fails (disk full) stops the campaign: no further run starts, the runs in flight
finish, ``runs.jsonl`` keeps every complete record, the records it could not take are
printed on stdout and the message says what to free.

All arguments are checked before any job starts or any file is written, the dask
scheduler of ``--scheduler`` included (it must answer within
:data:`SCHEDULER_TIMEOUT_S`). An ``--out`` that holds a campaign already is refused;
with ``--overwrite`` the new campaign is written beside it (a staging directory inside
``--out``) and replaces it when it ends. The summary goes to ``OUT/campaign.json`` with
PNG plots, and to the console as a table that fits 80 columns (the retries are in the
JSON).

Exit status: 0 when every invariant held in every run, 1 when some run violated one (the
violations are in the report), 2 for bad arguments, 3 when the harness itself failed in
some run (a crash or a dead worker), 4 when the results could not all be written, 130
when interrupted.
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

from aiocram.demo import (
    DEFAULT_OBJECTS,
    DEFAULT_ROBOT,
    DemoConfigError,
    add_objects_argument,
    crash_record,
    robot_names,
    whole,
)
from aiocram.demo import check_objects as _check_objects
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
    """One demo run: a seed, a uniform fault rate, projection reasoning on or off, a
    robot (its name in the ``robots`` package)."""

    seed: int
    fault_rate: float
    projection: bool
    objects: tuple[str, ...] = DEFAULT_OBJECTS
    runs: int = 3
    #: Read the run's experience-store rows after the run (issue 29).
    experience: bool = False
    #: The campaign's id in the store.
    campaign: str | None = None
    #: A database URL the worker writes the rows to itself (PostgreSQL); ``None``: the
    #: rows go back with the record and the parent writes them (SQLite: one writer).
    store: str | None = None
    #: A learned-priors file (``aiocram experience learn``) the run orders its choices by;
    #: ``None``: not used. Checked before any job starts (:func:`plan_campaign`).
    learned: str | None = None
    #: The robot that runs the job: a name of the ``robots`` package (``--robots``).
    robot: str = DEFAULT_ROBOT


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
            experience=job.experience,
            learned=job.learned,
            robot=job.robot,
        )
    except Exception as exc:  # the campaign records every failure of the harness itself
        result = _crashed(job, f"{type(exc).__name__}: {exc}")
    result["wall_time_s"] = time.perf_counter() - t0
    if job.experience:
        _experience_rows(job, result)
    return result


def _experience_rows(job: Job, result: dict[str, Any]) -> None:
    """Give ``result`` its store rows (a crashed run: its run row only), stamped with the
    campaign; with ``job.store`` write them here and note ``"stored"`` (or
    ``"store_error"``) instead."""
    from aiocram.experience import StoreError, run_rows

    rows = result.get("experience")
    if rows is None:
        faults = f"{job.fault_rate:g}"
        rows = run_rows(result, None, robot=job.robot, source="campaign", faults=faults)
    run = rows["runs"][0]
    run["campaign"] = job.campaign
    run["wall_time_s"] = result["wall_time_s"]
    result["experience"] = rows
    if job.store is None:
        return
    from aiocram.experience import Store

    del result["experience"]
    try:
        with Store(job.store, create=True) as store:
            result["stored"] = store.record(rows)
    except StoreError as exc:  # counted and reported by the parent
        result["store_error"] = str(exc)


def _jobs(
    seeds: int,
    faults: Sequence[float],
    modes: Sequence[bool],
    first_seed: int,
    objects: tuple[str, ...],
    learned: str | None = None,
    robots: Sequence[str] = (DEFAULT_ROBOT,),
) -> list[Job]:
    # Seed-major: every prefix of the job list covers each (robot, mode, fault rate) cell
    # evenly, so a campaign stopped early (Ctrl-C, a deadline) still compares like with like.
    return [
        Job(
            seed=first_seed + s,
            fault_rate=f,
            projection=p,
            objects=objects,
            learned=learned,
            robot=robot,
        )
        for s in range(seeds)
        for robot in robots
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
    record = _crashed(job, f"WorkerDied: the worker process running this job was {how}")
    record["wall_time_s"] = wall
    return record


def _crashed(job: Job, error: str) -> dict[str, Any]:
    """The record of ``job`` when it never reported (:func:`aiocram.demo.crash_record`)."""
    return crash_record(
        seed=job.seed,
        fault_rate=job.fault_rate,
        projection=job.projection,
        objects=job.objects,
        error=error,
        robot=_description_name(job.robot),
    )


def _description_name(robot: str) -> str:
    """The name the robot ``robot`` (a module of the ``robots`` package) records its runs
    under: its description's ``name`` (:attr:`aiocram.demo.DemoReport.robot`)."""
    from aiocram.demo import DemoConfig, robot_description

    return str(robot_description(DemoConfig(robot=robot)).name)


def _never() -> bool:
    return False


def _run_local(
    jobs: list[Job],
    workers: int,
    done: Callable[[dict[str, Any]], None],
    stop: Callable[[], bool] = _never,
) -> None:
    """Run ``jobs`` on ``workers`` worker processes (in this process when ``workers`` <= 1),
    calling ``done(record)`` as each ends. A worker that dies (killed, segfault) is
    recorded as an ``error`` run of its job and replaced; the other jobs go on. Once
    ``stop()`` is true no further job starts; the runs in flight finish and are reported.
    On KeyboardInterrupt the workers are killed and the interrupt propagates."""
    if workers <= 1:
        from aiocram.demo import frozen_imports

        with frozen_imports():
            for job in jobs:
                if stop():
                    return
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
            if stop():
                queue.clear()  # the runs in flight finish; no other starts
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


class CampaignStore:
    """The campaign's side of the experience store (issue 29): opened (and so checked)
    before any run starts; each run's rows are written as it ends, off the runs' control
    path: by the parent for SQLite (one writer; the rows come back with the record), by
    the workers themselves for a server (PostgreSQL), the dask workers included. A run
    whose rows could not be written is counted and reported, never silently dropped."""

    def __init__(self, url: Any) -> None:
        import datetime as dt
        import uuid

        from aiocram.experience import Store, store_url

        self.url = store_url(url)
        self.store = Store(self.url, create=True)  # StoreError: before anything runs
        now = dt.datetime.now(dt.UTC).strftime("%Y%m%dT%H%M%S")
        self.campaign = f"{now}-{uuid.uuid4().hex[:6]}"
        self.remote = self.url.get_backend_name() != "sqlite"
        self.recorded = 0  # invariant: runs whose rows are in the store
        self.errors: list[str] = []  # one message per run not recorded
        self.seconds = 0.0  # spent writing in this process

    def job(self, job: Job) -> Job:
        from dataclasses import replace

        url = self.url.render_as_string(hide_password=False) if self.remote else None
        return replace(job, experience=True, campaign=self.campaign, store=url)

    def take(self, record: dict[str, Any]) -> None:
        """Write (or account for) the rows of the run ``record``; they leave the record."""
        from aiocram.experience import StoreError, run_rows

        rows = record.pop("experience", None)
        if "stored" in record:
            self.recorded += 1
            record.pop("stored")
            return
        if "store_error" in record:
            self.errors.append(record.pop("store_error"))
            return
        if rows is None:  # a job that never reached run_job (a dead worker)
            rows = run_rows(record, None, robot=record["robot"], source="campaign")
            rows["runs"][0]["campaign"] = self.campaign
        try:
            self.seconds += self.store.record(rows)
            self.recorded += 1
        except StoreError as exc:
            self.errors.append(str(exc))

    def summary(self) -> dict[str, Any]:
        from aiocram.experience._engine import shown

        return {
            "store": shown(self.url),
            "campaign": self.campaign,
            "runs_recorded": self.recorded,
            "runs_not_recorded": len(self.errors),
            "write_s": self.seconds,
        }

    def close(self) -> None:
        self.store.close()


#: Seconds a ``--scheduler`` has to answer before the campaign gives up on it.
SCHEDULER_TIMEOUT_S = 5.0


class SchedulerError(ValueError):
    """The dask backend cannot be used: dask.distributed is missing, or the scheduler at
    ``--scheduler`` does not answer (the message says what to do)."""


def connect(scheduler: str, timeout: float = SCHEDULER_TIMEOUT_S) -> Any:
    """A ``dask.distributed.Client`` of the scheduler at ``scheduler``, or
    :class:`SchedulerError` within about ``timeout`` seconds."""
    try:
        from dask.distributed import Client
    except ImportError:  # pragma: no cover - depends on the installation
        raise SchedulerError(
            "--backend dask needs dask.distributed: pip install 'aiocram[dask]'"
        ) from None
    try:
        return Client(scheduler, timeout=timeout)
    except Exception as exc:  # refused, timed out, a bad address, not dask's protocol
        text = str(exc).splitlines()[0] if str(exc) else ""
        raise SchedulerError(
            f"--scheduler {scheduler}: no dask scheduler answered within {timeout:.0f} s "
            f"({type(exc).__name__}: {text[:200]}); start one (dask scheduler) and give its "
            "address, e.g. tcp://host:8786, or leave --scheduler out for a cluster on this "
            "machine"
        ) from None


def _run_dask(
    jobs: list[Job],
    workers: int,
    scheduler: str | None,
    done: Callable[[dict[str, Any]], None],
    stop: Callable[[], bool] = _never,
    client: Any = None,
) -> None:
    """Run ``jobs`` on a dask cluster: ``client`` (closed at the end), else the scheduler
    at ``scheduler``, else a ``LocalCluster`` of ``workers`` processes. Once ``stop()`` is
    true the jobs not finished are cancelled (on dask the runs in flight are dropped too)."""
    try:
        from dask.distributed import Client, LocalCluster, as_completed
    except ImportError:  # pragma: no cover - depends on the installation
        raise SchedulerError(
            "--backend dask needs dask.distributed: pip install 'aiocram[dask]'"
        ) from None
    cluster = None
    if client is None and scheduler is None:
        cluster = LocalCluster(
            n_workers=max(1, workers), threads_per_worker=1, processes=True, dashboard_address=None
        )
        client = Client(cluster)
    elif client is None:
        client = connect(scheduler)  # type: ignore[arg-type]  # not None here
    try:
        futures = client.map(run_job, jobs, pure=False)
        index = {f.key: i for i, f in enumerate(futures)}
        for fut in as_completed(futures):
            if stop():
                client.cancel([f for f in futures if not f.done()])
                return
            try:
                done(fut.result())
            except Exception as exc:  # a worker died (KilledWorker) or the cluster failed
                record = _crashed(jobs[index[fut.key]], f"{type(exc).__name__}: {exc}")
                record["wall_time_s"] = 0.0
                done(record)
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def check_objects(objects: Sequence[str]) -> tuple[str, ...]:
    """The demo objects as a tuple; unknown or repeated names, or none: ValueError
    (:class:`aiocram.demo.DemoConfigError`) saying which names the demo knows: the demo's
    own check (:func:`aiocram.demo.check_objects`)."""
    return _check_objects(objects)


def plan_campaign(
    *,
    seeds: int,
    faults: Sequence[float],
    projection_modes: Sequence[bool] = (True, False),
    backend: str = "local",
    first_seed: int = 1,
    objects: Sequence[str] = Job.objects,
    learned: str | os.PathLike[str] | None = None,
    robots: Sequence[str] | str = (DEFAULT_ROBOT,),
) -> list[Job]:
    """Check every argument and return the jobs; nothing runs. Bad arguments:
    ValueError naming what to fix (a bad ``learned`` file: a
    :class:`aiocram.experience.PriorsError`, a ValueError too). ``robots``: names of the
    ``robots`` package (or their comma-separated text, as ``--robots`` gives them), each
    crossed with every seed, mode and fault rate."""
    robots = _check_robots(robots)
    if seeds < 1:
        raise ValueError(f"--seeds must be at least 1, got {seeds}")
    if first_seed < 0:
        raise ValueError(
            f"--first-seed must be a whole number >= 0 (a demo seed), got {first_seed}"
        )
    bad = [f for f in faults if math.isnan(f) or not (0.0 <= f <= 1.0)]
    if bad:
        raise ValueError(f"fault rates are probabilities in [0, 1], got {bad}")
    if not faults:
        raise ValueError("--faults needs at least one rate, e.g. 0,0.1")
    repeated = sorted({f for f in faults if list(faults).count(f) > 1})
    if repeated:
        raise ValueError(f"--faults: {', '.join(f'{f:g}' for f in repeated)} given more than once")
    if backend not in ("local", "dask"):
        raise ValueError(f"unknown backend {backend!r}: use 'local' or 'dask'")
    if learned is not None:
        from aiocram.experience import LearnedPriors, PriorsError

        try:
            priors = LearnedPriors.load(learned)
            for robot in robots:  # priors are learned by one robot, for that robot
                priors.check_robot(_description_name(robot))
        except PriorsError as exc:
            raise type(exc)(f"--learned: {exc}") from None
    return _jobs(
        seeds,
        faults,
        projection_modes,
        first_seed,
        check_objects(objects),
        None if learned is None else str(learned),
        robots,
    )


def _check_robots(robots: Sequence[str] | str) -> tuple[str, ...]:
    """``robots`` (names, or their comma-separated text) checked: each a robot of the
    ``robots`` package, each once, at least one; else DemoConfigError (a ValueError)
    naming ``--robots`` and the robots there are."""
    text = robots if isinstance(robots, str) else ",".join(robots)
    if not text:
        raise DemoConfigError("--robots needs at least one robot, e.g. pr2 or pr2,panda")
    return robot_names(text)


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
    learned: str | os.PathLike[str] | None = None,
    robots: Sequence[str] | str = (DEFAULT_ROBOT,),
    progress: Callable[[int, int], None] | None = None,
    on_result: Callable[[dict[str, Any]], None] | None = None,
    results: list[dict[str, Any]] | None = None,
    stop: Callable[[], bool] = _never,
    client: Any = None,
    experience: Any = None,
) -> list[dict[str, Any]]:
    """Run every (robot, seed, fault rate, projection mode) job and return the raw results, in
    the order they ended. ``on_result(record)`` is called as each run ends (the command
    appends it to ``runs.jsonl``); ``results``, if given, is the list they are appended
    to, so a caller interrupted by Ctrl-C still holds every finished run. Once ``stop()``
    is true no further job starts (the command stops so when it cannot write). ``client``:
    a connected ``dask.distributed.Client`` for the dask backend (see :func:`connect`).
    ``experience``: a :class:`CampaignStore` the runs are recorded in (issue 29).
    Arguments are all checked before any job starts (ValueError)."""
    jobs = plan_campaign(
        seeds=seeds,
        faults=faults,
        projection_modes=projection_modes,
        backend=backend,
        first_seed=first_seed,
        objects=objects,
        learned=learned,
        robots=robots,
    )
    if experience is not None:
        jobs = [experience.job(j) for j in jobs]
    out: list[dict[str, Any]] = [] if results is None else results
    report = progress or (lambda done, total: None)

    def done(record: dict[str, Any]) -> None:
        if experience is not None:
            experience.take(record)
        out.append(record)
        if on_result is not None:
            on_result(record)
        report(len(out), len(jobs))

    if backend == "local":
        _run_local(jobs, workers, done, stop)
    else:
        _run_dask(jobs, workers, scheduler, done, stop, client)
    return out


def summarise(results: Iterable[dict[str, Any]]) -> dict[str, Any]:
    """Aggregate per (robot, projection mode, fault rate): objects delivered (measured on
    the true world), claimed by the plan, phantoms (claimed, not delivered), objects
    toppled or on the floor, retries by kind, distance, time, the knocked objects
    (:func:`knock_summary`) and invariant violations (each listed with its seed and why).
    ``success_rate`` is the delivered rate. A record without ``robot`` (written before
    robots were a choice) was run by the PR2-like robot, the only one there was."""
    groups: dict[tuple[str, bool, float], list[dict[str, Any]]] = defaultdict(list)
    for r in results:
        robot = str(r.get("robot", DEFAULT_ROBOT))
        groups[(robot, bool(r["projection"]), float(r["fault_rate"]))].append(r)
    rows = []
    for (robot, proj, rate), runs in sorted(groups.items()):
        objects = [o for r in runs for o in r.get("objects", {}).values()]
        # a crashed run's objects were not delivered: they stay in the denominator
        # (records without "planned", from before it was kept, count as many objects as
        # the group's other runs)
        usual = max((len(r.get("objects", {})) for r in runs if "error" not in r), default=5)
        crashed = [r for r in runs if "error" in r]
        for r in crashed:
            planned = r.get("planned")
            n = len(planned) if planned is not None else usual
            objects += [dict(_CRASHED) for _ in range(n - len(r.get("objects", {})))]
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
                "robot": robot,
                "projection": proj,
                "fault_rate": rate,
                "runs": len(runs),
                "runs_crashed": len(crashed),
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
                **knock_summary(runs),  # issue 26: objects knocked by robot motions
                "invariant_violations": violations,
            }
        )
    return {"rows": rows}


def knock_summary(runs: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """The knocks of ``runs`` (records of :func:`aiocram.demo.run_demo_once`, measured by
    :class:`aiocram.knocks.KnockWatcher` on the true world): ``knocked`` objects (each
    object once per run), ``knocks`` (every move of an object by a motion not its own
    pick-up or placing), ``runs_knocking``, ``knocked_by`` (knocks by motion type, with
    the arm: ``moving-tcp right``), ``knocked_in`` (knocks by the action the motion was
    part of) and ``drifted`` (objects that moved while no motion pushed). Crashed runs
    and records from before knocks were measured count zero."""
    by: dict[str, int] = defaultdict(int)
    within: dict[str, int] = defaultdict(int)
    knocked = knocks = knocking = drifted = 0
    for r in runs:
        names = r.get("knocked") or []
        knocked += len(names)
        knocking += bool(names)
        drifted += len(r.get("drifted") or [])
        for k in r.get("knocks") or []:
            knocks += 1
            by[" ".join([str(k.get("motion")), *k.get("arms", [])])] += 1
            within[str(k.get("action"))] += 1
    return {
        "knocked": knocked,
        "knocks": knocks,
        "runs_knocking": knocking,
        "knocked_by": dict(sorted(by.items())),
        "knocked_in": dict(sorted(within.items())),
        "drifted": drifted,
    }


#: What a crashed run's object counts as in the summary.
_CRASHED = {"claimed": False, "delivered": False, "where": "crashed run"}


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
    if not summary["rows"]:
        return []  # no run finished: no curve to draw
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
        robots = _robots(summary)
        for robot, proj in ((robot, proj) for robot in robots for proj in (True, False)):
            rows = [
                r
                for r in rows_all
                if r["projection"] is proj and r.get("robot", DEFAULT_ROBOT) == robot
            ]
            if not rows:
                continue
            xs = [r["fault_rate"] for r in rows]
            ys = [r[key] for r in rows]
            name = "with projection" if proj else "without projection"
            style = "-" if robot == robots[0] else "--"  # a robot's lines: one style
            if len(robots) > 1:
                name = f"{robot}, {name}"
            if key == "success_rate":
                bounds = [_wilson(int(r["delivered"]), int(r["objects"])) for r in rows]
                err = [
                    [y - lo for y, (lo, _) in zip(ys, bounds, strict=True)],
                    [hi - y for y, (_, hi) in zip(ys, bounds, strict=True)],
                ]
                ax.errorbar(
                    xs,
                    ys,
                    yerr=err,
                    marker="o",
                    capsize=3,
                    ls=style,
                    label=f"{name} (95 % interval)",
                )
            else:
                ax.plot(xs, ys, marker="o", ls=style, label=name)
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


def _robots(summary: dict[str, Any]) -> list[str]:
    """The robots of ``summary``'s rows, in the order of the rows."""
    return list(dict.fromkeys(str(r.get("robot", DEFAULT_ROBOT)) for r in summary["rows"]))


def summary_table(summary: dict[str, Any]) -> Any:
    """The summary as a rich table that fits 80 columns (retries and violation details
    are in ``campaign.json``), titled with its robot; with several robots, one such
    table per robot (a ``rich.console.Group``). ``crash``: runs the harness lost (their
    objects count as not delivered); ``bad runs``: runs that violated an invariant or
    crashed. ``knock``: objects knocked (:func:`knock_summary`; which motions knocked
    them is printed below the table)."""
    robots = _robots(summary)
    if len(robots) <= 1:
        return _robot_table(summary["rows"], robots[0] if robots else None)
    from rich.console import Group

    return Group(*(_robot_table(_rows_of(summary, robot), robot) for robot in robots))


def _rows_of(summary: dict[str, Any], robot: str) -> list[dict[str, Any]]:
    """The rows of ``summary`` that ``robot`` ran."""
    return [r for r in summary["rows"] if r.get("robot", DEFAULT_ROBOT) == robot]


def _robot_table(rows: list[dict[str, Any]], robot: str | None) -> Any:
    """The table of one robot's ``rows`` (see :func:`summary_table`)."""
    from rich import box
    from rich.table import Table

    table = Table(
        title="robustness campaign (true world" + ("" if robot is None else f", {robot}") + ")",
        box=box.SIMPLE_HEAD,
        padding=(0, 1),
        collapse_padding=True,
        show_edge=False,
        pad_edge=False,
    )
    for col, justify in (
        ("proj", "left"),
        ("faults", "right"),
        ("runs", "right"),
        ("delivered", "right"),
        ("claimed", "right"),
        ("phantoms", "right"),
        ("knock", "right"),
        ("dist\nm", "right"),
        ("sim\ns", "right"),
        ("crash", "right"),
        ("bad\nruns", "right"),
    ):
        table.add_column(col, justify=justify, no_wrap=True)  # type: ignore[arg-type]
    for r in rows:
        table.add_row(
            "yes" if r["projection"] else "no",
            f"{r['fault_rate']:.2f}",
            str(r["runs"]),
            f"{100 * r.get('delivered_rate', r['success_rate']):.1f} %",
            f"{100 * r.get('claimed_rate', 0.0):.1f} %",
            str(r.get("phantoms", 0)),
            str(r.get("knocked", 0)),
            f"{r['mean_distance_m']:.2f}",
            f"{r['mean_sim_time_s']:.0f}",
            str(r.get("runs_crashed", 0)),
            str(r.get("runs_violating", len(r["invariant_violations"]))),
        )
    return table


def _print_summary(summary: dict[str, Any]) -> None:
    """The table, projection fidelity and violations by kind: per robot, each part
    after its robot's table when there are several."""
    from rich.console import Console

    console = Console()
    robots = _robots(summary)
    for robot in robots if len(robots) > 1 else [None]:
        rows = summary["rows"] if robot is None else _rows_of(summary, robot)
        console.print(summary_table({**summary, "rows": rows}))
        for line in fidelity_lines(rows):
            console.print(line if robot is None else f"{robot}: {line}")
        kinds: dict[str, int] = defaultdict(int)
        for r in rows:
            for v in r["invariant_violations"]:
                kinds[v["invariant"]] += 1
        if kinds:
            console.print(
                ("" if robot is None else f"{robot}: ")
                + "violations by kind: "
                + ", ".join(f"{k} {n}" for k, n in sorted(kinds.items()))
            )
        for line in knock_lines(rows):
            console.print(line if robot is None else f"{robot}: {line}", highlight=False)


def knock_lines(rows: Sequence[dict[str, Any]]) -> list[str]:
    """Per cell that knocked something: which motions knocked how many objects."""
    out = []
    for r in rows:
        by = r.get("knocked_by") or {}
        if not by:
            continue
        cell = f"{'with' if r['projection'] else 'without'} projection, faults {r['fault_rate']:g}"
        motions = ", ".join(f"{k} {n}" for k, n in sorted(by.items(), key=lambda kv: -kv[1]))
        out.append(f"knocked ({cell}): {motions}")
    return out


def _rates(text: str) -> list[float]:
    """The argparse type of ``--faults``: comma-separated probabilities, each once."""
    parts = [p.strip() for p in text.split(",")]
    try:
        rates = [float(p) for p in parts]
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"takes fault rates separated by commas, like 0,0.05,0.1, got {text!r}"
        ) from None
    bad = [p for p, f in zip(parts, rates, strict=True) if not 0.0 <= f <= 1.0]
    if bad:
        raise argparse.ArgumentTypeError(
            f"a fault rate is a probability from 0 to 1, got {', '.join(bad)}"
        )
    repeated = sorted({f for f in rates if rates.count(f) > 1})
    if repeated:
        raise argparse.ArgumentTypeError(
            f"{', '.join(f'{f:g}' for f in repeated)} given more than once in {text!r}"
        )
    return rates


def add_parser(subparsers: Any) -> None:
    from aiocram._help import HelpFormatter
    from aiocram._outputs import out_dir_arg

    p = subparsers.add_parser(
        "campaign",
        help="run the robustness campaign",
        description=(
            "Run the table-setting demo headless for every seed and fault rate, with and "
            "without projection reasoning, and measure each run on the true world. Each "
            "run's record is appended to OUT/runs.jsonl as it ends; the summary goes to "
            "OUT/campaign.json, two plots and the console. Every flag is checked before a "
            "run starts or a file is written. An --out that holds a campaign already is "
            "refused unless --overwrite is given (the previous files then stay until the "
            "new campaign ends). Exit status: 0 every invariant held, 1 some run violated "
            "one, 2 bad arguments, 3 a run crashed in the harness, 4 the results could not "
            "all be written (the message says what to free), 130 interrupted (Ctrl-C)."
        ),
        formatter_class=HelpFormatter,
    )
    p.add_argument(
        "--seeds", type=whole(1), default=20, help="seeds per fault rate and mode (>= 1)"
    )
    p.add_argument(
        "--first-seed",
        type=whole(0),
        default=1,
        help="the first seed; the runs use FIRST .. FIRST+SEEDS-1 (>= 0)",
    )
    add_objects_argument(p, "objects to set in every run, each once", choices=False)
    p.add_argument(
        "--robots",
        default=DEFAULT_ROBOT,
        metavar="NAMES",
        help="robots that run every cell, comma-separated, each once: modules of the "
        "robots package (pr2, panda); each row of the summary is one robot's",
    )
    p.add_argument(
        "--faults",
        type=_rates,
        default="0,0.05,0.1,0.2",
        metavar="RATES",
        help="uniform fault rates to run, comma-separated, each once",
    )
    p.add_argument(
        "--no-projection",
        action="store_true",
        help="only run without projection reasoning (default: both modes)",
    )
    p.add_argument("--only-projection", action="store_true", help=argparse.SUPPRESS)
    p.add_argument(
        "--workers",
        type=whole(1),
        default=os.cpu_count() or 1,
        help="runs at the same time (local: worker processes; dask: LocalCluster workers)",
    )
    p.add_argument(
        "--backend",
        choices=("local", "dask"),
        default="local",
        help="where the runs go: worker processes here, or a dask.distributed cluster",
    )
    p.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="with --backend dask: the scheduler to use, e.g. tcp://host:8786 (default: a "
        f"LocalCluster); one that does not answer within {SCHEDULER_TIMEOUT_S:.0f} s is an "
        "error",
    )
    p.add_argument(
        "--out",
        type=out_dir_arg,
        default="out/campaign",
        metavar="DIR",
        help="directory for runs.jsonl, campaign.json and the plots",
    )
    p.add_argument(
        "--overwrite",
        action="store_true",
        help="replace the campaign already in --out when this one ends (interrupted or "
        "not); without it such an --out is refused",
    )
    p.add_argument(
        "--store",
        default=None,
        metavar="FILE_OR_URL",
        help="record every run in this experience store: an SQLite file or a database URL "
        "(postgresql+psycopg://user@host/db: the workers write to it); default: "
        "OUT/experience.sqlite, kept across campaigns (each has its own id)",
    )
    p.add_argument(
        "--no-store", action="store_true", help="do not record the runs in the experience store"
    )
    p.add_argument(
        "--learned",
        type=Path,
        default=None,
        metavar="FILE",
        help="every run orders its choices by these learned priors "
        "(aiocram experience learn --out FILE); default: not used",
    )
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


EXIT_OK, EXIT_VIOLATED, EXIT_USAGE, EXIT_HARNESS, EXIT_NOT_WRITTEN = 0, 1, 2, 3, 4

#: The files a campaign writes into its --out; a directory holding one of them holds a
#: campaign, which a new one never wipes unasked.
CAMPAIGN_FILES = ("runs.jsonl", "campaign.json", "success_rate.png", "distance.png")


class _RunsFile:
    """``runs.jsonl``, one whole record per line, written as each run ends.

    A write that fails (disk full, quota, an I/O error) is cut back off, so the file
    holds complete records only; from then on nothing more is written and ``error`` says
    why (the command stops starting runs and keeps the rest in memory)."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self._fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o666)
        self.written = 0  # invariant: the complete records in the file, and nothing else
        self.error: OSError | None = None  # the first failed write; then none is tried

    def append(self, record: dict[str, Any]) -> bool:
        """Write ``record``; False if it is not on disk (now or since an earlier error)."""
        if self.error is not None:
            return False
        data = (json.dumps(record) + "\n").encode()
        start = os.lseek(self._fd, 0, os.SEEK_END)
        try:
            view = memoryview(data)
            while view:
                view = view[os.write(self._fd, view) :]
        except OSError as exc:
            self.error = exc
            try:  # no half record: a reader of the file must not stumble on it
                os.ftruncate(self._fd, start)
            except OSError:  # pragma: no cover - ftruncate needs no space
                pass
            return False
        self.written += 1
        return True

    def close(self) -> None:
        os.close(self._fd)


def _previous_campaign(out: Path) -> list[str]:
    """The campaign files in ``out`` (none when it does not exist)."""
    return [name for name in CAMPAIGN_FILES if (out / name).exists()]


def _usage(message: str) -> int:
    print(f"aiocram campaign: error: {message}", file=sys.stderr)
    return EXIT_USAGE


def _write_json(path: Path, data: Any) -> None:
    """Write ``path`` whole or not at all (a temporary file renamed into place)."""
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        tmp.write_text(json.dumps(data, indent=2))
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def _command(args: argparse.Namespace) -> int:
    """Check every argument, then run; each run's record is appended to
    ``OUT/runs.jsonl`` as it ends; the summary goes to ``OUT/campaign.json`` and the
    console. Ctrl-C: the partial summary of the finished runs is written and printed,
    exit 130. A write that fails stops the campaign (no further run starts), keeps
    every run written so far, prints the runs it could not write and says what to free,
    exit 4."""
    from aiocram._outputs import OutputError, Outputs, check_out_dir

    modes: tuple[bool, ...] = (False,) if args.no_projection else (True, False)
    if args.only_projection:
        modes = (True,)
    settings = dict(
        seeds=args.seeds,
        faults=args.faults,
        projection_modes=modes,
        backend=args.backend,
        first_seed=args.first_seed,
        objects=args.objects,
        learned=args.learned,
        robots=args.robots,
    )
    try:
        jobs = plan_campaign(**settings)
        if args.workers < 1:
            raise ValueError(f"--workers must be at least 1, got {args.workers}")
        if args.scheduler is not None and args.backend != "dask":
            raise ValueError(f"--scheduler {args.scheduler}: a dask scheduler needs --backend dask")
        if args.no_store and args.store is not None:
            raise ValueError("--store and --no-store: give one of them")
        check_out_dir(args.out)
    except (ValueError, OutputError) as exc:
        return _usage(str(exc))
    out: Path = args.out
    previous = _previous_campaign(out)
    if previous and not args.overwrite:
        return _usage(
            f"--out {out} holds a campaign already ({', '.join(previous)}); give another "
            "--out, or add --overwrite to replace it when this campaign ends"
        )
    client = None
    if args.backend == "dask" and args.scheduler is not None:
        try:  # before anything is written: a scheduler that does not answer is an error
            client = connect(args.scheduler)
        except SchedulerError as exc:
            return _usage(str(exc))
    experience: CampaignStore | None = None
    if not args.no_store:
        from aiocram.experience import StoreError

        try:  # before anything runs: a locked, corrupt, newer or silent store is an error
            experience = CampaignStore(args.store or out / "experience.sqlite")
        except StoreError as exc:
            if client is not None:
                client.close()
            return _usage(f"--store: {exc}")
    # --overwrite: the new files are staged and replace the previous campaign's at the end
    staged: Outputs | None = None
    try:
        if previous:
            staged = Outputs(out, stale=CAMPAIGN_FILES)
            where = staged.staging
        else:
            out.mkdir(parents=True, exist_ok=True)
            where = out
        runs = _RunsFile(where / "runs.jsonl")
    except (OutputError, OSError) as exc:
        if client is not None:
            client.close()
        if experience is not None:
            experience.close()
        text = str(exc) if isinstance(exc, OutputError) else f"{exc.strerror or exc}"
        return _usage(f"--out {out}: cannot write there: {text}")

    unsaved: list[dict[str, Any]] = []  # finished runs that runs.jsonl could not take

    def append(record: dict[str, Any]) -> None:
        if not runs.append(record):
            unsaved.append(record)

    def progress(done: int, total: int) -> None:
        print(f"\r{done}/{total} runs", end="", file=sys.stderr, flush=True)

    t0 = time.perf_counter()
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
            stop=lambda: runs.error is not None,
            client=client,
            experience=experience,
        )
    except KeyboardInterrupt:
        interrupted = True
    finally:
        restore_sigint()
        runs.close()
        if experience is not None:
            experience.close()
    print(file=sys.stderr)
    summary = summarise(results)
    summary["command"] = " ".join(["aiocram", *sys.argv[1:]])
    summary["backend"] = args.backend
    summary["learned"] = None if args.learned is None else str(args.learned)
    summary["workers"] = args.workers
    summary["wall_time_s"] = time.perf_counter() - t0
    summary["runs_finished"] = len(results)
    summary["runs_planned"] = len(jobs)
    summary["partial"] = interrupted or runs.error is not None
    if experience is not None:
        summary["experience"] = experience.summary()
    failure: OSError | None = runs.error
    if staged is not None and not results:
        # interrupted before any run ended: nothing to replace the previous campaign with
        import shutil

        shutil.rmtree(staged.staging, ignore_errors=True)
        _print_summary(summary)
        print(
            f"aiocram campaign: no run finished; the previous campaign in {out} is left as it was",
            file=sys.stderr,
        )
        return 130
    written: list[Path] = []
    try:
        _write_json(where / "campaign.json", {"summary": summary, "runs": results})
        written.append(where / "campaign.json")
        written += _plot(summary, where)
    except OSError as exc:
        failure = failure or exc
    if staged is not None:
        staged.commit(CAMPAIGN_FILES)  # renames: they need no space
    final = [out / p.name for p in [runs.path, *written]]
    _print_summary(summary)
    print(f"wrote {', '.join(str(p) for p in final)}")
    if experience is not None:
        _print_recorded(experience)
    if failure is not None:
        path = out / "runs.jsonl" if failure is runs.error else failure.filename or out
        return _not_written(failure, path, out, runs.written, unsaved, len(results), len(jobs))
    if interrupted:
        print(
            f"aiocram campaign: interrupted; partial summary of {len(results)} of {len(jobs)} runs",
            file=sys.stderr,
        )
        return 130
    errors = sum(1 for r in results if "error" in r)
    if errors:
        print(
            f"{_runs(errors)} crashed in the harness (see 'error' in campaign.json)",
            file=sys.stderr,
        )
        return EXIT_HARNESS
    violated = sum(len(r["invariant_violations"]) for r in summary["rows"])
    return EXIT_VIOLATED if violated else EXIT_OK


def _print_recorded(experience: CampaignStore) -> None:
    """Where the runs were recorded; the runs that could not be, counted, each reason."""
    info = experience.summary()
    print(
        f"recorded {_runs(info['runs_recorded'])} in {info['store']} as campaign "
        f"{info['campaign']} (aiocram experience failures --store {info['store']})"
    )
    if experience.errors:
        print(
            f"aiocram campaign: {_runs(len(experience.errors))} not recorded in the "
            f"experience store (they are in runs.jsonl): {experience.errors[0]}",
            file=sys.stderr,
        )


def _runs(n: int) -> str:
    return "1 run" if n == 1 else f"{n} runs"


def _not_written(
    failure: OSError,
    path: Any,
    out: Path,
    on_disk: int,
    unsaved: list[dict[str, Any]],
    done: int,
    planned: int,
) -> int:
    """Say what could not be written and what to free; print the runs not on disk."""
    for record in unsaved:  # nothing finished is lost: the records go to stdout
        print(json.dumps(record))
    print(
        f"aiocram campaign: error: cannot write {path}: {failure.strerror or failure}. "
        f"The campaign stopped after {done} of {planned} runs: {out}/runs.jsonl keeps the "
        f"{_runs(on_disk)} written before"
        + (
            f"; the {_runs(len(unsaved))} finished that it could not take "
            f"{'is' if len(unsaved) == 1 else 'are'} printed on stdout as JSON lines "
            "(append them to runs.jsonl)"
            if unsaved
            else ""
        )
        + f". Free space on the file system of {out} (df -h {out}) or give an --out "
        "elsewhere, and run the remaining seeds (--first-seed) again.",
        file=sys.stderr,
    )
    return EXIT_NOT_WRITTEN


def main(argv: list[str] | None = None) -> int:
    """``aiocram campaign ...`` (``argv`` starts with ``"campaign"``); the exit status,
    2 for bad arguments, without raising ``SystemExit`` (see :func:`aiocram.cli.main`)."""
    from aiocram.cli import main as cli_main

    return cli_main(argv)
