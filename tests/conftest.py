"""Shared test helpers: run a plan on a mock clock with a transition checker."""

from __future__ import annotations

from typing import Any

import pytest

import cpl
from cpl._status import LEGAL_TRANSITIONS
from cpl.testing import MockClock


class TransitionChecker(cpl.Instrument):
    """Records every status change of a run and flags illegal ones."""

    def __init__(self) -> None:
        self.transitions: list[tuple[tuple[str, ...], cpl.Status, cpl.Status]] = []
        self.illegal: list[tuple[tuple[str, ...], cpl.Status, cpl.Status]] = []
        self.tasks: list[cpl.Task] = []

    def task_spawned(self, task: cpl.Task) -> None:
        self.tasks.append(task)

    def run_started(self, root: cpl.Task) -> None:
        self.tasks.append(root)

    def task_status_changed(self, task: cpl.Task, old: cpl.Status, new: cpl.Status) -> None:
        rec = (task.path, old, new)
        self.transitions.append(rec)
        if new not in LEGAL_TRANSITIONS[old]:
            self.illegal.append(rec)

    def alive(self) -> list[cpl.Task]:
        return [t for t in self.tasks if t.alive]


@pytest.fixture
def checker() -> TransitionChecker:
    return TransitionChecker()


@pytest.fixture
def mrun(checker: TransitionChecker) -> Any:
    """``mrun(fn, *args, name=...)``: cpl.run on a MockClock; afterwards asserts that no
    task is alive and every transition was legal."""

    def go(fn: Any, *args: Any, name: str | None = "test", **kw: Any) -> Any:
        try:
            return cpl.run(fn, *args, name=name, clock=MockClock(), instruments=[checker], **kw)
        finally:
            assert checker.illegal == [], checker.illegal
            assert checker.alive() == [], checker.alive()

    return go
