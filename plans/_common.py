"""Small helpers shared by the plan modules: failure-handling idioms that CRAM writes
inline (``(return)`` handlers, ``designator-error`` translation), the robot's arms and
frames (from the environment's :class:`executive.RobotDescription`: the plans never spell
a robot's joint, link or name), frame conversion through the world model, and the per-run
retry ledger the demo reads."""

from __future__ import annotations

import logging
from collections import Counter
from collections.abc import Awaitable, Callable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from typing import Any

import cpl
import executive
from executive import (
    ARM_NAMES,
    ArmDescription,
    DesignatorError,
    DesignatorInputError,
    LocationDesignator,
    ObjectDesignator,
    Pose,
    Resource,
    RobotDescription,
    a,
    current_environment,
    perform,
)

__all__ = [
    "CountedRetries",
    "arm_description",
    "arm_names",
    "arms_left_to_right",
    "as_location",
    "base_frame",
    "grippers_named",
    "hand_link_of",
    "hand_of",
    "ignoring",
    "object_label",
    "perform_ignoring",
    "retry_ledger",
    "tally",
    "the_base",
    "the_robot",
    "to_base",
    "tool_frame_of",
    "translating_designator_errors",
    "translating_failures",
]


def the_robot() -> RobotDescription:
    """The description of the robot the current environment drives
    (:attr:`executive.Environment.robot`; none -> :class:`executive.NoRobotDescription`
    naming the fix). Like CRAM's ``(rob-int:current-robot-name)``, read when a plan runs,
    never fixed when the plan is written."""
    return current_environment().robot


def arm_names() -> tuple[str, ...]:
    """The robot's arms in the order the plans try them (one arm: just ``left``)."""
    return the_robot().arm_names


def arms_left_to_right() -> tuple[str, ...]:
    """The robot's arms in CRAM's ``left``, ``right`` order (the order of the
    ``left-...`` / ``right-...`` keys of the arm actions), whichever order the description
    tries them in; a one-armed robot: ``("left",)``."""
    have = the_robot().arm_names
    return tuple(name for name in ARM_NAMES if name in have)


def arm_description(arm: str) -> ArmDescription:
    """The robot's arm called ``arm``; an arm the robot lacks -> :class:`LookupError`
    naming the robot's arms."""
    return the_robot().arm(arm)


def base_frame() -> str:
    """The robot's base frame (the frame base-relative poses are given in)."""
    return the_robot().base_frame


def tool_frame_of(arm: str) -> str:
    """The tool frame link of the robot's ``arm`` (grasp poses are in it)."""
    return arm_description(arm).tool_frame


def hand_link_of(arm: str) -> str:
    """The link an object held by the robot's ``arm`` hangs from."""
    return arm_description(arm).hand_link


def hand_of(arguments: Any) -> tuple[Resource, Resource]:
    """The resources of a plan that works with one hand (its ``arm`` argument): that arm
    and its gripper (see :func:`executive.register_resources`)."""
    arm = arguments["arm"]
    return Resource.arm(arm), Resource.gripper(arm)


_BASE_ONLY = (Resource.base(),)


def the_base(_arguments: Any) -> tuple[Resource]:
    """The resources of a plan that drives the base, or positions it for what it does next
    (going, navigating; fetching, delivering, searching, transporting, accessing): the
    base, for the plan's whole duration. Its own navigation claims it again within that
    claim; a sibling branch's plan that needs the base fails with
    :class:`executive.ResourceConflict` before it drives, instead of driving the base away
    between this plan's navigation and its grasp."""
    return _BASE_ONLY


def grippers_named(arguments: Any) -> tuple[Resource, ...]:
    """The resources of a gripper plan: the grippers of its ``gripper`` argument (one
    name, or several in a tuple)."""
    value = arguments["gripper"]
    return tuple(Resource.gripper(g) for g in ((value,) if isinstance(value, str) else value))


#: Every retry a :class:`CountedRetries` grants or refuses is logged here (INFO), so a
#: run's log (the demo's ``plans.log``) has each one the demo's summary counts.
_log = logging.getLogger("plans.retries")

#: Where :class:`CountedRetries` report the retries they grant (by kind), if anyone asks:
#: :func:`retry_ledger` binds a fresh counter for a block (the demo does, per object).
_LEDGER: ContextVar[Counter[str] | None] = ContextVar("plans_retry_ledger", default=None)


class CountedRetries(cpl.RetryCounter):
    """A :class:`cpl.RetryCounter` whose granted retries are also tallied, under its
    ``name``, in the ledger of the running context (see :func:`retry_ledger`)."""

    __slots__ = ()

    def do_retry(self) -> bool:
        granted = super().do_retry()
        ledger = _LEDGER.get()
        if granted and ledger is not None:
            ledger[self.name or "retries"] += 1
        task = cpl.current_task()
        _log.info(
            "retry %s %s (%d of %d used) in %s",
            self.name or "retries",
            "granted" if granted else "refused: none left",
            self.used,
            self.initial,
            "/".join(task.path) if task is not None else "?",
        )
        return granted


@contextmanager
def retry_ledger() -> Iterator[Counter[str]]:
    """Tally the retries granted by :class:`CountedRetries` in this block (and in the
    tasks it spawns, which copy the context) into the yielded ``Counter``."""
    ledger: Counter[str] = Counter()
    token = _LEDGER.set(ledger)
    try:
        yield ledger
    finally:
        _LEDGER.reset(token)


def tally(name: str) -> None:
    """Count one ``name`` in the ledger of the running context (:func:`retry_ledger`),
    if any: for what a plan ignores or gives up on purpose, so it is counted, not
    swallowed (e.g. an object on the floor out of reach)."""
    ledger = _LEDGER.get()
    if ledger is not None:
        ledger[name] += 1


async def perform_ignoring(
    designator: executive.Designator, failures: type[Exception] | tuple[type[Exception], ...]
) -> Any:
    """Perform ``designator``; a failure of type ``failures`` is swallowed (CRAM's handler
    ``(return)``) and ``None`` returned."""
    return await ignoring(lambda: perform(designator), failures)


async def ignoring(
    body: Callable[[], Awaitable[Any]],
    failures: type[Exception] | tuple[type[Exception], ...],
) -> Any:
    """Run ``body()``; a failure of type ``failures`` is swallowed and ``None`` returned."""
    return await cpl.with_failure_handling(body, [(failures, lambda _f: cpl.return_(None))])


async def translating_designator_errors(
    body: Callable[[], Awaitable[Any]], into: Callable[[BaseException], BaseException]
) -> Any:
    """Run ``body()``; a ``designator-error`` leaving it becomes ``into(error)`` (chained):
    CRAM's translation of designator errors at every plan boundary. A
    :class:`executive.DesignatorInputError` (a malformed designator) is not translated
    (see :func:`translating_failures`)."""
    return await translating_failures(DesignatorError, body, into)


async def translating_failures(
    failures: type[Exception] | tuple[type[Exception], ...],
    body: Callable[[], Awaitable[Any]],
    into: Callable[[BaseException], BaseException],
) -> Any:
    """Run ``body()``; a failure of type ``failures`` leaving it becomes ``into(failure)``
    (chained). A :class:`executive.DesignatorInputError` always leaves as itself: a
    misspelt name or key must reach the programmer with its hint, not as "object nowhere
    to be found" (deliberate difference from CRAM, which translated every
    ``designator-error``)."""

    def translate(error: BaseException) -> None:
        if isinstance(error, DesignatorInputError):
            return  # declined: the error propagates unchanged
        raise into(error) from error

    return await cpl.with_failure_handling(body, [(failures, translate)])


def as_location(target: Any) -> LocationDesignator:
    """A location designator for a pose (``(pose P)``), or the newest member of a given
    location designator's chain."""
    if isinstance(target, LocationDesignator):
        return target.current()
    if isinstance(target, Pose):
        return a.location(pose=target)
    raise DesignatorError(f"expected a location designator or a Pose, got {target!r}", target)


def to_base(pose: Pose) -> Pose:
    """``pose`` in the robot's base frame at the robot's current pose (world model)."""
    base = base_frame()
    if pose.frame == base:
        return pose
    if pose.frame != "map":
        raise DesignatorError(f"poses are given in map or {base}, not {pose.frame!r}")
    robot = current_environment().world.robot_pose().to_transform(base)
    result: Pose = robot.inverse() * pose
    return result


def to_map(pose: Pose) -> Pose:
    """``pose`` in ``map`` (a base-frame pose is taken at the robot's pose now)."""
    if pose.frame == "map":
        return pose
    robot = current_environment().world.robot_pose().to_transform(base_frame())
    result: Pose = robot * pose
    return result


def object_label(obj: Any) -> Any:
    """The newest member of an object designator's chain (what failures report)."""
    return obj.current() if isinstance(obj, ObjectDesignator) else obj
