"""``imagine_best``: imagine named alternatives, then run the best one for real.

Projection beyond one transport (CRAM projects only inside ``transporting``): a plan that
would otherwise make a choice by fixed order hands :func:`imagine_best` its alternatives,
each a zero-argument coroutine function (any ``cpl`` form, a ``perform``, a plan). In the
environment's imagination each runs once, from the same snapshot of the belief world, as
the subtree ``imagine-<name>`` (marked :attr:`cpl.Subtree.IMAGINED`); every one is
summarised as an :class:`Imagined` (outcome, retries, simulated duration, how far the
robot drove), annotated on its subtree; ``score`` ranks them (smaller is better; default
:func:`by_success_then_time`) and the best one runs for real as the subtree
``chosen-<name>`` (marked :attr:`cpl.Subtree.CHOSEN`), annotated with all the summaries
and the winner. Its value or failure is the result.

Both run on the imagination engine (:func:`plans.imagine`).

Pass-through (the first alternative runs as ``chosen-<name>``, nothing imagined) when
``enabled`` is false, the environment is already projecting (so reasoning inside
projection stays a pass-through) or it cannot imagine.

Example (the demo's order of transports)::

    order = await imagine_best({
        "cup-first": lambda: transport_then("cup", "bowl"),
        "bowl-first": lambda: transport_then("bowl", "cup"),
    })
"""

from __future__ import annotations

import contextvars
import math
from collections.abc import Awaitable, Callable, Mapping
from contextlib import aclosing
from dataclasses import dataclass
from typing import Any, TypeVar

import cpl
from executive import current_environment
from executive.events import RobotStateChanged

from ._imagination import ImaginedRun, can_imagine, imagine, run_for_real

__all__ = ["Imagined", "by_success_then_time", "imagine_best", "imagining"]

T = TypeVar("T")

#: The name of the alternative being imagined in this context (``None``: not imagining).
_IMAGINING: contextvars.ContextVar[str | None] = contextvars.ContextVar(
    "plans_imagining", default=None
)


def imagining() -> str | None:
    """The name of the :func:`imagine_best` alternative being imagined here, else ``None``
    (an alternative may skip the bookkeeping of a real run while it is only imagined)."""
    return _IMAGINING.get()


@dataclass(frozen=True)
class Imagined:
    """One imagined alternative: ``outcome`` ``"succeeded"`` or the failure class name;
    ``retries`` granted in it; ``sim_s`` its projected duration (seconds on the
    imagination's timeline, which its motions' modelled durations advance; not the wall
    or loop time imagining took); ``driven_m`` how far the imagined base moved; ``value``
    what it returned (``None`` when it failed)."""

    name: str
    outcome: str
    retries: int
    sim_s: float
    driven_m: float
    value: Any = None

    @property
    def succeeded(self) -> bool:
        return self.outcome == "succeeded"

    def line(self) -> str:
        return (
            f"{self.name}: {self.outcome}, {self.retries} retries, "
            f"{self.sim_s:.1f} s, {self.driven_m:.2f} m"
        )


def by_success_then_time(imagined: Imagined) -> tuple[Any, ...]:
    """The default score: success first, then retries, then simulated time, then driving."""
    return (not imagined.succeeded, imagined.retries, imagined.sim_s, imagined.driven_m)


async def imagine_best(
    alternatives: Mapping[str, Callable[[], Awaitable[T]]],
    score: Callable[[Imagined], Any] = by_success_then_time,
    *,
    enabled: bool = True,
) -> T:
    """Imagine every alternative, run the best for real (see the module docstring).
    No alternatives, or a name that is not a non-empty string: ValueError, before anything
    runs. Ties go to the earlier alternative."""
    if not alternatives:
        raise ValueError("imagine_best needs at least one alternative")
    for name, fn in alternatives.items():
        if not isinstance(name, str) or not name:
            raise ValueError(f"imagine_best: alternative names are non-empty strings, got {name!r}")
        if not callable(fn):
            raise ValueError(f"imagine_best: alternative {name!r} is not callable: {fn!r}")
    names = list(alternatives)
    imagination = can_imagine(enabled)
    if imagination is None or len(names) == 1:
        return await _chosen(names[0], alternatives[names[0]], (), "pass-through")
    results: list[Imagined] = []
    driven: dict[str, float] = {}
    runs = ((f"imagine-{n}", _watched(n, alternatives[n], driven)) for n in names)
    async with aclosing(imagine(imagination, runs)) as imagined:
        async for run in imagined:
            results.append(_summary(run, names[len(results)], driven))
    best = min(range(len(results)), key=lambda i: (score(results[i]), i))
    winner = names[best]
    reason = "; ".join(r.line() for r in results)
    return await _chosen(winner, alternatives[winner], tuple(results), reason)


def _watched(
    name: str, fn: Callable[[], Awaitable[T]], driven: dict[str, float]
) -> Callable[[], Awaitable[T]]:
    """``fn`` run as the imagined alternative ``name``: :func:`imagining` tells it so and
    ``driven[name]`` adds up how far the imagined base moves."""

    async def run() -> T:
        dream = current_environment()
        driven[name] = 0.0
        unsubscribe = None
        if dream.has_world:
            last = [dream.world.robot_pose()]

            def moved(_event: Any) -> None:
                now = dream.world.robot_pose()
                driven[name] += math.dist(now.position[:2], last[0].position[:2])
                last[0] = now

            unsubscribe = dream.subscribe(RobotStateChanged, moved)
        token = _IMAGINING.set(name)
        try:
            return await fn()
        finally:
            _IMAGINING.reset(token)
            if unsubscribe is not None:
                unsubscribe()

    return run


def _summary(run: ImaginedRun[Any], name: str, driven: Mapping[str, float]) -> Imagined:
    imagined = Imagined(name, run.outcome, run.retries, run.sim_s, driven.get(name, 0.0), run.value)
    if run.task is not None:
        run.task.annotate("imagined", imagined)
    return imagined


async def _chosen(
    name: str, fn: Callable[[], Awaitable[T]], imagined: tuple[Imagined, ...], reason: str
) -> T:
    notes = {"alternatives": imagined, "why": reason}
    return await run_for_real(f"chosen-{name}", cpl.Subtree.CHOSEN, fn, notes)
