"""What designators resolve to: the data a ``reference()`` returns.

- an action: :class:`ActionGrounding` ``(plan, arguments)``, CRAM's ``(plan-function . args)``;
- a motion: :class:`MotionCommand` ``(command, arguments)``, e.g. ``("move-base", {"pose": p})``;
- a location: an :class:`executive.Pose`;
- an object: :class:`ObjectData` (what perception found).

Both groundings are named tuples, so ``command, args = motion.reference()`` works and they
compare equal to plain tuples.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, NamedTuple

from ._pose import Pose, Transform

__all__ = ["ActionGrounding", "MotionCommand", "ObjectData"]


class ActionGrounding(NamedTuple):
    """A plan function and its arguments: a mapping (keyword arguments) or a sequence
    (positional arguments)."""

    plan: Callable[..., Any]
    arguments: Mapping[str, Any] | Sequence[Any]

    def __repr__(self) -> str:
        name = getattr(self.plan, "__name__", repr(self.plan))
        return f"ActionGrounding({name}, {self.arguments!r})"


class MotionCommand(NamedTuple):
    """A process-module command (CRAM's spelling, e.g. ``move-base``) and its keyword
    arguments (Python spelling, e.g. ``joint_angle``)."""

    command: str
    arguments: Mapping[str, Any]


@dataclass(frozen=True, slots=True)
class ObjectData:
    """A perceived object: its name and type, its pose (in the frame perception used) and,
    optionally, the transform from the robot base at detection time (CRAM's ``:transform``)
    and further properties."""

    name: str | None
    type: str | None
    pose: Pose
    transform: Transform | None = None
    extra: Mapping[str, Any] = field(default_factory=dict)
