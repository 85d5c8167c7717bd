"""Testing plans: the run checker, hang guards, task-tree assertions and fake robots.

The pytest fixtures built on these live in :mod:`aiocram.testing.pytest_plugin`
(registered as a ``pytest11`` entry point). Importing this package imports ``cpl`` only;
:class:`FakeRobot` (needs ``executive``) is loaded on first access.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from ._checker import TransitionChecker
from ._guard import DEFAULT_DEADLINE, Hung, call_with_deadline, run_guarded
from ._tree import as_tree, assert_attempts, assert_retried, find_nodes

if TYPE_CHECKING:
    from ._fakes import FakeRobot

__all__ = [
    "DEFAULT_DEADLINE",
    "FakeRobot",
    "Hung",
    "TransitionChecker",
    "as_tree",
    "assert_attempts",
    "assert_retried",
    "call_with_deadline",
    "find_nodes",
    "run_guarded",
]


def __getattr__(name: str) -> Any:
    if name == "FakeRobot":
        from ._fakes import FakeRobot

        return FakeRobot
    raise AttributeError(f"module 'aiocram.testing' has no attribute {name!r}")
