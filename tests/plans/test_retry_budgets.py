"""Each retry budget has one name (issue 24): the plans' scopes read it, and every table of
retry counts in the plans' docstrings says the same number (one of them had drifted: the
package's table said 30 pick checks where ``fetch`` probes 60)."""

from __future__ import annotations

import importlib
import re

import pytest

from plans import checks, deliver, fetch

#: The plan modules whose docstrings hold a table of retry counts.
_MODULES = ("atomic", "navigation", "search", "fetch", "deliver", "environment_access", "transport")


def _rows(action: str) -> list[tuple[str, str]]:
    """(module, retries cell) of every docstring table row of ``action`` in plans."""
    rows = []
    for name in ("plans", *(f"plans.{m}" for m in _MODULES)):
        module = importlib.import_module(name)
        for line in (module.__doc__ or "").splitlines():
            if line.startswith(action + " "):
                rows.append((name, re.split(r"\s{2,}", line.strip())[1]))
    return rows


@pytest.mark.parametrize(
    ("action", "module", "cell"),
    [
        (
            "fetching",
            "plans.fetch",
            f"{fetch.FETCH_RELOCATIONS} relocations, {fetch.FETCH_REGRASPS} regrasp, "
            f"{checks.PICK_CHECKS} pick checks",
        ),
        (
            "delivering",
            "plans.deliver",
            f"outer {deliver.DELIVER_TARGETS} targets, {deliver.DELIVER_RELOCATIONS} "
            f"relocations, {deliver.PLACE_TARGETS} targets",
        ),
    ],
)
def test_every_table_says_the_budgets_the_plans_use(action: str, module: str, cell: str) -> None:
    rows = _rows(action)
    assert {"plans", module} <= {m for m, _ in rows}, rows
    assert all(retries == cell for _, retries in rows), (cell, rows)


def test_the_budgets_are_what_the_scopes_grant() -> None:
    """The defaults the checks take are the named budgets (not a second literal)."""
    import inspect

    default = inspect.signature(checks.check_picking_up_collisions).parameters["retries"]
    assert default.default == checks.PICK_CHECKS
