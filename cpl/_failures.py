"""Plan failures, composite failures, evaporation, and ``fail``.

CRAM distinguishes *plan failures* (expected trouble a plan may recover from) from
programming errors. We keep that line: every failure a plan can handle derives from
:class:`PlanFailure`; a ``TypeError`` or ``KeyError`` is never turned into a plan
failure and travels unchanged through every form.

Deliberate difference from CRAM: ``plan-failure`` is a ``serious-condition`` but not an
``error`` in Lisp. In Python :class:`PlanFailure` derives from :class:`Exception`, so an
``except Exception`` (or a handler clause naming ``Exception``) does see plan failures.
Evaporation is *not* an exception of that kind: :class:`Evaporated` derives from
:class:`asyncio.CancelledError` (a ``BaseException``), so ``except Exception`` never
swallows it.
"""

from __future__ import annotations

import asyncio
from collections.abc import Mapping, Sequence
from typing import Any, NoReturn

__all__ = ["CompositeFailure", "Evaporated", "PlanFailure", "fail"]


class PlanFailure(Exception):
    """Root of every plan failure.

    ``message`` is a human sentence; ``details`` are free-form keyword fields (the object,
    the location, ...) that handlers and the task tree can read. Subclasses declare typed
    fields of their own and pass them on as details.
    """

    default_message = "Plan failure."

    def __init__(self, message: str | None = None, **details: Any) -> None:
        self.message: str = message if message is not None else self.default_message
        self.details: dict[str, Any] = dict(details)
        super().__init__(self.message)

    def __str__(self) -> str:
        if not self.details:
            return self.message
        fields = ", ".join(f"{k}={_short(v)}" for k, v in self.details.items())
        return f"{self.message} ({fields})"

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.message!r})"


class CompositeFailure(PlanFailure):
    """Raised by ``try_all`` and ``try_in_order`` when every branch failed.

    ``failures`` holds the branches' failures in branch (source) order. Deliberate
    difference from CRAM, whose ``try-all`` lists them in reverse creation order.
    """

    default_message = "All branches failed."

    def __init__(self, failures: Sequence[BaseException], message: str | None = None) -> None:
        self.failures: tuple[BaseException, ...] = tuple(failures)
        text = message or f"All {len(self.failures)} branches failed: " + "; ".join(
            f"{type(f).__name__}: {f}" for f in self.failures
        )
        super().__init__(text)


class Evaporated(asyncio.CancelledError):
    """Raised inside a task that is being evaporated (CRAM's evaporation = cancellation).

    It records who asked and why: ``by`` is the path of the evaporating task (``None``
    when the request came from outside any cpl task, e.g. a timeout around ``run``) and
    ``reason`` the sentence given to :meth:`cpl.Task.evaporate`.

    It derives from :class:`asyncio.CancelledError`, so asyncio's own machinery treats it
    as cancellation and ``except Exception`` never catches it. Do not swallow it: let
    ``finally`` blocks do the cleanup and let it propagate.
    """

    def __init__(self, reason: str = "evaporated", by: tuple[str, ...] | None = None) -> None:
        super().__init__(reason)
        self.reason = reason
        self.by = by

    def __str__(self) -> str:
        who = "/".join(self.by) if self.by else "outside any task"
        return f"evaporated by {who}: {self.reason}"


def fail(failure: PlanFailure | type[PlanFailure] | str | None = None, **details: Any) -> NoReturn:
    """Raise a plan failure (CRAM's ``fail``).

    - ``fail()`` raises ``PlanFailure("Plan failure.")``;
    - ``fail("text", object=cup)`` raises ``PlanFailure("text", object=cup)``;
    - ``fail(SomeFailure, **fields)`` instantiates the class with the fields;
    - ``fail(instance)`` raises that very object (identity is kept).

    A class or instance that is not a :class:`PlanFailure` is rejected with ``TypeError``:
    a plan failure must be something the handlers of a plan can name.
    """
    if failure is None or isinstance(failure, str):
        exc: PlanFailure = PlanFailure(failure, **details)
    elif isinstance(failure, type):
        if not issubclass(failure, PlanFailure):
            raise TypeError(
                f"fail() needs a PlanFailure subclass, got {failure.__name__}; derive your "
                "failure from cpl.PlanFailure or raise it directly"
            )
        exc = failure(**details)
    elif isinstance(failure, PlanFailure):
        if details:
            failure.details.update(details)
        exc = failure
    else:
        raise TypeError(
            f"fail() needs a PlanFailure, a PlanFailure subclass or a message, got "
            f"{type(failure).__name__}: raise ordinary exceptions with `raise`"
        )
    from ._failure_handling import signal_failure

    signal_failure(exc)  # before-unwinding handlers run here, at the signal point
    raise exc


def _short(value: Any, limit: int = 60) -> str:
    text = repr(value) if not isinstance(value, str) else value
    return text if len(text) <= limit else text[: limit - 3] + "..."


def flatten_details(details: Mapping[str, Any]) -> dict[str, str]:
    """Details as short strings, for snapshots and logs."""
    return {k: _short(v) for k, v in details.items()}
