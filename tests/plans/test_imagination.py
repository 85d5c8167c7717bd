"""The imagination engine (``plans.imagine``) under both front-ends, the typed marks of
its subtrees (``cpl.Subtree``) and the readers that go by them, and the ranking policy
(issue 24), on the fakes of ``test_reasoning``."""

from __future__ import annotations

from contextlib import aclosing
from typing import Any

import pytest
from test_reasoning import (  # type: ignore[import-not-found]
    RUN_NAMES,
    child,
    cpl_walk,
    run_real,
    setup,
    transporting,
    world_state,
)

import cpl
from executive import Pose, current_environment, perform
from plans import ImaginedRun, imagine
from plans._common import CountedRetries, retry_ledger
from plans.imagining import imagine_best
from plans.reasoning import DEFAULT_RANKING, Ranking, with_projected_task_tree


def _mover(x: float, *, fail: bool = False, retries: int = 0) -> Any:
    async def go() -> float:
        world: Any = current_environment().world  # the fakes' InMemoryWorld
        world.set_robot_pose(Pose((x, 0.0, 0.0)))
        counter = CountedRetries(retries, "relocations")
        for _ in range(retries):
            assert counter.do_retry()
        if fail:
            raise cpl.PlanFailure(f"no way to {x}")
        return x

    return go


# --------------------------------------------------------------------------- the engine
def test_the_engine_yields_each_run_in_its_imagined_world_and_restores_the_belief():
    world, real, _dream, imagination = setup()
    seen: list[tuple[str, str, Any, Pose]] = []

    async def body() -> Any:
        alternatives = [
            ("dream-a", _mover(1.0, retries=2)),
            ("dream-b", _mover(2.0, fail=True)),
        ]
        with retry_ledger() as mine:
            async with aclosing(imagine(imagination, alternatives)) as runs:
                async for run in runs:
                    assert isinstance(run, ImaginedRun) and run.task is not None
                    assert run.task.subtree is cpl.Subtree.IMAGINED
                    # the world is as this run left it
                    seen.append((run.name, run.outcome, run.value, run.env.world.robot_pose()))
                    assert run.retries == (2 if run.name == "dream-a" else 0)
        return dict(mine)

    before = world_state(world)
    _root, caller_ledger = run_real(real, imagination, body)
    assert [(n, o, v) for n, o, v, _ in seen] == [
        ("dream-a", "succeeded", 1.0),
        ("dream-b", "PlanFailure", None),
    ]
    assert [p.position[0] for *_, p in seen] == [1.0, 2.0]
    assert caller_ledger == {}  # imagined retries are not the caller's
    assert world_state(world) == before
    assert len(imagination.restored) == 3  # before each run and after the last


def test_stopping_early_restores_the_belief_at_once():
    world, real, _dream, imagination = setup()

    async def body() -> Pose:
        alternatives = [(f"dream-{i}", _mover(float(i))) for i in (1, 2, 3)]
        async with aclosing(imagine(imagination, alternatives)) as runs:
            async for _run in runs:
                break
        return world.robot_pose()  # read before anything else could restore

    before = world_state(world)
    root, pose = run_real(real, imagination, body)
    assert pose == before[1] and world_state(world) == before
    assert [t.name for t in cpl_walk(root) if t.subtree is cpl.Subtree.IMAGINED] == ["dream-1"]


# ------------------------------------------------------------------------ the marks
def test_both_front_ends_mark_their_subtrees_by_kind():
    _world, real, _dream, imagination = setup()

    async def body() -> Any:
        await perform(transporting())
        return await imagine_best({"near": _mover(0.5), "far": _mover(3.0, retries=1)})

    root, chosen = run_real(real, imagination, body)
    assert chosen == 0.5
    marks = {t.name: t.subtree for t in cpl_walk(root) if t.subtree is not None}
    assert marks == {
        **dict.fromkeys(RUN_NAMES, cpl.Subtree.IMAGINED),
        "real-run": cpl.Subtree.REAL,
        "imagine-near": cpl.Subtree.IMAGINED,
        "imagine-far": cpl.Subtree.IMAGINED,
        "chosen-near": cpl.Subtree.CHOSEN,
    }


def test_readers_go_by_the_mark_not_the_name():
    """Rename every reasoning subtree after the run: the foresight rows, the fidelity, the
    live view's notion of 'imagined' and the demo's final tree still find them."""
    from aiocram._views import fold_failures, imagined
    from aiocram.fidelity import fidelity_of
    from aiocram.foresight import foresight_records

    world, real, _dream, imagination = setup()
    world.fail_probe["arm"] = {n: True for n in range(1, 20 * 11 + 1)}  # run 1 fails
    root, _ = run_real(real, imagination, lambda: perform(transporting()))
    for task in cpl_walk(root):
        if task.subtree is cpl.Subtree.IMAGINED:
            task.name = "what-if-" + task.name.rsplit("-", 1)[-1]
        elif task.subtree is cpl.Subtree.REAL:
            task.name = "for-real"
    (row,) = foresight_records(root)
    assert len(row["imagined"]) == 3 and row["fidelity"]["agrees"] is True
    real_run = child(root, "for-real")
    assert fidelity_of(real_run) is not None
    failed_dream = child(root, "what-if-1")
    assert failed_dream.state is cpl.Status.FAILED
    inside = [t for t in cpl_walk(failed_dream) if t.state is cpl.Status.FAILED]
    assert inside and all(imagined(t) for t in inside)
    assert not any(imagined(t) for t in cpl_walk(real_run))
    assert fold_failures(cpl_walk(root)) == []  # the failures were all imagined


# --------------------------------------------------------------------------- ranking
def test_the_ranking_is_a_policy_object_passed_in():
    _world, real, _dream, imagination = setup()
    strict = Ranking(many_retries=0, retry_cost=5.0)

    async def body(ranking: Ranking) -> Any:
        return await with_projected_task_tree(
            lambda _p: _mover(1.0, retries=1)(), runs=2, ranking=ranking
        )

    for ranking in (DEFAULT_RANKING, strict):
        root, _ = run_real(real, imagination, lambda r=ranking: body(r))
        run = child(root, "projection-run-1").annotations["assessment"]
        assert run.ranking is ranking and run.retries == 1
        # one retry is "many" only for the strict ranking
        assert run.verdict().startswith("1 retries" if ranking is strict else "clean")


@pytest.mark.parametrize(
    "bad", [{"many_retries": -1}, {"retry_cost": -0.5}, {"tilt": "steep"}, {"floor_z": None}]
)
def test_a_ranking_with_a_bad_number_is_refused_naming_the_field(bad: dict[str, Any]) -> None:
    (field,) = bad
    with pytest.raises(ValueError, match=f"Ranking.{field}"):
        Ranking(**bad)


# ------------------------------------------------------------------- the transport body
def test_the_macro_draws_each_runs_alternative_and_the_body_only_takes_parameters():
    """What the imagined runs explore is declared to the macro (``FetchAndDeliver``): each
    imagined run's body is handed its own arm, pick base region and placing target; the
    real run's body gets the chosen run's parameters and no exploration at all."""
    from executive import a, an
    from plans.reasoning import FetchAndDeliver, ProjectedParameters

    _world, real, _dream, imagination = setup()
    given: list[tuple[bool, ProjectedParameters]] = []
    target = a.location(spots=5)

    async def main() -> Any:
        found = await perform(
            an.action(type="searching", object=an.object(type="cup"), location=a.location(spots=1))
        )

        async def body(params: ProjectedParameters) -> Any:
            me = cpl.current_task()
            assert me is not None
            given.append((cpl.within(me, cpl.Subtree.IMAGINED), params))
            fetched = await perform(
                an.action(
                    type="fetching",
                    object=found,
                    arm=params.arm,
                    robot_location=params.fetch_robot_location,
                    pick_up_action=params.pick_up_action,
                )
            )
            return await perform(
                an.action(
                    type="delivering",
                    object=fetched,
                    target=params.target if params.target is not None else target,
                    robot_location=params.deliver_robot_location,
                    place_action=params.place_action,
                )
            )

        return await with_projected_task_tree(body, 3, explore=FetchAndDeliver(found, target))

    run_real(real, imagination, main)
    imagined = [p for dreaming, p in given if dreaming]
    (real_params,) = [p for dreaming, p in given if not dreaming]
    assert [p.arm for p in imagined] == [None, "left", "right"]
    assert all(p.fetch_robot_location is not None and p.target is not None for p in imagined)
    assert [p.exploration.run for p in imagined if p.exploration] == [1, 2, 3]
    # the real run: the chosen run's base poses and actions, nothing explored
    assert real_params.exploration is None and real_params.arm is None
    assert real_params.target is None and real_params.fetch_robot_location is not None
    assert real_params.place_action is not None
