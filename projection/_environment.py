"""``with_projected_robot``: CRAM's ``pr2-proj:with-simulated-robot``.

The block runs in a new, independent :class:`executive.Environment` named ``projection``
whose world model is a :class:`~projection._world_model.ProjectedWorldModel`, whose
process modules are the six projection modules on the world, and whose rules are the
projection location rules (costmaps); it is marked ``projecting``, so projection
reasoning is a pass-through inside it (as in CRAM). It acts on the given world itself
(CRAM's copy of the world is commented out too). Leaving the block evaporates any goal
still running and leaves every module offline.

**Projected time.** The block runs on its own :class:`cpl.Timeline` (a nested block
shares the outer one's), which starts at the current time when the block is entered and
moves only when the event loop has nothing else to do, to the next projected deadline:
each motion takes its modelled duration (:mod:`projection._durations`) there, and
``cpl.sleep``, ``cpl.wait_for(timeout=)``, ``cpl.timeout_policy`` and
``cpl.shielded(timeout=)`` inside the block count projected seconds, as they count robot
seconds on the robot. No loop time passes for them: imagining stays as fast as the
computation, even when the loop runs in real time (``--speed 1``). Tasks started inside
the block are stamped in projected time (``start_time``/``end_time``: the time when the
block was entered plus projected seconds), so an imagined task's duration is its
projected duration, not the wall time its computation took; the imagined subtree's
stamps are not robot times and may run past its (robot-timed) parent's end.

Deliberate difference from CRAM: CRAM's projection has had no clock since 2017: motions
are instantaneous, sleeps and time-outs are wall-clock (inert or load-dependent), and
imagined events carry the wall or ROS time of a fast run.
"""

from __future__ import annotations

from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from typing import Any

import cpl
import executive
from projection._process_modules import projection_process_modules
from projection._world import World
from projection._world_model import ProjectedWorldModel

__all__ = ["with_projected_robot"]

_LOCATION_RULES: Any = object()  # sentinel: "use projection's location rules"


@asynccontextmanager
async def with_projected_robot(
    world: World,
    *,
    rules: executive.RuleSet | None = _LOCATION_RULES,
    name: str = "projection",
    preferences: executive.Preferences | None = None,
) -> AsyncIterator[executive.Environment]:
    """Run a block with the projected robot on ``world``::

        async with projection.with_projected_robot(world):
            await executive.perform(a.motion(type="going", pose=pose))

    ``rules`` defaults to ``projection._locations.location_rules(world)``; pass a
    :class:`executive.RuleSet` to use another, or ``None`` for
    :data:`executive.static_rules`. Blocks may nest, also for the same world: the inner
    block's modules, world model and rules win (its environment is independent, so events
    emitted inside reach only its subscribers). ``perform`` needs a running cpl task
    (``cpl.run``/``cpl.top_level``). Not a World: TypeError; a closed World:
    RuntimeError. ``preferences``: the order to try choices in, learned from experience
    (:attr:`executive.Environment.preferences`; None: the rules' own)."""
    if not isinstance(world, World):
        raise TypeError(f"with_projected_robot needs a projection.World, got {world!r}")
    world.client  # noqa: B018 - raises RuntimeError for a closed world
    if rules is _LOCATION_RULES:
        from projection._locations import location_rules

        rules = location_rules(world)
    env = executive.Environment(
        name,
        process_modules=projection_process_modules(world),
        world=ProjectedWorldModel(world),
        rules=rules,
        projecting=True,
        preferences=preferences,
    )
    timeline = cpl.current_timeline()
    if timeline is None:  # a nested block shares the projected time of the outer one
        timeline = cpl.Timeline(start=cpl.current_time(), name=name)
    with cpl.on_timeline(timeline):
        async with executive.environment(env):
            yield env
