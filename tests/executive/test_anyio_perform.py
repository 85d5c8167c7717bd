"""anyio cancel scopes around ``perform`` (the executive side of docs/async_interop.md)."""

from __future__ import annotations

from typing import Any

import anyio
import pytest

import cpl
from cpl.testing import MockClock
from executive import Pose, a, perform, with_process_modules
from executive.testing import FakeProcessModule

ISSUE_18 = pytest.mark.xfail(
    reason="issue 18: anyio re-delivers a scope's cancellation on every loop step; cpl's "
    "cleanup waits (here the shielded on_cancel) livelock on MockClock",
    strict=False,
)


@pytest.mark.parametrize("clock", [pytest.param("mock", marks=ISSUE_18), "system"])
def test_move_on_after_around_a_perform_whose_on_cancel_takes_time(
    clock: str, cpl_run: Any
) -> None:
    """Issue 18's second case: the scope fires while a process module's goal runs; the
    module's on_cancel (shielded, 0.3 s) runs once, and the run ends on both clocks."""
    nav = FakeProcessModule("navigation", accepts="going", delay=10.0, cancel_delay=0.3)

    async def main() -> bool:
        async with with_process_modules(nav):
            with anyio.move_on_after(0.05) as scope:
                await perform(a.motion(type="going", pose=Pose((1.0, 0.0, 0.0))))
            return scope.cancelled_caught

    c = MockClock() if clock == "mock" else cpl.SystemClock()
    assert cpl_run(main, clock=c, deadline=8.0) is True
    assert len(nav.calls) == 1 and len(nav.cancelled) == 1 and nav.completed == []
