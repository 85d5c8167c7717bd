"""Writing runs: each run's rows in one transaction (all of a run, or none of it).

Rows are inserted as batches (one ``executemany`` per table), after the run: nothing
is written while a plan runs, so the store never slows the control path; its cost is
measured in BENCHMARKS.md (issue 29).
"""

from __future__ import annotations

import time
from collections.abc import Iterable, Mapping
from typing import Any

from sqlalchemy import Engine
from sqlalchemy.exc import DBAPIError

from ._engine import _first_line, shown
from ._errors import StoreError, StoreLockedError
from ._schema import nodes, parameters, retries, run_objects, runs

__all__ = ["write_runs"]

Rows = Mapping[str, list[dict[str, Any]]]
_ORDER = (runs, run_objects, retries, nodes, parameters)


def write_runs(engine: Engine, batches: Iterable[Rows]) -> float:
    """Insert each run's rows (as :func:`aiocram.experience.run_rows` makes them), one
    transaction per run; returns the seconds spent. A failure raises :class:`StoreError`
    naming the store; the runs written before it stay."""
    t0 = time.perf_counter()
    for rows in batches:
        try:
            with engine.begin() as conn:
                for table in _ORDER:
                    batch = rows.get(table.name) or []
                    if batch:
                        conn.execute(table.insert(), batch)
        except DBAPIError as exc:
            where = shown(engine.url)
            if "locked" in _first_line(exc):
                raise StoreLockedError(
                    f"{where} stayed locked by another process; this run's rows were not "
                    "written (the run itself is in its other outputs)"
                ) from None
            raise StoreError(f"cannot write to {where}: {_first_line(exc)}") from None
    return time.perf_counter() - t0
