"""``ProjectionImagination``: how a real robot imagines, on its PyBullet belief world.

A real robot's environment carries one (``executive.Environment(imagination=...)``), so
that ``plans.with_projected_task_tree`` can run its plans in projection before running
them for real (CRAM's ``cram_pr2_projection_reasoning``).
"""

from __future__ import annotations

from contextlib import AbstractAsyncContextManager

import executive
from projection._environment import with_projected_robot
from projection._world import Snapshot, World

__all__ = ["ProjectionImagination"]


class ProjectionImagination:
    """:class:`executive.Imagination` over ``belief_world``: ``snapshot``/``restore`` are
    the world's own (robot, kitchen joints, objects, attachments; not its random
    generator, so samples drawn in imagination are not drawn again), ``projection()`` is
    :func:`projection.with_projected_robot` on the belief world (an environment marked
    ``projecting``). Not a World: TypeError."""

    __slots__ = ("belief_world", "preferences")

    def __init__(
        self, belief_world: World, preferences: executive.Preferences | None = None
    ) -> None:
        if not isinstance(belief_world, World):
            raise TypeError(f"ProjectionImagination needs a projection.World, got {belief_world!r}")
        self.belief_world = belief_world
        # the real environment's preferences: imagination tries choices in the same order
        self.preferences = preferences

    def snapshot(self) -> Snapshot:
        """Save the belief world (``World.snapshot``)."""
        return self.belief_world.snapshot()

    def restore(self, snapshot: Snapshot) -> None:
        """Put the belief world back exactly (``World.restore``; a snapshot of another
        world: ValueError)."""
        self.belief_world.restore(snapshot)

    def projection(self) -> AbstractAsyncContextManager[executive.Environment]:
        """Enter a projection environment over the belief world (projection process
        modules, costmap rules, ``projecting=True``). Leaving it evaporates any goal still
        running; the world is not restored here (the caller restores its snapshot)."""
        return with_projected_robot(
            self.belief_world, name="imagination", preferences=self.preferences
        )

    def __repr__(self) -> str:
        return f"<ProjectionImagination {self.belief_world!r}>"
