"""Designator-aware task-tree queries: which actions a (sub)tree performed, and with
which designators (CRAM's ``task-tree-prolog.lisp``, as plain functions over live
:class:`cpl.Task` objects).

:func:`executive.perform` puts the action designator on the task it runs
(``task.annotations["designator"]``); a task *performs* ``action_type`` when that
designator is an action of that type. The task's own name is the plan's (``fetch``,
``go-without-collisions``), so queries go by the designator, not the name.

Under a retention policy that retires finished top-level actions (``cpl.KeepRecent``,
``cpl.StreamFinished``) they see the tasks kept whole; a retired action's record keeps
its designator as a short string (``cpl.retired(root)``), and a plan that needs the
designator itself (``next_solution()``) keeps it in its own variable.
"""

from __future__ import annotations

from collections.abc import Collection
from typing import TypeVar

import cpl
from cpl._queries import previous_sibling, walk

from ._designator import ActionDesignator, Designator

__all__ = ["action_of", "newest_effective", "performed", "previous_performed"]

D = TypeVar("D", bound=Designator)

StateFilter = cpl.Status | Collection[cpl.Status] | None


def action_of(task: cpl.Task) -> ActionDesignator | None:
    """The action designator ``task`` performed (its ``"designator"`` annotation), or
    ``None`` for tasks that are not performed actions."""
    annotations = task.annotations
    if not annotations:
        return None
    desig = annotations.get("designator")
    return desig if isinstance(desig, ActionDesignator) else None


def _state_ok(task: cpl.Task, state: StateFilter) -> bool:
    if state is None:
        return True
    if isinstance(state, cpl.Status):
        return task.state is state
    return task.state in state


def performed(
    root: cpl.Task, action_type: str, *, state: StateFilter = cpl.Status.SUCCEEDED
) -> list[tuple[cpl.Task, ActionDesignator]]:
    """``(task, designator)`` for every task of ``root``'s subtree (``root`` included)
    that performed an action of ``action_type`` and is in ``state`` (a status, a
    collection of them, or ``None`` for any), in tree order (parents first, children in
    creation order)."""
    out: list[tuple[cpl.Task, ActionDesignator]] = []
    for task in walk(root):
        desig = action_of(task)
        if desig is not None and desig.type == action_type and _state_ok(task, state):
            out.append((task, desig))
    return out


def previous_performed(
    task: cpl.Task, action_type: str, *, state: StateFilter = None
) -> tuple[cpl.Task, ActionDesignator] | None:
    """The nearest earlier sibling of ``task`` that performed ``action_type`` (in
    ``state``; default any), with its designator: e.g. the ``navigating`` before a
    ``picking-up``. ``None`` if there is none."""

    def pred(t: cpl.Task) -> bool:
        desig = action_of(t)
        return desig is not None and desig.type == action_type and _state_ok(t, state)

    found = previous_sibling(task, pred=pred)
    if found is None:
        return None
    desig = action_of(found)
    assert desig is not None
    return found, desig


def newest_effective(desig: D | None) -> D | None:
    """The newest member of ``desig``'s chain that has been referenced (the sample that
    passed the checks), or ``None`` (also for ``None``)."""
    if desig is None:
        return None
    newest = desig.newest_effective()
    return newest if isinstance(newest, type(desig)) else None
