"""cpl: CRAM's concurrent plan language on asyncio.

Plans are async functions; forms (``seq``, ``par``, ``pursue``, ``try_all``,
``try_in_order``, ``par_loop``, ``partial_order``) compose them into a recorded task tree;
failures are plan failures handled with ``with_failure_handling`` and retry counters;
evaporation (cancellation) always lets cleanup run. Everything public is here; the
modules behind it are private.
"""

from ._failure_handling import RetryCounter, retry, return_, with_failure_handling, with_retry
from ._failures import CompositeFailure, Evaporated, PlanFailure, fail
from ._fluents import Fluent
from ._forms import Tagged, par, par_loop, partial_order, pursue, seq, tag, try_all, try_in_order
from ._instruments import Instrument
from ._plan import Plan, PlanCall, plan
from ._runtime import RunHistory, run, task_tree, top_level
from ._status import Status
from ._suspension import on_suspension, with_task_suspended
from ._task import Task, current_task, spawn, with_task
from ._waiting import shielded, sleep

__all__ = [
    "CompositeFailure",
    "Evaporated",
    "Fluent",
    "Instrument",
    "Plan",
    "PlanCall",
    "PlanFailure",
    "RetryCounter",
    "RunHistory",
    "Status",
    "Tagged",
    "Task",
    "current_task",
    "fail",
    "on_suspension",
    "par",
    "par_loop",
    "partial_order",
    "plan",
    "pursue",
    "retry",
    "return_",
    "run",
    "seq",
    "shielded",
    "sleep",
    "spawn",
    "tag",
    "task_tree",
    "top_level",
    "try_all",
    "try_in_order",
    "with_failure_handling",
    "with_retry",
    "with_task",
    "with_task_suspended",
]
