"""The demo's record carries the run's arm-motion cache counts per world (issue 26: the
campaign reports how often the probes', the imagined runs' and the controller's arm paths
were reused)."""

from __future__ import annotations

from typing import Any

from executive import Pose, current_environment
from robots.pr2 import DESCRIPTION as PR2


def test_the_record_counts_the_belief_worlds_sweeps() -> None:
    from aiocram.demo import DemoConfig, run_demo

    async def probe_a_park_twice(world: Any, config: Any) -> dict[str, Any]:
        model: Any = current_environment().world
        belief = model.belief_world
        # a box beside the robot, in its belief: within the arm's reach, clear of it
        belief.spawn_object("box-9", "breakfast-cereal", Pose((0.45, -0.45, 0.3)))
        carry = PR2.arm("right").state("carry")
        for _ in range(2):  # the same question twice: computed once, then remembered
            assert model.probe_arm_configuration(right=carry).ok
        return {}

    report = run_demo(
        DemoConfig(objects=("bowl",), seed=1, live=False, projection=False),
        plan=probe_a_park_twice,
    )
    cache = report.to_json()["motion_cache"]
    assert cache["belief"]["sweep_misses"] == 1 and cache["belief"]["sweep_hits"] == 1
    assert set(cache["true"]) == {
        "plan_hits",
        "plan_misses",
        "sweep_hits",
        "sweep_misses",
        "planning_fallbacks",
        "graze_repairs",
        "refused",
        "truncated",
    }
