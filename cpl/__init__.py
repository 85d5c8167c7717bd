"""cpl: CRAM's concurrent plan language on asyncio.

Plans are async functions; forms (``seq``, ``par``, ``pursue``, ``try_all``,
``try_in_order``, ``par_loop``, ``partial_order``) compose them into a recorded task tree;
failures are plan failures handled with ``with_failure_handling`` and retry counters;
evaporation (cancellation) always lets cleanup run. Everything public is here; the
modules behind it are private.
"""

from typing import Any

from ._cleanup import cleanup_failures
from ._clock import Clock, ScaledClock, SystemClock, current_clock
from ._eventlog import EventLog, load_events, tree_from_log, truncated_tail
from ._failure_handling import (
    Error,
    RetryCounter,
    retry,
    return_,
    with_failure_handling,
    with_retry,
)
from ._failures import CompositeFailure, Evaporated, PlanFailure, fail
from ._fluents import (
    Fluent,
    fl_and,
    fl_eq,
    fl_funcall,
    fl_not,
    fl_or,
    fl_value_changed,
    pulsed,
    wait_for,
    whenever,
)
from ._forms import (
    Tagged,
    par,
    par_loop,
    partial_order,
    pursue,
    seq,
    tag,
    try_all,
    try_each_in_order,
    try_in_order,
)
from ._instruments import Instrument
from ._lazy import LazyList
from ._plan import Plan, PlanCall, plan
from ._policies import (
    Policy,
    PolicyConditionMet,
    PolicyFailure,
    PolicyInitFailed,
    PolicyTimeout,
    timeout_policy,
    with_policies,
    with_policy,
)
from ._queries import ancestors, find_tasks, previous_sibling, walk
from ._retention import (
    KeepAll,
    KeepRecent,
    Retention,
    RetentionSummary,
    StreamFinished,
    retention_summary,
    retired,
)
from ._runtime import RunHistory, RunTimeout, run, task_tree, top_level
from ._status import Status
from ._subtree import Subtree, subtree_of, within
from ._suspension import on_suspension, with_task_suspended
from ._tags import Tags, with_tags
from ._task import Task, current_task, spawn, with_task
from ._task_fluents import task_alive, task_dead, task_failed, task_succeeded
from ._timeline import Timeline, current_time, current_timeline, on_timeline
from ._tree import FailureInfo, TaskNode, snapshot
from ._waiting import shielded, sleep, wait_quiescent

__all__ = [
    "Clock",
    "CompositeFailure",
    "Error",
    "Evaporated",
    "EventLog",
    "FailureInfo",
    "Fluent",
    "Instrument",
    "KeepAll",
    "KeepRecent",
    "LazyList",
    "Plan",
    "PlanCall",
    "PlanFailure",
    "Policy",
    "PolicyConditionMet",
    "PolicyFailure",
    "PolicyInitFailed",
    "PolicyTimeout",
    "Retention",
    "RetentionSummary",
    "RetryCounter",
    "RunHistory",
    "RunTimeout",
    "ScaledClock",
    "Status",
    "StreamFinished",
    "Subtree",
    "SystemClock",
    "Tagged",
    "Tags",
    "Task",
    "TaskNode",
    "Timeline",
    "ancestors",
    "cleanup_failures",
    "current_clock",
    "current_task",
    "current_time",
    "current_timeline",
    "fail",
    "find_tasks",
    "fl_and",
    "fl_eq",
    "fl_funcall",
    "fl_not",
    "fl_or",
    "fl_value_changed",
    "load_events",
    "on_suspension",
    "on_timeline",
    "par",
    "par_loop",
    "partial_order",
    "plan",
    "previous_sibling",
    "pulsed",
    "pursue",
    "retention_summary",
    "retired",
    "retry",
    "return_",
    "run",
    "seq",
    "shielded",
    "sleep",
    "snapshot",
    "spawn",
    "subtree_of",
    "tag",
    "task_alive",
    "task_dead",
    "task_failed",
    "task_succeeded",
    "task_tree",
    "timeout_policy",
    "top_level",
    "tree_from_log",
    "truncated_tail",
    "try_all",
    "try_each_in_order",
    "try_in_order",
    "wait_for",
    "wait_quiescent",
    "walk",
    "whenever",
    "with_failure_handling",
    "with_policies",
    "with_policy",
    "with_retry",
    "with_tags",
    "with_task",
    "with_task_suspended",
    "within",
]


def _fixup_module_metadata(module_name: str, namespace: dict[str, Any]) -> None:
    """Make public names report their public module (``cpl.PlanFailure``, not
    ``cpl._failures.PlanFailure``) in reprs, tracebacks, pickles and event logs, as trio's
    ``fixup_module_metadata`` does. Names keep working from the private module too."""
    seen: set[int] = set()

    def fix(name: str, obj: object) -> None:
        if id(obj) in seen:
            return
        seen.add(id(obj))
        mod = getattr(obj, "__module__", None)
        if isinstance(mod, str) and mod.startswith(module_name + "._"):
            try:
                setattr(obj, "__module__", module_name)  # noqa: B010 (any object)
            except (AttributeError, TypeError):  # a builtin or slot-less object
                return
            if isinstance(obj, type):
                for attr_name, attr in vars(obj).items():
                    if callable(attr) and getattr(attr, "__module__", None) == mod:
                        fix(attr_name, attr)

    for name in namespace.get("__all__", ()):
        fix(name, namespace[name])


_fixup_module_metadata(__name__, globals())
del _fixup_module_metadata
