"""aiocram's pytest plugin for plan writers (registered through the ``pytest11`` entry
point; without the installed package, enable it with ``-p aiocram.testing.pytest_plugin``
or ``pytest_plugins = ["aiocram.testing.pytest_plugin"]``).

Fixtures:

- ``cpl_checker``: a :class:`cpl.testing.TransitionChecker`; at teardown it fails the
  test if a task it saw is still alive or a status transition was illegal.
- ``cpl_run``: ``cpl_run(plan, *args, name="test")`` runs a plan as a top level on a fresh
  ``MockClock`` loop with the checker, in a worker thread with a deadline (a hang fails
  the test with the task tree instead of freezing pytest); returns the plan's value or
  raises its failure, then checks the run.
- ``cpl_top_level``: for ``pytest-asyncio`` tests: ``await cpl_top_level(plan, *args)``
  runs the plan as a top level on the test's own running loop, with the checker.
- ``fake_robot``: a :class:`~aiocram.testing.FakeRobot`: scripted fake process modules
  (``fail_on={n: failure}``) over an in-memory world.
- ``projection_world`` / ``projected_robot`` (need the ``projection`` package, imported only
  when used): a fresh PyBullet world per test, and its six process modules:
  ``await projected_robot.run(plan)``.
- ``robot_description``: the robot the projection fixtures load, the PR2-like robot by
  default; parametrize it (``@pytest.mark.parametrize("robot_description",
  [robots.by_name("panda")])``) or define a fixture of that name to run a test on another.

The cpl fixtures import only ``cpl``: a plan library without ``executive`` or
``projection`` can use them.
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable, Iterator
from typing import TYPE_CHECKING, Any

import pytest

import cpl
from cpl.testing import HangDetected, MockClock, TransitionChecker, run_guarded

if TYPE_CHECKING:
    from ._fakes import FakeRobot
    from ._projection import ProjectedRobot

__all__ = [
    "cpl_checker",
    "cpl_run",
    "cpl_top_level",
    "fake_robot",
    "projected_robot",
    "projection_world",
    "robot_description",
]


#: Wall seconds a ``cpl_run`` scenario may take by default (tests take milliseconds to
#: seconds; this only bounds a hang). The ``cpl_deadline`` ini option overrides it.
DEFAULT_DEADLINE = 60.0


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addini(
        "cpl_deadline",
        "wall seconds a cpl_run scenario may take before it counts as hung "
        f"(default {DEFAULT_DEADLINE})",
        default=str(DEFAULT_DEADLINE),
    )


@pytest.fixture
def cpl_checker() -> Iterator[TransitionChecker]:
    """A run checker. The test fails on a task left alive or an illegal status transition
    in any run it observed: checked when the test function returns (while an async test's
    loop still holds its tasks) and again at teardown (runs left by fixtures)."""
    checker = TransitionChecker()
    yield checker
    if not getattr(checker, "_failed_call", False):
        checker.assert_clean()


@pytest.hookimpl(wrapper=True)
def pytest_runtest_call(item: pytest.Item) -> Iterator[None]:
    result = yield  # the test function's exception, if any, propagates from here
    checker = getattr(item, "funcargs", {}).get("cpl_checker")
    if isinstance(checker, TransitionChecker) and checker.problems():
        checker._failed_call = True  # type: ignore[attr-defined]
        checker.assert_clean()
    return result


@pytest.fixture
def cpl_run(cpl_checker: TransitionChecker, request: pytest.FixtureRequest) -> Any:
    """``cpl_run(plan, *args, name="test", clock=None, deadline=None, instruments=(),
    **top_level_kwargs)``: run ``plan(*args)`` as a checked top level on a fresh loop
    (default clock: a new ``MockClock``), in a worker thread with a wall-clock deadline
    (``cpl.testing.run_guarded``); ``top_level_kwargs``: ``history``, ``timeout``,
    ``cleanup_timeout``."""
    default_deadline = float(request.config.getini("cpl_deadline"))

    def go(
        fn: Callable[..., Awaitable[Any]] | Awaitable[Any],
        *args: Any,
        name: str | None = "test",
        clock: cpl.Clock | None = None,
        deadline: float | None = None,
        instruments: Any = (),
        **top_level_kwargs: Any,
    ) -> Any:
        try:
            return run_guarded(
                fn,
                *args,
                name=name,
                clock=clock if clock is not None else MockClock(),
                instruments=[cpl_checker, *instruments],
                wall_timeout=deadline if deadline is not None else default_deadline,
                **top_level_kwargs,
            )
        except HangDetected:
            cpl_checker.forget_alive()  # the hang (with its tree) is the report
            raise
        finally:
            cpl_checker.assert_clean()

    return go


@pytest.fixture
def cpl_top_level(cpl_checker: TransitionChecker) -> Any:
    """``await cpl_top_level(plan, *args, name=None, **kw)`` in an async (pytest-asyncio)
    test: ``cpl.top_level`` on the test's loop with the checker, checked when it returns.

    Not hang-proof (a stuck shutdown of pytest-asyncio's runner cannot be interrupted);
    use ``cpl_run`` where a hang is a plausible failure.
    """

    async def go(fn: Any, *args: Any, instruments: Any = (), **kw: Any) -> Any:
        try:
            return await cpl.top_level(fn, *args, instruments=[cpl_checker, *instruments], **kw)
        finally:
            cpl_checker.assert_clean()

    return go


@pytest.fixture
def fake_robot() -> FakeRobot:
    """Scripted fake process modules over an in-memory world (needs ``executive``)."""
    from ._fakes import FakeRobot

    return FakeRobot()


@pytest.fixture
def robot_description() -> Any:
    """The :class:`executive.RobotDescription` the projection fixtures load: the PR2-like
    robot (``robots.by_name("pr2")``). Parametrize it, or define a fixture of this name,
    to test plans on another robot."""
    import robots

    return robots.by_name("pr2")


@pytest.fixture
def projection_world(robot_description: Any) -> Iterator[Any]:
    """A fresh ``projection.World(seed=0, robot=robot_description)`` (PyBullet, DIRECT),
    closed after the test."""
    from projection import World

    with World(seed=0, robot=robot_description) as world:
        yield world


@pytest.fixture
def projected_robot(projection_world: Any) -> ProjectedRobot:
    """The projected robot on this test's world: ``await projected_robot.run(plan)`` runs
    ``plan()`` with the six projection process modules (``with_projected_robot``)."""
    from ._projection import ProjectedRobot

    return ProjectedRobot(projection_world)
