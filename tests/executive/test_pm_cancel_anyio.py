"""anyio cancel scopes around ``perform`` whose process module cleans up slowly (issue 18):
the module's shielded ``on_cancel`` runs once and the loop stays idle meanwhile."""

from __future__ import annotations

import time
from typing import Any

import anyio
import pytest

import cpl
import executive
from cpl.testing import MockClock, TransitionChecker, run_guarded
from executive import an, perform


class SlowCancel(executive.ProcessModule):
    def __init__(self, events: list[str]) -> None:
        super().__init__("slow-cancel")
        self.events = events

    def accepts(self, motion: Any) -> bool:
        return True

    async def execute(self, motion: Any) -> None:
        await cpl.sleep(100)

    async def on_cancel(self, motion: Any) -> None:
        await cpl.sleep(0.3)
        self.events.append("on_cancel")


@pytest.mark.parametrize("use_mock", [False, True], ids=["system", "mock"])
def test_move_on_after_around_perform_with_slow_on_cancel(use_mock: bool) -> None:
    events: list[str] = []

    async def main() -> str:
        async with executive.with_process_modules(SlowCancel(events)):
            with anyio.move_on_after(0.05) as scope:
                await perform(an.motion(type="moving-torso", joint_angle=0.1))
        return "cancelled" if scope.cancelled_caught else "done"

    checker = TransitionChecker()
    cpu0, wall0 = time.process_time(), time.monotonic()
    result = run_guarded(
        main, clock=MockClock() if use_mock else None, instruments=[checker], wall_timeout=20
    )
    cpu, wall = time.process_time() - cpu0, time.monotonic() - wall0
    checker.assert_clean()
    assert result == "cancelled"
    assert events == ["on_cancel"]
    if not use_mock:
        assert wall >= 0.3
        assert cpu < 0.5 * wall, (cpu, wall)
