"""Task statuses and the legal transitions between them."""

from __future__ import annotations

import enum

__all__ = ["ALIVE", "DEAD", "LEGAL_TRANSITIONS", "Status"]


class Status(enum.Enum):
    """Where a task is in its life.

    ``CREATED`` -> ``RUNNING`` | ``EVAPORATED``; ``RUNNING`` -> ``SUSPENDED`` | ``SUCCEEDED``
    | ``FAILED`` | ``EVAPORATED``; ``SUSPENDED`` -> ``RUNNING`` | ``EVAPORATED`` |
    ``FAILED``. Dead statuses (``SUCCEEDED``, ``FAILED``, ``EVAPORATED``) are terminal.
    """

    # Members are singletons compared by identity, so an identity hash is consistent with
    # equality; it is a C-level hash, unlike Enum's default (hash of the name), and status
    # sets are checked on every transition of every task.
    __hash__ = object.__hash__

    CREATED = "created"
    RUNNING = "running"
    SUSPENDED = "suspended"
    SUCCEEDED = "succeeded"
    FAILED = "failed"
    EVAPORATED = "evaporated"

    @property
    def alive(self) -> bool:
        return self in ALIVE

    @property
    def dead(self) -> bool:
        return self in DEAD

    def __repr__(self) -> str:
        return f"Status.{self.name}"


ALIVE = frozenset({Status.CREATED, Status.RUNNING, Status.SUSPENDED})
DEAD = frozenset({Status.SUCCEEDED, Status.FAILED, Status.EVAPORATED})

LEGAL_TRANSITIONS: dict[Status, frozenset[Status]] = {
    Status.CREATED: frozenset({Status.RUNNING, Status.EVAPORATED}),
    Status.RUNNING: frozenset(
        {Status.SUSPENDED, Status.SUCCEEDED, Status.FAILED, Status.EVAPORATED}
    ),
    Status.SUSPENDED: frozenset({Status.RUNNING, Status.EVAPORATED, Status.FAILED}),
    Status.SUCCEEDED: frozenset(),
    Status.FAILED: frozenset(),
    Status.EVAPORATED: frozenset(),
}
