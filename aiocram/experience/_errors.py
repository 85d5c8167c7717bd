"""The store's typed errors: each names what to fix, and each is raised before a run
starts or a row is written."""

from __future__ import annotations

__all__ = [
    "StoreCorruptError",
    "StoreError",
    "StoreLockedError",
    "StoreMissingError",
    "StoreUnreachableError",
    "StoreVersionError",
]


class StoreError(ValueError):
    """The experience store cannot be used as given (a bad ``--store`` URL, an unknown
    database kind). Its subclasses say which of the usual reasons it is."""


class StoreMissingError(StoreError):
    """A question was asked of a store that does not exist (queries never create one)."""


class StoreVersionError(StoreError):
    """The store was written by a newer aiocram (its schema version is above ours)."""


class StoreLockedError(StoreError):
    """Another process holds the SQLite file's write lock and did not let go in time."""


class StoreCorruptError(StoreError):
    """The file is not an SQLite database, or a database that is not an experience store."""


class StoreUnreachableError(StoreError):
    """The database server at the URL did not answer (or refused the login)."""
