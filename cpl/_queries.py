"""Queries over the live task tree (CRAM's task-tree Prolog predicates, as plain functions).

They read :class:`~cpl.Task` objects as they are now (a running tree may grow while you
walk it; a walk sees the children that exist when it reaches a node). Children are
visited in creation order, so "before" and "after" mean "created before/after" (CRAM's
sibling order). Nothing here changes a task.

Under a retention policy (``cpl.KeepRecent``, ``cpl.StreamFinished``) they see the tasks
the run keeps whole: the top level's retired children are in :func:`cpl.retired` and in
snapshots, not among the live tasks.
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Iterator

from ._status import Status
from ._task import Task

__all__ = ["ancestors", "find_tasks", "previous_sibling", "walk"]

TaskPredicate = Callable[[Task], bool]


def walk(task: Task) -> Iterator[Task]:
    """``task`` and every task below it, depth first, parents before children, children
    in creation order."""
    stack = [task]
    while stack:
        node = stack.pop()
        yield node
        stack.extend(reversed(node.children))


def ancestors(task: Task) -> Iterator[Task]:
    """The parent of ``task``, its parent, ... up to the top level (``task`` excluded)."""
    node = task.parent
    while node is not None:
        yield node
        node = node.parent


def _matches(
    task: Task,
    name: str | None,
    kind: str | None,
    state: Status | Collection[Status] | None,
    pred: TaskPredicate | None,
) -> bool:
    if name is not None and task.name != name:
        return False
    if kind is not None and task.kind != kind:
        return False
    if state is not None:
        if isinstance(state, Status):
            if task.state is not state:
                return False
        elif task.state not in state:
            return False
    return pred is None or pred(task)


def find_tasks(
    root: Task,
    *,
    name: str | None = None,
    kind: str | None = None,
    state: Status | Collection[Status] | None = None,
    pred: TaskPredicate | None = None,
) -> list[Task]:
    """The tasks of ``root``'s subtree (``root`` included) that match every given
    criterion, in :func:`walk` order: ``name`` (the task name, not the ``name#n`` path
    entry), ``kind``, ``state`` (a :class:`~cpl.Status` or a collection of them) and
    ``pred`` (any test on the task)."""
    return [t for t in walk(root) if _matches(t, name, kind, state, pred)]


def previous_sibling(
    task: Task,
    *,
    name: str | None = None,
    kind: str | None = None,
    state: Status | Collection[Status] | None = None,
    pred: TaskPredicate | None = None,
) -> Task | None:
    """The nearest sibling created before ``task`` that matches the criteria (as in
    :func:`find_tasks`), scanning backwards; ``None`` if there is none or ``task`` has no
    parent. CRAM's projection reasoning uses it to find the ``navigating`` before a
    ``picking-up``."""
    parent = task.parent
    if parent is None:
        return None
    siblings = parent.children
    try:
        index = next(i for i, t in enumerate(siblings) if t is task)
    except StopIteration:
        return None
    for sibling in reversed(siblings[:index]):
        if _matches(sibling, name, kind, state, pred):
            return sibling
    return None
