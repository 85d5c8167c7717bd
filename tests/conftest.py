"""Shared test setup: pytester, and aiocram's own pytest plugin (the ``pytest11`` entry
point registers it when the package is installed; naming it here keeps the suite working
from a source checkout, and is a no-op otherwise)."""

from __future__ import annotations

from typing import Any

import pytest

from aiocram.testing import TransitionChecker

pytest_plugins = ["pytester", "aiocram.testing.pytest_plugin"]


@pytest.fixture
def checker(cpl_checker: TransitionChecker) -> TransitionChecker:
    """The plugin's ``cpl_checker`` (the name the project's older tests use)."""
    return cpl_checker


@pytest.fixture
def mrun(cpl_run: Any) -> Any:
    """The plugin's ``cpl_run`` (the name the project's older tests use): a checked run on
    a MockClock, in a worker thread with a deadline."""
    return cpl_run
