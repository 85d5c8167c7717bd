"""Assertions over task trees: what ran, in what order, with which outcome.

They take a live :class:`cpl.Task`, a :class:`cpl.TaskNode` snapshot or the name of a
top level recorded in the run history, and fail with the rendered tree in the message, so
a failing test shows what did happen.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence

import cpl
from cpl.display import render_text

__all__ = ["TreeLike", "as_tree", "assert_attempts", "assert_retried", "find_nodes"]

TreeLike = cpl.Task | cpl.TaskNode | str


def as_tree(tree: TreeLike) -> cpl.TaskNode:
    """A snapshot of ``tree`` (a task, a snapshot, or a named top level's last run)."""
    if isinstance(tree, cpl.TaskNode):
        return tree
    if isinstance(tree, cpl.Task):
        return cpl.snapshot(tree)
    if isinstance(tree, str):
        node = cpl.task_tree(tree)
        if node is None:
            raise LookupError(
                f"no top level named {tree!r} has run; pass name={tree!r} to cpl.run / "
                "cpl_run, or pass the task or snapshot itself"
            )
        return node
    raise TypeError(f"expected a cpl.Task, cpl.TaskNode or top-level name, got {tree!r}")


def _walk(node: cpl.TaskNode) -> Iterator[cpl.TaskNode]:
    stack = [node]
    while stack:
        n = stack.pop()
        yield n
        stack.extend(reversed(n.children))


def _render(node: cpl.TaskNode) -> str:
    return render_text(node, ascii=True, width=120)


def find_nodes(tree: TreeLike, name: str, *, under: str | None = None) -> list[cpl.TaskNode]:
    """Every node called ``name`` (its repeated calls ``name#2``, ``name#3``... included),
    depth first in creation order; with ``under``, only below a node called ``under``."""
    root = as_tree(tree)
    scopes = [n for n in _walk(root) if n.name == under] if under is not None else [root]
    if under is not None and not scopes:
        raise AssertionError(f"no task called {under!r} in the tree:\n{_render(root)}")
    out: list[cpl.TaskNode] = []
    seen: set[int] = set()
    for scope in scopes:
        for n in _walk(scope):
            if n.name == name and id(n) not in seen:
                seen.add(id(n))
                out.append(n)
    return out


def _attempt_groups(root: cpl.TaskNode, name: str) -> list[list[cpl.TaskNode]]:
    """Calls of ``name`` grouped by parent: each group is the sequence of attempts."""
    groups: list[list[cpl.TaskNode]] = []
    for parent in _walk(root):
        calls = [c for c in parent.children if c.name == name]
        if calls:
            groups.append(calls)
    return groups


def _status(outcome: str | cpl.Status) -> cpl.Status:
    if isinstance(outcome, cpl.Status):
        return outcome
    try:
        return cpl.Status[str(outcome).upper()]
    except KeyError:
        names = ", ".join(s.name.lower() for s in cpl.Status)
        raise ValueError(f"unknown task status {outcome!r}; use one of {names}") from None


def assert_attempts(
    tree: TreeLike, name: str, outcomes: Sequence[str | cpl.Status], *, under: str | None = None
) -> list[cpl.TaskNode]:
    """Assert that the calls of ``name`` under one parent ended with ``outcomes``, in order.

    ``outcomes`` are statuses or their names, case-insensitive: ``["failed", "failed",
    "succeeded"]`` says "two failed attempts, then one that succeeded". Returns the
    attempts. Raises ``AssertionError`` with the tree when no parent's calls match.
    """
    want = [_status(o) for o in outcomes]
    root = as_tree(tree)
    scopes = [n for n in _walk(root) if n.name == under] if under is not None else [root]
    if under is not None and not scopes:
        raise AssertionError(f"no task called {under!r} in the tree:\n{_render(root)}")
    seen: list[list[str]] = []
    for scope in scopes:
        for calls in _attempt_groups(scope, name):
            got = [c.status for c in calls]
            if got == want:
                return calls
            seen.append([s.name for s in got])
    wanted = [s.name for s in want]
    where = f" under {under!r}" if under else ""
    raise AssertionError(
        f"expected the calls of {name!r}{where} to end {wanted}, found "
        f"{seen or 'no call at all'}:\n{_render(root)}"
    )


def assert_retried(
    tree: TreeLike,
    name: str,
    times: int,
    *,
    then: str | cpl.Status = "succeeded",
    under: str | None = None,
) -> list[cpl.TaskNode]:
    """Assert that ``name`` failed ``times`` times and was retried, the last attempt ending
    ``then`` ("this retry scope retried twice, then succeeded":
    ``assert_retried(tree, "navigate", 2)``)."""
    if times < 0:
        raise ValueError(f"times is a count of retries (>= 0), got {times!r}")
    return assert_attempts(tree, name, ["failed"] * times + [then], under=under)
