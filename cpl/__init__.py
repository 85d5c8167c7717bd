"""cpl: CRAM's concurrent plan language on asyncio.

Plans are async functions; forms (``seq``, ``par``, ``pursue``, ``try_all``,
``try_in_order``, ``par_loop``, ``partial_order``) compose them into a recorded task tree;
failures are plan failures handled with ``with_failure_handling`` and retry counters;
evaporation (cancellation) always lets cleanup run. Everything public is here; the
modules behind it are private.
"""

from ._cleanup import cleanup_failures
from ._clock import Clock, ScaledClock, SystemClock, current_clock
from ._eventlog import EventLog, load_events, tree_from_log, truncated_tail
from ._failure_handling import RetryCounter, retry, return_, with_failure_handling, with_retry
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
from ._forms import Tagged, par, par_loop, partial_order, pursue, seq, tag, try_all, try_in_order
from ._instruments import Instrument
from ._lazy import LazyList
from ._plan import Plan, PlanCall, plan
from ._queries import ancestors, find_tasks, previous_sibling, walk
from ._runtime import RunHistory, run, task_tree, top_level
from ._status import Status
from ._suspension import on_suspension, with_task_suspended
from ._task import Task, current_task, spawn, with_task
from ._tree import FailureInfo, TaskNode, snapshot
from ._waiting import shielded, sleep

__all__ = [
    "Clock",
    "CompositeFailure",
    "Evaporated",
    "EventLog",
    "FailureInfo",
    "Fluent",
    "Instrument",
    "LazyList",
    "Plan",
    "PlanCall",
    "PlanFailure",
    "RetryCounter",
    "RunHistory",
    "ScaledClock",
    "Status",
    "SystemClock",
    "Tagged",
    "Task",
    "TaskNode",
    "ancestors",
    "cleanup_failures",
    "current_clock",
    "current_task",
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
    "par",
    "par_loop",
    "partial_order",
    "plan",
    "previous_sibling",
    "pulsed",
    "pursue",
    "retry",
    "return_",
    "run",
    "seq",
    "shielded",
    "sleep",
    "snapshot",
    "spawn",
    "tag",
    "task_tree",
    "top_level",
    "tree_from_log",
    "truncated_tail",
    "try_all",
    "try_in_order",
    "wait_for",
    "walk",
    "whenever",
    "with_failure_handling",
    "with_retry",
    "with_task",
    "with_task_suspended",
]
