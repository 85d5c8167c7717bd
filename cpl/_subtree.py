"""What a subtree of the task tree stands for in reasoning: imagined, real or chosen.

A plan that imagines (projection reasoning, ``plans.imagine_best``) runs each imagined
alternative as a subtree and then the winner for real as another; every reader of the
tree (live views, reports, the figures, ``aiocram show`` from an event log) tells them
apart by this typed mark on the subtree's root, never by its name. The names stay free
(``projection-run-2``, ``real-run``, ``chosen-cup-first``) and only label the tree.
"""

from __future__ import annotations

import enum
from typing import Any

__all__ = ["Subtree", "subtree_of", "within"]


class Subtree(enum.Enum):
    """The mark of a reasoning subtree's root task (``cpl.tag(name, aw, subtree=...)``);
    it is carried by the task, its snapshot (:class:`cpl.TaskNode`) and the event log."""

    #: runs only in imagination (a projection over the belief): its failures and moves
    #: are not the robot's
    IMAGINED = "imagined"
    #: the real run of a projected plan, with the parameters of the best imagined run
    REAL = "real"
    #: the real run of the alternative that imagining chose
    CHOSEN = "chosen"

    @classmethod
    def parse(cls, value: Any) -> Subtree | None:
        """The mark stored as ``value`` (its ``.value`` string, a member or ``None``);
        anything else: ValueError naming the accepted values."""
        if value is None or isinstance(value, Subtree):
            return value
        try:
            return cls(value)
        except ValueError:
            accepted = ", ".join(repr(m.value) for m in cls)
            raise ValueError(
                f"a subtree mark is one of {accepted} or None, got {value!r}"
            ) from None


def subtree_of(task: Any) -> Subtree | None:
    """The mark of ``task`` (a live :class:`cpl.Task` or a :class:`cpl.TaskNode`)."""
    mark = getattr(task, "subtree", None)
    return mark if isinstance(mark, Subtree) else None


def within(task: Any, mark: Subtree) -> bool:
    """Whether ``task`` or one of its ancestors is marked ``mark`` (a live task: walks its
    parents; a snapshot node, which has no parent link: only itself, so walk a recorded
    tree from its root and prune the marked subtrees instead)."""
    node = task
    while node is not None:
        if getattr(node, "subtree", None) is mark:
            return True
        node = getattr(node, "parent", None)
    return False
