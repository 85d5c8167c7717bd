"""The run: :func:`run_demo` runs a table-setting plan as projection-then-execute on the
simulated real robot and measures it from outside.

The robot's *belief* world is where plans and projection reason; a second PyBullet world
is the *true* world the real process modules act on (timed motions, physics, noisy
perception, injected faults). The scene is set up in the true world first, with one call
(:func:`projection.set_up_scene`); the robot's belief starts empty.

The plan (:data:`DemoPlan`; :func:`table_setting` by default) only sets the table and
returns its outcomes. What the app reports is gathered beside it: outcomes as they come
and metres driven per object from the events the plan emits (:class:`_Transports`, an
event subscriber), wall and simulated times and the task tree from cpl instruments, the
truth from :class:`aiocram.truth.TruthObserver`.

:func:`run_demo_once` is the headless variant the robustness campaign runs.
"""

from __future__ import annotations

import contextlib
import math
import sys
import time
from collections.abc import Awaitable, Callable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import cpl
from aiocram.foresight import foresight_records
from aiocram.knocks import KnockWatcher
from aiocram.truth import TruthObserver

from ._config import (
    DEFAULT_OBJECTS,
    DEFAULT_ROBOT,
    DemoConfig,
    DemoConfigError,
    fault_profile,
    learned_priors,
    robot_description,
)
from ._outputs import OUTPUT_FILES, STALE, route_plan_logs, write_pictures
from ._report import DemoReport

if TYPE_CHECKING:  # projection (PyBullet) is imported when a demo runs, not with this module
    from executive import Environment
    from plans.demo import ObjectOutcome
    from projection import World

__all__ = ["DemoPlan", "frozen_imports", "run_demo", "run_demo_once", "table_setting"]

#: A plan the demo runs: called with the true world (set up already) and the
#: configuration, in the simulated real robot's environment; returns ``{type: outcome}``
#: (:class:`plans.demo.ObjectOutcome`). An observer learns the outcomes as they come
#: from the events :func:`plans.demo.table_setting` emits; a plan that emits none is
#: reported with the outcomes it returns.
DemoPlan = Callable[["World", DemoConfig], Awaitable[Mapping[str, "ObjectOutcome"]]]


async def table_setting(world: World, config: DemoConfig) -> Mapping[str, ObjectOutcome]:
    """The demo's plan: :func:`plans.demo.table_setting` on the scene set up already,
    with projection reasoning as ``config`` says."""
    from plans.demo import table_setting as plan

    return await plan(
        config.objects, projection_reasoning=config.projection, projection_runs=config.runs
    )


class _Transports:
    """An event subscriber: the outcome of each object as the plan goes
    (:class:`plans.demo.TransportStarted` / ``TransportEnded``), the metres the base drove
    while it was transported (between consecutive ``RobotStateChanged`` events), and the
    moment the transports are over (``TransportsOver``: ``before_cleanup`` is called)."""

    def __init__(self, before_cleanup: Callable[[], None]) -> None:
        self.outcomes: dict[str, ObjectOutcome] = {}  # by type, in the order first tried
        self.distances: dict[str, float] = {}  # by type: metres driven while transported
        self._before_cleanup = before_cleanup
        self._driven = 0.0  # metres driven in the whole run so far
        self._start = 0.0  # ``_driven`` when the transport going on (if any) started

    def subscribe(self, env: Environment) -> Callable[[], None]:
        from executive.events import RobotStateChanged
        from plans.demo import TransportEnded, TransportsOver, TransportStarted

        world = env.world
        last = [world.robot_pose()]

        def moved(_event: RobotStateChanged) -> None:
            now = world.robot_pose()
            self._driven += now.distance_to(last[0])
            last[0] = now

        def started(event: TransportStarted) -> None:
            otype = event.outcome.type
            self.outcomes.setdefault(otype, event.outcome)
            self.distances.setdefault(otype, 0.0)
            self._start = self._driven

        def ended(event: TransportEnded) -> None:
            self.distances[event.outcome.type] += self._driven - self._start

        undo = [
            env.subscribe(RobotStateChanged, moved),
            env.subscribe(TransportStarted, started),
            env.subscribe(TransportEnded, ended),
            env.subscribe(TransportsOver, lambda _event: self._before_cleanup()),
        ]

        def unsubscribe() -> None:
            for u in undo:
                u()

        return unsubscribe


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
            watch.wall_time(t) for t in _walk(task) if t.subtree is cpl.Subtree.IMAGINED
        )
    return real, imagined


def _walk(task: cpl.Task) -> list[cpl.Task]:
    out, stack = [], [task]
    while stack:
        t = stack.pop()
        out.append(t)
        stack.extend(reversed(t.children))
    return out


def run_demo(
    config: DemoConfig,
    console: Any = None,
    *,
    interrupts: Any = None,
    plan: DemoPlan = table_setting,
) -> DemoReport:
    """Run ``plan`` (the table setting by default) on the demo's scene as configured;
    write its files if ``config.out`` is set.

    Every field is checked first (:meth:`DemoConfig.check`): a bad one raises
    :class:`DemoConfigError` before any file is touched. The files are written to a
    staging directory inside ``out`` and moved into place when the run ends (also when it
    failed or was interrupted), so until then ``out`` keeps the previous run's files.

    ``interrupts``: an :class:`aiocram._interrupt.Interrupts` that owns Ctrl-C (the
    command passes one); the run attaches its root task to it, so a Ctrl-C evaporates
    the plan and the report comes back with ``interrupted=True``.

    ``plan`` (see :data:`DemoPlan`): tests and other apps hand in their own."""
    config.check()
    _check_store(config)  # opens it: a locked, corrupt or newer store stops us here
    if not callable(plan):
        raise TypeError(
            f"run_demo(plan=...) takes an async function (world, config) -> outcomes, "
            f"like aiocram.demo.table_setting; got {plan!r}"
        )
    import plans
    from aiocram._figures import CameraRecorder, CostmapRecorder
    from aiocram._floorplan import RouteRecorder
    from aiocram._outputs import OutputError, Outputs
    from aiocram._views import DemoView, Progress
    from projection import make_world_pair, real_robot_clock, set_up_scene, with_real_robot

    del plans  # imported for its action rules
    faults = fault_profile(config)
    robot = robot_description(config)  # checked by config.check(): a RobotDescription
    preferences = learned_priors(config)  # checked by config.check(): None or usable
    watch = _Watch()
    progress = Progress(config.objects)
    instruments: list[cpl.Instrument] = [watch, progress]
    outputs: Outputs | None = None
    if config.out is not None:
        try:  # the first write: a directory that cannot be made is the user's to fix
            outputs = Outputs(Path(config.out), stale=STALE)
        except OutputError as exc:
            raise DemoConfigError(str(exc)) from None
        if interrupts is not None:
            interrupts.on_abort = lambda: outputs.commit(OUTPUT_FILES)
        instruments.append(cpl.EventLog(outputs.path("log.jsonl")))
    restore_logging = route_plan_logs(None if outputs is None else outputs.path("plans.log"))
    true_world: World | None = None
    belief_world: World | None = None
    outcomes: dict[str, ObjectOutcome] = {}  # by type: gathered, then what the plan returned
    transports: _Transports | None = None  # made with the observer, before the run
    engine_box: list[Any] = []
    observer: TruthObserver | None = None  # made with the worlds, before the run
    knocks: KnockWatcher | None = None  # made with the worlds, before the run (issue 26)

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
        assert observer is not None and transports is not None and knocks is not None
        async with with_real_robot(
            true_world,
            belief_world,
            faults=faults,
            speed=config.speed,
            rules=rules,
            preferences=preferences,
        ) as env:
            observer.subscribe(env)
            knocks.subscribe(env)
            transports.subscribe(env)
            engine_box.append(costmaps_of(current_environment().rules))
            run = plan(true_world, config)
            if config.live:
                async with DemoView(root, progress, console=console, refresh_per_second=4):
                    returned = await run
            else:
                returned = await run
            observer.body_returned()
            outcomes.update(returned)

    t0 = time.perf_counter()
    try:
        true_world, belief_world = make_world_pair(
            config.seed, objects={}, gui=config.gui, robot=robot
        )
        observer = TruthObserver(true_world, belief_world, lambda: watch.tasks)
        knocks = KnockWatcher(true_world)
        instruments.append(knocks)
        transports = _Transports(observer.before_cleanup)
        outcomes = transports.outcomes
        camera = CameraRecorder(true_world)
        costmaps = CostmapRecorder(belief_world)
        route = RouteRecorder(true_world)  # the floor plan's true route (issue 14)
        if outputs is not None:  # they record for the pictures only
            instruments += [camera, costmaps, route]
        set_up_scene(true_world, config.objects, seed=config.seed)
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
        knocked = knocks.report()  # before the truth's settle, which is no robot motion
        truth = observer.measure(
            {o.name: o.success for o in outcomes.values()}, interrupted=interrupted
        )
        real_sim, imagined = _transport_times(root, watch)
        if outputs is not None:
            write_pictures(outputs, true_world, camera, costmaps, engine_box, interrupts)
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
            distances=dict(transports.distances),
            knocks=knocked,
            motion_cache={
                "belief": belief_world.motion_cache_counts(),
                "true": true_world.motion_cache_counts(),
            },
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
    from aiocram.experience import StoreError, record_run, store_url

    assert config.store is not None
    faults = config.faults if isinstance(config.faults, str) else None
    try:
        report.store_s = record_run(config.store, report, robot=report.robot, faults=faults)
    except StoreError as exc:
        print(f"aiocram demo: the run was not recorded: {exc}", file=sys.stderr)
        return
    if store_url(config.store).get_backend_name() == "sqlite":
        # listed as it was given (OUT/experience.sqlite), like the run's other files
        given = str(config.store)
        files.append(Path(given.split("///", 1)[1] if "://" in given else given))


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
    from aiocram import _figures, _outputs, _views  # noqa: F401

    gc.freeze()
    try:
        yield
    finally:
        gc.unfreeze()


def run_demo_once(
    *,
    seed: int,
    fault_rate: float,
    projection: bool = True,
    objects: Sequence[str] = DEFAULT_OBJECTS,
    runs: int = 3,
    experience: bool = False,
    learned: str | None = None,
    robot: str = DEFAULT_ROBOT,
) -> dict[str, Any]:
    """One headless campaign run at a uniform fault rate (seeded by ``seed``); the JSON
    record of :class:`DemoReport`. ``experience=True``: the record also carries the run's
    experience-store rows under ``"experience"`` (:func:`aiocram.experience.run_rows`,
    read from the run's task tree after the run), for the campaign to write. ``learned``:
    a learned-priors file the run orders its choices by (``--learned``). ``robot``: the
    robot's name in the ``robots`` package (``--robots``)."""
    from projection import FaultProfile

    config = DemoConfig(
        objects=tuple(objects),
        seed=seed,
        runs=runs,
        projection=projection,
        faults=FaultProfile.uniform(fault_rate, seed=seed),
        live=False,
        learned=learned,
        robot=robot,
    )
    report = run_demo(config)
    record = report.to_json()
    record["fault_rate"] = fault_rate
    if experience:
        from aiocram.experience import run_rows

        record["experience"] = run_rows(
            {**record, "wall_time_s": report.wall_time_s},
            report.root,
            robot=report.robot,
            source="campaign",
            faults=f"{fault_rate:g}",
        )
    return record
