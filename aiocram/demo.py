"""``aiocram demo``: the table-setting demo as projection-then-execute on the simulated real
robot.

The robot's *belief* world is where plans and projection reason; a second PyBullet world
is the *true* world the real process modules act on (timed motions, physics, noisy
perception, injected faults). Before each transport the robot imagines fetch-and-deliver
``runs`` times in projection over its belief and executes the cheapest successful plan
for real (``--no-projection`` turns that off).

Outputs (``--out DIR``): ``log.jsonl`` (the event log; ``aiocram show DIR/log.jsonl``),
``final_scene.png`` (the true world at the end), ``robot_view.png`` (what the head camera
sees) and ``costmap-*.png`` (the base-pose costmaps the real run used).

:func:`run_demo_once` is the headless variant the robustness campaign runs.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import cpl
from aiocram.foresight import foresight_records, print_foresight
from aiocram.truth import TruthObserver, TruthReport

__all__ = ["DEFAULT_OBJECTS", "DemoConfig", "DemoReport", "add_parser", "run_demo", "run_demo_once"]

DEFAULT_OBJECTS = ("bowl", "cup", "spoon", "milk", "breakfast-cereal")

@dataclass
class DemoConfig:
    """What to run. ``faults``: a :class:`projection.FaultProfile`, its command-line text
    (``"0.1"``, ``"navigation=0.05,ik=0.1"``) or ``None`` (noise only). ``speed``: ``None``
    = as fast as possible, ``1.0`` = real time, or a factor."""

    objects: tuple[str, ...] = DEFAULT_OBJECTS
    seed: int = 1
    runs: int = 3
    projection: bool = True
    faults: Any = None
    speed: float | None = None
    gui: bool = False
    out: Path | None = None
    live: bool = True


@dataclass
class DemoReport:
    """What happened: per-object outcomes as the plan reported them, the truth measured
    on the true world (:class:`aiocram.truth.TruthReport`: delivered objects, phantoms,
    the invariants), and times (simulated robot seconds; wall seconds spent imagining)."""

    config: DemoConfig
    outcomes: dict[str, Any]
    invariants: dict[str, bool]
    violations: dict[str, str]
    sim_time_s: float
    wall_time_s: float
    imagined_wall_s: dict[str, float] = field(default_factory=dict)
    real_sim_s: dict[str, float] = field(default_factory=dict)
    files: list[Path] = field(default_factory=list)
    truth: TruthReport | None = None
    foresight: list[dict[str, Any]] = field(default_factory=list)  # aiocram.foresight

    @property
    def delivered(self) -> int:
        """Objects delivered, measured on the true world."""
        return 0 if self.truth is None else self.truth.delivered

    @property
    def claimed(self) -> int:
        """Objects the plan reported placed."""
        return sum(1 for o in self.outcomes.values() if o.success)

    def to_json(self) -> dict[str, Any]:
        objects = {}
        for name, o in self.outcomes.items():
            truth = None if self.truth is None else self.truth.objects.get(o.name)
            objects[name] = {
                **({} if truth is None else truth.to_json()),
                "claimed": o.success,
                "failure": None if o.failure is None else type(o.failure).__name__,
                "retries": dict(o.retries),
                "distance_driven": o.distance,
                "real_sim_s": self.real_sim_s.get(name, 0.0),
                "imagined_wall_s": self.imagined_wall_s.get(name, 0.0),
            }
        return {
            "seed": self.config.seed,
            "projection": self.config.projection,
            "objects": objects,
            "distance_driven": sum(o.distance for o in self.outcomes.values()),
            "real_time_s": self.sim_time_s,
            "foresight": self.foresight,
            "invariants": dict(self.invariants),
            "violations": dict(self.violations),
            "cleanup_intervened": [] if self.truth is None else list(self.truth.cleanup_intervened),
        }


class _Watch(cpl.Instrument):
    """Records wall-clock times of tasks and every task of the run (for the invariants)."""

    def __init__(self) -> None:
        self.tasks: list[cpl.Task] = []
        self.wall: dict[int, list[float]] = {}

    def run_started(self, root: cpl.Task) -> None:
        self.tasks.append(root)

    def task_spawned(self, task: cpl.Task) -> None:
        self.tasks.append(task)

    def task_status_changed(self, task: cpl.Task, old: cpl.Status, new: cpl.Status) -> None:
        if new is cpl.Status.RUNNING and old is cpl.Status.CREATED:
            self.wall[id(task)] = [time.perf_counter(), math.nan]
        elif new.dead and id(task) in self.wall:
            self.wall[id(task)][1] = time.perf_counter()

    def wall_time(self, task: cpl.Task) -> float:
        start, end = self.wall.get(id(task), (math.nan, math.nan))
        return 0.0 if math.isnan(start) or math.isnan(end) else end - start


def _faults(config: DemoConfig) -> Any:
    from projection import FaultProfile

    if config.faults is None:
        return FaultProfile(seed=config.seed)
    if isinstance(config.faults, str):
        profile = FaultProfile.parse(config.faults)
        if "seed=" not in config.faults:
            from dataclasses import replace

            profile = replace(profile, seed=config.seed)
        return profile
    return config.faults


def _transport_times(root: cpl.Task, watch: _Watch) -> tuple[dict[str, float], dict[str, float]]:
    """Per transported object type: simulated seconds of the transport, wall seconds spent
    in its imagined runs."""
    from executive import action_of

    real: dict[str, float] = {}
    imagined: dict[str, float] = {}
    for task in _walk(root):
        action = action_of(task)
        if action is None or action.type != "transporting" or task.end_time is None:
            continue
        obj = action.get("object")
        otype = str(obj.get("type")) if obj is not None else task.path_entry
        real[otype] = task.end_time - (task.start_time or task.end_time)
        imagined[otype] = sum(
            watch.wall_time(t) for t in _walk(task) if t.name.startswith("projection-run")
        )
    return real, imagined


def _walk(task: cpl.Task) -> list[cpl.Task]:
    out, stack = [], [task]
    while stack:
        t = stack.pop()
        out.append(t)
        stack.extend(reversed(t.children))
    return out


def _costmaps_used(root: cpl.Task, limit: int = 5) -> list[Any]:
    """The robot-location designators the real run navigated to, one per chain."""
    from executive import action_of

    found: list[Any] = []
    seen: set[int] = set()
    for task in _walk(root):
        action = action_of(task)
        if action is None or action.type != "navigating" or task.state is not cpl.Status.SUCCEEDED:
            continue
        if any(p.startswith("projection-run") for p in task.path):
            continue
        loc = action.get("location")
        if loc is None or not hasattr(loc, "first") or loc.get("pose") is not None:
            continue
        first = loc.first()
        if id(first) in seen:
            continue
        seen.add(id(first))
        found.append(loc)
        if len(found) >= limit:
            break
    return found


def run_demo(config: DemoConfig, console: Any = None) -> DemoReport:
    """Run the demo as configured; write its files if ``config.out`` is set."""
    import plans
    from plans.demo import table_setting
    from projection import make_world_pair, real_robot_clock, with_real_robot

    del plans  # imported for its action rules
    if config.runs < 1:
        raise ValueError(f"--runs must be at least 1, got {config.runs}")
    unknown = [o for o in config.objects if o not in DEFAULT_OBJECTS]
    if unknown:
        raise ValueError(f"unknown objects {unknown}; the demo knows {list(DEFAULT_OBJECTS)}")
    faults = _faults(config)
    watch = _Watch()
    instruments: list[cpl.Instrument] = [watch]
    files: list[Path] = []
    if config.out is not None:
        config.out.mkdir(parents=True, exist_ok=True)
        log = config.out / "log.jsonl"
        log.write_text("")
        instruments.append(cpl.EventLog(log))
        files.append(log)
    restore_logging = _route_plan_logs(config.out)
    true_world, belief_world = make_world_pair(config.seed, objects={}, gui=config.gui)
    observer = TruthObserver(true_world, belief_world, lambda: watch.tasks)
    outcomes: dict[str, Any] = {}

    async def main() -> dict[str, Any]:
        from cpl.display import LiveTaskTree

        root = cpl.current_task()
        assert root is not None
        async with with_real_robot(
            true_world, belief_world, faults=faults, speed=config.speed
        ) as env:
            observer.subscribe(env)
            if config.live:
                async with LiveTaskTree(root, console=console, refresh_per_second=4):
                    result = await table_setting(
                        true_world,
                        config.objects,
                        random=True,
                        seed=config.seed,
                        projection_reasoning=config.projection,
                        projection_runs=config.runs,
                        spawn=False,
                        before_cleanup=observer.before_cleanup,
                    )
            else:
                result = await table_setting(
                    true_world,
                    config.objects,
                    random=True,
                    seed=config.seed,
                    projection_reasoning=config.projection,
                    projection_runs=config.runs,
                    spawn=False,
                    before_cleanup=observer.before_cleanup,
                )
            observer.body_returned()
        return dict(result)

    t0 = time.perf_counter()
    try:
        _set_up_scene(true_world, config)
        root_box: list[cpl.Task] = []

        class _Root(cpl.Instrument):
            def run_started(self, root: cpl.Task) -> None:
                root_box.append(root)

        outcomes = cpl.run(
            main,
            name="demo",
            clock=real_robot_clock(config.speed),
            instruments=[*instruments, _Root()],
        )
        wall = time.perf_counter() - t0
        root = root_box[0]
        sim = (root.end_time or 0.0) - (root.start_time or 0.0)
        truth = observer.measure({o.name: o.success for o in outcomes.values()})
        real_sim, imagined = _transport_times(root, watch)
        if config.out is not None:
            files.extend(_write_pictures(config.out, true_world, belief_world, root))
        return DemoReport(
            config,
            outcomes,
            truth.invariants,
            truth.violations,
            sim,
            wall,
            imagined,
            real_sim,
            files,
            truth,
            foresight_records(root),
        )
    finally:
        restore_logging()
        true_world.close()
        belief_world.close()


def _set_up_scene(true_world: Any, config: DemoConfig) -> dict[str, Any]:
    """Spawn the demo objects in the true world, sampling their poses with location rules
    bound to the true world (so spawns are collision-free with each other), and let them
    come to rest. The robot's belief knows none of this: it learns by perceiving."""
    from plans.demo import spawn_scene
    from projection import settle, with_projected_robot

    async def set_up() -> dict[str, Any]:
        async with with_projected_robot(true_world):
            return spawn_scene(true_world, config.objects, random=True, seed=config.seed)

    spawned: dict[str, Any] = cpl.run(set_up, name="scene-setup")
    settle(true_world, 240)
    return {name: true_world.object_pose(name) for name in spawned}


def _route_plan_logs(out: Path | None) -> Callable[[], None]:
    """Plans log every retry ("Relocating", "No samples left"...); during the demo these go
    to ``OUT/plans.log`` (nowhere without ``--out``) so that the console shows the live tree
    and the summary. Returns the function that undoes this."""
    import logging

    handler: logging.Handler
    if out is not None:
        handler = logging.FileHandler(out / "plans.log", mode="w")
        handler.setFormatter(logging.Formatter("%(levelname)s %(name)s: %(message)s"))
    else:
        handler = logging.NullHandler()
    loggers = [logging.getLogger(name) for name in ("plans", "executive", "projection")]
    saved = [(lg, lg.propagate) for lg in loggers]
    for lg in loggers:
        lg.propagate = False
        lg.addHandler(handler)

    def undo() -> None:
        for lg, propagate in saved:
            lg.removeHandler(handler)
            lg.propagate = propagate
        handler.close()

    return undo


def _write_pictures(out: Path, true_world: Any, belief_world: Any, root: cpl.Task) -> list[Path]:
    from projection import render

    paths = [
        render.scene(true_world, out / "final_scene.png"),
        render.scene(true_world, out / "robot_view.png", camera="robot"),
    ]
    for i, loc in enumerate(_costmaps_used(root)):
        try:
            paths.append(render.costmap(loc, out / f"costmap-{i + 1}.png", world=belief_world))
        except Exception as exc:  # a picture must never fail the demo
            print(f"(costmap {i + 1} not drawn: {type(exc).__name__}: {exc})", file=sys.stderr)
    return paths


def run_demo_once(
    *,
    seed: int,
    fault_rate: float,
    projection: bool = True,
    objects: Sequence[str] = DEFAULT_OBJECTS,
    runs: int = 3,
) -> dict[str, Any]:
    """One headless campaign run at a uniform fault rate (seeded by ``seed``); the JSON
    record of :class:`DemoReport`."""
    from projection import FaultProfile

    config = DemoConfig(
        objects=tuple(objects),
        seed=seed,
        runs=runs,
        projection=projection,
        faults=FaultProfile.uniform(fault_rate, seed=seed),
        live=False,
    )
    record = run_demo(config).to_json()
    record["fault_rate"] = fault_rate
    return record


def _print_report(report: DemoReport, console: Any) -> None:
    from rich.table import Table

    table = Table(
        title=f"table setting, seed {report.config.seed}"
        f" ({'with' if report.config.projection else 'without'} projection reasoning)"
    )
    for col in (
        "object",
        "outcome",
        "retries",
        "distance (m)",
        "real time (s)",
        "imagined (wall s)",
    ):
        table.add_column(col)
    for name, o in report.outcomes.items():
        truth = None if report.truth is None else report.truth.objects.get(o.name)
        if truth is not None and truth.delivered:
            outcome = "[green]delivered[/]"
        elif truth is not None and truth.phantom:
            outcome = f"[red]phantom ({truth.where})[/]"
        else:
            outcome = f"[red]{type(o.failure).__name__}[/]"
        retries = ", ".join(f"{k} {v}" for k, v in sorted(o.retries.items()) if v) or "-"
        table.add_row(
            name,
            outcome,
            retries,
            f"{o.distance:.2f}",
            f"{report.real_sim_s.get(name, 0.0):.1f}",
            f"{report.imagined_wall_s.get(name, 0.0):.2f}",
        )
    console.print(table)
    print_foresight(report.foresight, console)
    console.print(
        f"{report.delivered}/{len(report.outcomes)} objects delivered (true world; the plan"
        f" claimed {report.claimed}); simulated "
        f"{report.sim_time_s:.1f} s in {report.wall_time_s:.1f} s wall time"
    )
    if report.truth is not None and report.truth.cleanup_intervened:
        console.print("final cleanup intervened: " + "; ".join(report.truth.cleanup_intervened))
    bad = {k: report.violations.get(k, "") for k, v in report.invariants.items() if not v}
    if bad:
        console.print(f"[red]invariants violated:[/] {bad}")
    else:
        console.print("invariants hold: " + ", ".join(report.invariants))
    for path in report.files:
        console.print(f"wrote {path}")


def add_parser(subparsers: Any) -> None:
    p = subparsers.add_parser(
        "demo", help="table setting: projection-then-execute on the simulated real robot"
    )
    p.add_argument(
        "--objects",
        nargs="+",
        default=list(DEFAULT_OBJECTS),
        help=f"objects to set (default: {' '.join(DEFAULT_OBJECTS)})",
    )
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--runs", type=int, default=3, help="imagined runs per transport")
    p.add_argument("--no-projection", action="store_true", help="execute without imagining")
    p.add_argument(
        "--faults",
        default=None,
        help="fault profile: a uniform rate ('0.1') or 'navigation=0.05,ik=0.1'",
    )
    p.add_argument(
        "--speed",
        default="max",
        help="simulated time vs wall clock: 'max' (default), 1 (real time), 5, ...",
    )
    p.add_argument("--gui", action="store_true", help="show the true world in a PyBullet GUI")
    p.add_argument("--out", default="out/demo", help="directory for the log and pictures")
    p.add_argument("--no-live", action="store_true", help="no live task tree")
    p.set_defaults(handler=_command)


def _command(args: argparse.Namespace) -> int:
    from rich.console import Console

    console = Console()
    try:
        speed = None if args.speed in ("max", "inf") else float(args.speed)
        if speed is not None and not (speed > 0 and math.isfinite(speed)):
            raise ValueError(f"--speed must be 'max' or a positive number, got {args.speed!r}")
        config = DemoConfig(
            objects=tuple(args.objects),
            seed=args.seed,
            runs=args.runs,
            projection=not args.no_projection,
            faults=args.faults,
            speed=speed,
            gui=args.gui,
            out=Path(args.out),
            live=not args.no_live,
        )
        if args.gui and not os.environ.get("DISPLAY"):
            raise ValueError("--gui needs a display (DISPLAY is not set); drop --gui")
        report = run_demo(config, console=console)
    except ValueError as exc:
        print(f"aiocram demo: {exc}", file=sys.stderr)
        return 2
    _print_report(report, console)
    return 0 if all(report.invariants.values()) else 1
