"""Fluents over a task's life (CRAM's ``task-alive`` and ``task-dead``), usable in nets::

await cpl.wait_for(cpl.fl_or(cpl.task_dead(grasping), too_close))
"""

from __future__ import annotations

from typing import Any

from ._fluents import fl_funcall
from ._status import Status
from ._task import Task

__all__ = ["task_alive", "task_dead", "task_failed", "task_succeeded"]

_DEAD = frozenset({Status.SUCCEEDED, Status.FAILED, Status.EVAPORATED})


def _is_dead(status: Status) -> bool:
    return status in _DEAD


def _is_alive(status: Status) -> bool:
    return status not in _DEAD


def _is_failed(status: Status) -> bool:
    return status is Status.FAILED


def _is_succeeded(status: Status) -> bool:
    return status is Status.SUCCEEDED


def _check(task: Any, what: str) -> Task:
    if not isinstance(task, Task):
        raise TypeError(f"cpl.{what} takes a cpl.Task, got {type(task).__name__}")
    return task


def task_alive(task: Task) -> Any:
    """A boolean fluent: true while ``task`` is CREATED, RUNNING or SUSPENDED."""
    return fl_funcall(_is_alive, _check(task, "task_alive").status)


def task_dead(task: Task) -> Any:
    """A boolean fluent: true once ``task`` SUCCEEDED, FAILED or was EVAPORATED."""
    return fl_funcall(_is_dead, _check(task, "task_dead").status)


def task_failed(task: Task) -> Any:
    """A boolean fluent: true once ``task`` FAILED."""
    return fl_funcall(_is_failed, _check(task, "task_failed").status)


def task_succeeded(task: Task) -> Any:
    """A boolean fluent: true once ``task`` SUCCEEDED."""
    return fl_funcall(_is_succeeded, _check(task, "task_succeeded").status)
