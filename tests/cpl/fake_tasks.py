"""A stand-in for :class:`cpl.Task` with the attributes that snapshots, the renderer and
the event log read, so tree-shaped tests need no running loop."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from cpl import Evaporated, Status


@dataclass(eq=False)
class FakeTask:
    """The attributes of cpl.Task that snapshot() reads."""

    name: str
    kind: str = "plan"
    state: Status = Status.SUCCEEDED
    start_time: float | None = 0.0
    end_time: float | None = 1.0
    result: Any = None
    failure: BaseException | None = None
    evaporation: Evaporated | None = None
    arguments: dict[str, Any] | None = None
    annotations: dict[str, Any] | None = None
    waiting_on: str | None = None
    parent: FakeTask | None = None
    children: list[FakeTask] = field(default_factory=list)
    path_entry: str | None = None

    @property
    def path(self) -> tuple[str, ...]:
        parts: list[str] = []
        node: FakeTask | None = self
        while node is not None:
            parts.append(node.path_entry or node.name)
            node = node.parent
        return tuple(reversed(parts))

    def add(self, child: FakeTask) -> FakeTask:
        child.parent = self
        same = sum(1 for c in self.children if c.name == child.name)
        child.path_entry = child.name if same == 0 else f"{child.name}#{same + 1}"
        self.children.append(child)
        return child
