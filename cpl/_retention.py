"""Retention policies: how much of a run's recorded task tree stays in memory.

A robot's executive may run for hours in one top level (a service loop, a shift of table
setting): if the tree kept every task it ever ran, with its designators and their
solution streams, the heap would grow with the run, and so would every full garbage
collection's stop-the-world pause. A policy, chosen per run (``cpl.run(...,
retention=...)`` / ``cpl.top_level``), bounds what stays:

- :class:`KeepAll`: every task, live, for good (the default: tests, the demo, short runs);
- :class:`KeepRecent`: the newest ``full`` finished children of the top level stay whole;
  older ones are replaced by a compact record each (name, status, times, failure,
  arguments, annotations as short strings; the size of the subtree it stood for), at
  most ``records`` of them (the oldest beyond are only counted);
- :class:`StreamFinished`: the newest ``full`` finished children stay whole; older ones
  are written, whole, to a JSON-lines log (one ``subtree`` event each, read back by
  :func:`cpl.tree_from_log` and ``aiocram show``) and only counted in memory.

Only the *top level's direct children* are retired, once they and their subtree are dead:
a service loop performing one action after another makes one child per action. Tasks
still alive are never touched. A retired task that a plan still holds keeps its own
fields (status, result, failure, times, parent, path) but no longer lists its children:
the tree's links are cut so that the retired subtree is freed by reference counting, not
left for a full collection. What a plan needs after an action ended (the designator,
to ask ``next_solution()``) is the plan's own variable, never the tree.

Queries see what is retained: :func:`cpl.walk` / :func:`cpl.find_tasks` (and the
executive's ``performed``) walk the live tasks kept in full; :func:`cpl.snapshot`, the
live view and ``aiocram show`` also show the compact records (as childless
:class:`cpl.TaskNode` values, oldest first, before the children kept in full) and count
what was dropped in the root's ``collapsed``; :func:`retired` and :func:`retention_summary`
read the records and the counts.

The records are plain tuples of strings, numbers and ``None`` (nested tuples alike), so
the cyclic garbage collector stops tracking them: a full collection does not scan them,
and its pause stays flat however long the run. ``freeze=True`` also moves the heap the
run starts with (imported modules, worlds and robots built before it) out of the
collector's sight (``gc.freeze()``, undone at the run's end), so a full collection scans
only what the run itself keeps: a few hundred kept tasks, not the whole program.

Deliberate difference from CRAM: CRAM keeps the whole task tree of a top level for its
lifetime (``*top-level-task-trees*``); a robot running all day cannot afford that, so a
run chooses what to keep.
"""

from __future__ import annotations

import abc
import gc
import os
from collections import deque
from collections.abc import Mapping
from dataclasses import dataclass
from typing import IO, TYPE_CHECKING, Any

from ._cleanup import log_cleanup_failures
from ._instruments import Instrument
from ._status import Status
from ._tree import FailureInfo, TaskNode, _one_line, failure_info, short_repr

if TYPE_CHECKING:
    from ._eventlog import EventLog
    from ._task import Task

__all__ = [
    "KeepAll",
    "KeepRecent",
    "Retention",
    "RetentionSummary",
    "StreamFinished",
    "retention_summary",
    "retired",
]

_HIDEABLE = frozenset({Status.SUCCEEDED, Status.EVAPORATED})

# A compact record: a plain tuple (untracked by the collector once it has seen it).
# (entry, name, kind, status value, start, end, size, arguments, result, failure,
#  evaporated_by, evaporation_reason, annotations, failed_below)
_Record = tuple[Any, ...]


class Retention(abc.ABC):
    """Base class of the retention policies (immutable configuration; the state of one
    run lives in the retainer :meth:`_start` makes for it)."""

    __slots__ = ()

    @abc.abstractmethod
    def _start(self, root: Task) -> _Retainer | None:
        """The retainer of the run whose top level is ``root`` (``None``: keep all)."""

    def __repr__(self) -> str:
        return f"cpl.{type(self).__name__}()"


class KeepAll(Retention):
    """Keep every task of the run, live, for good (the default)."""

    __slots__ = ()

    def _start(self, root: Task) -> _Retainer | None:
        return None


def _check_count(what: str, value: Any, *, allow_none: bool) -> None:
    if value is None and allow_none:
        return
    if type(value) is not int or value < 0:
        more = " or None (no bound)" if allow_none else ""
        raise TypeError(f"{what} must be an int >= 0{more}, got {value!r}")


def _check_flag(what: str, value: Any) -> None:
    if type(value) is not bool:
        raise TypeError(f"{what} must be True or False, got {value!r}")


class KeepRecent(Retention):
    """Keep the newest ``full`` finished top-level children whole, older ones as compact
    records (at most ``records`` of them, the newest; ``None``: all, which grows by about
    0.65 KB per retired perform of an action, its designator shown as a short string)."""

    __slots__ = ("freeze", "full", "records")

    def __init__(
        self, full: int = 100, *, records: int | None = None, freeze: bool = False
    ) -> None:
        _check_count("KeepRecent(full=...)", full, allow_none=False)
        _check_count("KeepRecent(records=...)", records, allow_none=True)
        _check_flag("KeepRecent(freeze=...)", freeze)
        self.full = full  # finished top-level children kept whole
        self.records = records  # compact records kept (None: unbounded)
        self.freeze = freeze  # gc.freeze() the heap the run starts with (see _Retainer)

    def __repr__(self) -> str:
        return f"cpl.KeepRecent({self.full}, records={self.records!r}, freeze={self.freeze})"

    def _start(self, root: Task) -> _Retainer:
        return _Retainer(root, self.full, self.records, None, self.freeze)


class StreamFinished(Retention):
    """Keep the newest ``full`` finished top-level children whole; write older ones to
    ``target`` (a path, opened in append mode, or a text stream) as ``subtree`` events and
    keep only their counts. At the end of the run the children still kept are written
    too, so the log holds the whole tree (``aiocram show LOG``)."""

    __slots__ = ("freeze", "full", "target")

    def __init__(
        self, target: str | os.PathLike[str] | IO[str], *, full: int = 100, freeze: bool = False
    ) -> None:
        _check_count("StreamFinished(full=...)", full, allow_none=False)
        _check_flag("StreamFinished(freeze=...)", freeze)
        if not isinstance(target, str | os.PathLike) and not hasattr(target, "write"):
            raise TypeError(
                f"StreamFinished needs a path or a text stream to write to, got {target!r}"
            )
        self.target = target
        self.full = full
        self.freeze = freeze

    def __repr__(self) -> str:
        return f"cpl.StreamFinished({self.target!r}, full={self.full}, freeze={self.freeze})"

    def _start(self, root: Task) -> _Retainer:
        from ._eventlog import EventLog

        return _Retainer(root, self.full, 0, EventLog(self.target), self.freeze)


@dataclass(frozen=True, slots=True)
class RetentionSummary:
    """What a run's retention policy took out of the live tree so far.

    ``retired`` top-level children (``tasks`` tasks in all, their subtrees included), by
    status (``by_status``: status value -> count); ``records`` of them are kept as compact
    records, ``dropped`` only counted (``streamed`` of those were written to the log).
    """

    retired: int = 0
    tasks: int = 0
    by_status: Mapping[str, int] | None = None
    records: int = 0
    dropped: int = 0
    streamed: int = 0


class _Retainer(Instrument):
    """The retention state of one run: told of every finished top-level child."""

    def __init__(
        self,
        root: Task,
        full: int,
        max_records: int | None,
        log: EventLog | None,
        freeze: bool = False,
    ) -> None:
        self.root = root
        self.freeze = freeze
        # Invariant: True while this run holds the heap frozen (it froze it, and will
        # unfreeze it at its end; a heap frozen by the caller before is left frozen).
        self.froze = False
        self.full = full
        self.max_records = max_records
        self.log = log
        # Invariant: the finished children of root still kept whole, oldest first.
        self.finished: deque[Task] = deque()
        # Invariant: the compact records (plain tuples), oldest first; at most max_records.
        self.records: deque[_Record] = deque()
        # Invariant: tasks (subtree sizes summed) standing behind self.records, and those
        # of the records whose subtree is folded away without failure (collapsible).
        self.record_tasks = 0
        self.record_hideable_tasks = 0
        self.records_shown = 0  # records with a failure: those a collapsing view shows
        # Invariant: children retired and not kept as records, and their tasks.
        self.dropped = 0
        self.dropped_tasks = 0
        self.streamed = 0
        self.retired = 0
        self.by_status: dict[str, int] = {}

    # ----------------------------------------------------------------- hooks
    def run_started(self, root: Task) -> None:
        if self.freeze and gc.get_freeze_count() == 0:
            # Everything alive now (modules, worlds, robots built before the run) lives as
            # long as the run: full collections need not scan it again and again.
            gc.collect()
            gc.freeze()
            self.froze = True
        if self.log is not None:
            self.log.run_started(root)

    def task_status_changed(self, task: Task, old: Status, new: Status) -> None:
        if task.parent is not self.root or not new.dead:
            return
        self.finished.append(task)
        while len(self.finished) > self.full:
            self._retire(self.finished.popleft())

    def run_finished(self, root: Task) -> None:
        if self.froze:
            self.froze = False
            gc.unfreeze()
        log = self.log
        if log is None:
            return
        try:
            for task in root.children:
                log.subtree(task)
            log.run_finished(root)
        finally:
            log.close()

    # ----------------------------------------------------------------- retiring
    def _retire(self, task: Task) -> None:
        failed_below = 0
        cleanup_failed = False
        subtree = [task]
        i = 0
        while i < len(subtree):
            t = subtree[i]
            i += 1
            if t._state.alive:
                return  # cannot happen for a finished child (its subtree is torn down)
            if t._state is Status.FAILED:
                if t is not task:
                    failed_below += 1
                if t.evaporation is not None and t.failure is not None:
                    cleanup_failed = True
            if t._children:
                subtree.extend(t._children)
        size = len(subtree)
        if cleanup_failed:
            # logged now, as the run's end would have (it will not see this subtree)
            log_cleanup_failures(task)
        children = self.root._children
        if children is None:
            return
        try:
            children.remove(task)
        except ValueError:
            return  # moved elsewhere meanwhile
        if self.log is not None:
            self.log.subtree(task)
        # Unlink the subtree (each task keeps its parent, no task its children): the
        # parent <-> children cycles were all that kept a finished subtree, with its
        # designators and their solution streams, for the cyclic collector; now reference
        # counting frees it as soon as no plan holds a part of it.
        # A dead task's asyncio task is done; its context names the task: cut that too.
        for t in subtree:
            t._children = None
            t._atask = None
        status = task._state.value
        self.by_status[status] = self.by_status.get(status, 0) + 1
        self.retired += 1
        if self.log is not None:
            self.streamed += 1
            self._drop(size)
            return
        record = _record(task, size, failed_below)
        self.records.append(record)
        self.record_tasks += size
        if _hideable(record):
            self.record_hideable_tasks += size
        else:
            self.records_shown += 1
        if self.max_records is not None:
            while len(self.records) > self.max_records:
                old = self.records.popleft()
                self.record_tasks -= old[6]
                if _hideable(old):
                    self.record_hideable_tasks -= old[6]
                else:
                    self.records_shown -= 1
                self._drop(old[6])

    def _drop(self, size: int) -> None:
        self.dropped += 1
        self.dropped_tasks += size

    # ----------------------------------------------------------------- reading
    def summary(self) -> RetentionSummary:
        return RetentionSummary(
            retired=self.retired,
            tasks=self.record_tasks + self.dropped_tasks,
            by_status=dict(self.by_status),
            records=len(self.records),
            dropped=self.dropped,
            streamed=self.streamed,
        )

    def nodes(self, parent_path: tuple[str, ...], *, only_failed: bool) -> list[TaskNode]:
        """The records as childless TaskNodes (oldest first); ``only_failed``: only those
        that failed or have a failure below."""
        if only_failed and not self.records_shown:
            return []  # a live view's frame need not scan the records
        return [_node(r, parent_path) for r in self.records if not (only_failed and _hideable(r))]


_HIDEABLE_VALUES = frozenset(s.value for s in _HIDEABLE)


def _hideable(record: _Record) -> bool:
    return record[3] in _HIDEABLE_VALUES and not record[13]


_ATOMIC = (str, int, float, bool, type(None))


def _short(value: Any) -> Any:
    return value if type(value) in _ATOMIC else short_repr(value)


def _pairs(mapping: Mapping[str, Any] | None) -> tuple[tuple[str, Any], ...]:
    if not mapping:
        return ()
    return tuple((str(k), _short(v)) for k, v in mapping.items())


def _record(task: Task, size: int, failed_below: int) -> _Record:
    """The compact record of a dead task: only strings, numbers, None and tuples of them
    (what :func:`cpl._tree.task_fields` keeps, with plain values kept as they are)."""
    state = task._state
    failure = task.failure
    evaporation = task.evaporation
    info = failure_info(failure) if failure is not None else None
    return (
        task.path_entry,
        task.name,
        task.kind,
        state.value,
        task.start_time,
        task.end_time,
        size,
        tuple((str(k), short_repr(v)) for k, v in (task.arguments or {}).items()),
        short_repr(task.result) if state is Status.SUCCEEDED else None,
        (
            (info.type, info.cram_name, info.message, tuple(info.details.items()))
            if info is not None
            else None
        ),
        (tuple(evaporation.by) if evaporation is not None and evaporation.by is not None else None),
        _one_line(str(evaporation.reason), 200) if evaporation is not None else None,
        _pairs(task.annotations),
        failed_below,
    )


def _node(r: _Record, parent_path: tuple[str, ...]) -> TaskNode:
    failure = r[9]
    annotations = dict(r[12])
    if r[13]:
        annotations["failures below"] = r[13]
    return TaskNode(
        name=r[1],
        path=(*parent_path, r[0]),
        kind=r[2],
        status=Status(r[3]),
        start_time=r[4],
        end_time=r[5],
        arguments=dict(r[7]),
        result=r[8],
        failure=(
            FailureInfo(failure[0], failure[1], failure[2], dict(failure[3]))
            if failure is not None
            else None
        ),
        evaporated_by=r[10],
        evaporation_reason=r[11],
        annotations=annotations,
        collapsed=r[6] - 1,
    )


def _retainer_of(task: Any) -> _Retainer | None:
    run = getattr(task, "_run", None)
    retainer = getattr(run, "retention", None)
    if retainer is None or retainer.root is not task:
        return None
    assert isinstance(retainer, _Retainer)
    return retainer


def retired(root: Task) -> list[TaskNode]:
    """The compact records of ``root``'s retired children (oldest first), as childless
    :class:`cpl.TaskNode` values whose ``collapsed`` counts the tasks below each; empty
    when the run keeps everything (or for a task that is not a run's top level)."""
    retainer = _retainer_of(root)
    if retainer is None:
        return []
    return retainer.nodes(tuple(root.path), only_failed=False)


def retention_summary(root: Task) -> RetentionSummary:
    """What the retention policy of ``root``'s run took out of its tree so far (all zero
    when the run keeps everything)."""
    retainer = _retainer_of(root)
    return retainer.summary() if retainer is not None else RetentionSummary(by_status={})
