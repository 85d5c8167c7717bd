"""Resolution rules: which function grounds which designators.

A :class:`RuleSet` maps a pattern ``(kind, type)`` to rule functions that *yield* solutions
lazily (CRAM's Prolog ``action-grounding`` / ``motion-grounding`` clauses), and holds the
location generators and validators of the location pipeline (``_location.py``).

Rule sets form a chain: a child sees its parent's rules, may add its own and may hide the
parent's rules for one pattern (``replace=True``). The chain at import time is::

    builtin_rules (frozen: robot-independent motions, the pose/of location generators,
      the object fallback)  <-  static_rules (what plans register at import time)

Why ``static_rules`` is module-level mutable state, the one exception in ``executive``:
rules are *knowledge*, like CRAM's Prolog rules, not run-time state. A plan module that
defines ``picking-up`` registers its grounding once, at import, and every environment (real
robot or projection) knows it. What differs between environments (process modules, world
model, event subscribers) lives in :class:`executive.Environment`. An environment may still
add or override rules for a block (``Environment(rules=static_rules.child())``), and tests
can use a fresh ``RuleSet()`` (builtins only) or ``RuleSet(parent=None)`` (empty).

Ordering: rules of one pattern run in ascending ``priority``; on ties, exact-type rules
before wildcard (``"*"``) rules, a child's rules before its parent's, then registration
order. Their solutions are concatenated lazily. Lookups are cached per ``(kind, type)`` and
invalidated by any registration anywhere in the chain (a version stamp), so ``perform``'s
hot path is one dict lookup and one tuple comparison.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any, Final, TypeVar

from ._ruledoc import RuleDoc

__all__ = [
    "KINDS",
    "WILDCARD",
    "RuleSet",
    "builtin_rules",
    "register_location_generator",
    "register_location_validator",
    "register_resources",
    "register_rule",
    "rule",
    "static_rules",
]

#: Designator kinds that have (kind, type) rules. Locations use the generator pipeline.
KINDS: Final = frozenset({"action", "motion", "object"})
#: A rule registered for this type applies to every designator of its kind.
WILDCARD: Final = "*"

F = TypeVar("F", bound=Callable[..., Any])


def _arity_adapter(fn: Callable[..., Any], base: int, what: str) -> Callable[..., Any]:
    """Wrap ``fn`` so it is always called with ``base + 1`` arguments (the last one being
    the environment), whether it declares ``base`` or ``base + 1`` positional parameters."""
    if not callable(fn):
        raise TypeError(f"{what} must be callable, got {fn!r}")
    try:
        sig = inspect.signature(fn)
    except (TypeError, ValueError):
        return lambda *args: fn(*args[:base])
    positional = 0
    for p in sig.parameters.values():
        if p.kind is p.VAR_POSITIONAL:
            return fn
        if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD):
            positional += 1
    if positional >= base + 1:
        return fn
    if positional == base:
        return lambda *args: fn(*args[:base])
    raise TypeError(
        f"{what} {getattr(fn, '__qualname__', fn)!r} must take {base} positional argument(s) "
        f"(or {base + 1} with the environment), it takes {positional}"
    )


@dataclass(frozen=True, slots=True)
class Rule:
    """One registered function. ``call`` always takes ``(designator, environment)`` (or
    ``(designator, pose, environment)`` for validators)."""

    kind: str
    type: str
    priority: float
    seq: int
    fn: Callable[..., Any]
    call: Callable[..., Any]
    #: The property keys the rule understands (``type`` is always known), or ``None``: not
    #: declared, any key accepted. See :meth:`RuleSet.register`.
    keys: frozenset[str] | None = None
    #: What the rule documents about itself (keys, failures, retries), or ``None``; the
    #: designator reference is generated from it (see :class:`executive.RuleDoc`).
    doc: RuleDoc | None = None

    @property
    def name(self) -> str:
        return str(getattr(self.fn, "__qualname__", repr(self.fn)))


def _declared(keys: Iterable[str] | None) -> frozenset[str] | None:
    """The ``keys=`` of a registration, in designator spelling (``joint_angle`` ->
    ``joint-angle``)."""
    if keys is None:
        return None
    if isinstance(keys, str):
        raise TypeError(f"keys must be a collection of key names, got the string {keys!r}")
    return frozenset(str(k).replace("_", "-") for k in keys)


def _keys_and_doc(
    keys: Iterable[str] | None, doc: RuleDoc | None, what: str
) -> tuple[frozenset[str] | None, RuleDoc | None]:
    """The declared keys of a registration: ``doc``'s keys when it has a doc (one source
    of truth; ``keys`` given too must name the same ones)."""
    declared = _declared(keys)
    if doc is None:
        return declared, None
    if not isinstance(doc, RuleDoc):
        raise TypeError(f"{what}: doc must be an executive.RuleDoc, got {doc!r}")
    if declared is not None and (doc.any_key or declared != doc.key_names):
        raise ValueError(
            f"{what}: keys= {sorted(declared)} differ from the doc's keys "
            f"{sorted(doc.key_names)}; drop keys= (the doc's keys are the declared ones)"
        )
    return (None if doc.any_key else doc.key_names), doc


class RuleSet:
    """A set of resolution rules, location generators and location validators.

    ``RuleSet()`` starts from the frozen builtins; ``RuleSet(parent=None)`` is empty;
    ``rules.child()`` overlays a set on ``rules``. Registering on a frozen set raises
    ``RuntimeError``.
    """

    def __init__(self, parent: RuleSet | str | None = "builtin", *, name: str = "rules") -> None:
        if parent == "builtin":
            parent = builtin_rules
        if parent is not None and not isinstance(parent, RuleSet):
            raise TypeError(f"parent must be a RuleSet or None, got {parent!r}")
        self.parent: RuleSet | None = parent
        self.name = name
        self._rules: dict[tuple[str, str], list[Rule]] = {}
        self._replaced: set[tuple[str, str]] = set()
        self._generators: list[Rule] = []
        self._validators: list[Rule] = []
        # grounding target (an action's plan function, a motion's command name) ->
        # (function of the grounding's arguments naming the resources, shared?)
        self._resources: dict[Any, tuple[Callable[[Any], Any], bool]] = {}
        self._seq = 0
        self._version = 0
        self._frozen = False
        self._cache: dict[Any, tuple[tuple[int, ...], tuple[Rule, ...]]] = {}
        # (kind, type) -> (stamp, rules, keys they read or None); see lookup()
        self._lookups: dict[
            tuple[str, str], tuple[tuple[int, ...], tuple[Rule, ...], frozenset[str] | None]
        ] = {}
        #: After this many candidates in a row are rejected, a location stream ends
        #: (CRAM's ``*location-generator-max-retries*``).
        self.location_max_rejections: int = parent.location_max_rejections if parent else 30

    # -- registration ---------------------------------------------------------------------
    def _bump(self) -> int:
        if self._frozen:
            raise RuntimeError(
                f"rule set {self.name!r} is frozen; register on executive.static_rules "
                "or on a child (rules.child())"
            )
        self._seq += 1
        self._version += 1
        return self._seq

    def register(
        self,
        kind: str,
        type: str,
        fn: F,
        *,
        priority: float = 0,
        replace: bool = False,
        keys: Iterable[str] | None = None,
        doc: RuleDoc | None = None,
    ) -> F:
        """Register ``fn(designator[, environment])``, a generator of solutions, for
        designators of ``kind`` (``"action"``, ``"motion"``, ``"object"``) whose ``type``
        property is ``type`` (``"*"``: any type). ``replace=True`` hides the parent chain's
        rules for this pattern. Returns ``fn`` (so it works as a decorator body).

        ``keys``: the property keys the rule reads (``type`` is implied). When every rule
        for a designator's kind and type declares its keys, a designator with another key
        (a typo such as ``objekt``) fails to resolve with a ``DesignatorError`` that lists
        the known keys, before anything is performed (CRAM ignored unknown keys silently;
        we differ on purpose). A rule registered without ``keys`` accepts any key: that is
        how a rule explicitly allows keys it does not list.

        Solutions: actions yield ``(plan_function, arguments)``, motions
        ``(command, arguments)``, objects :class:`executive.ObjectData` (or anything with a
        ``pose``). Raise :class:`executive.DesignatorError` for a missing or bad property.

        ``doc``: an :class:`executive.RuleDoc` (keys with types and defaults, failures,
        retries) for the generated designator reference; its keys are the declared keys.
        """
        if kind == "location":
            raise ValueError(
                "location designators are resolved by the generator/validator pipeline: "
                "use register_location_generator(fn, priority) / "
                "register_location_validator(fn, priority)"
            )
        if kind not in KINDS:
            raise ValueError(f"unknown designator kind {kind!r}; expected one of {sorted(KINDS)}")
        if not isinstance(type, str) or not type:
            raise TypeError(f"a rule's type must be a non-empty string (or '*'), got {type!r}")
        call = _arity_adapter(fn, 1, f"{kind} rule for {type!r}")
        declared, doc = _keys_and_doc(keys, doc, f"{kind} rule for {type!r}")
        seq = self._bump()
        key = (kind, type)
        if replace:
            self._replaced.add(key)
        self._rules.setdefault(key, []).append(
            Rule(kind, type, priority, seq, fn, call, declared, doc)
        )
        return fn

    def rule(
        self,
        kind: str,
        type: str,
        *,
        priority: float = 0,
        replace: bool = False,
        keys: Iterable[str] | None = None,
        doc: RuleDoc | None = None,
    ) -> Callable[[F], F]:
        """Decorator form of :meth:`register`."""

        def deco(fn: F) -> F:
            return self.register(
                kind, type, fn, priority=priority, replace=replace, keys=keys, doc=doc
            )

        return deco

    def register_location_generator(
        self,
        fn: F,
        priority: float = 0,
        *,
        keys: Iterable[str] | None = None,
        doc: RuleDoc | None = None,
    ) -> F:
        """Register ``fn(designator[, environment])`` yielding candidate poses (possibly
        infinitely many). Generators run in ascending priority (CRAM: Prolog groundings at
        10, costmaps at 20); their outputs are concatenated lazily. ``keys``: the location
        keys it understands; when every generator declares them, a location designator with
        another key fails to resolve, listing the known ones (as :meth:`register`);
        ``doc`` as for :meth:`register`."""
        call = _arity_adapter(fn, 1, "location generator")
        declared, doc = _keys_and_doc(keys, doc, "location generator")
        seq = self._bump()
        self._generators.append(Rule("location", WILDCARD, priority, seq, fn, call, declared, doc))
        return fn

    def register_location_validator(self, fn: F, priority: float = 0) -> F:
        """Register ``fn(designator, pose[, environment])`` returning ``"accept"``,
        ``"reject"`` (or ``None``/``False``), ``"maybe-reject"`` or ``"unknown"`` (or a
        :class:`executive.Validation`). Validators run in ascending priority."""
        call = _arity_adapter(fn, 2, "location validator")
        seq = self._bump()
        self._validators.append(Rule("location", "validator", priority, seq, fn, call))
        return fn

    def register_resources(
        self, target: Any, fn: Callable[[Any], Any], *, shared: bool = False
    ) -> None:
        """Declare the robot parts (:class:`executive.Resource`) a goal occupies, as a
        function of its grounding's resolved arguments: ``target`` is the plan function an
        action rule yields (``fn(arguments)`` for an action grounding ``(plan,
        arguments)``) or the command name of a motion (``fn(arguments)`` for a motion
        command ``(command, arguments)``). ``fn`` returns the resources (an iterable).

        An action claims them for its whole duration, exclusively; a motion uses them
        while it runs, sharing them with other motions; ``shared=True`` makes an action's
        claim shared too (it coexists with other shared uses and with motions, and
        conflicts with an exclusive claim held outside its subtree). See
        :mod:`executive._resources` for what two goals on one resource do."""
        if not (isinstance(target, str) and target) and not callable(target):
            raise TypeError(
                "register_resources needs the plan function an action rule yields or a "
                f"motion command name, got {target!r}"
            )
        if not callable(fn):
            raise TypeError(
                f"register_resources needs a function of the grounding's arguments, got {fn!r}"
            )
        self._bump()
        self._resources[target] = (fn, bool(shared))

    def resources_for(self, target: Any) -> tuple[Callable[[Any], Any], bool] | None:
        """The registration for a grounding target (this set's, else the nearest
        parent's), or ``None``: the goal needs no resource."""
        rs: RuleSet | None = self
        while rs is not None:
            if rs._resources:
                try:
                    found = rs._resources.get(target)
                except TypeError:  # an unhashable target: registered for nothing
                    return None
                if found is not None:
                    return found
            rs = rs.parent
        return None

    def child(self, name: str | None = None) -> RuleSet:
        """A new rule set overlaid on this one."""
        return RuleSet(parent=self, name=name or f"{self.name}+")

    def freeze(self) -> None:
        """Refuse further registrations (the builtins are frozen at import)."""
        self._frozen = True

    @property
    def frozen(self) -> bool:
        return self._frozen

    @contextmanager
    def restoring(self) -> Iterator[RuleSet]:
        """Undo, on leaving the block, every registration made on this set inside it (a
        test that registers on :data:`static_rules` leaves it as it found it)."""
        saved = (
            {key: list(rules) for key, rules in self._rules.items()},
            set(self._replaced),
            list(self._generators),
            list(self._validators),
            self._frozen,
            dict(self._resources),
        )
        try:
            yield self
        finally:
            (
                self._rules,
                self._replaced,
                self._generators,
                self._validators,
                self._frozen,
                self._resources,
            ) = saved
            self._version += 1  # a new stamp: lookups cached in the block are stale

    # -- lookup -----------------------------------------------------------------------------
    def _stamp(self) -> tuple[int, ...]:
        if self.parent is None:
            return (self._version,)
        return (self._version, *self.parent._stamp())

    def _chain(self) -> list[RuleSet]:
        out: list[RuleSet] = []
        rs: RuleSet | None = self
        while rs is not None:
            out.append(rs)
            rs = rs.parent
        return out

    def _collect(self, key: tuple[str, str]) -> list[tuple[int, Rule]]:
        found: list[tuple[int, Rule]] = []
        for level, rs in enumerate(self._chain()):
            found.extend((level, r) for r in rs._rules.get(key, ()))
            if key in rs._replaced:
                break
        return found

    def rules_for(self, kind: str, type: str) -> tuple[Rule, ...]:
        """The rules that ground a designator of ``kind`` and ``type``, in call order."""
        return self.lookup(kind, type)[0]

    def lookup(self, kind: str, type: str) -> tuple[tuple[Rule, ...], frozenset[str] | None]:
        """The rules for ``kind`` and ``type`` (as :meth:`rules_for`) and the keys they
        read: ``None`` when one of them does not declare its keys (then any key is
        accepted). Cached until the rule set (or a parent) changes."""
        key = (kind, type)
        stamp = self._stamp()
        hit = self._lookups.get(key)
        if hit is not None and hit[0] == stamp:
            return hit[1], hit[2]
        rules = self._sorted_rules(kind, type)
        declared = [r.keys for r in rules]
        known = (
            None
            if not declared or any(k is None for k in declared)
            else frozenset({"type"}.union(*(k for k in declared if k is not None)))
        )
        self._lookups[key] = (stamp, rules, known)
        return rules, known

    def _sorted_rules(self, kind: str, type: str) -> tuple[Rule, ...]:
        key = (kind, type)
        tagged = [(r.priority, 0, level, r.seq, r) for level, r in self._collect(key)]
        if type != WILDCARD:
            tagged += [
                (r.priority, 1, level, r.seq, r) for level, r in self._collect((kind, WILDCARD))
            ]
        tagged.sort(key=lambda t: t[:4])
        return tuple(t[4] for t in tagged)

    def _location(self, which: str) -> tuple[Rule, ...]:
        stamp = self._stamp()
        hit = self._cache.get(which)
        if hit is not None and hit[0] == stamp:
            return hit[1]
        tagged = []
        for level, rs in enumerate(self._chain()):
            entries = rs._generators if which == "generators" else rs._validators
            tagged += [(r.priority, level, r.seq, r) for r in entries]
        tagged.sort(key=lambda t: t[:3])
        rules = tuple(t[3] for t in tagged)
        self._cache[which] = (stamp, rules)
        return rules

    def location_generators(self) -> tuple[Rule, ...]:
        """Location generators in call order."""
        return self._location("generators")

    def location_validators(self) -> tuple[Rule, ...]:
        """Location validators in call order."""
        return self._location("validators")

    def documented_rules(self, kind: str) -> dict[str, tuple[Rule, ...]]:
        """Every concrete type of ``kind`` with the rules that ground it, in call order
        (types sorted): what the designator reference walks."""
        return {t: self.rules_for(kind, t) for t in self.known_types(kind)}

    def known_types(self, kind: str) -> list[str]:
        """Every concrete type with a rule of ``kind`` (for error messages)."""
        types: set[str] = set()
        for rs in self._chain():
            types.update(t for (k, t) in rs._rules if k == kind and t != WILDCARD)
        return sorted(types)

    def __repr__(self) -> str:
        parent = f" parent={self.parent.name!r}" if self.parent else ""
        return f"<RuleSet {self.name!r}{parent} version={self._version}>"


#: Robot-independent knowledge shipped with ``executive``; frozen once the package loads.
builtin_rules: Final = RuleSet(parent=None, name="builtin")
#: Static knowledge registered by plan modules at import time (see the module docstring).
static_rules: Final = RuleSet(parent=builtin_rules, name="static")


def register_rule(
    kind: str,
    type: str,
    fn: F,
    *,
    priority: float = 0,
    replace: bool = False,
    keys: Iterable[str] | None = None,
    doc: RuleDoc | None = None,
) -> F:
    """Register a rule in the static rule set (see :meth:`RuleSet.register`)."""
    return static_rules.register(
        kind, type, fn, priority=priority, replace=replace, keys=keys, doc=doc
    )


def rule(
    kind: str,
    type: str,
    *,
    priority: float = 0,
    replace: bool = False,
    keys: Iterable[str] | None = None,
    doc: RuleDoc | None = None,
) -> Callable[[F], F]:
    """Decorator: ``@executive.rule("action", "picking-up", doc=RuleDoc(...))`` registers
    statically."""
    return static_rules.rule(kind, type, priority=priority, replace=replace, keys=keys, doc=doc)


def register_location_generator(
    fn: F, priority: float = 0, *, keys: Iterable[str] | None = None, doc: RuleDoc | None = None
) -> F:
    """Register a location generator in the static rule set."""
    return static_rules.register_location_generator(fn, priority, keys=keys, doc=doc)


def register_location_validator(fn: F, priority: float = 0) -> F:
    """Register a location validator in the static rule set."""
    return static_rules.register_location_validator(fn, priority)


def register_resources(target: Any, fn: Callable[[Any], Any], *, shared: bool = False) -> None:
    """Declare a goal's resources in the static rule set (see
    :meth:`RuleSet.register_resources`)."""
    static_rules.register_resources(target, fn, shared=shared)
