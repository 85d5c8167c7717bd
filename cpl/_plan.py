"""``@cpl.plan``: CRAM's ``def-cram-function``.

Each call of a plan runs as a named child task (kind ``plan``) that records the call's
arguments in the task tree, and is joined: ``await go(pose)`` returns the plan's value or
re-raises its failure. Calling the same plan again at the same place gets the path entry
``name#2``, ``name#3``... (CRAM's ``:call n``). Forms take plan calls as named branches.
"""

from __future__ import annotations

import functools
import inspect
from collections.abc import Callable, Coroutine, Generator
from typing import Any, Generic, ParamSpec, TypeVar, overload

from ._task import Task, _require_task, run_joined

__all__ = ["PlanCall", "plan"]

P = ParamSpec("P")
R = TypeVar("R")


class PlanCall(Generic[R]):
    """One pending call of a plan. Await it (or hand it to a form) exactly once."""

    __slots__ = ("_annotations", "_args", "_arguments", "_consumed", "_kwargs", "_plan")

    def __init__(
        self,
        plan: Plan[Any, R],
        args: tuple[Any, ...],
        kwargs: dict[str, Any],
        arguments: dict[str, Any],
    ) -> None:
        self._plan = plan
        self._args = args
        self._kwargs = kwargs
        self._arguments = arguments
        self._annotations: dict[str, Any] | None = None
        self._consumed = False

    @property
    def name(self) -> str:
        return self._plan.name

    def annotate(self, **annotations: Any) -> PlanCall[R]:
        """Put annotations on the task node before it starts (e.g. the designator)."""
        if self._annotations is None:
            self._annotations = {}
        self._annotations.update(annotations)
        return self

    def make_task(self, parent: Task) -> Task:
        if self._consumed:
            raise RuntimeError(f"the call of plan {self.name!r} was already awaited; call it again")
        self._consumed = True
        coro = self._plan.fn(*self._args, **self._kwargs)
        return Task(
            coro,
            self._plan.name,
            kind="plan",
            arguments=self._arguments,
            annotations=self._annotations,
            parent=parent,
        )

    def close(self) -> None:
        self._consumed = True

    def __await__(self) -> Generator[Any, None, R]:
        parent = _require_task(f"plan {self.name!r}")
        child = self.make_task(parent)
        result: R = yield from run_joined(child).__await__()
        return result

    def __repr__(self) -> str:
        return f"<PlanCall {self.name}>"


class Plan(Generic[P, R]):
    """A plan function; calling it returns a :class:`PlanCall` to await."""

    def __init__(self, fn: Callable[P, Coroutine[Any, Any, R]], name: str | None = None) -> None:
        if not inspect.iscoroutinefunction(fn):
            raise TypeError(
                f"@cpl.plan decorates async functions; {getattr(fn, '__name__', fn)!r} is not one"
            )
        self.fn = fn
        self.name = name or fn.__name__
        self.signature = inspect.signature(fn)
        params = list(self.signature.parameters.values())
        # Fast path for the common plan signature (plain positional-or-keyword parameters):
        # names in order and their defaults; anything else goes through Signature.bind.
        simple = all(p.kind is inspect.Parameter.POSITIONAL_OR_KEYWORD for p in params)
        self._names: tuple[str, ...] | None = tuple(p.name for p in params) if simple else None
        self._defaults = {p.name: p.default for p in params if p.default is not p.empty}
        functools.update_wrapper(self, fn)

    def bind(self, args: tuple[Any, ...], kwargs: dict[str, Any]) -> dict[str, Any]:
        names = self._names
        if names is not None and len(args) <= len(names):
            bound = dict(zip(names, args))
            if kwargs:
                for key, value in kwargs.items():
                    if key not in names or key in bound:
                        break
                    bound[key] = value
                else:
                    kwargs = {}
            if not kwargs:
                for name in names[len(args) :]:
                    if name not in bound:
                        if name not in self._defaults:
                            break
                        bound[name] = self._defaults[name]
                else:
                    return bound
        try:
            full = self.signature.bind(*args, **kwargs)
        except TypeError as exc:
            raise TypeError(f"plan {self.name!r}: {exc}") from None
        full.apply_defaults()
        return dict(full.arguments)

    def __call__(self, *args: P.args, **kwargs: P.kwargs) -> PlanCall[R]:
        # Bind at the call site: bad arguments fail early, where the mistake is.
        return PlanCall(self, args, kwargs, self.bind(args, kwargs))

    def __repr__(self) -> str:
        return f"<cpl.plan {self.name}>"


@overload
def plan(fn: Callable[P, Coroutine[Any, Any, R]], /) -> Plan[P, R]: ...
@overload
def plan(*, name: str) -> Callable[[Callable[P, Coroutine[Any, Any, R]]], Plan[P, R]]: ...


def plan(fn: Any = None, /, *, name: str | None = None) -> Any:
    """Decorate an async function as a plan: ``@cpl.plan`` or ``@cpl.plan(name="...")``."""
    if fn is None:
        return lambda f: Plan(f, name)
    return Plan(fn, name)
