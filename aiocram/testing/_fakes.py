"""Fake robots for plan tests without a simulator: scripted process modules in an
environment over an in-memory world."""

from __future__ import annotations

from collections.abc import Awaitable, Callable, Mapping
from typing import Any

import executive
from executive.testing import AcceptSpec, FakeProcessModule, InMemoryWorld

__all__ = ["FakeRobot"]


class FakeRobot:
    """Fake process modules (``executive.testing.FakeProcessModule``) in one environment.

    ``robot.add("navigation", accepts="going", fail_on={1: NavigationPoseUnreachable})``
    scripts a module (the first goal fails, the others succeed); ``await robot.run(plan)``
    runs ``plan()`` inside an environment with every module added so far. ``robot[name]``
    gives a module back, with its ``calls``, ``completed`` and ``cancelled`` records.
    """

    def __init__(self, world: InMemoryWorld | None = None) -> None:
        self.world = world if world is not None else InMemoryWorld()
        self.process_modules: dict[str, FakeProcessModule] = {}

    def add(
        self,
        name: str,
        *,
        accepts: AcceptSpec = None,
        fail_on: Mapping[int, BaseException | type[BaseException]] | None = None,
        result: Any = None,
        delay: float = 0.0,
        cancel_delay: float = 0.0,
    ) -> FakeProcessModule:
        """Add a scripted module (see ``FakeProcessModule`` for the arguments)."""
        if name in self.process_modules:
            raise ValueError(f"the fake robot already has a process module named {name!r}")
        pm = FakeProcessModule(
            name,
            accepts=accepts,
            fail_on=fail_on,
            result=result,
            delay=delay,
            cancel_delay=cancel_delay,
        )
        self.process_modules[name] = pm
        return pm

    def __getitem__(self, name: str) -> FakeProcessModule:
        try:
            return self.process_modules[name]
        except KeyError:
            known = ", ".join(self.process_modules) or "none"
            raise KeyError(f"no fake process module {name!r} (added: {known})") from None

    async def run(self, plan: Callable[..., Awaitable[Any]], *args: Any) -> Any:
        """Run ``plan(*args)`` inside an environment with this robot's modules and world
        (call it inside a cpl run)."""
        env = executive.Environment(
            "fake-robot", process_modules=self.process_modules.values(), world=self.world
        )
        async with executive.environment(env):
            return await plan(*args)
