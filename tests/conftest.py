"""Shared test setup: pytester, aiocram's own pytest plugin (the ``pytest11`` entry point
registers it when the package is installed; naming it here keeps the suite working from a
source checkout, and is a no-op otherwise), and a fresh run history per test."""

from __future__ import annotations

from typing import Any

import pytest

from cpl.testing import TransitionChecker

pytest_plugins = ["pytester", "aiocram.testing.pytest_plugin"]


@pytest.fixture
def checker(cpl_checker: TransitionChecker) -> TransitionChecker:
    """The plugin's ``cpl_checker`` (the name the project's older tests use)."""
    return cpl_checker


@pytest.fixture
def mrun(cpl_run: Any) -> Any:
    """The plugin's ``cpl_run`` (the name the project's older tests use):
    ``mrun(fn, *args, name=...)`` runs on a MockClock in a worker thread with a wall-clock
    deadline (a hang fails with the task tree), then asserts that no task is alive and
    every transition was legal."""
    return cpl_run


@pytest.fixture(autouse=True)
def _fresh_run_history() -> Any:
    """Each test starts and ends with an empty process-wide run history (the one store
    behind ``cpl.task_tree(name)``), so no test reads another test's runs."""
    from cpl._runtime import DEFAULT_HISTORY

    DEFAULT_HISTORY.clear()
    yield
    DEFAULT_HISTORY.clear()
