"""Low-level debugging helpers.

:func:`dump_task_tree` prints the task tree as plain text, with what every alive task is
waiting on. It never awaits and uses no live display, so it may be called from a signal
handler (``loop.add_signal_handler(signal.SIGUSR1, cpl.lowlevel.dump_task_tree)``) or a
debugger to see where a hanging plan is stuck.
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Sequence
from typing import IO, Any

from ._tree import TaskLike, snapshot
from .display import render_text

__all__ = ["dump_task_tree"]

_DUMP_WIDTH = 120


def _current_roots() -> Sequence[TaskLike]:
    try:
        from . import _runtime
    except ImportError:
        raise RuntimeError(
            "dump_task_tree() cannot find the running top levels in this cpl version "
            "(no cpl._runtime.current_roots); pass the task to dump"
        ) from None
    current_roots: Callable[[], Any] = _runtime.current_roots
    return list(current_roots())


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
