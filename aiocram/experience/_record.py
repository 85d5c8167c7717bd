"""The demo's hook: :func:`record_run` writes one finished demo run into the store."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from sqlalchemy.engine import URL

from ._engine import STORE_FILE, shown
from ._extract import run_rows
from ._store import Store

__all__ = ["check_store", "default_store", "record_run"]


def default_store(out: str | os.PathLike[str]) -> Path:
    """The store a demo or campaign with ``--out OUT`` writes by default."""
    return Path(out) / STORE_FILE


def check_store(store: str | os.PathLike[str] | URL) -> str:
    """Open ``store`` for writing (made and migrated if new) and close it: the check a
    command runs before its run starts; a :class:`StoreError` names what to fix. Returns
    the store as messages show it."""
    with Store(store, create=True) as s:
        return shown(s.url)


def record_run(
    store: str | os.PathLike[str] | URL, report: Any, *, robot: str, faults: str | None = None
) -> float:
    """Write the demo run of ``report`` (an :class:`aiocram.demo.DemoReport`, after the
    run) into ``store``; returns the seconds spent reading the tree and writing."""
    import time

    t0 = time.perf_counter()
    record = report.to_json()
    record["wall_time_s"] = report.wall_time_s
    rows = run_rows(record, report.root, robot=robot, source="demo", faults=faults)
    with Store(store, create=True) as s:
        s.record(rows)
    return time.perf_counter() - t0
