"""aiocram's pytest plugin, run as a user would, with ``pytester``.

In-process runs (``runpytest``) for the synchronous fixtures (they are hang-guarded
themselves); subprocess runs with a time-out (``runpytest_subprocess(timeout=...)``) for
tests on pytest-asyncio's or anyio's runner, which nothing inside a process can interrupt.
"""

from __future__ import annotations

import importlib
import os
import sys
import tomllib
from pathlib import Path

import pytest

import executive
import projection

# Loaded here, before any in-process pytester run: such a run restores sys.modules
# afterwards, and numpy / pybullet cannot be imported twice in one process.
_PRELOAD = (executive.Pose, projection.World, projection.with_projected_robot)

ROOT = Path(__file__).resolve().parents[2]
PLUGIN = "aiocram.testing.pytest_plugin"
# The plugin is named explicitly so that these runs work from a source checkout too; the
# entry point's name is the module's name, so with the package installed this is a no-op.
P = ("-p", PLUGIN)
SUBPROCESS_TIMEOUT = 120.0


INI = "[pytest]\nasyncio_default_fixture_loop_scope = function\n"


@pytest.fixture(autouse=True)
def user_ini(pytester: pytest.Pytester) -> None:
    """A user's project configuration (pytest-asyncio wants its loop scope set)."""
    pytester.makeini(INI)


@pytest.fixture
def sub_env(monkeypatch: pytest.MonkeyPatch) -> None:
    """Subprocess runs import this checkout (not another installed copy)."""
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join([str(ROOT), *sys.path]))


def test_the_plugin_is_registered_as_a_pytest11_entry_point() -> None:
    meta = tomllib.loads((ROOT / "pyproject.toml").read_text())
    eps = meta["project"]["entry-points"]["pytest11"]
    assert eps == {PLUGIN: PLUGIN}
    module = importlib.import_module(eps[PLUGIN])
    for name in (
        "cpl_run",
        "cpl_checker",
        "cpl_top_level",
        "fake_robot",
        "projected_robot",
        "robot_description",
    ):
        assert hasattr(module, name)


def test_cpl_fixtures_do_not_import_projection(pytester: pytest.Pytester, sub_env: None) -> None:
    pytester.makepyfile(
        """
        import sys
        import cpl

        def test_plan(cpl_run):
            async def plan():
                await cpl.sleep(5)
                return "ok"
            assert cpl_run(plan) == "ok"
            assert "projection" not in sys.modules and "pybullet" not in sys.modules
        """
    )
    result = pytester.runpytest_subprocess(*P, timeout=SUBPROCESS_TIMEOUT)
    result.assert_outcomes(passed=1)


def test_a_users_plan_test_with_retries_passes(pytester: pytest.Pytester) -> None:
    pytester.makepyfile((ROOT / "tests" / "aiocram" / "test_readme_example.py").read_text())
    result = pytester.runpytest(*P)
    result.assert_outcomes(passed=1)


def test_assert_retried_failure_shows_the_tree(pytester: pytest.Pytester) -> None:
    pytester.makepyfile(
        """
        import cpl
        from aiocram.testing import assert_retried
        from executive import NavigationPoseUnreachable, Pose, a, perform

        async def go():
            going = a.motion(type="going", pose=Pose((1.0, 0.5, 0.0)))
            await cpl.with_retry(lambda: perform(going), on=NavigationPoseUnreachable, counter=3)

        def test_claims_two_retries(cpl_run, fake_robot):
            fake_robot.add("navigation", fail_on={1: NavigationPoseUnreachable})
            cpl_run(fake_robot.run, go, name="go")
            assert_retried("go", "navigation", times=2)
        """
    )
    result = pytester.runpytest(*P)
    result.assert_outcomes(failed=1)
    out = result.stdout.str()
    assert (
        "expected the calls of 'navigation' to end ['FAILED', 'FAILED', 'SUCCEEDED'], "
        "found [['FAILED', 'SUCCEEDED']]"
    ) in out
    assert "`-- + navigation#2" in out  # the tree as it ran


def test_a_task_left_alive_fails_the_test(pytester: pytest.Pytester, sub_env: None) -> None:
    """The checker fails a (pytest-asyncio) test that leaves a plan running."""
    pytester.makepyfile(
        """
        import asyncio
        import cpl
        import pytest

        async def forever():
            await cpl.sleep(1000)

        @pytest.mark.asyncio
        async def test_forgets_its_plan(cpl_checker):
            asyncio.create_task(cpl.top_level(forever, name="forgotten", instruments=[cpl_checker]))
            await asyncio.sleep(0.01)

        @pytest.mark.asyncio
        async def test_awaits_its_plan(cpl_top_level):
            async def short():
                await cpl.sleep(0.01)
                return "done"
            assert await cpl_top_level(short) == "done"
        """
    )
    result = pytester.runpytest_subprocess(*P, "-p", "asyncio", timeout=SUBPROCESS_TIMEOUT)
    result.assert_outcomes(passed=1, failed=1)
    result.stdout.fnmatch_lines(
        [
            "*task left alive: forgotten (RUNNING, sleeping until t=*",
            "FAILED *::test_forgets_its_plan*",
        ]
    )


def test_an_illegal_transition_fails_the_test(pytester: pytest.Pytester) -> None:
    pytester.makepyfile(
        """
        import cpl
        from types import SimpleNamespace

        def test_reports_a_dead_task_coming_back(cpl_checker):
            ghost = SimpleNamespace(path=("top", "ghost"), alive=False)
            cpl_checker.task_status_changed(ghost, cpl.Status.SUCCEEDED, cpl.Status.RUNNING)
        """
    )
    result = pytester.runpytest(*P)
    result.assert_outcomes(failed=1)
    result.stdout.fnmatch_lines(
        ["*illegal status transition SUCCEEDED -> RUNNING of task top/ghost*"]
    )


def test_a_hung_plan_fails_at_its_deadline_with_the_task_tree(
    pytester: pytest.Pytester,
) -> None:
    pytester.makeini(INI + "cpl_deadline = 1.0\n")
    pytester.makepyfile(
        """
        import asyncio
        import cpl

        async def stuck():
            await cpl.par(cpl.tag("waits-forever", asyncio.Event().wait()), cpl.sleep(1))

        def test_hangs(cpl_run):
            cpl_run(stuck, name="stuck")
        """
    )
    result = pytester.runpytest(*P)
    result.assert_outcomes(failed=1)
    result.stdout.fnmatch_lines(
        [
            "*HangDetected: the run of 'stuck' did not end within 1.0 s of wall time*",
            "*waits-forever*",
        ]
    )


def test_anyio_pytest_plugin_on_asyncio_works_and_trio_is_refused(
    pytester: pytest.Pytester, sub_env: None
) -> None:
    pytest.importorskip("trio")
    pytester.makepyfile(
        """
        import cpl
        import pytest

        @pytest.fixture(params=["asyncio", "trio"])
        def anyio_backend(request):
            return request.param

        @pytest.mark.anyio
        async def test_plan(anyio_backend):
            async def plan():
                await cpl.sleep(0.01)
                return "ok"
            assert await cpl.top_level(plan) == "ok"
        """
    )
    result = pytester.runpytest_subprocess(*P, timeout=SUBPROCESS_TIMEOUT)
    result.assert_outcomes(passed=1, failed=1)
    result.stdout.fnmatch_lines(["*RuntimeError: cpl.top_level runs on asyncio only*trio*"])


def test_projected_robot_fixture_moves_the_true_world(pytester: pytest.Pytester) -> None:
    pytester.makepyfile(
        """
        from executive import Pose, a, perform

        GOAL = Pose.from_xyz_yaw(0.5, -0.2, 0.0, 0.4)

        async def drive():
            await perform(a.motion(type="going", pose=GOAL))

        def test_drive(cpl_run, projected_robot, projection_world):
            assert projected_robot.world is projection_world
            assert not projection_world.robot_pose().isclose(GOAL, 1e-6, 1e-6)
            cpl_run(projected_robot.run, drive)
            assert projection_world.robot_pose().isclose(GOAL, 1e-9, 1e-9)

        def test_fresh_world(projection_world):
            assert not projection_world.robot_pose().isclose(GOAL, 1e-6, 1e-6)
        """
    )
    result = pytester.runpytest(*P)
    result.assert_outcomes(passed=2)


def test_the_projection_fixtures_load_the_robot_description_fixture(
    pytester: pytest.Pytester,
) -> None:
    pytester.makepyfile(
        """
        import pytest
        import robots

        def test_default(projection_world):
            assert projection_world.robot is robots.by_name("pr2")

        @pytest.mark.parametrize("robot_description", [robots.by_name("panda")])
        def test_chosen(projection_world, robot_description):
            assert projection_world.robot is robot_description
        """
    )
    result = pytester.runpytest(*P)
    result.assert_outcomes(passed=2)
