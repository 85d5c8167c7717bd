"""Testing plans: the run checker and hang guards (from :mod:`cpl.testing`), task-tree
assertions and fake robots.

The pytest fixtures built on these live in :mod:`aiocram.testing.pytest_plugin`
(registered as a ``pytest11`` entry point). Importing this package imports ``cpl`` only;
:class:`FakeRobot` (needs ``executive``) is loaded on first access.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from cpl.testing import (
    HangDetected,
    MockClock,
    TransitionChecker,
    call_guarded,
    run_app_guarded,
    run_guarded,
)

from ._tree import as_tree, assert_attempts, assert_retried, find_nodes

if TYPE_CHECKING:
    from ._fakes import FakeRobot

__all__ = [
    "FakeRobot",
    "HangDetected",
    "MockClock",
    "TransitionChecker",
    "as_tree",
    "assert_attempts",
    "assert_retried",
    "call_guarded",
    "find_nodes",
    "run_app_guarded",
    "run_guarded",
]


def __getattr__(name: str) -> Any:
    if name == "FakeRobot":
        from ._fakes import FakeRobot

        return FakeRobot
    raise AttributeError(f"module 'aiocram.testing' has no attribute {name!r}")
