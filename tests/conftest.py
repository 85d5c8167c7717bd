"""Shared test helpers: run a plan on a mock clock with a transition checker."""

from __future__ import annotations

from typing import Any

import pytest

from cpl.testing import MockClock, TransitionChecker, run_guarded


@pytest.fixture
def checker() -> TransitionChecker:
    return TransitionChecker()


@pytest.fixture
def mrun(checker: TransitionChecker) -> Any:
    """``mrun(fn, *args, name=...)``: cpl.run on a MockClock, guarded against hangs (a run
    that does not end within 60 s of wall time fails with the task tree); afterwards
    asserts that no task is alive and every transition was legal."""

    def go(fn: Any, *args: Any, name: str | None = "test", **kw: Any) -> Any:
        kw.setdefault("clock", MockClock())
        try:
            return run_guarded(
                fn, *args, name=name, instruments=[checker], wall_timeout=60.0, **kw
            )
        finally:
            assert checker.illegal == [], checker.illegal
            assert checker.alive() == [], checker.alive()

    return go


@pytest.fixture(autouse=True)
def _fresh_run_history() -> Any:
    """Each test starts and ends with an empty process-wide run history (the one store
    behind ``cpl.task_tree(name)``), so no test reads another test's runs."""
    from cpl._runtime import DEFAULT_HISTORY

    DEFAULT_HISTORY.clear()
    yield
    DEFAULT_HISTORY.clear()
