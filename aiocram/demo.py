"""``aiocram demo``: the table-setting demo as projection-then-execute on the simulated real
robot.

The robot's *belief* world is where plans and projection reason; a second PyBullet world
is the *true* world the real process modules act on (timed motions, physics, noisy
perception, injected faults). Before each transport the robot imagines fetch-and-deliver
``runs`` times in projection over its belief and executes the cheapest successful plan
for real (``--no-projection`` turns that off).

Outputs (``--out DIR``): ``log.jsonl`` (the event log; ``aiocram show DIR/log.jsonl``),
``final_scene.png`` (the true world at the end, from a camera that shows every object),
``robot_view.png`` (what the head camera sees) and ``costmap-*.png`` (the base-pose
costmaps the real run used, with the alternatives it imagined).

:func:`run_demo_once` is the headless variant the robustness campaign runs.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import math
import os
import re
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import cpl
from aiocram.foresight import foresight_records, print_foresight
from aiocram.truth import TruthObserver, TruthReport

if TYPE_CHECKING:  # projection (PyBullet) is imported when a demo runs, not with this module
    from projection import World

__all__ = ["DEFAULT_OBJECTS", "DemoConfig", "DemoReport", "add_parser", "run_demo", "run_demo_once"]

DEFAULT_OBJECTS = ("bowl", "cup", "spoon", "milk", "breakfast-cereal")


class DemoConfigError(ValueError):
    """A :class:`DemoConfig` field (a command-line flag) is wrong; the message names the
    flag and says what to give instead. Raised before anything is written or moved."""


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
    #: The experience store the run is recorded in (an SQLite path or a database URL;
    #: ``None``: not recorded). The command's default is ``OUT/experience.sqlite``.
    store: str | Path | None = None

    def check(self) -> None:
        """Raise :class:`DemoConfigError` (naming the flag) for the first bad field. Touches
        nothing: :func:`run_demo` calls it before it writes a file or builds a world."""
        from aiocram._outputs import OutputError, check_out_dir

        unknown = [o for o in self.objects if o not in DEFAULT_OBJECTS]
        if unknown:
            raise DemoConfigError(
                f"--objects: unknown objects {unknown}; the demo knows {' '.join(DEFAULT_OBJECTS)}"
            )
        if not self.objects:
            raise DemoConfigError("--objects: give at least one object")
        twice = sorted({o for o in self.objects if self.objects.count(o) > 1})
        if twice:
            raise DemoConfigError(f"--objects: each object at most once, got {twice} twice")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            raise DemoConfigError(f"--seed must be a whole number >= 0, got {self.seed!r}")
        if isinstance(self.runs, bool) or not isinstance(self.runs, int) or self.runs < 1:
            raise DemoConfigError(f"--runs must be a whole number >= 1, got {self.runs!r}")
        if self.speed is not None and not (
            isinstance(self.speed, int | float) and self.speed > 0 and not math.isnan(self.speed)
        ):
            raise DemoConfigError(
                f"--speed must be 'max' or a number > 0 (1 = real time), got {self.speed!r}"
            )
        _faults(self)  # raises DemoConfigError for a bad profile
        if self.gui and not os.environ.get("DISPLAY"):
            raise DemoConfigError("--gui needs a display (DISPLAY is not set); drop --gui")
        if self.out is not None:
            try:
                check_out_dir(Path(self.out))
            except OutputError as exc:
                raise DemoConfigError(str(exc)) from None
        if self.store is not None:
            from aiocram.experience import StoreError, store_url

            try:
                store_url(self.store)
            except StoreError as exc:
                raise DemoConfigError(str(exc)) from None


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
    #: True when Ctrl-C ended the run early (the outcomes are those of the objects done).
    interrupted: bool = False
    #: The run's root task (dead), for the final tree.
    root: Any = None
    #: Evaporated tasks whose cleanup raised (``cpl.cleanup_failures``; each is logged).
    cleanup_failures: int = 0
    #: What the true world says after the run (``None`` if it was never measured).
    truth: TruthReport | None = None
    foresight: list[dict[str, Any]] = field(default_factory=list)  # aiocram.foresight
    #: Wall seconds spent recording the run in the experience store (after the run).
    store_s: float = 0.0

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
            "cleanup_intervened": (
                [] if self.truth is None else list(self.truth.cleanup_intervened)
            ),
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
    """The fault profile of ``config`` (DemoConfigError naming ``--faults`` if bad)."""
    from dataclasses import replace

    from projection import FaultProfile

    if config.faults is None:
        return FaultProfile(seed=config.seed)
    if isinstance(config.faults, FaultProfile):
        return config.faults
    if not isinstance(config.faults, str):
        raise DemoConfigError(
            f"--faults takes a FaultProfile or its text ('0.1', 'ik=0.2'), got {config.faults!r}"
        )
    try:
        bare = float(config.faults)
    except ValueError:
        bare = None
    if bare is not None and not 0.0 <= bare <= 1.0:
        raise DemoConfigError(
            f"--faults {config.faults}: a fault rate is a probability from 0 to 1 (e.g. "
            "--faults 0.1, or per kind: --faults navigation=0.05,ik=0.1)"
        )
    try:
        profile = FaultProfile.parse(config.faults)
    except (TypeError, ValueError) as exc:
        text = str(exc).replace("FaultProfile.", "")
        raise DemoConfigError(
            f"--faults {config.faults!r}: {text} (rates are probabilities from 0 to 1, "
            "e.g. --faults 0.1 or --faults navigation=0.05,ik=0.1)"
        ) from None
    if "seed=" not in config.faults:
        profile = replace(profile, seed=config.seed)
    return profile


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


#: Files of a demo run in ``--out``, in the order the summary lists them; ``costmap-*``
#: come after. Older runs' files of these kinds are replaced when the run ends.
OUTPUT_FILES = ("log.jsonl", "plans.log", "final_scene.png", "robot_view.png")
_STALE = (*OUTPUT_FILES, "costmap-*.png", "floor_plan.png")


def run_demo(config: DemoConfig, console: Any = None, *, interrupts: Any = None) -> DemoReport:
    """Run the demo as configured; write its files if ``config.out`` is set.

    Every field is checked first (:meth:`DemoConfig.check`): a bad one raises
    :class:`DemoConfigError` before any file is touched. The files are written to a
    staging directory inside ``out`` and moved into place when the run ends (also when it
    failed or was interrupted), so until then ``out`` keeps the previous run's files.

    ``interrupts``: an :class:`aiocram._interrupt.Interrupts` that owns Ctrl-C (the
    command passes one); the run attaches its root task to it, so a Ctrl-C evaporates
    the plan and the report comes back with ``interrupted=True``."""
    config.check()
    _check_store(config)  # opens it: a locked, corrupt or newer store stops us here
    import plans
    from plans.demo import table_setting
    from projection import make_world_pair, real_robot_clock, with_real_robot

    from ._figures import CameraRecorder, CostmapRecorder
    from ._floorplan import RouteRecorder
    from ._outputs import OutputError, Outputs
    from ._views import DemoView, Progress

    del plans  # imported for its action rules
    faults = _faults(config)
    watch = _Watch()
    progress = Progress(config.objects)
    instruments: list[cpl.Instrument] = [watch, progress]
    outputs: Outputs | None = None
    if config.out is not None:
        try:  # the first write: a directory that cannot be made is the user's to fix
            outputs = Outputs(Path(config.out), stale=_STALE)
        except OutputError as exc:
            raise DemoConfigError(str(exc)) from None
        if interrupts is not None:
            interrupts.on_abort = lambda: outputs.commit(OUTPUT_FILES)
        instruments.append(cpl.EventLog(outputs.path("log.jsonl")))
    restore_logging = _route_plan_logs(None if outputs is None else outputs.path("plans.log"))
    true_world: World | None = None
    belief_world: World | None = None
    outcomes: dict[str, Any] = {}
    engine_box: list[Any] = []
    observer: TruthObserver | None = None  # made with the worlds, before the run

    async def main() -> None:
        from executive import current_environment
        from projection._locations import costmaps_of

        root = cpl.current_task()
        assert root is not None
        assert true_world is not None and belief_world is not None  # made before the run
        if interrupts is not None:
            interrupts.attach(root)
        from projection._locations import location_rules

        rules = location_rules(belief_world)
        if outputs is not None:  # note every candidate pose, for the costmap pictures
            rules = costmaps.recording(rules)
        assert observer is not None
        async with with_real_robot(
            true_world, belief_world, faults=faults, speed=config.speed, rules=rules
        ) as env:
            observer.subscribe(env)
            engine_box.append(costmaps_of(current_environment().rules))
            plan = table_setting(
                true_world,
                config.objects,
                random=True,
                seed=config.seed,
                projection_reasoning=config.projection,
                projection_runs=config.runs,
                spawn=False,
                outcomes=outcomes,
                before_cleanup=observer.before_cleanup,
            )
            if config.live:
                async with DemoView(root, progress, console=console, refresh_per_second=4):
                    await plan
            else:
                await plan
            observer.body_returned()

    t0 = time.perf_counter()
    try:
        true_world, belief_world = make_world_pair(config.seed, objects={}, gui=config.gui)
        observer = TruthObserver(true_world, belief_world, lambda: watch.tasks)
        camera = CameraRecorder(true_world)
        costmaps = CostmapRecorder(belief_world)
        route = RouteRecorder(true_world)  # the floor plan's true route (issue 14)
        if outputs is not None:  # they record for the pictures only
            instruments += [camera, costmaps, route]
        _set_up_scene(true_world, config)
        root_box: list[cpl.Task] = []

        class _Root(cpl.Instrument):
            def run_started(self, root: cpl.Task) -> None:
                root_box.append(root)

        cpl.run(
            main,
            name="demo",
            clock=real_robot_clock(config.speed),
            instruments=[*instruments, _Root()],
        )
        wall = time.perf_counter() - t0
        root = root_box[0]
        interrupted = interrupts is not None and interrupts.interrupted
        sim = (root.end_time or 0.0) - (root.start_time or 0.0)
        truth = observer.measure(
            {o.name: o.success for o in outcomes.values()}, interrupted=interrupted
        )
        real_sim, imagined = _transport_times(root, watch)
        if outputs is not None:
            _write_pictures(outputs, true_world, camera, costmaps, engine_box, interrupts)
            route.write(true_world, foresight_records(root), outputs.path("floor_plan.png"))
        report = DemoReport(
            config,
            outcomes,
            truth.invariants,
            truth.violations,
            sim,
            wall,
            imagined,
            real_sim,
            [],
            interrupted=interrupted,
            root=root,
            cleanup_failures=len(cpl.cleanup_failures(root)),
            truth=truth,
            foresight=foresight_records(root),
        )
    finally:
        restore_logging()
        files = [] if outputs is None else outputs.commit(OUTPUT_FILES)
        for world in (true_world, belief_world):
            if world is not None:
                world.close()
    report.files = files
    if config.store is not None:
        _record_experience(config, report, files)
    return report


# -------------------------------------------------------------- experience (issue 29)
def _check_store(config: DemoConfig) -> None:
    """Open the store before the run (DemoConfigError naming what to fix)."""
    if config.store is None:
        return
    from aiocram.experience import StoreError, check_store

    try:
        check_store(config.store)
    except StoreError as exc:
        inside = config.out is not None and Path(config.store).parent == Path(config.out)
        raise DemoConfigError(f"{'--out' if inside else '--store'}: {exc}") from None


def _record_experience(config: DemoConfig, report: DemoReport, files: list[Path]) -> None:
    """Record the finished run in the experience store (after the run, off its control
    path); an SQLite store is listed with the files written. A store that fails now (it
    was checked before the run) is reported on stderr: the run's own outputs stand."""
    from aiocram.experience import StoreError, record_run, robot_name, store_url

    assert config.store is not None
    faults = config.faults if isinstance(config.faults, str) else None
    try:
        report.store_s = record_run(config.store, report, robot=robot_name(), faults=faults)
    except StoreError as exc:
        print(f"aiocram demo: the run was not recorded: {exc}", file=sys.stderr)
        return
    url = store_url(config.store)
    if url.get_backend_name() == "sqlite":
        files.append(Path(os.path.relpath(str(url.database))))


@contextlib.contextmanager
def frozen_imports() -> Iterator[None]:
    """Import what a demo run needs and move every object alive now (modules, classes,
    functions, constants: a few hundred thousand) to the collector's permanent generation
    (``gc.freeze``) until the block ends, so that the full collections the runs inside
    trigger no longer traverse them. For the code that runs demos (``aiocram demo``, a
    campaign's worker); it changes when cyclic garbage is freed, never what a run does.
    Undone at the end (``gc.unfreeze``): frozen objects are invisible to
    ``gc.get_referrers``, which other code in the process (hypothesis) relies on."""
    import gc

    import plans.demo  # noqa: F401  (and plans: the action rules)
    import projection  # noqa: F401

    from . import _figures, _outputs, _views  # noqa: F401

    gc.freeze()
    try:
        yield
    finally:
        gc.unfreeze()


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


def _route_plan_logs(path: Path | None) -> Callable[[], None]:
    """Plans log every retry (``plans.retries``: each one a ``CountedRetries`` grants or
    refuses, INFO) and every failure a retry scope handles (WARNING); during the demo
    these go to ``path`` (``OUT/plans.log``; nowhere without ``--out``) at INFO, so that
    the console shows the live view and the summary. Returns the function that undoes
    this."""
    import logging

    handler: logging.Handler
    if path is not None:
        handler = logging.FileHandler(path, mode="w", encoding="utf-8")
        handler.setFormatter(logging.Formatter("%(levelname)s %(name)s: %(message)s"))
    else:
        handler = logging.NullHandler()
    loggers = [logging.getLogger(name) for name in ("plans", "executive", "projection", "cpl")]
    saved = [(lg, lg.propagate, lg.level) for lg in loggers]
    for lg in loggers:
        lg.propagate = False
        lg.setLevel(logging.INFO)
        lg.addHandler(handler)

    def undo() -> None:
        for lg, propagate, level in saved:
            lg.removeHandler(handler)
            lg.propagate = propagate
            lg.setLevel(level)
        handler.close()

    return undo


def _write_pictures(
    outputs: Any,
    true_world: Any,
    camera: Any,
    costmaps: Any,
    engine_box: list[Any],
    interrupts: Any = None,
) -> None:
    """The final scene (true world), the head camera at the last detection, and the
    costmaps the real run navigated by (see :mod:`aiocram._figures`). A picture that
    cannot be drawn is reported on stderr: a picture never fails the demo."""
    from projection import render

    from ._figures import write_scene

    engine = engine_box[0] if engine_box else None
    # every other costmap figure is drawn by a forked copy of this process meanwhile (the
    # same pictures in about half the wall time on two cores)
    child = None
    if engine is not None and len(costmaps.uses) > 1:
        adopt = interrupts.adopt if interrupts is not None else None
        child = _fork(lambda: costmaps.figures(engine, outputs.staging, part=(1, 2)), adopt)
    try:
        try:
            # from where every object shows (the fixed overview hid some behind others)
            shot = render.camera_showing(true_world)
            caption = "the true world at the end of the run"
            write_scene(true_world, outputs.path("final_scene.png"), shot, caption)
            camera.write(outputs.path("robot_view.png"))
        except Exception as exc:  # reported; the run's outcome stands
            print(f"(pictures not drawn: {type(exc).__name__}: {exc})", file=sys.stderr)
        if engine is not None:
            costmaps.figures(engine, outputs.staging, part=(0, 1) if child is None else (0, 2))
    finally:
        if child is not None:
            _, status = os.waitpid(child, 0)
            if interrupts is not None:
                interrupts.release(child)
            if status != 0:
                print(
                    f"(some costmap pictures not drawn: their process ended with {status})",
                    file=sys.stderr,
                )


def _fork(work: Callable[[], Any], adopt: Callable[[int], None] | None = None) -> int | None:
    """Run ``work`` in a forked child that ends with ``os._exit`` (none of this process's
    cleanup runs there) and ignores Ctrl-C (the parent waits for it); the child's pid, or
    None where there is no fork or other threads run (``work`` is then left to the
    caller). ``adopt(pid)`` is called in the parent before a Ctrl-C can be handled (SIGINT
    is blocked around the fork), so an abort by a second Ctrl-C can kill the child
    (:meth:`aiocram._interrupt.Interrupts.adopt`) rather than leave it writing after the
    command ended."""
    import logging
    import signal
    import threading

    if not hasattr(os, "fork") or threading.active_count() > 1:
        return None  # a forked child would hold only this thread (--gui has others)
    # nothing buffered is inherited (the child could write it a second time)
    sys.stdout.flush()
    sys.stderr.flush()
    for name in ("plans", "executive", "projection", "cpl"):
        for handler in logging.getLogger(name).handlers:
            handler.flush()
    mask = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        pid = os.fork()
    except OSError:
        signal.pthread_sigmask(signal.SIG_SETMASK, mask)
        return None
    if pid:
        try:
            if adopt is not None:
                adopt(pid)
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, mask)  # a pending Ctrl-C runs now
        return pid
    code = 1
    try:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        signal.pthread_sigmask(signal.SIG_SETMASK, mask)
        work()
        code = 0
    except BaseException:
        import traceback

        traceback.print_exc()
    finally:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)


def run_demo_once(
    *,
    seed: int,
    fault_rate: float,
    projection: bool = True,
    objects: Sequence[str] = DEFAULT_OBJECTS,
    runs: int = 3,
    experience: bool = False,
) -> dict[str, Any]:
    """One headless campaign run at a uniform fault rate (seeded by ``seed``); the JSON
    record of :class:`DemoReport`. ``experience=True``: the record also carries the run's
    experience-store rows under ``"experience"`` (:func:`aiocram.experience.run_rows`,
    read from the run's task tree after the run), for the campaign to write."""
    from projection import FaultProfile

    config = DemoConfig(
        objects=tuple(objects),
        seed=seed,
        runs=runs,
        projection=projection,
        faults=FaultProfile.uniform(fault_rate, seed=seed),
        live=False,
    )
    report = run_demo(config)
    record = report.to_json()
    record["fault_rate"] = fault_rate
    if experience:
        from aiocram.experience import robot_name, run_rows

        record["experience"] = run_rows(
            {**record, "wall_time_s": report.wall_time_s},
            report.root,
            robot=robot_name(),
            source="campaign",
            faults=f"{fault_rate:g}",
        )
    return record


def _retries_text(retries: dict[str, int]) -> str:
    """``"61: detecting 56, search 3, …"``: the total, then the kinds most granted first
    (the console cuts what does not fit; plans.log and the JSON have every one)."""
    granted = {k: v for k, v in retries.items() if v}
    if not granted:
        return "-"
    kinds = sorted(granted.items(), key=lambda kv: (-kv[1], kv[0]))
    return f"{sum(granted.values())}: " + ", ".join(f"{k} {v}" for k, v in kinds)


#: The table's numeric columns: the full header, the short one for a narrow console
#: (the caption explains both).
_NUMBER_HEADERS = (("dist (m)", "dist"), ("sim (s)", "sim"), ("imag (s)", "imag"))
_TABLE_CHROME = 19  # 7 vertical rules and a space each side of 6 cells


def _breaks(text: str, width: int) -> str:
    """``text`` broken into lines of at most ``width`` where words join: before a capital
    (``ObjectNowhere`` / ``ToBeFound``), after a hyphen or at a space; a part longer than
    ``width`` is left for the table to fold."""
    parts = re.findall(r"[A-Z]?[^A-Z\s-]*-?\s*", text)
    lines = [""]
    for part in (p for p in parts if p):
        if lines[-1] and len(lines[-1]) + len(part.rstrip()) > width:
            lines.append("")
        lines[-1] += part
    return "\n".join(line.rstrip() for line in lines)


def outcome_table(report: DemoReport, width: int = 80) -> Any:
    """The summary per object as a rich table at most ``width`` columns wide (down to
    about 50). A number is never cut: the numeric columns are as wide as their widest
    value, with short headers when the console is narrow; the object and outcome cells
    wrap where words join; the retries cell, whose kinds are listed in full below the
    table, keeps its total and is cut after it with an ellipsis."""
    from rich.markup import escape
    from rich.table import Table

    rows: list[tuple[str, str, str, str, list[str]]] = []  # name, outcome, style, retries
    for name, o in report.outcomes.items():
        truth = None if report.truth is None else report.truth.objects.get(o.name)
        if truth is not None and truth.delivered:
            outcome, style = "delivered", "green"
        elif truth is not None and truth.phantom:
            outcome, style = f"phantom ({truth.where})", "red"
        elif o.failure is None or isinstance(o.failure, asyncio.CancelledError):
            outcome, style = "interrupted", "grey50"  # Ctrl-C evaporated the plan
        else:
            outcome, style = type(o.failure).__name__, "red"
        numbers = [
            f"{o.distance:.2f}",
            f"{report.real_sim_s.get(name, 0.0):.1f}",
            f"{report.imagined_wall_s.get(name, 0.0):.2f}",
        ]
        rows.append((name, outcome, style, _retries_text(o.retries), numbers))
    headers = [full for full, _ in _NUMBER_HEADERS]
    widths = [max([len(h), *(len(r[4][i]) for r in rows)]) for i, h in enumerate(headers)]
    room = width - _TABLE_CHROME - sum(widths)
    if room < 32:  # narrow: the short headers
        headers = [short for _, short in _NUMBER_HEADERS]
        widths = [max([len(h), *(len(r[4][i]) for r in rows)]) for i, h in enumerate(headers)]
        room = width - _TABLE_CHROME - sum(widths)
    # the three text columns (object, outcome, retries) share ``room``, shrunk one
    # character at a time: the retries down to 10, then object and outcome (wrapping)
    # down to 12, then the retries down to their total and an ellipsis, then the rest
    text = [
        max([6, *(len(r[0]) for r in rows)]),
        max([7, *(len(r[1]) for r in rows)]),
        max([7, *(len(r[3]) for r in rows)]),
    ]
    total = max([1, *(len(r[3].split(":")[0]) for r in rows)])
    for floors in ((99, 99, 10), (12, 12, 10), (12, 12, total + 2), (4, 4, total + 2)):
        for i in (2, 1, 0):
            cut = min(sum(text) - room, text[i] - min(floors[i], text[i]))
            text[i] -= max(0, cut)
    table = Table(
        title=f"table setting, seed {report.config.seed}"
        f" ({'with' if report.config.projection else 'without'} projection reasoning)",
        caption="dist: m driven · sim: simulated s · imag: wall s imagining",
    )
    table.add_column("object", width=text[0], overflow="fold")
    table.add_column("outcome", width=text[1], overflow="fold")
    table.add_column("retries", width=text[2], no_wrap=True, overflow="ellipsis")
    for header, w in zip(headers, widths, strict=True):
        table.add_column(header, justify="right", no_wrap=True, width=w)
    for name, outcome, style, retries, numbers in rows:
        table.add_row(
            _breaks(name, text[0]),
            f"[{style}]{escape(_breaks(outcome, text[1]))}[/]",
            retries,
            *numbers,
        )
    return table


def _print_report(report: DemoReport, console: Any) -> None:

    from ._views import final_tree

    if report.root is not None:
        log = next((str(p) for p in report.files if p.name == "log.jsonl"), None)
        console.print(final_tree(report.root))
        if log is not None:
            console.print(
                f"the whole tree: aiocram show {log}",
                soft_wrap=True,
                markup=False,
                highlight=False,
                style="dim",
            )
    console.print(outcome_table(report, console.width))
    print_foresight(report.foresight, console)
    kinds = [(name, _retries_text(o.retries)) for name, o in report.outcomes.items()]
    kinds = [(name, text.split(": ", 1)[1]) for name, text in kinds if text != "-"]
    if kinds:
        console.print("retries by kind (each one is in plans.log):")
        for name, text in kinds:
            console.print(f"  {name}: {text}", highlight=False)
    n = len(report.config.objects)
    if report.interrupted:
        console.print(
            f"interrupted by Ctrl-C during object {len(report.outcomes)} of {n}: the plan was "
            "evaporated and its cleanup ran"
        )
    console.print(
        f"{report.delivered}/{n} objects delivered (true world; the plan claimed {report.claimed})"
    )
    console.print(f"simulated {report.sim_time_s:.1f} s in {report.wall_time_s:.1f} s wall time")
    if report.truth is not None and report.truth.cleanup_intervened:
        console.print("final cleanup intervened: " + "; ".join(report.truth.cleanup_intervened))
    if report.cleanup_failures:
        where = " (each in plans.log)" if report.files else ""
        console.print(
            f"[red]{report.cleanup_failures} cleanup failure(s)[/]: the cleanup of an "
            f"evaporated task raised{where}"
        )
    bad = {k: report.violations.get(k, "") for k, v in report.invariants.items() if not v}
    if bad:
        from rich.text import Text

        console.print("[red]invariants violated:[/]")
        for name, why in bad.items():  # one per line, the detail as recorded
            console.print(Text(f"  {name}: {why or '(no detail recorded)'}"), soft_wrap=True)
    else:
        console.print("invariants hold: " + ", ".join(report.invariants))
    for path in report.files:  # whole, so that it can be copied
        console.print(f"wrote {path}", soft_wrap=True, markup=False, highlight=False)


# ----------------------------------------------------------------------- command line
def _speed_arg(text: str) -> float | None:
    if text.strip().lower() in ("max", "inf"):
        return None
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (value > 0 and math.isfinite(value)):
        raise argparse.ArgumentTypeError(
            f"must be 'max' or a number > 0 (1 = real time), got {text!r}"
        )
    return value


def _whole(minimum: int) -> Callable[[str], int]:
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            value = minimum - 1
        if value < minimum:
            raise argparse.ArgumentTypeError(f"must be a whole number >= {minimum}, got {text!r}")
        return value

    return parse


def add_parser(subparsers: Any) -> None:
    from aiocram._help import HelpFormatter
    from aiocram._outputs import out_dir_arg

    p = subparsers.add_parser(
        "demo",
        help="table setting: projection-then-execute on the simulated real robot",
        description=(
            "Set the kitchen island's table on the simulated real robot: before each "
            "transport the robot imagines it --runs times in projection and executes the "
            "cheapest plan. Writes the event log, plans.log and pictures to --out. Exit "
            "status: 0 all invariants hold, 1 one was violated, 2 bad arguments, "
            "3 internal error, 130 interrupted (Ctrl-C)."
        ),
        formatter_class=HelpFormatter,
    )
    p.add_argument(
        "--objects",
        nargs="+",
        default=list(DEFAULT_OBJECTS),
        choices=DEFAULT_OBJECTS,
        metavar="OBJECT",
        help=f"objects to set, in this order; any of: {' '.join(DEFAULT_OBJECTS)}",
    )
    p.add_argument(
        "--seed",
        type=_whole(0),
        default=1,
        help="seeds the scene, the sampling and the faults (whole number >= 0)",
    )
    p.add_argument("--runs", type=_whole(1), default=3, help="imagined runs per transport (>= 1)")
    p.add_argument(
        "--no-projection",
        action="store_true",
        help="execute without imagining first",
    )
    p.add_argument(
        "--faults",
        default=None,
        metavar="PROFILE",
        help="faults to inject: a rate for every kind ('0.1') or 'navigation=0.05,ik=0.1' "
        "(kinds: navigation, ptu, perception, grasp_slip, drop, ik; also miss_rate, "
        "detection_noise=POS:YAW, seed); default: detection noise only",
    )
    p.add_argument(
        "--speed",
        type=_speed_arg,
        default="max",
        help="simulated seconds per wall second: 'max' (as fast as possible), "
        "1 (real time), 5, ...",
    )
    p.add_argument("--gui", action="store_true", help="show the true world in a PyBullet GUI")
    p.add_argument(
        "--out",
        type=out_dir_arg,
        default="out/demo",
        metavar="DIR",
        help="directory for log.jsonl, plans.log and the pictures (replaced when the run "
        "ends; a bad argument leaves it untouched)",
    )
    p.add_argument(
        "--no-live",
        action="store_true",
        help="no live view (for logs and pipes); the summary is printed still",
    )
    p.add_argument(
        "--store",
        default=None,
        metavar="FILE_OR_URL",
        help="record the run in this experience store: an SQLite file or a database URL "
        "(postgresql+psycopg://user@host/db); default: OUT/experience.sqlite",
    )
    p.add_argument(
        "--no-store", action="store_true", help="do not record the run in the experience store"
    )
    p.set_defaults(handler=_command)


EXIT_OK, EXIT_VIOLATED, EXIT_USAGE, EXIT_INTERNAL = 0, 1, 2, 3


def _command(args: argparse.Namespace) -> int:
    import traceback

    from rich.console import Console

    from ._interrupt import EXIT_INTERRUPTED, Interrupts

    console = Console()
    config = DemoConfig(
        objects=tuple(args.objects),
        seed=args.seed,
        runs=args.runs,
        projection=not args.no_projection,
        faults=args.faults,
        speed=args.speed,
        gui=args.gui,
        out=Path(args.out),
        live=not args.no_live,
        store=None if args.no_store else (args.store or Path(args.out) / "experience.sqlite"),
    )
    if args.no_store and args.store is not None:
        print("aiocram demo: error: --store and --no-store: give one of them", file=sys.stderr)
        return EXIT_USAGE
    try:
        config.check()
    except DemoConfigError as exc:
        print(f"aiocram demo: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    try:
        with frozen_imports(), Interrupts() as interrupts:
            report = run_demo(config, console=console, interrupts=interrupts)
    except DemoConfigError as exc:  # e.g. --out could not be created after all
        print(f"aiocram demo: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:  # Ctrl-C before the plan started (building the worlds)
        print("aiocram demo: interrupted before the robot started", file=sys.stderr)
        return EXIT_INTERRUPTED
    except Exception:  # a bug, not the user's input: say so, with the trace
        traceback.print_exc()
        print(
            f"aiocram demo: internal error (a bug, not your input); the files written so "
            f"far are in {config.out}",
            file=sys.stderr,
        )
        return EXIT_INTERNAL
    _print_report(report, console)
    if report.interrupted:
        return EXIT_INTERRUPTED
    return EXIT_OK if all(report.invariants.values()) else EXIT_VIOLATED
