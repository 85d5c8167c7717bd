"""``run_demo(config, plan=...)`` (issue 24): the demo app runs the plan it is handed on
the scene it set up, and gathers the outcomes, the distance driven and the truth from
outside the plan (the events the plan emits, instruments, the truth observer)."""

from __future__ import annotations

from pathlib import Path

import pytest

pytest.importorskip("projection")

from aiocram.demo import DemoConfig, run_demo
from plans.demo import ObjectOutcome


def test_run_demo_runs_the_plan_it_is_given() -> None:
    """A plan handed in is called once with the true world (the scene already set up)
    and the configuration; what the report says comes from that plan's run."""
    from plans.demo import table_setting

    calls: list[tuple[object, DemoConfig, list[str]]] = []

    async def bowl_without_imagining(world, config):
        calls.append((world, config, sorted(world.objects)))
        return await table_setting(config.objects, projection_reasoning=False)

    config = DemoConfig(objects=("bowl",), seed=1, live=False)
    report = run_demo(config, plan=bowl_without_imagining)
    assert len(calls) == 1
    _world, given, objects = calls[0]
    assert given is config
    assert objects == ["bowl-1"]  # the app set the scene up before the plan ran
    assert report.outcomes["bowl"].success
    assert report.delivered == 1 and report.claimed == 1
    # gathered by the app's subscriber, not by the plan: metres driven for the bowl
    assert report.distances["bowl"] > 0.5
    assert report.to_json()["distance_driven"] == pytest.approx(report.distances["bowl"])
    # this plan never imagines (the default plan would, with config.projection on)
    assert report.foresight == []
    assert report.invariants["nothing_attached_before_cleanup"]  # TransportsOver was seen


def test_outcomes_a_plan_only_returns_are_reported_and_checked_against_the_truth() -> None:
    """A plan that emits no events and moves nothing, but claims the bowl placed: the
    report holds its claim, the true world says it was not delivered (a phantom), and
    the moment before the cleanup never came (the invariant fails, it is not assumed)."""

    async def claims_the_bowl(world, config):
        return {"bowl": ObjectOutcome("bowl", "bowl-1", success=True)}

    report = run_demo(
        DemoConfig(objects=("bowl",), seed=1, live=False, projection=False),
        plan=claims_the_bowl,
    )
    assert list(report.outcomes) == ["bowl"]
    assert report.claimed == 1 and report.delivered == 0
    assert report.truth is not None and report.truth.phantoms == 1
    assert report.distances == {}
    assert not report.invariants["nothing_attached_before_cleanup"]


def test_a_plan_that_is_not_callable_is_refused_before_anything_is_written(
    tmp_path: Path,
) -> None:
    out = tmp_path / "out"
    with pytest.raises(TypeError, match=r"run_demo\(plan=...\) takes an async function"):
        run_demo(DemoConfig(objects=("bowl",), out=out, live=False), plan="table_setting")  # type: ignore[arg-type]
    assert not out.exists()
