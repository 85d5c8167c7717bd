"""Resources: the robot's parts an action occupies, and what two concurrent goals on one
part do.

A :class:`Resource` is one part of the robot as data: a kind (:class:`ResourceKind`:
``BASE``, ``TORSO``, ``HEAD``, ``ARM``, ``GRIPPER``) and, for the kinds a robot may have
several of, the part's name (``Resource.arm("left")``). ``executive`` defines only the
kinds; which parts a robot has is robot data: each process module lists the parts it
drives (:attr:`executive.ProcessModule.resources`), and an environment's parts are those
of its modules (:attr:`executive.Environment.resources`). A goal that needs a part of a
listed kind that is not listed (the left arm of a one-armed robot) fails to resolve, with
a :class:`executive.DesignatorError` naming the parts there are.

What a goal needs is knowledge, registered like the resolution rules, for the target of
its grounding (:meth:`executive.RuleSet.register_resources`): for an action, the plan
function its rule yields, read from the resolved arguments (``pick-up``'s ``arm``: the arm
and the gripper of that side); for a motion, its command (``move-base``: the base;
``move-tcp``: the arms that have a pose). A goal whose target has no registration needs
nothing (CRAM's behaviour).

Two goals on one part:

- **An action claims its parts for its whole duration**, exclusively. Its own subtree
  (sub-actions, motions) uses them freely; a sub-action claims them again within the
  claim (nested claims: the innermost holder decides).
- **A second action, or a motion, from a task outside the claiming action's subtree
  fails at once** with :class:`executive.ResourceConflict`, naming both goals, the part
  and what to do (sequence them, or use another part that is free), before its plan
  starts or it reaches a process module: nothing moves for it. In a ``par``, that
  failure evaporates the sibling that holds the claim, as any failure does; an action
  yields to the loop twice between its claim and its plan (``perform``), so siblings
  that one form started claim before any of them moves, and the form evaporates the
  holder before it moved either.
- **Motions outside any claiming action share the part**: several at once on one process
  module wait their turn, one goal at a time in FIFO order (CRAM's ``pm-execute``). An
  action claiming a part that such a motion is using fails (the motion does not wait for
  the action, nor the action for the motion).
- ``shared`` registrations (perception's use of the head: ``detecting`` moves nothing but
  needs the camera where it is) coexist with each other and with motions, and conflict
  with a claim held outside their subtree.

Deliberate difference from CRAM: CRAM has no resources. Its process modules take one goal
at a time and queue a second one silently, so two concurrent ``pick-up`` with one arm
interleave their motions in the arm module's queue (the first object is dragged to the
second and left in the hand, and the failure that surfaces is about the second object),
and ``par(pick-up, releasing)`` on one arm opens the hand mid-pick without a word. We
neither preempt (the first goal would be left half done: an object half grasped) nor wait
(a plan that waits for an arm its sibling holds until the sibling ends deadlocks when
the sibling waits for it in turn); the second goal fails, as a plan failure that a
handler may answer by sequencing the two.
"""

from __future__ import annotations

import enum
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from .failures import DesignatorError, ResourceConflict

if TYPE_CHECKING:
    import cpl

    from ._designator import Designator

__all__ = ["Resource", "ResourceKind"]


class ResourceKind(enum.Enum):
    """The kinds of robot parts a goal can occupy (robot-independent)."""

    BASE = "base"
    TORSO = "torso"
    HEAD = "head"
    ARM = "arm"
    GRIPPER = "gripper"


#: The kinds a robot has one of (their resources carry no part name).
_SINGLE: frozenset[ResourceKind] = frozenset(
    {ResourceKind.BASE, ResourceKind.TORSO, ResourceKind.HEAD}
)


@dataclass(frozen=True, slots=True, eq=False)
class Resource:
    """One part of the robot: ``Resource.base()``, ``Resource.arm("left")``,
    ``Resource.gripper("right")``. Compared and hashed by value (kind and part)."""

    kind: ResourceKind
    # Invariant: None exactly for the kinds a robot has one of (base, torso, head); a
    # non-empty name (the robot's own, e.g. "left") for arms and grippers.
    part: str | None = None
    # hash((kind, part)), computed once: resources are looked up on perform's hot path
    _hash: int = field(init=False, repr=False)

    def __post_init__(self) -> None:
        if not isinstance(self.kind, ResourceKind):
            raise TypeError(
                f"a resource's kind is an executive.ResourceKind (BASE, TORSO, HEAD, ARM, "
                f"GRIPPER), got {self.kind!r}"
            )
        if self.kind in _SINGLE:
            if self.part is not None:
                raise ValueError(
                    f"a robot has one {self.kind.value}: Resource.{self.kind.value}() takes no "
                    f"part name, got {self.part!r}"
                )
        elif not isinstance(self.part, str) or not self.part:
            raise ValueError(
                f"a {self.kind.value} resource names its part: Resource.{self.kind.value}"
                f"('left'), got {self.part!r}"
            )
        object.__setattr__(self, "_hash", hash((self.kind.value, self.part)))

    def __eq__(self, other: object) -> bool:
        if other.__class__ is not Resource:
            return NotImplemented
        assert isinstance(other, Resource)
        return self.kind is other.kind and self.part == other.part

    def __hash__(self) -> int:
        return self._hash

    @classmethod
    def base(cls) -> Resource:
        """The robot's base (one per robot)."""
        return cls(ResourceKind.BASE)

    @classmethod
    def torso(cls) -> Resource:
        """The torso lift (one per robot)."""
        return cls(ResourceKind.TORSO)

    @classmethod
    def head(cls) -> Resource:
        """The head: pan/tilt and the camera it points (one per robot)."""
        return cls(ResourceKind.HEAD)

    @classmethod
    def arm(cls, part: str) -> Resource:
        """The arm named ``part`` (CRAM's ``left`` / ``right``)."""
        return cls(ResourceKind.ARM, part)

    @classmethod
    def gripper(cls, part: str) -> Resource:
        """The gripper of the arm named ``part``."""
        return cls(ResourceKind.GRIPPER, part)

    def __str__(self) -> str:
        return self.kind.value if self.part is None else f"{self.kind.value} {self.part!r}"

    def __repr__(self) -> str:
        part = "" if self.part is None else repr(self.part)
        return f"Resource.{self.kind.value}({part})"


class _Use:
    """One goal's hold on one resource, from ``acquire`` to ``release``."""

    __slots__ = ("exclusive", "goal", "is_action", "owner", "resource")

    def __init__(
        self,
        resource: Resource,
        owner: cpl.Task,
        goal: Designator,
        is_action: bool,
        exclusive: bool,
    ) -> None:
        self.resource = resource
        # the task that performs the goal: for an action, the parent of the action's task
        # (the hold's scope is that child, found by its "designator" annotation, the goal);
        # for a motion, the task whose goal it is
        self.owner = owner
        self.goal = goal
        self.is_action = is_action
        self.exclusive = exclusive

    def contains(self, task: cpl.Task) -> bool:
        """Whether ``task`` runs inside this hold's scope (so may use the resource)."""
        node: Any = task
        owner = self.owner
        if not self.is_action:
            while node is not None:
                if node is owner:
                    return True
                node = node.parent
            return False
        goal = self.goal
        while node is not None:
            parent = node.parent
            if parent is owner:
                notes = node.annotations
                return notes is not None and notes.get("designator") is goal
            node = parent
        return False

    @property
    def what(self) -> str:
        return label(self.goal)

    def describe(self) -> str:
        return f"{self.what} (performed by {_path(self.owner)})"


def label(designator: Designator) -> str:
    """A goal in a conflict's message: its kind and first properties, shortened
    (``action (type picking-up) (object <object (type cup) ...>) (arm left)``)."""
    from ._designator import _fmt_short  # here: _designator imports the environment

    props = designator.properties
    shown = " ".join(f"({k} {_fmt_short(v)})" for k, v in props[:4])
    return f"{designator.kind} {shown}{' ...' if len(props) > 4 else ''}"


def _path(task: cpl.Task) -> str:
    return "/".join(task.path) or task.name


class ResourceLedger:
    """Who holds which resource in one environment (shared by the environments derived
    from it, as its process modules are)."""

    __slots__ = ("_uses",)

    def __init__(self) -> None:
        # Invariant: every list is non-empty and holds the uses acquired and not yet
        # released, in acquisition order.
        self._uses: dict[Resource, list[_Use]] = {}

    def acquire(
        self,
        resources: tuple[Resource, ...],
        task: cpl.Task,
        goal: Designator,
        *,
        is_action: bool,
        exclusive: bool,
        parts: frozenset[Resource] = frozenset(),
    ) -> list[_Use]:
        """Hold every one of ``resources`` for ``goal`` (an action or a motion) performed
        by ``task``, or none: :class:`executive.ResourceConflict` for the first one held
        outside the goal's reach (nothing is acquired then). ``parts``: the robot's parts
        (for the hint naming a free one)."""
        uses = self._uses
        if uses:
            for resource in resources:
                for use in uses.get(resource, ()):
                    if (exclusive or use.exclusive) and not use.contains(task):
                        raise _conflict(resource, use, goal, task, parts, self)
        acquired = []
        for resource in resources:  # distinct (resources_of)
            use = _Use(resource, task, goal, is_action, exclusive)
            held = uses.get(resource)
            if held is None:
                uses[resource] = [use]
            else:
                held.append(use)
            acquired.append(use)
        return acquired

    def release(self, uses: list[_Use]) -> None:
        """Give back what :meth:`acquire` returned (once, when the goal ends)."""
        held_by = self._uses
        for use in uses:
            held = held_by.get(use.resource)
            if held is None:
                continue
            if len(held) == 1:
                if held[0] is use:
                    del held_by[use.resource]
            elif use in held:  # _Use compares by identity
                held.remove(use)


def _conflict(
    resource: Resource,
    holder: _Use,
    goal: Designator,
    task: cpl.Task,
    parts: frozenset[Resource],
    ledger: ResourceLedger,
) -> ResourceConflict:
    free = sorted(
        str(p.part)
        for p in parts
        if p.kind is resource.kind and p != resource and p not in ledger._uses
    )
    advice = "perform them one after the other (await one, then the other; or cpl.seq)"
    if free:
        advice += f", or use another {resource.kind.value} ({', '.join(free)} is free)"
    what = label(goal)
    return ResourceConflict(
        f"{what} (performed by {_path(task)}) needs the {resource}, held by "
        f"{holder.describe()}: {advice}",
        resource=resource,
        holder=holder.what,
        holder_task=_path(holder.owner),
        goal=what,
        task=_path(task),
    )


def check_parts(
    resources: Iterable[Resource], parts: frozenset[Resource], designator: Designator
) -> None:
    """:class:`executive.DesignatorError` when ``designator`` needs a part the robot does
    not have (``parts``: the environment's). Only the kinds of which some module declares
    a part are checked: a kind none declares is unknown, and any part of it is accepted."""
    if not parts:
        return
    for resource in resources:
        if resource not in parts and any(p.kind is resource.kind for p in parts):
            have = ", ".join(sorted(str(p) for p in parts if p.kind is resource.kind)) or "none"
            raise DesignatorError(
                f"{designator.short()} needs the {resource}, which this robot does not have "
                f"(its {resource.kind.value}s: {have})",
                designator,
            )


def resources_of(fn: Any, arguments: Any, designator: Designator) -> tuple[Resource, ...]:
    """The distinct resources a registered function names for a grounding's arguments;
    a function that fails on them is a :class:`executive.DesignatorError`, one that
    names something else than resources a ``TypeError``."""
    try:
        out = fn(arguments)
        found = out if type(out) is tuple else tuple(out) if out is not None else ()
    except (KeyError, TypeError, ValueError, LookupError) as exc:
        raise DesignatorError(
            f"{designator.short()}: its resources could not be read from its grounding "
            f"({exc!r}); check the function registered with register_resources",
            designator,
        ) from exc
    for r in found:
        if r.__class__ is not Resource:
            raise TypeError(
                f"the resources registered for {designator.short()} must be "
                f"executive.Resource values, got {r!r}"
            )
    return found if len(found) < 2 else tuple(dict.fromkeys(found))
