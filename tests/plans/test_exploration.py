"""Imagined runs that explore (each its own region / arm / target), the choice by
predicted success then cost, and the fidelity record of the real run (issue 14)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from test_reasoning import (  # type: ignore[import-not-found]
    RUN_NAMES,
    child,
    nav_pose_before,
    run_real,
    setup,
    transporting,
)

import cpl
from aiocram.fidelity import fidelity_of, measure_fidelity
from executive import DesignatorError, Pose, a, perform, performed
from plans._exploration import learned_weight
from plans.reasoning import (
    Exploration,
    ProjectedParameters,
    RunAssessment,
    assess_run,
    partition_by_bearing,
    pick_by_prediction,
    why,
)


# ------------------------------------------------------------------------ exploration
def test_imagined_runs_explore_different_regions_and_arms():
    _world, real, _dream, imagination = setup()
    root, result = run_real(real, imagination, lambda: perform(transporting()))
    assert result is not None
    runs = [child(root, n) for n in RUN_NAMES]
    explored = [r.annotations["assessment"].explored for r in runs]
    assert [e["arm"] for e in explored] == ["any", "left", "right"]
    assert len({e["pick base"] for e in explored}) == 3
    # the pick base poses the runs drove to are three different poses, one per region
    bases = [nav_pose_before(r, "fetching", "picking-up") for r in runs]
    assert len({p.position for p in bases}) == 3
    # the picking-up used the explored arm where the run fixed one
    for run, arm in zip(runs[1:], ("left", "right")):
        picks = [d for _t, d in performed(run, "picking-up")]
        assert picks and picks[-1].get("arm") == arm


def test_a_region_is_tried_first_then_the_plans_own_solutions():
    """The real run's relocations start in the chosen region and, once it is used up, go
    on with the plan's own designator (the region's poses not repeated)."""
    _world, real, _dream, imagination = setup()

    async def regions() -> list[list[Pose]]:
        pools: dict[str, Any] = {}
        out = []
        for run in (1, 2, 3):
            own = a.location(spots=12)
            region = Exploration(run, 3, pools).region("spots", own, around=(1.0, 1.1))
            out.append([p for p in region.solutions()])
        return out

    _root, (first, second, third) = run_real(real, imagination, regions)
    spots = [Pose((1.0, 0.2 * k, 0.8)) for k in range(12)]
    for got in (first, second, third):
        head = got[:4]
        assert len(got) == 12 and sorted(p.position for p in got) == sorted(
            p.position for p in spots
        )
        assert all(any(p == q for q in spots) for p in head)
    assert len({tuple(p.position for p in r[:4]) for r in (first, second, third)}) == 3


def test_learned_weights_hand_the_likeliest_region_to_the_first_run():
    """With a weight (learned priors), run 1 imagines the region whose poses weigh most;
    without, the regions go out by bearing. Fails if the weight is ignored."""
    _world, real, _dream, imagination = setup()

    def first_regions(weight: Any) -> list[list[Pose]]:
        async def regions() -> list[list[Pose]]:
            pools: dict[str, Any] = {}
            out = []
            for run in (1, 2, 3):
                own = a.location(spots=12)
                exploration = Exploration(run, 3, pools)
                region = exploration.region("spots", own, around=(1.0, 1.1), weight=weight)
                out.append(list(region.solutions())[:4])
            return out

        return run_real(real, imagination, regions)[1]

    plain = first_regions(None)
    # the weight favours the region the bearing order hands out last (near its mean y)...
    centre = sum(q.position[1] for q in plain[2]) / 4
    weighted = first_regions(lambda p: -abs(p.position[1] - centre))
    assert [q.position for q in weighted[0]] == [q.position for q in plain[2]]
    # ...and every region is still imagined by exactly one run
    assert sorted(tuple(q.position for q in r) for r in weighted) == sorted(
        tuple(q.position for q in r) for r in plain
    )


def test_learned_weight_reads_the_environments_preferences():
    import executive

    class Ahead:
        def order_choices(self, action: str, obj: str, choices: Any) -> list[Any]:
            return list(choices)

        def base_density(self, action: str, obj: str) -> Any:
            if obj != "cup":
                return None
            # the base 0.6 m in front of the object (its -x), facing it
            return lambda x, y, yaw: np.exp(-((x + 0.6) ** 2 + y**2) / 0.02 - yaw**2)

    target = Pose((1.0, 1.0, 0.9))
    got: dict[str, Any] = {}

    async def main() -> None:
        got["none"] = learned_weight("picking-up", "cup", target)
        env = executive.Environment(preferences=Ahead())
        async with executive.environment(env):
            got["cup"] = learned_weight("picking-up", "cup", target)
            got["bowl"] = learned_weight("picking-up", "bowl", target)

    cpl.run(main)
    assert got["none"] is None and got["bowl"] is None
    weight = got["cup"]
    in_front = Pose((0.4, 1.0, 0.0))  # yaw 0: facing the object
    behind = Pose((1.6, 1.0, 0.0))
    assert weight(in_front) == pytest.approx(1.0) and weight(behind) < 1e-6


def test_then_must_be_a_location_designator():
    _world, real, _dream, imagination = setup()

    async def bad() -> Any:
        with pytest.raises(DesignatorError, match=r"\(then \.\.\.\) takes a location"):
            list(a.location(among=(Pose((1.0, 0.0, 0.0)),), then="the sink").solutions())

    run_real(real, imagination, bad)


@given(
    st.lists(
        st.tuples(st.floats(-3, 3), st.floats(-3, 3)).filter(lambda p: math.hypot(*p) > 0.1),
        max_size=20,
    ),
    st.integers(1, 5),
)
def test_partition_by_bearing_splits_every_pose_into_contiguous_regions(points, parts):
    poses = [Pose((x, y, 0.0)) for x, y in points]
    regions = partition_by_bearing(poses, (0.0, 0.0), parts)
    assert len(regions) == parts
    flat = [p for r in regions for p in r]
    assert sorted(map(id, flat)) == sorted(map(id, poses))
    sizes = [len(r) for r in regions]
    assert max(sizes) - min(sizes) <= 1


def test_partition_needs_a_part():
    with pytest.raises(ValueError, match="at least one part"):
        partition_by_bearing([], (0.0, 0.0), 0)


# ------------------------------------------------------------------------- prediction
def _assessment(name: str, route_x: float, **kw: Any) -> RunAssessment:
    before = {"cup-1": Pose((1.0, 0.0, 0.9)), "bowl-1": Pose((1.2, 0.0, 0.9))}
    after = dict(kw.pop("after", before))
    params = ProjectedParameters()
    outcome, retries = kw.pop("outcome", "succeeded"), kw.pop("retries", 0)
    a = assess_run(name, outcome, params, None, before, after, "cup-1", retries)
    route = (Pose((0.0, 0.0, 0.0)), Pose((route_x, 0.0, 0.0)))
    return RunAssessment(
        a.name,
        a.failure,
        a.knocked,
        a.unstable,
        a.retries,
        route,
        route_x + a.retries,
        params,
        {},
    )


def test_a_predicted_knock_off_loses_to_a_clean_longer_run():
    knocked = {"cup-1": Pose((2.0, 0.0, 0.9)), "bowl-1": Pose((1.2, 0.3, 0.0))}
    short = _assessment("projection-run-1", 1.0, after=knocked)
    long = _assessment("projection-run-2", 5.0)
    assert short.knocked == ("bowl-1",) and not short.clean and long.clean
    assert pick_by_prediction([short, long]) is long
    assert "projection-run-1 knocks bowl-1" in why(long, [short, long])


def test_a_predicted_unstable_placement_loses_to_a_clean_longer_run():
    s = math.sin(0.5)
    toppled = {
        "cup-1": Pose((2.0, 0.0, 0.9), (s, 0.0, 0.0, math.cos(0.5))),
        "bowl-1": Pose((1.2, 0.0, 0.9)),
    }
    short = _assessment("projection-run-1", 1.0, after=toppled)
    long = _assessment("projection-run-2", 5.0)
    assert short.unstable and not short.knocked
    assert pick_by_prediction([short, long]) is long


def test_many_retries_lose_and_failures_never_win():
    retried = _assessment("projection-run-1", 1.0, retries=5)
    failed = _assessment("projection-run-2", 0.5, outcome="ObjectUnfetchable")
    clean = _assessment("projection-run-3", 4.0)
    assert pick_by_prediction([retried, failed, clean]) is clean
    assert pick_by_prediction([failed]) is None
    # among clean runs the cheaper route (retries priced in) wins
    a, b = _assessment("a", 2.0, retries=1), _assessment("b", 2.5)
    assert pick_by_prediction([a, b]) is b


def test_the_verdict_says_the_retries_once_and_in_the_singular_for_one():
    many = _assessment("projection-run-1", 1.0, retries=15)
    one = _assessment("projection-run-2", 1.0, retries=1)
    none = _assessment("projection-run-3", 1.0)
    assert many.verdict() == "15 retries, cost 16.00"
    assert one.verdict() == "clean, cost 2.00, 1 retry"
    assert none.verdict() == "clean, cost 1.00, 0 retries"


# --------------------------------------------------------------------------- fidelity
def test_fidelity_records_a_real_run_that_disagrees_with_its_prediction():
    """Scripted: the imagined runs succeed; the real robot's arm fails on every motion
    (object-unfetchable). The record says: predicted succeeded, real ObjectUnfetchable."""
    from conftest import make_robot

    from executive import ManipulationLowLevelFailure, ObjectUnfetchable

    world, _real, _dream, imagination = setup()
    real = make_robot(world, arms={n: ManipulationLowLevelFailure for n in range(1, 10_000)})
    box: list[cpl.Task] = []

    async def body() -> Any:
        me = cpl.current_task()
        assert me is not None
        box.append(me)
        return await perform(transporting())

    with pytest.raises(ObjectUnfetchable):
        run_real(real, imagination, body)
    real_run = child(box[0], "real-run")
    assert real_run.state is cpl.Status.FAILED
    fid = fidelity_of(real_run)
    assert fid is not None
    assert fid.predicted == "succeeded" and fid.real == "ObjectUnfetchable"
    assert not fid.agrees
    assert fid.to_json()["agrees"] is False
    # it never placed: no place base pose to compare
    assert fid.place_base_m is None


def test_measure_fidelity_on_a_finished_task_tree():
    """measure_fidelity reads the real run's own tree: here it failed -> disagreement."""
    _world, real, _dream, imagination = setup()
    root, _ = run_real(real, imagination, lambda: perform(transporting()))
    real_run = child(root, "real-run")
    fid = fidelity_of(real_run)
    assert fid is not None
    assert fid.chosen == real_run.annotations["chosen"]
    assert fid.predicted == "succeeded" and fid.real == "succeeded" and fid.agrees
    assert fid.pick_base_m == pytest.approx(0.0) and fid.place_base_m == pytest.approx(0.0)
    chosen = next(
        r.annotations["assessment"]
        for r in (child(root, n) for n in RUN_NAMES)
        if r.name == fid.chosen
    )
    disagreeing = measure_fidelity(chosen, real_run, None, ValueError("boom"))
    assert disagreeing.real == "ValueError" and not disagreeing.agrees
    # a real run stopped by Ctrl-C (its task cancelled) was interrupted, not a failure
    stopped = measure_fidelity(chosen, real_run, None, cpl.Evaporated("interrupted by Ctrl-C"))
    assert stopped.real == "interrupted" and not stopped.agrees


def test_the_demo_and_campaign_read_the_fidelity_from_the_tree():
    """aiocram.foresight: the per-transport rows and the campaign's fidelity aggregate,
    on one transport that agrees and one whose real robot failed."""
    from conftest import make_robot

    from aiocram.foresight import fidelity_lines, fidelity_summary, foresight_records
    from executive import ManipulationLowLevelFailure, ObjectUnfetchable

    _world, real, _dream, imagination = setup()
    root, _ = run_real(real, imagination, lambda: perform(transporting()))
    (good,) = foresight_records(root)
    assert good["object"] == "cup" and len(good["imagined"]) == 3
    assert good["chosen"] in RUN_NAMES and good["fidelity"]["agrees"] is True

    world, _real, _dream, imagination = setup()
    failing = make_robot(world, arms={n: ManipulationLowLevelFailure for n in range(1, 10_000)})
    box: list[cpl.Task] = []

    async def body() -> Any:
        me = cpl.current_task()
        assert me is not None
        box.append(me)
        return await perform(transporting())

    with pytest.raises(ObjectUnfetchable):
        run_real(failing, imagination, body)
    (bad,) = foresight_records(box[0])
    assert bad["fidelity"]["real"] == "ObjectUnfetchable" and not bad["fidelity"]["agrees"]
    summary = fidelity_summary([{"foresight": [good]}, {"foresight": [bad]}])
    assert summary["transports"] == 2 and summary["agreed"] == 1
    assert summary["fidelity"] == pytest.approx(0.5)
    (line,) = fidelity_lines([{"fault_rate": 0.1, "fidelity": summary}])
    assert "1/2 = 50.0 % predicted" in line
    assert fidelity_lines([{"fault_rate": 0.0, "fidelity": fidelity_summary([])}]) == []


# ------------------------------------------------------ fidelity against the true base
def _short_real_robot(world: Any, short: float) -> tuple[Any, list[Pose]]:
    """A real robot whose navigation *believes* it reached every goal (the belief robot is
    set to the goal) while the true base stops ``short`` m before it along x; returns the
    robot and a one-element list holding the true base pose."""
    from conftest import make_robot

    from executive.testing import FakeProcessModule

    robot = make_robot(world)
    true_base = [world.robot_pose()]

    def drive(m: Any) -> None:
        goal = m.reference().arguments["pose"]
        world.set_robot_pose(goal)  # the belief: arrived
        x, y, z = goal.position
        true_base[0] = Pose((x - short, y, z), goal.orientation, goal.frame)

    robot.pms["navigation"] = FakeProcessModule("navigation", accepts="going", result=drive)
    return robot, true_base


def _run_witnessed(robot: Any, imagination: Any, true_base: list[Pose]) -> cpl.Task:
    """One transport in the real environment with a witness of the true base
    (:func:`aiocram.fidelity.watch_bases`, as the demo's truth observer does)."""
    from aiocram.fidelity import watch_bases
    from executive import current_environment

    box: list[cpl.Task] = []

    async def body() -> Any:
        me = cpl.current_task()
        assert me is not None
        box.append(me)
        unwatch = watch_bases(current_environment(), lambda: true_base[0])
        try:
            return await perform(transporting())
        finally:
            unwatch()

    run_real(robot, imagination, body)
    return box[0]


def test_fidelity_compares_the_true_base_with_the_imagined_one():
    """Scripted disagreement: the real base stops 0.25 m short of every goal while the
    belief says it arrived (so the commanded goals agree, 0 m); the fidelity record
    measures the true base 0.25 m from where the imagined robot stood, at pick and place;
    the foresight rows and the campaign aggregate carry it."""
    from aiocram.fidelity import TRUE_BASES
    from aiocram.foresight import fidelity_lines, fidelity_summary, foresight_records

    world, _real, _dream, imagination = setup()
    robot, true_base = _short_real_robot(world, 0.25)
    root = _run_witnessed(robot, imagination, true_base)
    real_run = child(root, "real-run")
    fid = fidelity_of(real_run)
    assert fid is not None
    assert fid.agrees  # the outcome was predicted ...
    assert fid.pick_base_m == pytest.approx(0.0)  # ... and the commanded goals agree,
    assert fid.true_pick_base_m == pytest.approx(0.25, abs=1e-6)  # the true base does not
    assert fid.true_place_base_m == pytest.approx(0.25, abs=1e-6)
    assert fid.true_pick_base_deg == pytest.approx(0.0, abs=1e-6)
    # the imagined bases are the chosen run's own, where its robot stood at pick / place
    chosen = child(root, fid.chosen).annotations["assessment"]
    imagined_pick = nav_pose_before(child(root, fid.chosen), "fetching", "picking-up")
    assert chosen.bases["pick"].position == pytest.approx(imagined_pick.position)
    true_pick = real_run.annotations[TRUE_BASES]["pick"]
    assert true_pick.position[0] == pytest.approx(imagined_pick.position[0] - 0.25)
    (row,) = foresight_records(root)
    assert row["true_bases"]["pick"][0] == pytest.approx(true_pick.position[0], abs=1e-3)
    assert all(set(r["bases"]) == {"pick", "place"} for r in row["imagined"])
    summary = fidelity_summary([{"foresight": [row]}])
    assert summary["true_pick_n"] == 1
    assert summary["mean_true_pick_base_m"] == pytest.approx(0.25, abs=1e-6)
    (line,) = fidelity_lines([{"fault_rate": 0.0, "fidelity": summary}])
    assert "true base vs imagined: pick 0.25 m" in line


def test_fidelity_of_a_true_base_that_arrived():
    """The same witness on a robot that really arrives: 0 m at pick and place; without a
    witness there is no true-base figure at all (never the belief's)."""
    world, _real, _dream, imagination = setup()
    robot, true_base = _short_real_robot(world, 0.0)
    fid = fidelity_of(child(_run_witnessed(robot, imagination, true_base), "real-run"))
    assert fid is not None
    assert fid.true_pick_base_m == pytest.approx(0.0) and fid.true_place_base_m == pytest.approx(
        0.0
    )
    _world, real, _dream, imagination = setup()
    root, _ = run_real(real, imagination, lambda: perform(transporting()))
    unwitnessed = fidelity_of(child(root, "real-run"))
    assert unwitnessed is not None
    assert unwitnessed.true_pick_base_m is None and unwitnessed.true_place_base_m is None


# ----------------------------------------------------------------- the floor-plan picture
def test_the_floor_plan_shows_the_imagined_bases_the_chosen_run_and_the_true_route():
    """The figure's content, not its pixels: every imagined run's pick and place base is
    plotted where the imagined robot stood (read from the tree's assessments), the chosen
    run is ringed, the true bases and the true route (recorded by RouteRecorder from the
    true world: 0.25 m short of every goal) are where the truth had them."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    import executive
    from aiocram._floorplan import RouteRecorder, draw_floor_plan
    from aiocram.fidelity import TRUE_BASES, watch_bases
    from aiocram.foresight import foresight_records
    from cpl.testing import MockClock
    from executive import current_environment

    world, _real, _dream, imagination = setup()
    robot, true_base = _short_real_robot(world, 0.25)

    class TrueWorld:
        def robot_pose(self) -> Pose:
            return true_base[0]

    recorder = RouteRecorder(TrueWorld())
    box: list[cpl.Task] = []

    async def main() -> Any:
        env = executive.Environment(
            "real",
            process_modules=robot.pms.values(),
            world=robot.world,
            rules=robot.rules,
            imagination=imagination,
        )
        async with executive.environment(env):
            box.append(cpl.current_task())  # type: ignore[arg-type]
            unwatch = watch_bases(current_environment(), lambda: true_base[0])
            try:
                return await perform(transporting())
            finally:
                unwatch()

    cpl.run(main, clock=MockClock(), instruments=[recorder])
    root = box[0]
    (row,) = foresight_records(root)
    fig, ax = plt.subplots()
    try:
        draw_floor_plan(ax, [((0.0, 0.0, 0.0), (1.0, 1.0, 1.0))], recorder.route, [row])
        plotted = {
            c.get_gid(): [tuple(p) for p in np.asarray(c.get_offsets())]
            for c in ax.collections
            if c.get_gid()
        }
        (line,) = [ln for ln in ax.lines if ln.get_gid() == "route"]
        drawn_route = list(zip(np.asarray(line.get_xdata()), np.asarray(line.get_ydata())))
    finally:
        plt.close(fig)
    for name in RUN_NAMES:
        bases = child(root, name).annotations["assessment"].bases
        for kind in ("pick", "place"):
            (point,) = plotted[f"imagined-1-{name}-{kind}"]
            assert point == pytest.approx(bases[kind].position[:2], abs=1e-3)
    chosen = child(root, row["chosen"]).annotations["assessment"].bases
    true = child(root, "real-run").annotations[TRUE_BASES]
    for kind in ("pick", "place"):
        assert plotted[f"chosen-1-{kind}"][0] == pytest.approx(chosen[kind].position[:2], abs=1e-3)
        assert plotted[f"true-1-{kind}"][0] == pytest.approx(true[kind].position[:2], abs=1e-3)
        # the true base stood 0.25 m short (in x) of the chosen imagined base
        assert plotted[f"true-1-{kind}"][0][0] == pytest.approx(
            plotted[f"chosen-1-{kind}"][0][0] - 0.25, abs=1e-3
        )
    # the route: the true base at the start and after each real navigation, in order
    assert drawn_route == [(x, y) for x, y, _yaw in recorder.route]
    assert len(drawn_route) >= 3
    for kind in ("pick", "place"):
        assert any(p == pytest.approx(true[kind].position[:2]) for p in drawn_route)
    # nothing imagined is on the route: the recorder skips imagined navigations
    imagined_only = {
        tuple(round(v, 3) for v in b.position[:2])
        for name in RUN_NAMES
        for b in child(root, name).annotations["assessment"].bases.values()
    }
    assert not imagined_only & {tuple(round(v, 3) for v in p) for p in drawn_route}
