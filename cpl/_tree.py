"""Immutable snapshots of the task tree (CRAM's task tree, reference §1.23).

:func:`snapshot` copies the live tree of :class:`cpl.Task` objects into frozen
:class:`TaskNode` values that are safe to keep, compare, serialise and render after the
run went on or ended. Live objects (arguments, results, failures' details, designators)
are stored as short, stable strings, so a snapshot never holds a reference into the run.

Snapshots are built without recursion (an explicit stack), so trees of 100k tasks and
deep chains of nested plans are fine.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol

from ._status import Status
from ._subtree import Subtree

if TYPE_CHECKING:
    from rich.console import RenderableType

__all__ = [
    "REPR_LIMIT",
    "TREE_SCHEMA",
    "FailureInfo",
    "TaskLike",
    "TaskNode",
    "failure_info",
    "jsonable",
    "path_entry",
    "short_repr",
    "snapshot",
    "task_fields",
]

TREE_SCHEMA = "aiocram.task-tree/1"
"""Version tag of :meth:`TaskNode.to_dict`'s JSON layout."""

REPR_LIMIT = 80
"""Longest repr (in characters) a snapshot keeps of a live object."""

_MESSAGE_LIMIT = 200
_JSON_DEPTH_LIMIT = 16
_HIDEABLE = frozenset({Status.SUCCEEDED, Status.EVAPORATED})


class EvaporationLike(Protocol):
    """What a snapshot reads from :class:`cpl.Evaporated`."""

    @property
    def by(self) -> tuple[str, ...] | None: ...

    @property
    def reason(self) -> str: ...


class TaskLike(Protocol):
    """The attributes of a live :class:`cpl.Task` that :func:`snapshot` reads."""

    @property
    def name(self) -> str: ...

    @property
    def path(self) -> tuple[str, ...]: ...

    @property
    def kind(self) -> str: ...

    @property
    def children(self) -> Sequence[TaskLike]: ...

    @property
    def state(self) -> Status: ...

    @property
    def result(self) -> Any: ...

    @property
    def failure(self) -> BaseException | None: ...

    @property
    def evaporation(self) -> EvaporationLike | None: ...

    @property
    def start_time(self) -> float | None: ...

    @property
    def end_time(self) -> float | None: ...

    @property
    def arguments(self) -> Mapping[str, Any] | None: ...

    @property
    def annotations(self) -> Mapping[str, Any] | None: ...

    @property
    def waiting_on(self) -> str | None: ...


# --------------------------------------------------------------------------- values


def _one_line(text: str, limit: int) -> str:
    text = text.replace("\r", " ").replace("\n", " ")
    return text if len(text) <= limit else text[: limit - 3] + "..."


def short_repr(value: Any, limit: int = REPR_LIMIT) -> str:
    """``repr(value)`` on one line, cut to ``limit`` characters; never raises."""
    try:
        text = repr(value)
    except Exception as exc:  # a broken __repr__ must not break a snapshot
        text = f"<{type(value).__name__} object (repr failed: {type(exc).__name__})>"
    return _one_line(text, limit)


def _short_text(value: Any, limit: int = REPR_LIMIT) -> str:
    return _one_line(value, limit) if isinstance(value, str) else short_repr(value, limit)


class _NotJSON(Exception):
    pass


def _to_json(value: Any, depth: int) -> Any:
    if depth > _JSON_DEPTH_LIMIT:
        raise _NotJSON
    kind = type(value)
    if value is None or kind is bool or kind is int or kind is str:
        return value
    if kind is float:
        if math.isfinite(value):
            return value
        raise _NotJSON
    if kind is list or kind is tuple:
        return [_to_json(v, depth + 1) for v in value]
    if kind is dict:
        out: dict[str, Any] = {}
        for k, v in value.items():
            if type(k) is not str:
                raise _NotJSON
            out[k] = _to_json(v, depth + 1)
        return out
    raise _NotJSON


def jsonable(value: Any, limit: int = REPR_LIMIT) -> Any:
    """``value`` itself if it is plain JSON data (tuples become lists), else its short repr.

    Only exact ``None``/``bool``/``int``/finite ``float``/``str``/``list``/``tuple``/
    ``dict`` (string keys) count, so the result survives a JSON round trip unchanged.
    """
    try:
        return _to_json(value, 0)
    except _NotJSON:
        return short_repr(value, limit)


# --------------------------------------------------------------------------- failures


@dataclass(frozen=True, slots=True)
class FailureInfo:
    """A failure as plain strings.

    ``type`` is the qualified class name, ``cram_name`` the CRAM failure name of executive
    failures (else the class name), ``message`` one line, ``details`` short reprs.
    """

    type: str
    cram_name: str
    message: str
    details: Mapping[str, str] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """This failure as a JSON-able dict."""
        return {
            "type": self.type,
            "cram_name": self.cram_name,
            "message": self.message,
            "details": dict(self.details),
        }

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> FailureInfo:
        """Inverse of :meth:`to_dict`."""
        return cls(
            type=str(d["type"]),
            cram_name=str(d["cram_name"]),
            message=str(d["message"]),
            details={str(k): str(v) for k, v in dict(d.get("details") or {}).items()},
        )

    def __hash__(self) -> int:
        return hash((self.type, self.cram_name, self.message))

    def __str__(self) -> str:
        return f"{self.cram_name}: {self.message}" if self.message else self.cram_name


def failure_info(exc: BaseException) -> FailureInfo:
    """Describe ``exc`` as a :class:`FailureInfo` (never raises)."""
    cls = type(exc)
    module = getattr(cls, "__module__", "") or ""
    qualified = cls.__qualname__ if module == "builtins" else f"{module}.{cls.__qualname__}"
    cram_name = getattr(cls, "cram_name", None)
    message_attr = getattr(exc, "message", None)
    if isinstance(message_attr, str):
        message = message_attr
    else:
        try:
            message = str(exc)
        except Exception:
            message = ""
    raw_details = getattr(exc, "details", None)
    details: dict[str, str] = {}
    if isinstance(raw_details, Mapping):
        details = {str(k): _short_text(v) for k, v in raw_details.items()}
    return FailureInfo(
        type=qualified,
        cram_name=cram_name if isinstance(cram_name, str) else cls.__name__,
        message=_one_line(message, _MESSAGE_LIMIT),
        details=details,
    )


# --------------------------------------------------------------------------- nodes

_Pred = Callable[["TaskNode"], bool]


def _matcher(pred_or_name: str | _Pred) -> _Pred:
    if isinstance(pred_or_name, str):
        name = pred_or_name
        return lambda n: n.name == name
    return pred_or_name


@dataclass(frozen=True, slots=True, eq=False)
class TaskNode:
    """One task of a task-tree snapshot; ``children`` in creation order.

    ``collapsed`` counts finished descendants that a collapsing :func:`snapshot` folded
    away below this node, ``truncated`` descendants left out by a node cap; both are 0 in
    a full snapshot. Equality is structural (and iterative, so deep trees compare fine).
    """

    name: str
    path: tuple[str, ...]
    kind: str
    status: Status
    start_time: float | None = None
    end_time: float | None = None
    arguments: Mapping[str, str] = field(default_factory=dict)
    result: str | None = None
    failure: FailureInfo | None = None
    evaporated_by: tuple[str, ...] | None = None
    evaporation_reason: str | None = None
    annotations: Mapping[str, Any] = field(default_factory=dict)
    waiting_on: str | None = None
    children: tuple[TaskNode, ...] = ()
    collapsed: int = 0
    truncated: int = 0
    #: what the subtree stands for in reasoning (:class:`cpl.Subtree`), else ``None``
    subtree: Subtree | None = None

    # ----------------------------------------------------------------- helpers

    @property
    def duration(self) -> float | None:
        """``end_time - start_time``, or ``None`` while either is unknown."""
        if self.start_time is None or self.end_time is None:
            return None
        return self.end_time - self.start_time

    @property
    def succeeded(self) -> bool:
        return self.status is Status.SUCCEEDED

    @property
    def failed(self) -> bool:
        return self.status is Status.FAILED

    @property
    def evaporated(self) -> bool:
        return self.status is Status.EVAPORATED

    @property
    def alive(self) -> bool:
        return self.status.alive

    def walk(self) -> Iterator[TaskNode]:
        """All nodes of this subtree in pre-order (self first)."""
        stack = [self]
        while stack:
            node = stack.pop()
            yield node
            stack.extend(reversed(node.children))

    def find(self, pred_or_name: str | _Pred) -> TaskNode | None:
        """First node (pre-order) with that name or satisfying the predicate, else None."""
        match = _matcher(pred_or_name)
        return next((n for n in self.walk() if match(n)), None)

    def find_all(self, pred_or_name: str | _Pred) -> list[TaskNode]:
        """All nodes (pre-order) with that name or satisfying the predicate."""
        match = _matcher(pred_or_name)
        return [n for n in self.walk() if match(n)]

    def child(self, name: str) -> TaskNode:
        """The direct child called ``name``; ``KeyError`` if there is none."""
        for c in self.children:
            if c.name == name:
                return c
        names = ", ".join(c.name for c in self.children) or "none"
        raise KeyError(f"{'/'.join(self.path)} has no child {name!r} (children: {names})")

    def by_path(self, path: Sequence[str] | str) -> TaskNode:
        """The node at ``path`` (absolute, or relative to this node; ``"a/b"`` works too)."""
        parts = tuple(path.split("/")) if isinstance(path, str) else tuple(path)
        if parts[: len(self.path)] != self.path:
            parts = self.path + parts
        node = self
        while node.path != parts:
            nxt = None
            for c in node.children:
                if parts[: len(c.path)] == c.path:
                    nxt = c
                    break
            if nxt is None:
                raise KeyError(f"no task at {'/'.join(parts)!r} below {'/'.join(self.path)!r}")
            node = nxt
        return node

    def __len__(self) -> int:
        """Number of nodes in this snapshot subtree."""
        return sum(1 for _ in self.walk())

    # ----------------------------------------------------------------- equality

    def _own(self) -> tuple[Any, ...]:
        return (
            self.name,
            self.path,
            self.kind,
            self.status,
            self.start_time,
            self.end_time,
            dict(self.arguments),
            self.result,
            self.failure,
            self.evaporated_by,
            self.evaporation_reason,
            dict(self.annotations),
            self.waiting_on,
            self.collapsed,
            self.truncated,
            self.subtree,
            len(self.children),
        )

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, TaskNode):
            return NotImplemented
        stack: list[tuple[TaskNode, TaskNode]] = [(self, other)]
        while stack:
            a, b = stack.pop()
            if a is b:
                continue
            if a._own() != b._own():
                return False
            stack.extend(zip(a.children, b.children))
        return True

    def __hash__(self) -> int:
        return hash((self.path, self.status, self.start_time, self.end_time, len(self.children)))

    def __repr__(self) -> str:
        return (
            f"TaskNode(path={'/'.join(self.path)!r}, kind={self.kind!r}, "
            f"status={self.status.name}, children={len(self.children)})"
        )

    def __rich__(self) -> RenderableType:
        from .display import render

        return render(self)

    # ----------------------------------------------------------------- JSON

    def to_dict(self) -> dict[str, Any]:
        """The subtree as JSON-able data: ``{"schema": TREE_SCHEMA, "nodes": [...]}``.

        ``nodes`` lists the tasks in pre-order, each with the index of its ``parent``
        (``None`` for the first); the flat layout keeps deep trees serialisable.
        """
        nodes: list[dict[str, Any]] = []
        stack: list[tuple[TaskNode, int | None]] = [(self, None)]
        while stack:
            node, parent = stack.pop()
            index = len(nodes)
            nodes.append(
                {
                    "parent": parent,
                    "name": node.name,
                    "path": list(node.path),
                    "kind": node.kind,
                    "status": node.status.value,
                    "start_time": node.start_time,
                    "end_time": node.end_time,
                    "arguments": dict(node.arguments),
                    "result": node.result,
                    "failure": node.failure.to_dict() if node.failure else None,
                    "evaporated_by": (
                        list(node.evaporated_by) if node.evaporated_by is not None else None
                    ),
                    "evaporation_reason": node.evaporation_reason,
                    "annotations": dict(node.annotations),
                    "waiting_on": node.waiting_on,
                    "collapsed": node.collapsed,
                    "truncated": node.truncated,
                    "subtree": node.subtree.value if node.subtree is not None else None,
                }
            )
            stack.extend((c, index) for c in reversed(node.children))
        return {"schema": TREE_SCHEMA, "nodes": nodes}

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> TaskNode:
        """Rebuild a tree from :meth:`to_dict` output; ``ValueError`` on a foreign schema."""
        if not isinstance(d, Mapping):
            raise ValueError(f"expected a task-tree dict, got {type(d).__name__}")
        schema = d.get("schema")
        if schema != TREE_SCHEMA:
            raise ValueError(
                f"unsupported task-tree schema {schema!r}; this aiocram reads {TREE_SCHEMA!r}"
            )
        raw = d.get("nodes")
        if not isinstance(raw, list) or not raw:
            raise ValueError("task-tree dict has no 'nodes' list")
        kids: list[list[TaskNode]] = [[] for _ in raw]
        root: TaskNode | None = None
        for i in range(len(raw) - 1, -1, -1):
            item = raw[i]
            parent = item.get("parent")
            if (i == 0) != (parent is None) or (parent is not None and not 0 <= parent < i):
                raise ValueError(f"task-tree node {i} has an invalid parent index {parent!r}")
            kids[i].reverse()
            node = _node_from_record(item, tuple(kids[i]))
            if parent is None:
                root = node
            else:
                kids[parent].append(node)
        assert root is not None
        return root


def _node_from_record(item: Mapping[str, Any], children: tuple[TaskNode, ...]) -> TaskNode:
    """A :class:`TaskNode` from a flat JSON record (``to_dict`` node or event-log state)."""
    failure = item.get("failure")
    by = item.get("evaporated_by")
    try:
        return TaskNode(
            name=str(item["name"]),
            path=tuple(item["path"]),
            kind=str(item.get("kind", "task")),
            status=Status(item["status"]),
            start_time=item.get("start_time"),
            end_time=item.get("end_time"),
            arguments=dict(item.get("arguments") or {}),
            result=item.get("result"),
            failure=FailureInfo.from_dict(failure) if failure else None,
            evaporated_by=tuple(by) if by is not None else None,
            evaporation_reason=item.get("evaporation_reason"),
            annotations=dict(item.get("annotations") or {}),
            waiting_on=item.get("waiting_on"),
            children=children,
            collapsed=int(item.get("collapsed", 0)),
            truncated=int(item.get("truncated", 0)),
            subtree=Subtree.parse(item.get("subtree")),
        )
    except (KeyError, TypeError, ValueError) as exc:
        raise ValueError(f"malformed task record {dict(item)!r}: {exc!r}") from exc


# --------------------------------------------------------------------------- snapshot


def path_entry(task: TaskLike) -> str:
    """The last part of ``task.path`` (``name`` or ``name#n``), in O(1) when the task has
    a ``path_entry`` attribute (``task.path`` walks up to the root)."""
    entry = getattr(task, "path_entry", None)
    return entry if isinstance(entry, str) else task.path[-1]


def task_fields(task: TaskLike, path: tuple[str, ...] | None = None) -> dict[str, Any]:
    """The fields of ``task``'s :class:`TaskNode` except the tree ones, as stable values.

    ``path`` saves reading ``task.path`` when the caller already knows it.
    """
    state = task.state
    evaporation = task.evaporation
    failure = task.failure
    result = task.result
    return {
        "name": task.name,
        "path": tuple(task.path) if path is None else path,
        "kind": task.kind,
        "subtree": getattr(task, "subtree", None),
        "status": state,
        "start_time": task.start_time,
        "end_time": task.end_time,
        "arguments": {str(k): short_repr(v) for k, v in (task.arguments or {}).items()},
        "result": short_repr(result) if state is Status.SUCCEEDED else None,
        "failure": failure_info(failure) if failure is not None else None,
        "evaporated_by": (
            tuple(evaporation.by)
            if evaporation is not None and evaporation.by is not None
            else None
        ),
        "evaporation_reason": (
            _one_line(str(evaporation.reason), _MESSAGE_LIMIT) if evaporation is not None else None
        ),
        "annotations": {str(k): jsonable(v) for k, v in (task.annotations or {}).items()},
        "waiting_on": (
            _one_line(task.waiting_on, _MESSAGE_LIMIT)
            if task.waiting_on is not None and state.alive
            else None
        ),
    }


def _subtree_size(task: TaskLike) -> int:
    if not task.children:
        return 1
    count = 0
    stack = [task]
    while stack:
        t = stack.pop()
        count += 1
        stack.extend(t.children)
    return count


def _finished_size(task: TaskLike) -> int | None:
    """Size of ``task``'s subtree if it may be folded away (see :func:`snapshot`)."""
    if task.state not in _HIDEABLE:
        return None
    count = 0
    stack = [task]
    while stack:
        t = stack.pop()
        if t.state.alive or t.state is Status.FAILED:
            return None  # alive tasks and failures (even recovered ones) stay visible
        count += 1
        stack.extend(t.children)
    return count


def _retained_records(
    task: TaskLike,
    path: tuple[str, ...],
    collapse_finished: bool,
    collapsed: list[int],
) -> list[TaskNode]:
    """When ``task`` is the top level of a run with a retention policy: its compact records
    (only those with a failure when ``collapse_finished``; the others are counted in
    ``collapsed[0]``, as the children the policy dropped)."""
    run = getattr(task, "_run", None)
    retainer = getattr(run, "retention", None)
    if retainer is None or retainer.root is not task:
        return []
    collapsed[0] += retainer.dropped_tasks
    if collapse_finished:
        collapsed[0] += retainer.record_hideable_tasks
    nodes: list[TaskNode] = retainer.nodes(path, only_failed=collapse_finished)
    return nodes


def snapshot(
    task: TaskLike, *, max_nodes: int | None = None, collapse_finished: bool = False
) -> TaskNode:
    """Copy the live subtree of ``task`` into a frozen :class:`TaskNode` tree.

    Pure: reads the tasks, changes nothing. Call it on the event loop (between two awaits
    the tree cannot change). ``collapse_finished`` folds every child subtree that finished
    without any failure in it (status succeeded or evaporated, nothing alive or failed
    below, so also a recovered failure keeps its path visible) into its parent's
    ``collapsed`` count, so failures and alive tasks stay visible. ``max_nodes``
    keeps the first that many tasks in pre-order and counts the rest in ``truncated``.
    Folded and cut subtrees are only counted, not copied.

    Under a retention policy (``cpl.KeepRecent``, ``cpl.StreamFinished``) a snapshot of
    the run's top level shows the compact records of its retired children first (oldest
    first; with ``max_nodes``, at most half the room, the newest) and counts the children
    the policy dropped in the top level's ``collapsed``.
    """
    if max_nodes is not None and max_nodes < 1:
        raise ValueError(f"max_nodes must be at least 1, got {max_nodes}")
    tasks: list[TaskLike] = []
    paths: list[tuple[str, ...]] = []
    parents: list[int] = []
    collapsed: list[int] = []
    truncated: list[int] = []
    stack: list[tuple[TaskLike, int]] = [(task, -1)]
    # the compact records of a retention policy (cpl._retention), shown first below the
    # top of the run; `extra` counts them against max_nodes
    records: list[TaskNode] = []
    extra = 0
    while stack:
        t, parent = stack.pop()
        if max_nodes is not None and len(tasks) + extra >= max_nodes:
            truncated[parent] += _subtree_size(t)
            continue
        index = len(tasks)
        tasks.append(t)
        paths.append(tuple(t.path) if parent < 0 else (*paths[parent], path_entry(t)))
        parents.append(parent)
        collapsed.append(0)
        truncated.append(0)
        if parent < 0:
            records = _retained_records(t, paths[0], collapse_finished, collapsed)
            if max_nodes is not None and records:
                # records take at most half the room left (the newest), the live tasks the rest
                cut = len(records) - max(0, (max_nodes - 1) // 2)
                if cut > 0:
                    truncated[0] += sum(r.collapsed + 1 for r in records[:cut])
                    del records[:cut]
            extra = len(records)
        shown: list[TaskLike] = []
        for c in t.children:
            size = _finished_size(c) if collapse_finished else None
            if size is None:
                shown.append(c)
            else:
                collapsed[index] += size
        if max_nodes is not None:
            # Pre-order takes at most `room` more tasks, so children past the first `room`
            # can never be shown: count them now instead of queueing them one by one.
            room = max_nodes - len(tasks) - extra
            if len(shown) > room:
                truncated[index] += sum(_subtree_size(c) for c in shown[room:])
                del shown[room:]
        stack.extend((c, index) for c in reversed(shown))
    kids: list[list[TaskNode]] = [[] for _ in tasks]
    root: TaskNode | None = None
    for i in range(len(tasks) - 1, -1, -1):
        kids[i].reverse()
        node = TaskNode(
            **task_fields(tasks[i], paths[i]),
            children=(*records, *kids[i]) if i == 0 else tuple(kids[i]),
            collapsed=collapsed[i],
            truncated=truncated[i],
        )
        if parents[i] < 0:
            root = node
        else:
            kids[parents[i]].append(node)
    assert root is not None
    return root
