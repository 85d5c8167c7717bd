"""``perform``: CRAM's ``exe:perform``.

- **Action designator**: referenced (first grounding ``(plan, arguments)``), then the plan
  runs as a child task of kind ``"plan"`` whose node carries the annotations
  ``"designator"`` (the action) and ``"resolved"`` (the grounding). A ``@cpl.plan``
  function keeps its own name; a plain async function gets the action's type as name.
- **Motion designator**: (1) the running process modules of the current environment that
  accept it are the candidates, none -> :class:`executive.NoProcessModule`; (2) it is
  referenced; (3) the candidates are tried in registration order (CRAM's
  ``try-each-in-order``) until one succeeds; if all fail, the first failure is raised (a
  :class:`cpl.CompositeFailure` is unwrapped to its first failure, as ``pm-execute-matching``
  does). Deliberate difference: the candidates are tried in a plain loop, not through a
  ``try_in_order`` form, to keep one task (the goal's) per motion.
- **Object or location designator**: :class:`executive.DesignatorError`, they describe
  things, not something to do.

Resources (:mod:`executive._resources`): an action whose plan has registered resources
claims them, once resolved and before its plan starts, for its whole duration; a motion
whose command has registered resources uses them while it runs. A resource held by a
concurrent action outside the goal's own subtree: :class:`executive.ResourceConflict`,
before anything moves for the goal.

Resolution errors (:class:`executive.DesignatorError`) propagate unchanged; evaporation of
the caller evaporates the running plan or goal (see :mod:`executive._process_module`).
"""

from __future__ import annotations

import asyncio
import inspect
from collections.abc import Mapping
from typing import Any

import cpl

from ._designator import ActionDesignator, Designator, MotionDesignator
from ._environment import Environment, current_environment
from ._resources import check_parts, resources_of
from .failures import DesignatorError, NoProcessModule

__all__ = ["perform"]


def _unwrap(failure: BaseException) -> BaseException:
    while isinstance(failure, cpl.CompositeFailure) and failure.failures:
        failure = failure.failures[0]
    return failure


async def perform(designator: Designator) -> Any:
    """Perform an action or motion designator and return the plan's or module's value.

    Raises :class:`executive.DesignatorError` if it cannot be resolved (or is an object or
    location), :class:`executive.NoProcessModule` if no running module accepts a motion,
    and whatever plan failure the plan or module raises.
    """
    if type(designator) is MotionDesignator:
        return await _perform_motion(designator)
    if type(designator) is ActionDesignator:
        return await _perform_action(designator)
    if isinstance(designator, MotionDesignator):
        return await _perform_motion(designator)
    if isinstance(designator, ActionDesignator):
        return await _perform_action(designator)
    if isinstance(designator, Designator):
        raise DesignatorError(
            f"cannot perform {designator.short()}: only action and motion designators are "
            f"performed; reference() a {designator.kind} designator to get its solution",
            designator,
        )
    raise TypeError(f"perform() needs an action or motion designator, got {designator!r}")


async def _perform_motion(motion: MotionDesignator) -> Any:
    env = current_environment()
    candidates = [pm for pm in env.process_modules if pm._active and pm.accepts(motion)]
    if not candidates:
        # a motion that cannot resolve (unknown type: the error lists the known ones; an
        # unknown key or a bad value) says so rather than "no process module"
        motion.reference()
        names = ", ".join(pm.name for pm in env.process_modules) or "none"
        hint = ""
        if not any(pm._active for pm in env.process_modules):
            hint = (
                "; motions need a robot: perform them inside `async with "
                "projection.with_projected_robot(world):` (projection) or `async with "
                "projection.with_real_robot(true_world, belief_world):` (the simulated "
                "real robot), or your own environment's process modules"
            )
        raise NoProcessModule(
            f"no running process module accepts {motion!r} (running in environment "
            f"{env.name!r}: {names}){hint}",
            motion=motion,
        )
    command, arguments = motion.reference()
    uses = _motion_uses(motion, command, arguments, env)
    first: BaseException | None = None
    try:
        for pm in candidates:
            try:
                return await pm._submit(motion, env)
            except cpl.PlanFailure as failure:
                if first is None:
                    first = _unwrap(failure)
        assert first is not None
        raise first
    finally:
        # this frame is in ``first``'s traceback: drop the local, or failure -> traceback
        # -> frame -> failure is a reference cycle only the cyclic collector frees
        first = None
        if uses is not None:
            env._ledger.release(uses)


def _motion_uses(
    motion: MotionDesignator, command: str, arguments: Any, env: Environment
) -> list[Any] | None:
    """The resources a motion uses while it runs (shared with other motions), acquired;
    ``None`` when its command registered none."""
    declared = env.rules.resources_for(command)
    if declared is None:
        return None
    return _acquire(env, declared[0], arguments, motion, is_action=False, exclusive=False)


def _acquire(
    env: Environment, fn: Any, arguments: Any, goal: Designator, *, is_action: bool, exclusive: bool
) -> list[Any] | None:
    """Acquire the resources ``fn`` names for ``goal``'s ``arguments`` in the environment's
    ledger (:class:`executive.ResourceConflict` if another holds them); ``None`` when it
    names none, or outside a task."""
    resources = resources_of(fn, arguments, goal)
    task = cpl.current_task()
    if task is None or not resources:
        return None
    parts = env.resources
    check_parts(resources, parts, goal)
    return env._ledger.acquire(
        resources, task, goal, is_action=is_action, exclusive=exclusive, parts=parts
    )


async def _perform_action(action: ActionDesignator) -> Any:
    grounding = action.reference()
    plan, arguments = grounding
    env = current_environment()
    declared = env.rules.resources_for(plan)
    if declared is None:
        return await _run_plan(action, grounding)
    fn, shared = declared
    uses = _acquire(env, fn, arguments, action, is_action=True, exclusive=not shared)
    if uses is None:
        return await _run_plan(action, grounding)
    try:
        await _let_siblings_claim()
        return await _run_plan(action, grounding)
    finally:
        env._ledger.release(uses)


async def _let_siblings_claim() -> None:
    """Two scheduling points between an action's claim and its plan's first step.

    A form starts its branches one after the other: without them, the first branch's
    plan could run up to its first motion (a projected motion teleports at once) before
    the second branch claims, and the conflict would evaporate a branch that had moved
    already. With them, the siblings the same form started claim first (the loop runs
    each branch's first step in order), and a conflict's failure reaches the form, which
    evaporates this branch, before this plan resumes: neither moves. (One point lets the
    siblings run; the second lets the form, woken by a sibling's failure, act first.)"""
    await asyncio.sleep(0)
    await asyncio.sleep(0)


async def _run_plan(action: ActionDesignator, grounding: Any) -> Any:
    plan, arguments = grounding
    if isinstance(arguments, Mapping):
        call = plan(**arguments)
        named = dict(arguments)
    else:
        call = plan(*arguments)
        named = {f"arg{i}": v for i, v in enumerate(arguments)}
    annotations = {"designator": action, "resolved": grounding}
    if isinstance(call, cpl.PlanCall):
        return await call.annotate(**annotations)
    if inspect.isawaitable(call):
        return await cpl.with_task(
            call, name=str(action.type), kind="plan", arguments=named, annotations=annotations
        )
    raise TypeError(
        f"the grounding of {action.short()} names {plan!r}, which returned "
        f"{type(call).__name__}: action rules must yield async plan functions"
    )
