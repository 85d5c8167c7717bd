"""Process modules: the robot's body parts, one goal at a time (CRAM's ``cram_process_modules``).

Subclasses implement :meth:`ProcessModule.accepts` and :meth:`ProcessModule.execute`
(and optionally :meth:`ProcessModule.on_cancel`); the framework owns the lifecycle:

- **Exclusivity.** One goal runs at a time; further goals wait their turn in FIFO order, as
  with CRAM's ``pm-execute``. A goal evaporated while waiting never runs.
- **Task tree.** Every goal is a task (kind ``"task"``, named after the module) with the
  motion designator as its ``"motion"`` annotation.
- **Status.** ``status`` is a :class:`cpl.Fluent` of :class:`PMStatus`: ``OFFLINE`` outside
  any block that activates the module, ``IDLE`` when waiting for goals, ``RUNNING`` while a
  goal executes, ``FAILED`` after the last goal failed (until the next one starts).
- **Blocking work.** A module whose driver blocks derives from
  :class:`executive.BlockingProcessModule` (``blocking = True``): its synchronous
  ``execute_blocking`` runs in a worker thread, and evaporation first asks the driver to
  stop (a :class:`executive.CancelRequest`) and waits for it, then calls ``on_cancel``.
- **Scheduling point.** Before it starts, every goal waits until every other task that
  can run has run (:func:`cpl.wait_quiescent`: at least one switch to the loop), in
  the framework (so every module does, even one whose ``execute`` never awaits, as the
  projected modules' teleports): ``par`` branches interleave motion by motion, a monitor
  in ``pursue`` sees every motion, and an evaporation requested during a motion takes
  effect at the next one at the latest (the goal then never starts, nothing moves).
  Deliberate difference from CRAM: CRAM's process modules run in threads, preempted
  anywhere; asyncio tasks switch only where they await, so the framework adds the await.
- **Cancellation.** Evaporating a goal's task while ``execute`` runs calls
  ``on_cancel(motion)`` once, shielded from further evaporation and limited to
  ``cancel_timeout`` seconds (a failure or time-out of the hook is logged, never raised),
  then the evaporation propagates. The caller, if it is not evaporated itself, gets
  :class:`executive.ProcessModuleGoalEvaporated`.
"""

from __future__ import annotations

import abc
import asyncio
import enum
import logging
import re
from collections import deque
from typing import TYPE_CHECKING, Any, ClassVar

import cpl

from ._environment import Environment, current_environment
from .failures import NoProcessModule, ProcessModuleGoalEvaporated

if TYPE_CHECKING:
    from ._designator import Designator
    from ._resources import Resource

__all__ = ["PMStatus", "ProcessModule", "pm_execute"]

log = logging.getLogger("executive.process_modules")


class PMStatus(enum.Enum):
    """A process module's state (CRAM's ``:offline``, ``:waiting``, ``:running``,
    ``:failed``; ``IDLE`` is CRAM's ``:waiting``)."""

    OFFLINE = "offline"
    IDLE = "idle"
    RUNNING = "running"
    FAILED = "failed"


class _Goal:
    __slots__ = ("env", "evaporation", "motion", "started", "task")

    def __init__(self, env: Environment, motion: Designator) -> None:
        self.env = env
        self.motion = motion
        self.task: cpl.Task | None = None
        self.started = False
        self.evaporation: BaseException | None = None


def _kebab(name: str) -> str:
    return re.sub(r"(?<!^)(?=[A-Z])", "-", name).lower()


class ProcessModule(abc.ABC):
    """Base class of process modules. ``name`` defaults to the class name in kebab case.

    Override :meth:`accepts` (or set ``motion_types``), :meth:`execute` and optionally
    :meth:`on_cancel`. A module instance may be active in several environments at once; it
    still runs one goal at a time (it is one piece of hardware).
    """

    #: Motion types this module accepts (used by the default :meth:`accepts`).
    motion_types: ClassVar[frozenset[str]] = frozenset()
    #: Seconds ``on_cancel`` may take before it is abandoned (for a blocking module, also
    #: how long an evaporated driver call may take to return).
    cancel_timeout: float = 2.0
    #: Whether this module's work blocks (a synchronous driver call). Blocking modules
    #: derive from :class:`executive.BlockingProcessModule`, which runs the work in a worker
    #: thread so that the loop stays responsive (``executive._blocking``).
    blocking: ClassVar[bool] = False
    #: The robot parts this module drives (robot data: ``{Resource.base()}`` for a
    #: navigation module); the environment's parts are its modules'. Empty: not declared.
    resources: frozenset[Resource] = frozenset()

    def __init__(self, name: str | None = None) -> None:
        if name is not None and (not isinstance(name, str) or not name):
            raise TypeError(f"a process module name is a non-empty string, got {name!r}")
        self.name: str = name or _kebab(type(self).__name__)
        self.status: cpl.Fluent[PMStatus] = cpl.Fluent(PMStatus.OFFLINE, name=f"{self.name}-status")
        self._queue: deque[_Goal] = deque()
        self._active = 0

    # -- to override ------------------------------------------------------------------
    def accepts(self, motion: Designator) -> bool:
        """Whether this module can execute ``motion`` (default: its type is in
        ``motion_types``). Must be cheap and side-effect free."""
        return motion.type in self.motion_types

    @abc.abstractmethod
    async def execute(self, motion: Designator) -> Any:
        """Execute one motion (``motion.reference()`` gives its command and arguments).
        Raise a low-level plan failure when it fails; the value returned is ``perform``'s."""

    async def on_cancel(self, motion: Designator) -> None:  # noqa: B027 (optional hook)
        """Clean up after an evaporated goal (stop the base, open the gripper...). Runs
        shielded and time-limited; the default does nothing."""

    # -- lifecycle --------------------------------------------------------------------
    @property
    def running(self) -> bool:
        """True while some block has this module active (CRAM: the module is running)."""
        return self._active > 0

    @property
    def pending(self) -> int:
        """Goals running or waiting."""
        return len(self._queue)

    def _activate(self) -> None:
        self._active += 1
        if self._active == 1:
            self.status.value = PMStatus.IDLE

    async def _deactivate(self, env: Environment) -> None:
        self._active -= 1
        leftovers = [g for g in self._queue if g.task is not None and g.env.is_within(env)]
        for goal in leftovers:
            assert goal.task is not None
            goal.task.evaporate(f"the block running process module {self.name!r} was left")
        if leftovers:
            try:
                await cpl.shielded(_join_all(leftovers), timeout=self.cancel_timeout + 1.0)
            except TimeoutError:
                log.warning("process module %s: goals did not end after evaporation", self.name)
        if self._active == 0:
            self.status.value = PMStatus.OFFLINE

    async def _submit(self, motion: Designator, env: Environment) -> Any:
        goal = _Goal(env, motion)
        result = await cpl.with_task(
            self._run_goal(goal), name=self.name, kind="task", annotations={"motion": motion}
        )
        if goal.evaporation is not None:
            raise ProcessModuleGoalEvaporated(
                f"process module {self.name!r}: the goal {motion.short()} was evaporated "
                f"({goal.evaporation})",
                motion=motion,
                module=self.name,
            )
        return result

    async def _run_goal(self, goal: _Goal) -> Any:
        if self._active == 0:
            raise NoProcessModule(
                f"process module {self.name!r} is not running (its block was left)",
                motion=goal.motion,
            )
        goal.task = cpl.current_task()
        queue = self._queue
        queue.append(goal)
        failed = False
        try:
            try:
                while queue[0] is not goal:
                    ahead = queue[queue.index(goal) - 1].task
                    assert ahead is not None
                    try:
                        await ahead.join()
                    except Exception:  # the goal ahead failed: our turn may have come
                        pass
                # Every goal is a scheduling point, whatever the module: every other task
                # that can run runs first (a sibling in ``par``, a monitor in ``pursue``
                # reacting to the last motion), and an evaporation or suspension requested
                # meanwhile takes effect here, before the motion starts.
                await cpl.wait_quiescent()
            except asyncio.CancelledError as exc:
                goal.evaporation = exc
                raise
            goal.started = True
            self.status.value = PMStatus.RUNNING
            try:
                return await self.execute(goal.motion)
            except asyncio.CancelledError as exc:
                goal.evaporation = exc
                await self._cleanup(goal.motion)
                raise
            except BaseException:
                failed = True
                raise
        finally:
            if queue and queue[0] is goal:
                queue.popleft()
            else:
                queue.remove(goal)
            if not queue:
                if self._active == 0:
                    self.status.value = PMStatus.OFFLINE
                else:
                    self.status.value = PMStatus.FAILED if failed else PMStatus.IDLE

    async def _cleanup(self, motion: Designator) -> None:
        try:
            await cpl.shielded(self.on_cancel(motion), timeout=self.cancel_timeout)
        except TimeoutError:
            log.warning(
                "process module %s: on_cancel(%s) did not finish within %s s",
                self.name,
                motion.short(),
                self.cancel_timeout,
            )
        except Exception:
            log.exception("process module %s: on_cancel(%s) failed", self.name, motion.short())

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.name!r} {self.status.value.value}>"


async def _join_all(goals: list[_Goal]) -> None:
    for goal in goals:
        if goal.task is not None:
            try:
                await goal.task.join()
            except Exception:
                pass


async def pm_execute(name: str, motion: Designator) -> Any:
    """Execute ``motion`` on the running process module called ``name`` in the current
    environment (CRAM's ``pm-execute``: no matching check). Raises
    :class:`executive.NoProcessModule` if there is none."""
    env = current_environment()
    pm = env.find_process_module(name)
    if pm is None or not pm.running:
        names = ", ".join(p.name for p in env.process_modules) or "none"
        raise NoProcessModule(
            f"no running process module named {name!r} (running: {names})", motion=motion
        )
    return await pm._submit(motion, env)
