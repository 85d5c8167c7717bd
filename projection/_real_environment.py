"""``with_real_robot``: a block run by the simulated real robot (its six process
modules on the true world, a :class:`RealWorldModel`, the belief world's location rules
and an imagination over the belief world)."""

from __future__ import annotations

from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from typing import Any

import executive
from projection._real_body import sync_robot
from projection._real_clock import check_clock
from projection._real_faults import FaultProfile
from projection._real_process_modules import real_process_modules
from projection._real_world_model import RealWorldModel
from projection._world import World

__all__ = ["with_real_robot"]

_LOCATION_RULES: Any = object()  # sentinel: "use the belief world's location rules"


@asynccontextmanager
async def with_real_robot(
    true_world: World,
    belief_world: World,
    faults: FaultProfile | None = None,
    speed: float | None = None,
    *,
    rules: executive.RuleSet | None = _LOCATION_RULES,
    name: str = "real",
    preferences: executive.Preferences | None = None,
) -> AsyncIterator[executive.Environment]:
    """Run a block with the simulated real robot (like ``with_projected_robot``)::

        async def main() -> None:
            async with projection.with_real_robot(true, belief, FaultProfile.uniform(0.05)):
                await executive.perform(a.motion(type="going", pose=pose))

        cpl.run(main, clock=projection.real_robot_clock(speed))

    The six real modules act on ``true_world``; the world model is a
    :class:`RealWorldModel`; ``rules`` default to
    ``projection._locations.location_rules(belief_world)`` (``None``:
    :data:`executive.static_rules`). ``faults`` default to :class:`FaultProfile()` (noise
    only). The clock belongs to the loop, so the caller picks it; ``speed`` (None: any)
    only checks that the running loop's clock has that speed (ValueError otherwise; see
    :func:`real_robot_clock`). On entry the belief robot is set to the true one. Leaving
    the block (also on failure or evaporation) stops and evaporates every running motion
    and leaves every module offline. ``preferences`` (learned from experience, carried by
    the environment and its imagination; None: the rules' order). Not Worlds, or the
    same world twice: TypeError / ValueError; a closed World: RuntimeError."""
    model = RealWorldModel(true_world, belief_world)
    true_world.client  # noqa: B018 - raise RuntimeError for a closed world
    belief_world.client  # noqa: B018
    if speed is not None:
        check_clock(speed)
    if rules is _LOCATION_RULES:
        from projection._locations import location_rules

        rules = location_rules(belief_world)
    sync_robot(true_world, belief_world)
    from projection._imagination import ProjectionImagination

    env = executive.Environment(
        name,
        process_modules=real_process_modules(true_world, belief_world, faults),
        world=model,
        rules=rules,
        imagination=ProjectionImagination(belief_world, preferences),
        preferences=preferences,
    )
    async with executive.environment(env):
        yield env
