"""The projected robot fixture's helper (imports ``projection``: only loaded when a test
asks for ``projected_robot``)."""

from __future__ import annotations

from collections.abc import Awaitable, Callable
from typing import Any

from projection import World, with_projected_robot

__all__ = ["ProjectedRobot"]


class ProjectedRobot:
    """A projection world and the block that activates its six process modules."""

    def __init__(self, world: World) -> None:
        self.world = world

    async def run(self, plan: Callable[..., Awaitable[Any]], *args: Any, **kw: Any) -> Any:
        """Run ``plan(*args)`` inside ``with_projected_robot(world, **kw)`` (call it inside
        a cpl run, e.g. ``cpl_run(projected_robot.run, plan)``)."""
        async with with_projected_robot(self.world, **kw):
            return await plan(*args)
