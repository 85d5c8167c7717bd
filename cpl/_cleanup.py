"""Failures raised by cleanup code of evaporated tasks.

When a task is evaporated (a sibling branch of ``par`` failed, ``pursue`` finished, a
monitor fired), its ``finally`` blocks run. If one of them raises, the task ends FAILED
with that failure, but nobody awaits it any more: the form that evaporated it has its own
outcome to report, so the failure would be seen only in the recorded tree. These helpers
make it visible: :func:`cleanup_failures` finds such tasks, and every top-level run logs
each one on the ``cpl.cleanup`` logger (ERROR, with its traceback) when it ends.
"""

from __future__ import annotations

import logging
from typing import Any

from ._status import Status

__all__ = ["cleanup_failures", "log_cleanup_failures"]

log = logging.getLogger("cpl.cleanup")


def cleanup_failures(root: Any) -> list[Any]:
    """The tasks under ``root`` (included) that were evaporated and whose cleanup raised:
    status FAILED, an evaporation request recorded, and a failure. Pre-order."""
    found: list[Any] = []
    stack = [root]
    while stack:
        task = stack.pop()
        if (
            task.state is Status.FAILED
            and task.evaporation is not None
            and task.failure is not None
        ):
            found.append(task)
        stack.extend(reversed(task.children))
    return found


def log_cleanup_failures(root: Any) -> int:
    """Log each of :func:`cleanup_failures` on ``cpl.cleanup``; returns how many."""
    failures = cleanup_failures(root)
    for task in failures:
        exc: BaseException = task.failure
        log.error(
            "the cleanup of evaporated task %s raised %s: %s (it was evaporated because: "
            "%s; the failure does not propagate, the form that evaporated it reports its "
            "own outcome)",
            "/".join(task.path),
            type(exc).__name__,
            exc,
            task.evaporation,
            exc_info=(type(exc), exc, exc.__traceback__),
        )
    return len(failures)
