"""Environments: which process modules, rules, world model and event subscribers are active.

CRAM binds these with special variables (``*projection-environment*``, the TF transformer,
the designator role). We bind them with one context variable, so a projected plan and a real
one can run in the same process, even concurrently in two tasks, without touching each
other: every asyncio (and cpl) task copies the context of its creator.

``async with executive.environment(world=w, process_modules=[...])`` starts an independent
environment; ``async with executive.with_process_modules(pm, ...)`` derives one from the
current environment that shares its world, rules and event subscribers and adds modules.
Outside any block, :func:`current_environment` returns an empty, read-only environment that
knows the static rules and nothing else.
"""

from __future__ import annotations

from collections.abc import AsyncIterator, Callable, Iterable, Sequence
from contextlib import AbstractAsyncContextManager, asynccontextmanager
from contextvars import ContextVar
from typing import TYPE_CHECKING, Any, Protocol, TypeVar

from ._resources import Resource, ResourceLedger
from ._rules import RuleSet, static_rules
from ._world import ProjectionWorld
from .failures import NoKitchenDescription, NoRobotDescription, NoWorldModel

if TYPE_CHECKING:
    from ._kitchen import KitchenDescription
    from ._process_module import ProcessModule
    from ._robot import RobotDescription
    from .events import Event

__all__ = [
    "Environment",
    "Imagination",
    "Preferences",
    "current_environment",
    "environment",
    "with_process_modules",
]

E = TypeVar("E", bound="Event")


class Imagination(Protocol):
    """How a robot that acts in the real world imagines (CRAM's projection reasoning): a
    cheap snapshot / restore of its belief world, and a projection environment over that
    belief world. The real robot's environment carries one; projection environments carry
    none (``with_projected_task_tree`` is a pass-through there)."""

    def snapshot(self) -> Any:
        """Save the belief world."""
        ...

    def restore(self, snapshot: Any) -> None:
        """Put the belief world back exactly as saved."""
        ...

    def projection(self) -> AbstractAsyncContextManager[Any]:
        """Enter a projection environment (projected process modules, rules and world
        model) over the belief world."""
        ...


class Preferences(Protocol):
    """What experience taught about the order to try a plan's choices in (e.g. the
    experience store's learned priors): robot-independent, carried by an environment
    (:attr:`Environment.preferences`, None: the rules' own order). It only reorders the
    choices it is given, never adds or drops one."""

    def order_choices(
        self, action: str, obj: str, choices: Sequence[tuple[str, str | None]]
    ) -> list[tuple[str, str | None]]:
        """``choices`` ((arm, grasp) pairs for ``action`` on an ``obj`` type), best first."""
        ...

    def base_density(self, action: str, obj: str) -> Callable[[Any, Any, Any], Any] | None:
        """Where the base stood when ``action`` on an ``obj`` type succeeded: a function
        of the base pose in the object's frame (x, y, yaw; numpy arrays of one shape) to
        a weight in [0, 1] (1: where experience says to stand), or None when nothing was
        learned. Location resolution multiplies it into a base costmap, never emptying it."""
        ...


class _Subscribers:
    """Event callbacks by event type, shared by an environment and those derived from it."""

    __slots__ = ("by_type",)

    def __init__(self) -> None:
        self.by_type: dict[type, list[Callable[[Any], Any]]] = {}


class Environment:
    """The process modules, rules, world model and event subscribers of a block.

    Build one directly (``Environment(name="projection", world=w, process_modules=[...])``)
    and enter it with :func:`environment`; or derive one with :meth:`derive`. ``rules``
    defaults to :data:`executive.static_rules`; :meth:`register_rule` gives the environment
    its own overlay on first use, so rules added for a block never leak out of it.
    """

    __slots__ = (
        "_frozen",
        "_ledger",
        "_owns_rules",
        "_parts",
        "_subscribers",
        "_world",
        "imagination",
        "name",
        "parent",
        "preferences",
        "process_modules",
        "projecting",
        "rules",
    )

    def __init__(
        self,
        name: str = "environment",
        *,
        process_modules: Iterable[ProcessModule] = (),
        world: ProjectionWorld | None = None,
        rules: RuleSet | None = None,
        projecting: bool = False,
        imagination: Imagination | None = None,
        preferences: Preferences | None = None,
    ) -> None:
        self.name = name
        #: The order to try choices in, learned from experience; None: the rules' order.
        self.preferences = preferences
        #: True in a projection environment (the robot is imagining, not acting).
        self.projecting = projecting
        #: How to imagine from here (set by a real robot's environment), else None.
        self.imagination = imagination
        self.process_modules: tuple[ProcessModule, ...] = _check_modules(process_modules)
        self._world = world
        self.rules: RuleSet = rules if rules is not None else static_rules
        if not isinstance(self.rules, RuleSet):
            raise TypeError(f"rules must be an executive.RuleSet, got {rules!r}")
        self._owns_rules = rules is not None and not self.rules.frozen
        self._subscribers = _Subscribers()
        # who holds which robot part (executive._resources); shared with the environments
        # derived from this one, which drive the same robot
        self._ledger = ResourceLedger()
        # the robot's parts (see resources), computed on first use: the process modules
        # and the parts they declare do not change once the environment is built
        self._parts: frozenset[Resource] | None = None
        self.parent: Environment | None = None
        self._frozen = False

    # -- world ------------------------------------------------------------------------
    @property
    def world(self) -> ProjectionWorld:
        """The world model; raises :class:`executive.NoWorldModel` when there is none."""
        if self._world is None:
            raise NoWorldModel(
                f"environment {self.name!r} has no world model: enter "
                "executive.environment(world=...) around the plan"
            )
        return self._world

    @property
    def has_world(self) -> bool:
        return self._world is not None

    @property
    def robot(self) -> RobotDescription:
        """The description of the robot this environment drives: its world model's
        (:attr:`executive.WorldQueries.robot`). Plans read the robot's name, arms, frames
        and named states here and never spell them. No world model:
        :class:`executive.NoWorldModel`; a world model without a description:
        :class:`executive.NoRobotDescription`."""
        robot = self.world.robot
        if robot is None:
            raise NoRobotDescription(
                f"environment {self.name!r}: its world model {type(self.world).__name__} "
                "carries no robot description; build it with robot=<a "
                "RobotDescription, e.g. from the top-level robots package>"
            )
        return robot

    @property
    def kitchen(self) -> KitchenDescription:
        """The description of the kitchen this environment's robot works in: its world
        model's (:attr:`executive.WorldQueries.kitchen`). Plans read the kitchen's surfaces,
        container, floor height and demo scene here and never spell its link names. No
        world model: :class:`executive.NoWorldModel`; a world model without a description:
        :class:`executive.NoKitchenDescription`."""
        kitchen = self.world.kitchen
        if kitchen is None:
            raise NoKitchenDescription(
                f"environment {self.name!r}: its world model {type(self.world).__name__} "
                "carries no kitchen description; build it with kitchen=<a "
                "KitchenDescription, e.g. from the top-level kitchens package>"
            )
        return kitchen

    # -- derivation -------------------------------------------------------------------
    def derive(
        self,
        name: str | None = None,
        *,
        process_modules: Iterable[ProcessModule] = (),
        world: ProjectionWorld | None = None,
        rules: RuleSet | None = None,
    ) -> Environment:
        """A child environment: this one's modules followed by ``process_modules``; the same
        world, rules and event subscribers unless overridden."""
        env = Environment(
            name or self.name,
            process_modules=(*self.process_modules, *_check_modules(process_modules)),
            world=world if world is not None else self._world,
            rules=rules if rules is not None else self.rules,
            projecting=self.projecting,
            imagination=self.imagination,
            preferences=self.preferences,
        )
        env._owns_rules = False if rules is None else env._owns_rules
        env._subscribers = self._subscribers
        env._ledger = self._ledger
        env.parent = self
        return env

    @property
    def resources(self) -> frozenset[Resource]:
        """The robot's parts: those its process modules drive
        (:attr:`executive.ProcessModule.resources`). A goal that needs a part of a kind
        listed here that is not listed fails to resolve; a kind no module lists is
        unknown, and any part of it is accepted."""
        parts = self._parts
        if parts is None:
            parts = self._parts = frozenset().union(*(pm.resources for pm in self.process_modules))
        return parts

    def is_within(self, other: Environment) -> bool:
        """True if this environment is ``other`` or was derived from it."""
        env: Environment | None = self
        while env is not None:
            if env is other:
                return True
            env = env.parent
        return False

    # -- rules ------------------------------------------------------------------------
    def _own_rules(self) -> RuleSet:
        self._check_mutable()
        if not self._owns_rules:
            self.rules = self.rules.child(f"{self.name}-rules")
            self._owns_rules = True
        return self.rules

    def register_rule(
        self,
        kind: str,
        type: str,
        fn: Callable[..., Any],
        *,
        priority: float = 0,
        replace: bool = False,
        keys: Any = None,
        doc: Any = None,
    ) -> None:
        """Add (or with ``replace=True`` override) a rule for this environment only
        (``keys``, ``doc``: see :meth:`executive.RuleSet.register`)."""
        self._own_rules().register(
            kind, type, fn, priority=priority, replace=replace, keys=keys, doc=doc
        )

    def register_location_generator(
        self, fn: Callable[..., Any], priority: float = 0, *, keys: Any = None, doc: Any = None
    ) -> None:
        self._own_rules().register_location_generator(fn, priority, keys=keys, doc=doc)

    def register_location_validator(self, fn: Callable[..., Any], priority: float = 0) -> None:
        self._own_rules().register_location_validator(fn, priority)

    # -- events -----------------------------------------------------------------------
    def subscribe(self, event_type: type[E], callback: Callable[[E], Any]) -> Callable[[], None]:
        """Call ``callback(event)`` for every emitted event that is an instance of
        ``event_type``. Returns a function that unsubscribes. Callbacks run synchronously
        inside :meth:`emit`, after the world model; an exception in one propagates to the
        emitter."""
        self._check_mutable()
        if not isinstance(event_type, type):
            raise TypeError(f"subscribe() needs an event class, got {event_type!r}")
        if not callable(callback):
            raise TypeError(f"subscribe() needs a callable, got {callback!r}")
        callbacks = self._subscribers.by_type.setdefault(event_type, [])
        callbacks.append(callback)

        def unsubscribe() -> None:
            if callback in callbacks:
                callbacks.remove(callback)

        return unsubscribe

    def emit(self, event: Event) -> None:
        """Deliver ``event`` to the world model (``handle_event``), then to subscribers of
        its class and its base classes, in subscription order."""
        if self._world is not None:
            self._world.handle_event(event)
        by_type = self._subscribers.by_type
        if not by_type:
            return
        for cls in type(event).__mro__:
            for cb in tuple(by_type.get(cls, ())):
                cb(event)

    # -- misc -------------------------------------------------------------------------
    def _check_mutable(self) -> None:
        if self._frozen:
            raise RuntimeError(
                "no executive environment is active: wrap the code in "
                "`async with executive.environment(...)` (or with_process_modules(...))"
            )

    def find_process_module(self, name: str) -> ProcessModule | None:
        for pm in self.process_modules:
            if pm.name == name:
                return pm
        return None

    def __repr__(self) -> str:
        pms = ", ".join(pm.name for pm in self.process_modules)
        return f"<Environment {self.name!r} pms=[{pms}] rules={self.rules.name!r}>"


def _check_modules(pms: Iterable[Any]) -> tuple[ProcessModule, ...]:
    out = tuple(pms)
    if not out:
        return ()
    from ._process_module import ProcessModule

    for pm in out:
        if not isinstance(pm, ProcessModule):
            raise TypeError(f"expected executive.ProcessModule instances, got {pm!r}")
    return out


def _null_environment() -> Environment:
    env = Environment("no-environment")
    env._frozen = True
    return env


#: The read-only environment seen outside any block (static rules; no modules, no world).
_NULL: Environment = _null_environment()
_CURRENT: ContextVar[Environment] = ContextVar("executive_environment", default=_NULL)


def current_environment() -> Environment:
    """The environment of the running code (an empty read-only one outside any block)."""
    return _CURRENT.get()


@asynccontextmanager
async def environment(
    env: Environment | None = None,
    /,
    *,
    name: str = "environment",
    process_modules: Iterable[ProcessModule] = (),
    world: ProjectionWorld | None = None,
    rules: RuleSet | None = None,
    projecting: bool = False,
    imagination: Imagination | None = None,
) -> AsyncIterator[Environment]:
    """Run a block in ``env`` (or a new independent :class:`Environment` built from the
    keywords). Its process modules are activated for the block; on leaving (also on failure
    or evaporation) every goal submitted from within the block is evaporated and awaited, so
    no goal outlives it."""
    if env is None:
        env = Environment(
            name,
            process_modules=process_modules,
            world=world,
            rules=rules,
            projecting=projecting,
            imagination=imagination,
        )
    elif process_modules or world is not None or rules is not None or imagination is not None:
        raise TypeError("pass either an Environment or keywords to build one, not both")
    async with _activated(env, env.process_modules):
        yield env


@asynccontextmanager
async def with_process_modules(*pms: ProcessModule) -> AsyncIterator[Environment]:
    """Activate ``pms`` for a block (CRAM's ``with-process-modules-running``): the block runs
    in an environment derived from the current one (same world, rules and subscribers) with
    these modules appended. Leaving the block evaporates any goal still running on them."""
    parent = _CURRENT.get()
    if parent._frozen:
        env = Environment("process-modules", process_modules=pms)
    else:
        env = parent.derive(process_modules=pms)
    async with _activated(env, pms):
        yield env


@asynccontextmanager
async def _activated(env: Environment, pms: Iterable[ProcessModule]) -> AsyncIterator[None]:
    started: list[ProcessModule] = []
    token = _CURRENT.set(env)
    try:
        for pm in pms:
            pm._activate()
            started.append(pm)
        yield
    finally:
        try:
            for pm in reversed(started):
                await pm._deactivate(env)
        finally:
            _CURRENT.reset(token)
