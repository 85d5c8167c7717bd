"""A JSON-lines event log of runs, and rebuilding task trees from it.

:class:`EventLog` is an instrument: pass it to ``cpl.run(fn, instruments=[EventLog(p)])``
and every task creation and status change of the run becomes one JSON object per line::

    {"schema": "aiocram.events/1", "event": "task-started", "t": 0.25,
     "path": ["demo", "fetching"], "parent": ["demo"], "name": "fetching", ...}

Events: ``run-started`` (the top-level task), ``task-started`` (a task was created; it
is CREATED and may start later), ``task-status`` (RUNNING or SUSPENDED), ``task-finished``
(a dead status, with result, failure or evaporation), ``fluent-changed`` (only with
``fluents=True``), ``subtree`` (a finished child's whole subtree in one event, as
:class:`cpl.StreamFinished` writes them: ``nodes`` in :meth:`cpl.TaskNode.to_dict`'s
layout) and ``run-finished`` (the top level and its subtree are dead). ``t`` is
the event loop's clock. Values are the short strings of :mod:`cpl._tree`'s snapshots, so
:func:`tree_from_log` rebuilds exactly the tree :func:`cpl._tree.snapshot` would give at
the end of the run (except ``waiting_on``, which is not logged).
"""

from __future__ import annotations

import asyncio
import json
import logging
import math
import os
import time
import weakref
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import IO, TYPE_CHECKING, Any

from ._instruments import Instrument
from ._status import Status
from ._tree import TaskLike, TaskNode, _node_from_record, jsonable, path_entry, task_fields

if TYPE_CHECKING:
    from ._fluents import Fluent
    from ._task import Task

__all__ = ["EVENT_SCHEMA", "EventLog", "load_events", "tree_from_log", "truncated_tail"]

EVENT_SCHEMA = "aiocram.events/1"
"""Version tag written in every event line."""

_JSON_SEPARATORS = (",", ":")


def _now() -> float:
    try:
        return asyncio.get_running_loop().time()
    except RuntimeError:
        return time.monotonic()


def _record_json(fields: Mapping[str, Any]) -> dict[str, Any]:
    """The JSON form of :func:`cpl._tree.task_fields` output (without the name/kind)."""
    failure = fields["failure"]
    by = fields["evaporated_by"]
    full = {
        "status": fields["status"].value,
        "start_time": fields["start_time"],
        "end_time": fields["end_time"],
        "result": fields["result"],
        "failure": failure.to_dict() if failure is not None else None,
        "evaporated_by": list(by) if by is not None else None,
        "reason": fields["evaporation_reason"],
        "annotations": fields["annotations"],
    }
    # Unset fields are left out: a reader keeps a task's last reported value per field.
    return {k: v for k, v in full.items() if v is not None and v != {}}


def _subtree_json(fields: Mapping[str, Any]) -> dict[str, Any]:
    """``{"subtree": "imagined"}`` for a marked reasoning subtree (:class:`cpl.Subtree`);
    nothing for an ordinary task (its line is as before the mark existed)."""
    mark = fields["subtree"]
    return {} if mark is None else {"subtree": mark.value}


class EventLog(Instrument):
    """Instrument that writes a run's events as JSON lines.

    ``target`` is a path (the file is opened in append mode for each run and closed when
    the run finishes, so one file can hold many runs), a text stream (written and
    flushed, never closed) or a :class:`logging.Logger` (one record per event, at
    ``level``). ``fluents=True`` also logs every fluent change.
    """

    def __init__(
        self,
        target: str | os.PathLike[str] | IO[str] | logging.Logger,
        *,
        fluents: bool = False,
        level: int = logging.INFO,
    ) -> None:
        self._target = target
        self._fluents = fluents
        self._level = level
        self._file: IO[str] | None = None
        # Where each live task was last reported: detects re-parenting and spares
        # walking up the tree for each status change.
        self._paths: weakref.WeakKeyDictionary[Any, tuple[str, ...]] = weakref.WeakKeyDictionary()

    def __repr__(self) -> str:
        return f"EventLog({self._target!r}, fluents={self._fluents})"

    # ------------------------------------------------------------------ output

    def _emit(self, event: dict[str, Any]) -> None:
        line = json.dumps(
            {"schema": EVENT_SCHEMA, **event}, separators=_JSON_SEPARATORS, default=str
        )
        target = self._target
        if isinstance(target, logging.Logger):
            target.log(self._level, "%s", line)
            return
        if isinstance(target, str | os.PathLike):
            if self._file is None:
                self._file = open(target, "a", encoding="utf-8", buffering=1)
            self._file.write(line + "\n")
            return
        target.write(line + "\n")

    def flush(self) -> None:
        """Push buffered lines out."""
        if self._file is not None:
            self._file.flush()
        elif not isinstance(self._target, str | os.PathLike | logging.Logger):
            self._target.flush()

    def close(self) -> None:
        """Close the file this log opened (streams and loggers are left alone)."""
        if self._file is not None:
            self._file.close()
            self._file = None

    def __enter__(self) -> EventLog:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------------ hooks

    def _known(self, task: TaskLike) -> tuple[str, ...] | None:
        try:
            return self._paths.get(task)
        except TypeError:  # not weak-referenceable
            return None

    def _path(self, task: TaskLike) -> tuple[str, ...]:
        known = self._known(task)
        return known if known is not None else tuple(task.path)

    def _remember(self, task: TaskLike, path: tuple[str, ...]) -> None:
        try:
            self._paths[task] = path
        except TypeError:
            pass

    def run_started(self, root: Task) -> None:
        path = tuple(root.path)
        self._remember(root, path)
        fields = task_fields(root, path)
        self._emit(
            {
                "event": "run-started",
                "t": _now(),
                "path": list(path),
                "parent": None,
                "name": fields["name"],
                "kind": fields["kind"],
                **_subtree_json(fields),
                **({"arguments": fields["arguments"]} if fields["arguments"] else {}),
                **_record_json(fields),
            }
        )

    def task_spawned(self, task: Task) -> None:
        parent = task.parent
        old = self._known(task)
        if parent is not None:
            parent_path = self._path(parent)
            path = (*parent_path, path_entry(task))
        else:
            parent_path = None
            path = tuple(task.path)
        self._remember(task, path)
        fields = task_fields(task, path)
        event: dict[str, Any] = {
            "event": "task-started",
            "t": _now(),
            "path": list(path),
            "parent": list(parent_path) if parent_path is not None else None,
            "name": fields["name"],
            "kind": fields["kind"],
            **_subtree_json(fields),
            **({"arguments": fields["arguments"]} if fields["arguments"] else {}),
            **_record_json(fields),
        }
        if old is not None and old != path:
            event["moved_from"] = list(old)
        self._emit(event)

    def task_status_changed(self, task: Task, old: Status, new: Status) -> None:
        path = self._path(task)
        if new.dead:
            fields = task_fields(task, path)
            self._emit(
                {"event": "task-finished", "t": _now(), "path": list(path), **_record_json(fields)}
            )
        else:
            self._emit(
                {
                    "event": "task-status",
                    "t": _now(),
                    "path": list(path),
                    "status": new.value,
                    "old": old.value,
                    "start_time": task.start_time,
                }
            )

    def subtree(self, task: TaskLike) -> None:
        """Write ``task``'s whole (finished) subtree as one ``subtree`` event: its
        :meth:`~cpl.TaskNode.to_dict` nodes below ``parent`` (what
        :class:`cpl.StreamFinished` writes for each child it retires)."""
        from ._tree import snapshot

        path = tuple(task.path)
        self._emit(
            {
                "event": "subtree",
                "t": _now(),
                "path": list(path),
                "parent": list(path[:-1]),
                "nodes": snapshot(task).to_dict()["nodes"],
            }
        )

    def fluent_changed(self, fluent: Fluent[Any], value: Any) -> None:
        if not self._fluents:
            return
        self._emit(
            {
                "event": "fluent-changed",
                "t": _now(),
                "fluent": str(getattr(fluent, "name", "fluent")),
                "value": jsonable(value),
            }
        )

    def run_finished(self, root: Task) -> None:
        path = self._path(root)
        try:
            self._emit(
                {
                    "event": "run-finished",
                    "t": _now(),
                    "path": list(path),
                    **_record_json(task_fields(root, path)),
                }
            )
            self.flush()
        finally:
            self.close()
            self._paths.clear()


# --------------------------------------------------------------------------- reading


def _check_schema(event: Mapping[str, Any], where: str) -> None:
    schema = event.get("schema")
    if schema != EVENT_SCHEMA:
        raise ValueError(
            f"{where}: unsupported event schema {schema!r}; this aiocram reads {EVENT_SCHEMA!r}"
        )


def load_events(path: str | os.PathLike[str]) -> list[dict[str, Any]]:
    """The events of a log file, in order.

    Lines written through a logger may carry a prefix from the handler's format: the JSON
    object is taken from the first ``{``. Blank lines and lines without a JSON object are
    skipped; a JSON object with a foreign ``schema`` raises ``ValueError`` naming it. A
    last line cut mid-write (no line end, not valid JSON: how the log of a crashed or
    killed run ends) is left out; :func:`truncated_tail` tells whether there is one. A
    malformed line anywhere else raises ``ValueError`` naming the line.
    """
    return [event for _lineno, event in _load_numbered(path)]


def _read_lines(path: str | os.PathLike[str]) -> list[str]:
    """The lines of a log file; a binary file is a ``ValueError`` saying so (not a codec
    error), a folder an ``IsADirectoryError``."""
    with open(path, "rb") as f:
        data = f.read()
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ValueError(
            f"not a text file: byte {exc.start} (0x{data[exc.start]:02x}) is not UTF-8 text; "
            "an event log is JSON lines"
        ) from None
    if "\x00" in text:
        raise ValueError(
            f"not a text file: it holds a NUL byte (at {text.index(chr(0))}); an event log "
            "is JSON lines"
        )
    return text.splitlines(keepends=True)


def _load_numbered(path: str | os.PathLike[str]) -> list[tuple[int, dict[str, Any]]]:
    """:func:`load_events` with each event's line number."""
    events: list[tuple[int, dict[str, Any]]] = []
    lines = _read_lines(path)
    cut = _cut_line(lines)
    for lineno, line in enumerate(lines, 1):
        start = line.find("{")
        if start < 0:
            continue
        where = f"{os.fspath(path)}:{lineno}"
        try:
            event = json.loads(line[start:])
        except json.JSONDecodeError as exc:
            if lineno == cut:
                continue
            if start == 0:
                raise ValueError(f"{where}: not a JSON event line: {exc}") from exc
            continue
        except RecursionError:
            raise ValueError(f"{where}: JSON nested too deeply to be an event") from None
        except ValueError as exc:  # e.g. an integer of more than 4300 digits
            raise ValueError(f"{where}: not a JSON event line: {exc}") from None
        if not isinstance(event, dict):
            continue
        _check_schema(event, where)
        events.append((lineno, event))
    return events


def _cut_line(lines: list[str]) -> int | None:
    """The number of the last line if it was cut mid-write: no line end and no complete
    JSON object."""
    if not lines or lines[-1].endswith("\n"):
        return None
    last = lines[-1]
    start = last.find("{")
    if start < 0:
        return None
    try:
        json.loads(last[start:])
    except (json.JSONDecodeError, RecursionError):
        return len(lines)
    except ValueError:
        return None  # complete, but not an event: load_events says why
    return None


def truncated_tail(path: str | os.PathLike[str]) -> int | None:
    """The line number of a log file's last line if it was cut mid-write (see
    :func:`load_events`, which leaves it out), else ``None``."""
    return _cut_line(_read_lines(path))


def _names(value: Any) -> bool:
    return isinstance(value, list) and all(isinstance(v, str) for v in value)


def _finite(value: Any) -> bool:
    if isinstance(value, bool) or not isinstance(value, int | float):
        return False
    try:
        return math.isfinite(value)
    except OverflowError:  # an int too large for a float
        return False


_STATUS_VALUES: frozenset[str] = frozenset(s.value for s in Status)

#: What each field of a tree event must be, if present: (test, what to say).
_FIELD_CHECKS: dict[str, tuple[Any, str]] = {
    "parent": (lambda v: v is None or (_names(v) and v), "null or a list of task names"),
    "moved_from": (lambda v: v is None or (_names(v) and v), "null or a list of task names"),
    "name": (lambda v: isinstance(v, str), "a string"),
    "kind": (lambda v: isinstance(v, str), "a string"),
    "status": (lambda v: v in _STATUS_VALUES, "one of " + ", ".join(s.value for s in Status)),
    "start_time": (lambda v: v is None or _finite(v), "null or a finite number"),
    "end_time": (lambda v: v is None or _finite(v), "null or a finite number"),
    "arguments": (lambda v: v is None or isinstance(v, dict), "null or an object"),
    "annotations": (lambda v: v is None or isinstance(v, dict), "null or an object"),
    "failure": (
        lambda v: (
            v is None
            or (
                isinstance(v, dict)
                and all(isinstance(v.get(k), str) for k in ("type", "cram_name", "message"))
                and isinstance(v.get("details") or {}, dict)
            )
        ),
        "null or a failure object (type, cram_name, message: strings; details: an object)",
    ),
    "evaporated_by": (lambda v: v is None or _names(v), "null or a list of task names"),
    "reason": (lambda v: v is None or isinstance(v, str), "null or a string"),
}


def _check_event(ev: Mapping[str, Any], where: str) -> None:
    """``ValueError`` naming ``where`` and the field when a tree event is malformed."""
    path = ev.get("path")
    if not (_names(path) and path):
        raise ValueError(f"{where}: 'path' must be a non-empty list of task names, got {path!r}")
    for key, (test, what) in _FIELD_CHECKS.items():
        if key in ev and not test(ev[key]):
            raise ValueError(f"{where}: {key!r} must be {what}, got {ev[key]!r}")
    if ev.get("event") == "run-started" and "status" not in ev:
        raise ValueError(f"{where}: a run-started event needs a 'status'")


def _add_subtree(
    ev: Mapping[str, Any],
    records: dict[tuple[str, ...], dict[str, Any]],
    children: dict[tuple[str, ...], list[tuple[str, ...]]],
) -> None:
    """Add a ``subtree`` event's nodes below its parent (replacing what the log said of
    that subtree before: a task's last report wins)."""
    parent = tuple(ev.get("parent") or ())
    nodes = ev.get("nodes")
    if parent not in records or not isinstance(nodes, list) or not nodes:
        raise ValueError(
            f"event log is inconsistent: subtree {'/'.join(ev['path'])!r} under unknown "
            f"parent {parent!r} or without nodes"
        )
    paths: list[tuple[str, ...]] = []
    for i, node in enumerate(nodes):
        path = tuple(node["path"])
        index = node.get("parent")
        up = parent if i == 0 else paths[index]
        paths.append(path)
        if path not in records:
            children[up].append(path)
        else:  # reported before (a full event log in the same file): start it afresh
            stack = list(children.get(path, ()))
            while stack:
                gone = stack.pop()
                stack.extend(children.pop(gone, ()))
                records.pop(gone, None)
        records[path] = {**node, "parent": up, "path": path}
        children[path] = []


_STATE_KEYS = (
    "status",
    "start_time",
    "end_time",
    "result",
    "failure",
    "evaporated_by",
    "annotations",
)


def tree_from_log(
    source: str | os.PathLike[str] | Iterable[Mapping[str, Any]], *, run: int = -1
) -> TaskNode:
    """Rebuild the task tree of one run (the last by default) from its events.

    ``source`` is a log file or the events themselves. The tree shows each task as last
    reported, so the log of an interrupted run gives the tree at the interruption.

    A damaged log (a field of the wrong type, a missing path, a time that is not a finite
    number, a task moved under itself) is a ``ValueError`` naming the line (or event
    index) and the field, never a ``KeyError``/``TypeError`` from deep inside.
    """
    events: list[Mapping[str, Any]]
    wheres: list[str]
    if isinstance(source, str | os.PathLike):
        numbered = _load_numbered(Path(source))
        events = [ev for _n, ev in numbered]
        wheres = [f"{os.fspath(source)}:{n}" for n, _ev in numbered]
    else:
        events = list(source)
        wheres = [f"event {i}" for i in range(len(events))]
        for ev, where in zip(events, wheres):
            if not isinstance(ev, Mapping):
                raise ValueError(f"{where}: an event is a JSON object, got {type(ev).__name__}")
            _check_schema(ev, where)
    starts = [i for i, ev in enumerate(events) if ev.get("event") == "run-started"]
    if not starts:
        raise ValueError("the event log holds no run (no 'run-started' event)")
    try:
        first = starts[run]
    except IndexError:
        raise ValueError(
            f"run index {run} out of range: the log holds {len(starts)} run(s)"
        ) from None
    following = [i for i in starts if i > first]
    end = following[0] if following else len(events)

    records: dict[tuple[str, ...], dict[str, Any]] = {}
    children: dict[tuple[str, ...], list[tuple[str, ...]]] = {}
    root_path: tuple[str, ...] | None = None
    for ev, where in zip(events[first:end], wheres[first:end]):
        kind = ev.get("event")
        if kind not in (
            "run-started",
            "task-started",
            "task-status",
            "task-finished",
            "run-finished",
            "subtree",
        ):
            continue
        _check_event(ev, where)
        path = tuple(ev["path"])
        if kind == "subtree":
            _add_subtree(ev, records, children)
            continue
        if kind in ("run-started", "task-started"):
            moved = ev.get("moved_from")
            if moved is not None:
                moved_path = tuple(moved)
                old = records.pop(moved_path, None)
                if old is not None and old["parent"] is not None:
                    children[old["parent"]].remove(moved_path)
                children.pop(moved_path, None)
            parent = tuple(ev["parent"]) if ev.get("parent") is not None else None
            if kind == "run-started":
                root_path = path
                parent = None
            elif parent is None or parent not in records:
                raise ValueError(
                    f"{where}: event log is inconsistent: task {'/'.join(path)!r} started "
                    f"under unknown parent {parent!r}"
                )

            if path not in records:
                records[path] = {"path": path, "parent": parent}
                children[path] = []
                if parent is not None:
                    children[parent].append(path)
            record = records[path]
            record["name"] = ev.get("name", path[-1] if path else "")
            record["kind"] = ev.get("kind", "task")
            record["subtree"] = ev.get("subtree")
            record["arguments"] = ev.get("arguments") or {}
        elif path not in records:
            raise ValueError(
                f"{where}: event log is inconsistent: {kind} for unknown task {path!r}"
            )
        record = records[path]
        for key in _STATE_KEYS:
            if key in ev:
                record[key] = ev[key]
        if "reason" in ev:
            record["evaporation_reason"] = ev["reason"]
    assert root_path is not None
    if root_path not in records:
        raise ValueError("event log is inconsistent: its top-level task was moved away")

    # Rebuild bottom-up without recursion: reverse pre-order puts children first.
    order: list[tuple[str, ...]] = []
    stack = [root_path]
    seen: set[tuple[str, ...]] = set()
    while stack:
        p = stack.pop()
        if p in seen:  # a task moved under its own descendant
            raise ValueError(
                f"event log is inconsistent: task {'/'.join(p)!r} is its own ancestor (a cycle "
                "of parent links)"
            )
        seen.add(p)
        order.append(p)
        stack.extend(reversed(children[p]))
    if len(order) != len(records):
        lost = len(records) - len(order)
        raise ValueError(
            f"event log is inconsistent: {lost} task{'s' if lost > 1 else ''} cut off from the "
            "top-level task (a task moved under its own descendant: a cycle of parent links)"
        )
    built: dict[tuple[str, ...], TaskNode] = {}
    for p in reversed(order):
        kids = tuple(built.pop(c) for c in children[p])
        built[p] = _node_from_record(records[p], kids)
    return built[root_path]
