"""``with_projected_robot``: CRAM's ``pr2-proj:with-simulated-robot``.

The block runs in a new, independent :class:`executive.Environment` named ``projection``
whose world model is a :class:`~projection._world_model.ProjectedWorldModel`, whose
process modules are the six projection modules on the world, and whose rules are the
projection location rules (costmaps); it is marked ``projecting``, so projection
reasoning is a pass-through inside it (as in CRAM). It acts on the given world itself
(CRAM's copy of the world is commented out too). Leaving the block evaporates any goal
still running and leaves every module offline.
"""

from __future__ import annotations

from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from typing import Any

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
    RuntimeError."""
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
    )
    async with executive.environment(env):
        yield env
