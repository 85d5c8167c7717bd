"""The imagination engine: run alternatives in the belief world's imagination, one after
the other from the same snapshot, then run the chosen one for real.

Both kinds of projection reasoning are front-ends over it: projection reasoning's
:func:`plans.reasoning.with_projected_task_tree` (the same body, explored differently in
every run) and :func:`plans.imagining.imagine_best` (named alternatives). The engine does
what they share:

* :func:`can_imagine`: whether to imagine at all (enabled, not already projecting, the
  environment has an :class:`executive.Imagination`);
* :func:`imagine`: snapshot the belief world, enter the imagination's projection, and for
  every alternative restore the snapshot and run it as a subtree marked
  :attr:`cpl.Subtree.IMAGINED`, with its own retry ledger; a plan failure or designator
  error ends that run only. It yields an :class:`ImaginedRun` per alternative *while the
  imagined world is as that run left it* (read the world before asking for the next).
  Retries granted in imagination are not tallied in the caller's ledger; the snapshot is
  restored after the last run, also when the caller stops early or is evaporated;
* :func:`run_for_real`: run the chosen body as a marked subtree
  (:attr:`cpl.Subtree.REAL` / :attr:`cpl.Subtree.CHOSEN`) annotated with why it won.

What is measured about a run (poses before and after, where the robot stood, how far it
drove) is the front-end's: it wraps its alternatives, whose code runs after the restore.
"""

from __future__ import annotations

import logging
from collections.abc import AsyncGenerator, Awaitable, Callable, Iterable, Mapping
from dataclasses import dataclass
from typing import Any, Generic, TypeVar

import cpl
from executive import DesignatorError, Environment, Imagination, current_environment

from ._common import retry_ledger

__all__ = ["ImaginedRun", "can_imagine", "imagine", "run_for_real"]

log = logging.getLogger("plans.imagination")

T = TypeVar("T")


@dataclass(frozen=True)
class ImaginedRun(Generic[T]):
    """One imagined alternative, as it ended.

    ``task``: its subtree (marked :attr:`cpl.Subtree.IMAGINED`; ``None`` if its body never
    started); ``value``: what it returned (``None`` when it failed); ``failure``: the plan
    failure or designator error that ended it; ``retries``: the retries granted in it;
    ``env``: the projection environment it ran in (its world is still the imagined one
    while this record is the engine's latest)."""

    name: str
    task: cpl.Task | None
    value: T | None
    failure: BaseException | None
    retries: int
    env: Environment

    @property
    def outcome(self) -> str:
        """``"succeeded"`` or the class name of the failure that ended the run."""
        return "succeeded" if self.failure is None else type(self.failure).__name__

    @property
    def sim_s(self) -> float:
        """The run's projected duration (its task's times on the imagination's timeline)."""
        task = self.task
        if task is None or task.start_time is None or task.end_time is None:
            return 0.0
        return task.end_time - task.start_time


def can_imagine(enabled: bool = True) -> Imagination | None:
    """The current environment's imagination when reasoning should imagine: ``enabled``,
    the environment not itself projecting (reasoning inside projection is a pass-through)
    and able to imagine; else ``None``."""
    env = current_environment()
    if not enabled or env.projecting:
        return None
    return env.imagination


async def imagine(
    imagination: Imagination,
    alternatives: Iterable[tuple[str, Callable[[], Awaitable[T]]]],
) -> AsyncGenerator[ImaginedRun[T], None]:
    """Imagine ``alternatives`` (``(subtree name, body)`` pairs, taken one at a time, so a
    body may be made for its run) and yield each one's :class:`ImaginedRun` (see the
    module docstring). Use it as ``async with contextlib.aclosing(imagine(...)) as
    runs:`` so that an early exit restores the belief at once."""
    snapshot = imagination.snapshot()
    try:
        with retry_ledger():  # imagined retries are not the caller's
            async with imagination.projection():
                dream = current_environment()
                for name, body in alternatives:
                    imagination.restore(snapshot)
                    yield await _one_run(name, body, dream)
    finally:
        imagination.restore(snapshot)


async def _one_run(
    name: str, body: Callable[[], Awaitable[T]], dream: Environment
) -> ImaginedRun[T]:
    started: cpl.Task | None = None

    async def run() -> T:
        nonlocal started
        started = cpl.current_task()
        return await body()

    value: T | None = None
    failure: BaseException | None = None
    with retry_ledger() as ledger:
        try:
            value = await cpl.tag(name, run(), subtree=cpl.Subtree.IMAGINED)
        except (cpl.PlanFailure, DesignatorError) as error:
            failure = error
            log.info("imagined run %s failed: %r", name, error)
    return ImaginedRun(name, started, value, failure, sum(ledger.values()), dream)


async def run_for_real(
    name: str,
    mark: cpl.Subtree,
    body: Callable[[], Awaitable[T]],
    notes: Mapping[str, Any] = {},
) -> T:
    """Run ``body`` for real as the subtree ``name`` marked ``mark``, annotated with
    ``notes`` (what was imagined, what was chosen and why) before it starts."""

    async def real() -> T:
        me = cpl.current_task()
        if me is not None:
            for key, value in notes.items():
                me.annotate(key, value)
        return await body()

    result: T = await cpl.tag(name, real(), subtree=mark)
    return result
