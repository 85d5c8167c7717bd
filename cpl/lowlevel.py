"""Low-level debugging helpers.

:func:`dump_task_tree` prints the task tree as plain text, with what every alive task is
waiting on. It never awaits and uses no live display, so it may be called from a signal
handler (``loop.add_signal_handler(signal.SIGUSR1, cpl.lowlevel.dump_task_tree)``) or a
debugger to see where a hanging plan is stuck.

:func:`stray_asyncio_tasks` lists the plain asyncio tasks a run created and left pending
(invariant checks such as the demo's ``no_task_leaked`` use it).
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from typing import IO

from ._runtime import current_roots, stray_asyncio_tasks
from ._tree import TaskLike, snapshot
from .display import render_text

__all__ = ["dump_task_tree", "render_roots", "stray_asyncio_tasks"]

_DUMP_WIDTH = 120


def _current_roots() -> Sequence[TaskLike]:
    return current_roots()


def dump_task_tree(task: TaskLike | None = None, file: IO[str] | None = None) -> str:
    """Write the tree of ``task`` (default: every running top level) as ASCII text.

    Writes to ``file`` (default ``sys.stderr``, like :mod:`faulthandler`) and returns the
    text. Each alive task's line ends with what it is doing or waiting on.
    """
    roots = [task] if task is not None else _current_roots()
    if roots:
        text = "".join(render_text(snapshot(root), ascii=True, width=_DUMP_WIDTH) for root in roots)
    else:
        text = "(no cpl run in progress)\n"
    out = file if file is not None else sys.stderr
    out.write(text)
    out.flush()
    return text


def render_roots(roots: Sequence[TaskLike]) -> str:
    """The ASCII dump of the trees under ``roots`` (best effort: a tree changing in
    another thread is rendered as far as it can be)."""
    parts: list[str] = []
    for root in roots:
        try:
            parts.append(render_text(snapshot(root), ascii=True, width=_DUMP_WIDTH))
        except Exception as exc:  # the tree changed under us: say so, keep the rest
            parts.append(f"(could not render {root!r}: {exc!r})\n")
    return "".join(parts) or "(no tree)\n"
