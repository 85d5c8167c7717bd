"""The run checker: an instrument that records every status change of a run and flags
illegal transitions and tasks left alive."""

from __future__ import annotations

import cpl
from cpl._status import LEGAL_TRANSITIONS

__all__ = ["TransitionChecker"]

Transition = tuple[tuple[str, ...], cpl.Status, cpl.Status]


class TransitionChecker(cpl.Instrument):
    """Records every status change of the runs it observes and flags illegal ones.

    Pass it as an instrument (``cpl.run(plan, instruments=[checker])`` or
    ``cpl.top_level(..., instruments=[checker])``); afterwards :meth:`check` raises
    ``AssertionError`` naming every illegal transition and every task still alive. One
    checker may observe several runs of one test.
    """

    def __init__(self) -> None:
        # Every transition seen, in order: (task path, old, new).
        self.transitions: list[Transition] = []
        # The subset of ``transitions`` not allowed by cpl.Status' life cycle.
        self.illegal: list[Transition] = []
        # Every task of the observed runs (roots included), in creation order.
        self.tasks: list[cpl.Task] = []

    def run_started(self, root: cpl.Task) -> None:
        self.tasks.append(root)

    def task_spawned(self, task: cpl.Task) -> None:
        self.tasks.append(task)

    def task_status_changed(self, task: cpl.Task, old: cpl.Status, new: cpl.Status) -> None:
        rec = (task.path, old, new)
        self.transitions.append(rec)
        if new not in LEGAL_TRANSITIONS[old]:
            self.illegal.append(rec)

    def alive(self) -> list[cpl.Task]:
        """The observed tasks that are not dead now."""
        return [t for t in self.tasks if t.alive]

    def problems(self) -> list[str]:
        """One line per illegal transition and per task left alive (empty when all is well)."""
        out = [
            f"illegal status transition {old.name} -> {new.name} of task {'/'.join(path)}"
            for path, old, new in self.illegal
        ]
        out += [
            f"task left alive: {'/'.join(t.path)} ({t.state.name}"
            + (f", {t.waiting_on}" if t.waiting_on else "")
            + ")"
            for t in self.alive()
        ]
        return out

    def forget_alive(self) -> list[cpl.Task]:
        """Stop tracking the tasks alive now and return them (for a run that hung: the hang
        is the failure, its stuck tasks are not reported a second time)."""
        alive = self.alive()
        self.tasks = [t for t in self.tasks if not t.alive]
        return alive

    def check(self) -> None:
        """Raise ``AssertionError`` if a transition was illegal or a task is still alive."""
        problems = self.problems()
        if problems:
            raise AssertionError("cpl run checker:\n  " + "\n  ".join(problems))
