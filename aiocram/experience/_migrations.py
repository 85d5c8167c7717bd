"""Versioned schema migrations, applied when a store is opened for writing.

Each migration is ``(version, description, apply(connection))``; the table
``experience_schema`` holds one row per applied version. Opening a store applies the
missing ones in order, in one transaction; a store whose highest version is above
:data:`SCHEMA_VERSION` is refused (:class:`StoreVersionError`): an older aiocram never
writes into a newer schema.

Why not alembic: one linear list of small functions is all this store needs, it runs on
SQLite and PostgreSQL alike inside the writer's own transaction, and it spares a
dependency and its environment script. A later schema adds a function here.
"""

from __future__ import annotations

import datetime as _dt
from collections.abc import Callable

from sqlalchemy import Connection, func, inspect, select

from ._errors import StoreCorruptError, StoreVersionError
from ._schema import MIGRATIONS_TABLE, SCHEMA_VERSION, metadata

__all__ = ["MIGRATIONS", "migrate", "stored_version"]


def _v1(conn: Connection) -> None:
    """The first schema: runs, run_objects, retries, nodes, parameters."""
    metadata.create_all(
        conn, tables=[t for t in metadata.sorted_tables if t is not MIGRATIONS_TABLE]
    )


MIGRATIONS: tuple[tuple[int, str, Callable[[Connection], None]], ...] = (
    (1, "runs, objects, retries, task-tree nodes, chosen parameters", _v1),
)
assert MIGRATIONS[-1][0] == SCHEMA_VERSION


def stored_version(conn: Connection, where: str) -> int | None:
    """The store's schema version; ``None`` for an empty database. A database holding
    other tables but no ``experience_schema``: :class:`StoreCorruptError`."""
    names = set(inspect(conn).get_table_names())
    if MIGRATIONS_TABLE.name not in names:
        if names:
            raise StoreCorruptError(
                f"{where} is a database but not an aiocram experience store (it has the "
                f"tables {', '.join(sorted(names)[:5])}, not experience_schema); give "
                "--store a new file or an empty database"
            )
        return None
    version = conn.execute(select(func.max(MIGRATIONS_TABLE.c.version))).scalar()
    return int(version or 0)


def check_version(version: int | None, where: str) -> None:
    if version is not None and version > SCHEMA_VERSION:
        raise StoreVersionError(
            f"{where} has schema version {version}, newer than this aiocram's "
            f"{SCHEMA_VERSION}: it was written by a newer aiocram. Upgrade aiocram, or give "
            "--store another file; nothing was written"
        )


def migrate(conn: Connection, where: str) -> int:
    """Bring the store to :data:`SCHEMA_VERSION` (inside the caller's transaction);
    returns the version found before."""
    version = stored_version(conn, where)
    check_version(version, where)
    if version is None:
        MIGRATIONS_TABLE.create(conn)
        version = 0
    now = _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")
    for number, description, apply in MIGRATIONS:
        if number > version:
            apply(conn)
            conn.execute(
                MIGRATIONS_TABLE.insert(),
                {"version": number, "description": description, "applied_at": now},
            )
    return version
