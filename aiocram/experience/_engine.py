"""Store URLs and opening a database: the checks that run before a run starts.

``--store`` takes a SQLAlchemy URL (``sqlite:///path``, ``postgresql+psycopg://user@host/db``)
or a plain file path (an SQLite file). :func:`open_engine` connects, refuses a store of a
newer schema, a locked or corrupt SQLite file, or a server that does not answer, each with a
typed :class:`StoreError` naming what to fix, and (``create=True``) applies the migrations.
"""

from __future__ import annotations

import os
import sqlite3
from pathlib import Path
from typing import Any

from sqlalchemy import Engine, create_engine, event, text
from sqlalchemy.engine import URL, make_url
from sqlalchemy.exc import ArgumentError, DatabaseError, OperationalError

from ._errors import (
    StoreCorruptError,
    StoreError,
    StoreLockedError,
    StoreMissingError,
    StoreUnreachableError,
)
from ._migrations import check_version, migrate, stored_version

__all__ = ["CONNECT_TIMEOUT_S", "LOCK_TIMEOUT_S", "STORE_FILE", "open_engine", "store_url"]

#: The SQLite file name a demo or campaign writes next to its outputs.
STORE_FILE = "experience.sqlite"
#: Seconds a database server has to answer.
CONNECT_TIMEOUT_S = 5
#: Seconds an SQLite writer waits for another one's lock before it gives up.
LOCK_TIMEOUT_S = 10.0
_DIALECTS = ("sqlite", "postgresql")


def store_url(text: str | os.PathLike[str] | URL) -> URL:
    """The URL of ``--store TEXT``: a URL as it is, a plain path as an SQLite file.
    Anything else: :class:`StoreError` naming the forms that work."""
    if isinstance(text, URL):
        url = text
    elif isinstance(text, os.PathLike) or "://" not in str(text):
        path = Path(os.fspath(text)).expanduser()
        if not str(text).strip():
            raise StoreError("--store: give a file path or a database URL, got nothing")
        return URL.create("sqlite", database=str(path.resolve()))
    else:
        try:
            url = make_url(str(text))
        except ArgumentError as exc:
            raise StoreError(f"--store {text!r}: not a database URL ({exc})") from None
    if url.get_backend_name() not in _DIALECTS:
        raise StoreError(
            f"--store {url.render_as_string(hide_password=True)}: the store runs on SQLite "
            "(a file path, or sqlite:///path) or PostgreSQL "
            "(postgresql+psycopg://user@host/db), not "
            f"{url.get_backend_name()}"
        )
    if url.get_backend_name() == "sqlite" and not url.database:
        raise StoreError("--store sqlite://: give a file (sqlite:///path/experience.sqlite)")
    return url


def shown(url: URL) -> str:
    """The URL as a message shows it (no password)."""
    if url.get_backend_name() == "sqlite":
        return str(url.database)
    return url.render_as_string(hide_password=True)


def _sqlite_pragmas(dbapi_conn: Any, _record: Any) -> None:
    cursor = dbapi_conn.cursor()
    cursor.execute("PRAGMA foreign_keys=ON")
    cursor.close()


def _engine(url: URL) -> Engine:
    if url.get_backend_name() == "sqlite":
        engine = create_engine(url, connect_args={"timeout": LOCK_TIMEOUT_S})
        event.listen(engine, "connect", _sqlite_pragmas)
        return engine
    return create_engine(
        url, connect_args={"connect_timeout": CONNECT_TIMEOUT_S}, pool_pre_ping=True
    )


def open_engine(url: URL, *, create: bool, lock_timeout: float = 2.0) -> Engine:
    """An engine on the store at ``url``, checked: ``create=True`` makes the file or the
    tables if missing and migrates (the writers); ``create=False`` needs an existing store
    (the questions: :class:`StoreMissingError` otherwise) and never writes. Raises a
    :class:`StoreError` subclass for a newer schema, a lock held longer than
    ``lock_timeout`` seconds, a corrupt file or an unreachable server."""
    where = shown(url)
    sqlite = url.get_backend_name() == "sqlite"
    if sqlite:
        path = Path(str(url.database))
        if not create and not path.exists():
            raise StoreMissingError(
                f"no experience store at {where}: run a demo or a campaign first (they "
                "write OUT/experience.sqlite), or give --store FILE_OR_URL"
            )
        if create and path.parent and not path.parent.exists():
            try:
                path.parent.mkdir(parents=True, exist_ok=True)
            except OSError as exc:
                raise StoreError(f"--store {where}: cannot make its directory: {exc}") from None
    engine = _engine(url)
    try:
        with engine.connect() as conn:
            if sqlite:
                # a corrupt file fails here; a locked one times out here (BEGIN IMMEDIATE
                # takes the write lock a writer needs, then gives it back at once)
                conn.exec_driver_sql(f"PRAGMA busy_timeout={int(lock_timeout * 1000)}")
                conn.exec_driver_sql("PRAGMA schema_version").scalar()
                if create:
                    conn.exec_driver_sql("BEGIN IMMEDIATE")
                    conn.exec_driver_sql("ROLLBACK")
            version = stored_version(conn, where)
            check_version(version, where)
            conn.rollback()
        if not create and version is None:
            raise StoreMissingError(f"{where} holds no experience yet (an empty database)")
        if create:
            with engine.begin() as conn:
                migrate(conn, where)
    except StoreError:
        engine.dispose()
        raise
    except OperationalError as exc:
        engine.dispose()
        raise _operational(exc, where, sqlite) from None
    except DatabaseError as exc:
        engine.dispose()
        raise StoreCorruptError(
            f"{where} is not a readable SQLite database ({_first_line(exc)}); move it away "
            "or give --store another file; it was left as it is"
        ) from None
    return engine


def _first_line(exc: BaseException) -> str:
    orig = getattr(exc, "orig", None) or exc
    return (str(orig).strip().splitlines() or [type(orig).__name__])[0][:200]


def _operational(exc: OperationalError, where: str, sqlite: bool) -> StoreError:
    orig = exc.orig
    message = _first_line(exc)
    if sqlite and isinstance(orig, sqlite3.OperationalError):
        if "locked" in message or "busy" in message:
            return StoreLockedError(
                f"{where} is locked by another process (a demo or campaign writing it?); "
                "wait for it to end or give --store another file; nothing was written"
            )
        if "unable to open" in message:
            return StoreError(f"--store {where}: cannot open the file ({message})")
        return StoreCorruptError(f"{where}: {message}; move it away or give another --store")
    return StoreUnreachableError(
        f"--store {where}: the database did not answer within {CONNECT_TIMEOUT_S} s or "
        f"refused the connection ({message}); start the server, check the URL (user, host, "
        "port, database) or use an SQLite file (--store FILE); nothing was written"
    )


def probe(url: URL) -> None:
    """Connect once and run ``SELECT 1`` (the dask workers' check)."""
    engine = _engine(url)
    try:
        with engine.connect() as conn:
            conn.execute(text("SELECT 1"))
    finally:
        engine.dispose()
