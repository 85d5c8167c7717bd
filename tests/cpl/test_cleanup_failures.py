"""A cleanup that raises in an evaporated branch is logged (cpl.cleanup) and findable
(cpl.cleanup_failures), not only recorded in the tree."""

from __future__ import annotations

import logging

import pytest

import cpl
from cpl.testing import MockClock


class Boom(cpl.PlanFailure):
    pass


async def _slow_with_broken_cleanup() -> None:
    try:
        await cpl.sleep(10)
    finally:
        raise RuntimeError("cleanup broke")


async def _fail_soon() -> None:
    await cpl.sleep(1)
    raise Boom("the other branch failed")


async def _done_soon() -> str:
    await cpl.sleep(1)
    return "done"


def _run(main, caplog):
    box: list[cpl.Task] = []

    class Root(cpl.Instrument):
        def run_started(self, root: cpl.Task) -> None:
            box.append(root)

    with caplog.at_level(logging.ERROR, logger="cpl.cleanup"):
        try:
            result = cpl.run(main, name="main", clock=MockClock(), instruments=[Root()])
        except Boom as failure:
            result = failure
    return result, box[0]


def test_par_branch_cleanup_failure_is_logged(caplog):
    async def main() -> None:
        await cpl.par(cpl.tag("slow", _slow_with_broken_cleanup), cpl.tag("fail", _fail_soon))

    result, root = _run(main, caplog)
    assert isinstance(result, Boom)  # the form's own outcome is unchanged
    broken = cpl.cleanup_failures(root)
    assert [t.path for t in broken] == [("main", "par", "slow")]
    assert isinstance(broken[0].failure, RuntimeError)
    records = [r for r in caplog.records if r.name == "cpl.cleanup"]
    assert len(records) == 1
    assert "main/par/slow" in records[0].getMessage()
    assert "cleanup broke" in records[0].getMessage()
    assert records[0].exc_info is not None  # with its traceback


def test_pursue_branch_cleanup_failure_is_logged(caplog):
    async def main() -> str:
        return await cpl.pursue(
            cpl.tag("done", _done_soon), cpl.tag("slow", _slow_with_broken_cleanup)
        )

    _, root = _run(main, caplog)
    assert [t.path[-1] for t in cpl.cleanup_failures(root)] == ["slow"]
    assert any("cleanup broke" in r.getMessage() for r in caplog.records)


def test_clean_evaporation_logs_nothing(caplog):
    async def quiet() -> None:
        await cpl.sleep(10)

    async def main() -> str:
        return await cpl.pursue(cpl.tag("done", _done_soon), cpl.tag("quiet", quiet))

    _, root = _run(main, caplog)
    assert cpl.cleanup_failures(root) == []
    assert not [r for r in caplog.records if r.name == "cpl.cleanup"]
    with pytest.raises(AssertionError):  # the check can fail: it does on a broken cleanup
        assert (
            cpl.cleanup_failures(
                _run(
                    lambda: cpl.par(
                        cpl.tag("s", _slow_with_broken_cleanup), cpl.tag("f", _fail_soon)
                    ),
                    caplog,
                )[1]
            )
            == []
        )
