"""Instruments: hooks that observe a run (tree recorder, event log, live console).

An instrument subclasses :class:`Instrument` and overrides the hooks it needs. Hooks are
called synchronously at the moment of the event; they must be quick and must not await.
An instrument that raises is removed from the run and the error is logged on the
``cpl.instruments`` logger: observing a plan never fails it.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterable
from typing import TYPE_CHECKING, Any

from ._status import Status

if TYPE_CHECKING:
    from ._fluents import Fluent
    from ._task import Task

__all__ = ["HOOKS", "Instrument", "InstrumentSet"]

_log = logging.getLogger("cpl.instruments")

HOOKS = ("run_started", "run_finished", "task_spawned", "task_status_changed", "fluent_changed")


class Instrument:
    """Base class of run observers; every hook is a no-op by default."""

    def run_started(self, root: Task) -> None:
        """The top-level task of a run was created (before it starts)."""

    def run_finished(self, root: Task) -> None:
        """The top-level task and all its descendants are dead."""

    def task_spawned(self, task: Task) -> None:
        """A task was created as a child of ``task.parent`` (status CREATED)."""

    def task_status_changed(self, task: Task, old: Status, new: Status) -> None:
        """A task moved from ``old`` to ``new``."""

    def fluent_changed(self, fluent: Fluent[Any], value: Any) -> None:
        """A fluent pulsed with ``value`` (only fluents read inside a run are reported)."""


class InstrumentSet:
    """The instruments of one run, with per-hook dispatch tuples (empty tuples cost nothing
    on the hot path)."""

    __slots__ = ("_instruments", *HOOKS)

    run_started: tuple[Callable[..., None], ...]
    run_finished: tuple[Callable[..., None], ...]
    task_spawned: tuple[Callable[..., None], ...]
    task_status_changed: tuple[Callable[..., None], ...]
    fluent_changed: tuple[Callable[..., None], ...]

    def __init__(self, instruments: Iterable[Instrument] = ()) -> None:
        self._instruments: list[Instrument] = []
        for hook in HOOKS:
            setattr(self, hook, ())
        for inst in instruments:
            self.add(inst)

    def add(self, instrument: Instrument) -> None:
        if instrument in self._instruments:
            raise ValueError(f"instrument {instrument!r} is already registered for this run")
        self._instruments.append(instrument)
        self._rebuild()

    def remove(self, instrument: Instrument) -> None:
        if instrument in self._instruments:
            self._instruments.remove(instrument)
            self._rebuild()

    def __iter__(self) -> Any:
        return iter(list(self._instruments))

    def _rebuild(self) -> None:
        base = Instrument
        for hook in HOOKS:
            bound = tuple(
                self._guard(inst, hook)
                for inst in self._instruments
                if getattr(type(inst), hook, None) is not getattr(base, hook)
            )
            setattr(self, hook, bound)

    def _guard(self, inst: Instrument, hook: str) -> Callable[..., None]:
        method = getattr(inst, hook)

        def call(*args: Any) -> None:
            try:
                method(*args)
            except Exception:
                _log.exception("instrument %r raised in %s; removed from the run", inst, hook)
                self.remove(inst)

        return call
