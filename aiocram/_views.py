"""What ``aiocram demo`` shows on the console: a live view that keeps the robot in sight,
and the collapsed tree printed at the end.

The live view (:class:`DemoView`) is three parts, each short enough for an 80-column
terminal: a progress line (object k of n, its name, simulated and wall time), the running
path (the chain of running tasks from the root to the deepest one, each with the action
type and the object it is about, so the object's name is never cut off behind a long
designator), and the failures of the current object folded into one line per kind with a
count. Failures inside imagined runs (subtrees marked :attr:`cpl.Subtree.IMAGINED`) are
not the robot's: they are left out of the counts.

:func:`final_tree` is the tree printed after the run: the root (finished), one line per
top-level step, each step's failures folded the same way.
"""

from __future__ import annotations

import asyncio
import re
import time
from collections import Counter
from collections.abc import Callable, Iterator, Sequence
from typing import Any

from rich.console import Group, RenderableType
from rich.text import Text
from rich.tree import Tree

import cpl
from cpl.display import STATUS_STYLES, LiveTaskTree, format_duration

__all__ = ["DemoView", "Progress", "brief", "final_tree", "fold_failures"]

_NUMBERED = re.compile(r"#\d+$")


def imagined(task: Any) -> bool:
    """Whether ``task`` runs inside an imagined (projection) run: a subtree marked
    :attr:`cpl.Subtree.IMAGINED` (projection reasoning's runs and the alternatives of
    ``plans.imagine_best``, e.g. the search's imagined viewpoints). A recorded node
    (:class:`cpl.TaskNode`) knows no parent: walk recorded trees with :func:`_walk`, which
    leaves imagined subtrees out."""
    return cpl.within(task, cpl.Subtree.IMAGINED)


#: In a recorded tree (:class:`cpl.TaskNode`) the designator is its text:
#: ``<an action (type detecting) (object <an object (type spoon) (name spoon-1)>) ...``
_ACTION_TYPE = re.compile(r"^<an? action \(type ([^()\s]+)\)")
_ACTION_OBJECT = re.compile(r"\(object <an? object ((?:\([^()]*\)\s*)*)")
_PROPERTY = re.compile(r"\((name|type) ([^()\s]+)\)")


def _recorded_brief(node: cpl.TaskNode) -> str:
    text = str((node.annotations or {}).get("designator", ""))
    action = _ACTION_TYPE.match(text)
    if action is None:
        return ""
    words = [action.group(1)]
    obj = _ACTION_OBJECT.search(text)
    if obj is not None:
        props = dict(_PROPERTY.findall(obj.group(1)))
        name = props.get("name") or props.get("type")
        if name is not None:
            words.append(name)
    return " ".join(words)


def _state(task: Any) -> cpl.Status:
    """A live task's state, or a recorded one's (:class:`cpl.TaskNode`) status."""
    return task.status if isinstance(task, cpl.TaskNode) else task.state


def _entry(task: Any) -> str:
    """The last part of the task's path (``name`` or ``name#n``)."""
    return task.path[-1] if isinstance(task, cpl.TaskNode) else task.path_entry


def brief(task: Any) -> str:
    """A few words on what ``task`` does: its action type and the object it is about
    (``detecting spoon-1``), or ``""`` for tasks that are not performed actions. Also
    for a recorded task (:class:`cpl.TaskNode`), from its designator's text."""
    from executive import action_of

    if isinstance(task, cpl.TaskNode):
        return _recorded_brief(task)
    action = action_of(task)
    if action is None:
        return ""
    words = [str(action.type)]
    obj = action.get("object")
    if obj is not None and hasattr(obj, "get"):
        name = obj.get("name") or obj.get("type")
        if name is not None:
            words.append(str(name))
    return " ".join(words)


def _walk(task: Any) -> Iterator[Any]:
    """``task`` and its descendants in pre-order, imagined subtrees left out."""
    stack = [task]
    while stack:
        t = stack.pop()
        if cpl.subtree_of(t) is cpl.Subtree.IMAGINED:
            continue
        yield t
        stack.extend(reversed(t.children))


def _base(task: Any) -> str:
    return _NUMBERED.sub("", _entry(task))


def _failure_text(failure: BaseException | cpl.FailureInfo | None, limit: int) -> str:
    if failure is None:
        return ""
    if isinstance(failure, cpl.FailureInfo):  # recorded: as the failure's str() reads
        name = failure.type.rsplit(".", 1)[-1]
        fields = ", ".join(f"{k}={v}" for k, v in failure.details.items())
        message = f"{failure.message} ({fields})" if fields else failure.message
        text = f"{name}: {message}" if message else name
    else:
        text = f"{type(failure).__name__}: {failure}"
    text = text.replace("\n", " ")
    return text if len(text) <= limit else text[: limit - 1] + "…"


def _count(n: int, noun: str) -> str:
    """``"1 failed task"``, ``"2 failed tasks"``."""
    return f"{n} {noun}" if n == 1 else f"{n} {noun}s"


def fold_failures(tasks: Any) -> list[tuple[str, int, Any]]:
    """Failed tasks (imagined ones left out) folded by name without its ``#N``: ``(name,
    count, last failure)``, most frequent first."""
    counts: Counter[str] = Counter()
    last: dict[str, Any] = {}
    for t in tasks:
        if _state(t) is cpl.Status.FAILED and not imagined(t):
            name = _base(t)
            counts[name] += 1
            last[name] = t.failure
    return [(name, n, last[name]) for name, n in counts.most_common()]


class Progress(cpl.Instrument):
    """Follows the real (not imagined) transports: which object, which of how many."""

    def __init__(
        self, objects: Sequence[str], *, wall: Callable[[], float] = time.perf_counter
    ) -> None:
        self.objects = tuple(objects)
        self.index = 0  # 1-based number of the current object; 0 before the first
        self.current: Any = None  # the current transport task
        self._wall = wall  # the wall clock (a test passes a fake one)
        self.wall_start = wall()

    def task_status_changed(self, task: cpl.Task, old: cpl.Status, new: cpl.Status) -> None:
        if new is not cpl.Status.RUNNING or old is not cpl.Status.CREATED:
            return
        from executive import action_of

        action = action_of(task)
        if action is None or action.type != "transporting" or imagined(task):
            return
        self.index += 1
        self.current = task

    def line(self, sim_now: float | None, root: Any) -> Text:
        n = len(self.objects)
        k = min(self.index, n)
        name = self.objects[k - 1] if k else "getting ready"
        started = root.start_time
        sim = sim_now - started if sim_now is not None and started is not None else 0.0
        wall = self._wall() - self.wall_start
        text = Text()
        text.append(f"object {k} of {n}: ", style="bold")
        text.append(name, style="bold cyan")
        text.append(f" · simulated {sim:.1f} s · wall {wall:.1f} s", style="dim")
        return text


def _line(task: Any, *, extra: str = "", ascii: bool = False) -> Text:
    look = STATUS_STYLES[_state(task)]
    text = Text(no_wrap=True, overflow="ellipsis")
    text.append(look.ascii if ascii else look.glyph, style=look.style)
    text.append(" ")
    text.append(_entry(task), style="bold" if task.kind == "top-level" else "")
    what = brief(task)
    if what:
        text.append(f" {what}", style="cyan")
    if extra:
        text.append(extra, style="dim")
    return text


def running_path(root: Any) -> list[Any]:
    """The chain of alive tasks from ``root`` down, following at each level the newest
    alive child that is not an imagined run's (the real robot's work), else the newest
    alive child."""
    path = [root]
    node = root
    while True:
        alive = [c for c in node.children if c.alive]
        if not alive:
            return path
        real = [c for c in alive if cpl.subtree_of(c) is not cpl.Subtree.IMAGINED]
        node = (real or alive)[-1]
        path.append(node)


class DemoView(LiveTaskTree):
    """The live view of ``aiocram demo`` (see the module docstring)."""

    def __init__(self, root: Any, progress: Progress, **kwargs: Any) -> None:
        super().__init__(root, **kwargs)
        self.progress = progress

    def renderable(self, *, final: bool = False) -> RenderableType:
        root = self._task()
        if root is None:
            return Text("(no task yet)", style="dim")
        try:
            now: float | None = asyncio.get_running_loop().time()
        except RuntimeError:
            now = None
        parts: list[RenderableType] = [self.progress.line(now, root)]
        path = running_path(root)
        for depth, task in enumerate(path):
            line = Text("  " * depth)
            line.append_text(_line(task))
            line.no_wrap, line.overflow = True, "ellipsis"
            parts.append(line)
        scope = self.progress.current if self.progress.current is not None else root
        folded = fold_failures(_walk(scope))
        if folded:
            summary = Text("failures so far: ", style="red", no_wrap=True, overflow="ellipsis")
            summary.append(", ".join(f"{name} ×{n}" for name, n, _ in folded[:6]))
            if len(folded) > 6:
                summary.append(f", … ({len(folded) - 6} more kinds)")
            parts.append(summary)
        return Group(*parts)


def _evaporation_reason(task: Any) -> str | None:
    if isinstance(task, cpl.TaskNode):
        return task.evaporation_reason if task.evaporated else None
    return None if task.evaporation is None else task.evaporation.reason


def final_tree(root: Any, *, log: str | None = None, ascii: bool = False) -> RenderableType:
    """The collapsed tree of a finished run: the root, one line per top-level step (the
    steps that finished without failing before the first transport folded into one line),
    and under each step its failures folded by name with a count and the last failure.
    With ``log``, a last line points to the whole tree (``aiocram show LOG``).

    ``root`` is the live root task or a recorded one (:class:`cpl.TaskNode`, e.g. from
    :func:`cpl.tree_from_log`): ``aiocram show --collapse`` prints this same tree."""
    look = STATUS_STYLES[_state(root)]
    label = Text()
    label.append(look.ascii if ascii else look.glyph, style=look.style)
    label.append(f" {_entry(root)} [top-level]", style="bold")
    if root.end_time is not None and root.start_time is not None:
        label.append(f" {format_duration(root.end_time - root.start_time)}", style="dim cyan")
    if root.failure is not None:
        label.append(f" — {_failure_text(root.failure, 80)}", style="red")
    reason = _evaporation_reason(root)
    if reason is not None:
        label.append(f" — evaporated: {reason}", style="grey50")
    tree = Tree(label, guide_style="dim")
    quiet = 0
    for child in root.children:
        folded = fold_failures(_walk(child))
        interesting = bool(folded) or brief(child).startswith("transporting")
        if not interesting and _state(child) is cpl.Status.SUCCEEDED:
            quiet += 1
            continue
        if quiet:
            tree.add(Text(f"(+{quiet} finished)", style="dim"))
            quiet = 0
        duration = ""
        if child.end_time is not None and child.start_time is not None:
            duration = f" {format_duration(child.end_time - child.start_time)}"
        failed = sum(n for _, n, _ in folded)
        extra = duration + (f" — {_count(failed, 'failed task')}" if failed else "")
        branch = tree.add(_line(child, extra=extra, ascii=ascii))
        if child.failure is not None:
            branch.add(Text(_failure_text(child.failure, 100), style="red"))
        for name, n, last in folded[:5]:
            row = Text(no_wrap=True, overflow="ellipsis")
            row.append("x" if ascii else "✘", style="bold red")
            row.append(f" {name} ×{n}")
            row.append(f" — last: {_failure_text(last, 90)}", style="red")
            branch.add(row)
        if len(folded) > 5:
            branch.add(Text(f"… {len(folded) - 5} more kinds of failure", style="dim"))
    if quiet:
        tree.add(Text(f"(+{quiet} finished)", style="dim"))
    if log is None:
        return tree
    hint = Text(f"the whole tree: aiocram show {log}", style="dim")
    return Group(tree, hint)
