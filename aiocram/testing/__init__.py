"""Testing plans: the run checker and hang guards (from :mod:`cpl.testing`), task-tree
assertions, fake robots, and a check that a picture shows something
(:func:`assert_picture_shows_something`).

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

from ._pictures import (
    PictureStats,
    assert_picture_shows_something,
    picture_problems,
    picture_stats,
)
from ._tree import as_tree, assert_attempts, assert_retried, find_nodes

if TYPE_CHECKING:
    from ._fakes import FakeRobot

__all__ = [
    "FakeRobot",
    "HangDetected",
    "MockClock",
    "PictureStats",
    "TransitionChecker",
    "as_tree",
    "assert_attempts",
    "assert_picture_shows_something",
    "assert_retried",
    "call_guarded",
    "find_nodes",
    "picture_problems",
    "picture_stats",
    "run_app_guarded",
    "run_guarded",
]


def __getattr__(name: str) -> Any:
    if name == "FakeRobot":
        from ._fakes import FakeRobot

        return FakeRobot
    raise AttributeError(f"module 'aiocram.testing' has no attribute {name!r}")
