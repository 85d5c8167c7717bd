"""Rendering task-tree snapshots with rich, and a live view of a running tree.

:func:`render` is a pure function of a :class:`~cpl._tree.TaskNode` snapshot: one line
per task with a status glyph (:data:`STATUS_STYLES`), the name, the kind (for the forms),
the duration, the failure, who evaporated it and why, the designator and, for alive
tasks, what it is waiting on. :func:`render_text` turns that into plain text (logs,
golden tests). :class:`LiveTaskTree` redraws a running tree from the event loop.

Cost: rich needs roughly 80 us per rendered line, so large trees are watched with a node
cap and with finished subtrees folded into one "(+N finished)" line.
"""

from __future__ import annotations

import asyncio
import io
import json
import math
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from types import MappingProxyType, TracebackType
from typing import Any, TypeAlias, cast

from rich.console import Console, RenderableType
from rich.live import Live
from rich.text import Text
from rich.tree import Tree

from ._status import Status
from ._tree import TaskLike, TaskNode, snapshot

__all__ = [
    "ANNOTATIONS_SHOWN",
    "STATUS_STYLES",
    "LiveTaskTree",
    "StatusStyle",
    "format_duration",
    "render",
    "render_text",
]


@dataclass(frozen=True, slots=True)
class StatusStyle:
    """How a status is drawn: unicode glyph, ASCII fallback, rich style."""

    glyph: str
    ascii: str
    style: str


STATUS_STYLES: Mapping[Status, StatusStyle] = MappingProxyType(
    {
        Status.CREATED: StatusStyle("○", "o", "dim"),
        Status.RUNNING: StatusStyle("▶", ">", "yellow"),
        Status.SUSPENDED: StatusStyle("⏸", "=", "magenta"),
        Status.SUCCEEDED: StatusStyle("✔", "+", "green"),
        Status.FAILED: StatusStyle("✘", "x", "bold red"),
        Status.EVAPORATED: StatusStyle("~", "~", "grey50"),
    }
)
"""The one table of status glyphs and colours."""

ANNOTATIONS_SHOWN: tuple[str, ...] = ("designator", "chosen", "why")  # recorded: also "resolved"
"""Annotation keys drawn on a task's line (others stay in the snapshot only)."""

_PLAIN_KINDS = frozenset({"plan", "task"})
_FOLDABLE = frozenset({Status.SUCCEEDED, Status.EVAPORATED})
_ANNOTATION_LIMIT = 60


def format_duration(seconds: float) -> str:
    """``0.4ms``, ``12.0ms``, ``1.25s``, ``2m03.5s``."""
    if round(seconds * 1000, 1) < 1000.0:
        return f"{seconds * 1000:.1f}ms"
    if round(seconds, 2) < 60.0:
        return f"{seconds:.2f}s"
    minutes, rest = divmod(round(seconds, 1), 60.0)
    return f"{int(minutes)}m{rest:04.1f}s"


def _shorten(text: str, limit: int, ascii: bool) -> str:
    if len(text) <= limit:
        return text
    return text[: limit - 3] + "..." if ascii else text[: limit - 1] + "…"


def _annotation_text(value: Any) -> str:
    if isinstance(value, str):
        return value
    return json.dumps(value, separators=(",", ":"), ensure_ascii=False)


def _label(node: TaskNode, ascii: bool, show_times: bool) -> Text:
    look = STATUS_STYLES[node.status]
    dash = " - " if ascii else " — "
    text = Text(no_wrap=not ascii, overflow="fold" if ascii else "ellipsis")
    text.append(look.ascii if ascii else look.glyph, style=look.style)
    text.append(" ")
    entry = node.path[-1] if node.path else node.name  # "fetching#2" tells calls apart
    text.append(entry, style="bold" if node.kind == "top-level" else "")
    if node.kind not in _PLAIN_KINDS:
        text.append(f" [{node.kind}]", style="dim")
    if show_times:
        duration = node.duration
        if duration is not None:
            text.append(f" {format_duration(duration)}", style="dim cyan")
        elif node.start_time is not None and node.status.alive:
            text.append(f" since t={node.start_time:.2f}", style="dim cyan")
    if node.failure is not None:
        text.append(f"{dash}{node.failure}", style="red")
    if node.status is Status.EVAPORATED and (node.evaporated_by or node.evaporation_reason):
        who = "by " + "/".join(node.evaporated_by) if node.evaporated_by else "from outside"
        why = f": {node.evaporation_reason}" if node.evaporation_reason else ""
        text.append(f"{dash}evaporated {who}{why}", style="grey50")
    for key in ANNOTATIONS_SHOWN:
        if key in node.annotations:
            value = _shorten(_annotation_text(node.annotations[key]), _ANNOTATION_LIMIT, ascii)
            text.append(f" {key}={value}", style="cyan")
    if node.status.alive and node.waiting_on:
        text.append(f"{dash}{node.waiting_on}", style="italic yellow")
    return text


def _weight(node: TaskNode) -> int:
    """Number of tasks a snapshot subtree stands for, folded and cut ones included."""
    return sum(1 + n.collapsed + n.truncated for n in node.walk())


def _foldable_weight(node: TaskNode) -> int | None:
    if node.status not in _FOLDABLE:
        return None
    total = 0
    for n in node.walk():
        # a cut subtree may hide alive tasks; failures (even recovered ones) stay visible
        if n.status.alive or n.truncated or n.status is Status.FAILED:
            return None
        total += 1 + n.collapsed + n.truncated
    return total


def render(
    node: TaskNode,
    *,
    ascii: bool = False,
    max_nodes: int | None = None,
    collapse_finished: bool = False,
    show_times: bool = True,
) -> Tree:
    """Draw a snapshot as a :class:`rich.tree.Tree` (pure; does not touch live tasks).

    ``collapse_finished`` folds each child subtree that finished without any failure in it
    into a "(+N finished)" line under its parent (failed and alive tasks, also failures a
    retry recovered from, stay visible with the path to them; folds
    already made by ``snapshot(collapse_finished=True)`` are drawn the same way).
    ``max_nodes`` draws at most that many tasks in pre-order and ends with "… N more".
    """
    if max_nodes is not None and max_nodes < 1:
        raise ValueError(f"max_nodes must be at least 1, got {max_nodes}")
    root = Tree(_label(node, ascii, show_times), guide_style="dim")
    drawn = 0
    more = 0
    stack: list[tuple[TaskNode, Tree | None]] = [(node, None)]
    while stack:
        n, parent = stack.pop()
        if max_nodes is not None and drawn >= max_nodes:
            more += _weight(n)
            continue
        drawn += 1
        branch = root if parent is None else parent.add(_label(n, ascii, show_times))
        more += n.truncated
        finished = n.collapsed
        shown: list[TaskNode] = []
        for c in n.children:
            weight = _foldable_weight(c) if collapse_finished else None
            if weight is None:
                shown.append(c)
            else:
                finished += weight
        if finished:
            branch.add(Text(f"(+{finished} finished)", style="dim"))
        stack.extend((c, branch) for c in reversed(shown))
    if more:
        root.add(Text(f"{'...' if ascii else '…'} {more} more", style="dim"))
    return root


class _AsciiBuffer(io.StringIO):
    """A text buffer that tells rich to stick to ASCII (tree guides included)."""

    @property
    def encoding(self) -> str:  # type: ignore[override]
        return "ascii"


def render_text(
    node: TaskNode,
    *,
    ascii: bool = True,
    width: int = 100,
    max_nodes: int | None = None,
    collapse_finished: bool = False,
    show_times: bool = True,
) -> str:
    """:func:`render` as plain text without colour at a fixed width (logs, golden tests).

    In ASCII mode long lines wrap; in unicode mode they are cut with an ellipsis.
    """
    buffer: io.StringIO = _AsciiBuffer() if ascii else io.StringIO()
    console = Console(
        file=buffer,
        width=width,
        color_system=None,
        no_color=True,
        force_terminal=False,
        force_jupyter=False,
        force_interactive=False,
        highlight=False,
        emoji=False,
        markup=False,
        legacy_windows=False,
        soft_wrap=False,
        _environ={},
    )
    console.print(
        render(
            node,
            ascii=ascii,
            max_nodes=max_nodes,
            collapse_finished=collapse_finished,
            show_times=show_times,
        )
    )
    return "".join(line.rstrip() + "\n" for line in buffer.getvalue().splitlines())


RootSource: TypeAlias = "TaskLike | Callable[[], TaskLike | None]"


class LiveTaskTree:
    """A live terminal view of a running task tree, redrawn from the event loop.

    ``root`` is a task or a callable returning the task to watch (or ``None`` while there
    is none yet). An asyncio task takes a collapsing, capped :func:`snapshot` every
    ``1/refresh_per_second`` seconds and hands the rendered tree to a
    :class:`rich.live.Live` that never refreshes on its own thread, so nothing reads the
    tree while it changes. On exit the final state is drawn once (not folded, capped)::

        async with LiveTaskTree(top):
            await top
    """

    def __init__(
        self,
        root: RootSource,
        *,
        refresh_per_second: float = 4,
        max_nodes: int = 100,
        console: Console | None = None,
        ascii: bool = False,
        transient: bool = False,
    ) -> None:
        if refresh_per_second <= 0:
            raise ValueError("refresh_per_second must be positive")
        if max_nodes < 1:
            raise ValueError("max_nodes must be at least 1")
        self._root = root
        self._interval = 1.0 / refresh_per_second
        self._max_nodes = max_nodes
        self._ascii = ascii
        self._live = Live(
            Text(""),
            console=console,
            auto_refresh=False,
            transient=transient,
        )
        self._refresher: asyncio.Task[None] | None = None

    def _task(self) -> TaskLike | None:
        root = self._root
        if hasattr(root, "children") or not callable(root):
            return cast(TaskLike, root)
        return root()

    def renderable(self, *, final: bool = False) -> RenderableType:
        """What the view shows now: the rendered snapshot of the watched tree."""
        task = self._task()
        if task is None:
            return Text("(no task yet)", style="dim")
        node = snapshot(task, max_nodes=self._max_nodes, collapse_finished=not final)
        return render(node, ascii=self._ascii, collapse_finished=not final)

    def refresh(self, *, final: bool = False) -> None:
        """Redraw now (call it on the event loop)."""
        self._live.update(self.renderable(final=final), refresh=True)

    async def _refresh_forever(self) -> None:
        # Paced by the wall clock: under a mock or scaled clock the loop's time may run far
        # ahead of real time, and a frame per simulated interval would swamp the run.
        last = -math.inf
        while True:
            now = time.monotonic()
            if now - last >= self._interval:
                self.refresh()
                last = now
            await asyncio.sleep(self._interval)

    async def __aenter__(self) -> LiveTaskTree:
        self._live.start(refresh=False)
        self._refresher = asyncio.get_running_loop().create_task(
            self._refresh_forever(), name="aiocram-live-task-tree"
        )
        return self

    async def __aexit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        refresher, self._refresher = self._refresher, None
        try:
            if refresher is not None:
                refresher.cancel()
                try:
                    await refresher
                except asyncio.CancelledError:
                    current = asyncio.current_task()
                    if current is not None and current.cancelling():
                        raise
            self.refresh(final=True)
        finally:
            self._live.stop()
            if not self._live.console.is_terminal:
                # rich leaves a non-terminal's last frame without a line end
                self._live.console.line()
