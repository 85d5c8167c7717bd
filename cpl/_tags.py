"""``with_tags``: tasks named inside a block, referable before they run (CRAM's
``with-tags`` and ``(:tag name ...)``).

Python cannot walk code, so the tags are declared by name at the top of the block::

    with cpl.with_tags("grasp", "watch") as tags:
        async def watch():
            await cpl.wait_for(cpl.task_dead(tags["grasp"]))   # before "grasp" even ran
        await cpl.par(tags.run("grasp", grasp_cup()), tags.run("watch", watch()))

- ``tags[name]`` is the task the name stands for *now*: a CREATED task until the tag runs,
  then the running task, then the dead one. Its status, result and status fluent can be
  read, it can be joined, suspended or put into ``partial_order`` before it runs.
- ``tags.run(name, aw)`` runs ``aw`` as that task (a child of the task that runs it) and
  joins it, like CRAM's ``(:tag name body)``: sequential, no hidden parallelism. Running a
  tag again (a loop, a ``retry``) makes a new task ``name#2``, ``name#3``... and the name
  is re-bound to it, as CRAM re-binds the tag variable.
- Leaving the block evaporates tags that never ran, so nobody waits on them forever.

Deliberate differences from CRAM: tags are declared, not collected by a code walker; an
unknown name is a ``KeyError`` listing the declared ones; nested ``with_tags`` blocks work
(each has its own names).
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable, Iterator
from contextlib import contextmanager
from typing import Any

from ._status import Status
from ._task import Task, _require_task, run_joined

__all__ = ["Tags", "with_tags"]


class Tags:
    """The tags of one ``with_tags`` block (see the module docstring)."""

    __slots__ = ("_closed", "_owner", "_tasks", "_used")

    def __init__(self, owner: Task, names: tuple[str, ...]) -> None:
        self._owner = owner
        # Invariant: _tasks[name] is the task the name is bound to now; _used holds the names
        # whose bound task has been started (a further run makes a new task).
        self._tasks: dict[str, Task] = {}
        self._used: set[str] = set()
        self._closed = False
        for name in names:
            if not isinstance(name, str) or not name:
                raise TypeError(f"a tag name is a non-empty string, got {name!r}")
            if name in self._tasks:
                raise ValueError(f"tag {name!r} is declared twice")
            self._tasks[name] = Task(None, name, kind="tag", parent=owner)

    def __getitem__(self, name: str) -> Task:
        try:
            return self._tasks[name]
        except KeyError:
            raise KeyError(
                f"no tag {name!r} in this with_tags block; declared: {sorted(self._tasks)}"
            ) from None

    def __contains__(self, name: object) -> bool:
        return name in self._tasks

    def __iter__(self) -> Iterator[str]:
        return iter(self._tasks)

    async def run(self, name: str, aw: Awaitable[Any] | Callable[[], Awaitable[Any]]) -> Any:
        """Run ``aw`` as the tag ``name`` (a child task of the caller) and join it: its value,
        or its failure re-raised. Raises ``RuntimeError`` after the block was left."""
        task = self[name]
        if self._closed:
            _close(aw)
            raise RuntimeError(
                f"tag {name!r} run after its with_tags block was left; run tags inside it"
            )
        caller = _require_task(f"tags.run({name!r})")
        if name in self._used or task.state is not Status.CREATED:
            task = Task(None, name, kind="tag", parent=caller)
            self._tasks[name] = task
        else:
            task._move_under(caller)
        self._used.add(name)
        task._aw = aw
        return await run_joined(task)

    def _close(self) -> None:
        self._closed = True
        for name, task in self._tasks.items():
            if name not in self._used and task.state is Status.CREATED:
                task.evaporate("its with_tags block ended before the tag ran")


def _close(aw: Any) -> None:
    close = getattr(aw, "close", None)
    if callable(close) and hasattr(aw, "cr_code"):
        close()


@contextmanager
def with_tags(*names: str) -> Iterator[Tags]:
    """Declare the tags ``names`` for the block (CRAM's ``with-tags``); see :class:`Tags`.
    Must run inside a cpl task."""
    owner = _require_task("cpl.with_tags")
    tags = Tags(owner, names)
    try:
        yield tags
    finally:
        tags._close()
