"""Designators: immutable symbolic descriptions resolved lazily into solutions.

``an.action(type="picking-up", object=cup, arm="left")`` describes an action;
``a.location(("side", "left"), ("side", "front"), on=counter, range=0.5)`` a location.
Properties are an ordered sequence of ``(key, value)`` pairs and a key may repeat, as in
CRAM's ``(side left) (side front)``: repeats are given as positional pairs. Keys are stored
in CRAM's spelling: a keyword's underscores become hyphens (``range_invert=`` ->
``range-invert``) and a trailing underscore is dropped (``in_=`` -> ``in``); lookups accept
either spelling. A list value is one value (stored as a tuple so the description stays
immutable). Properties whose value is ``None`` are left out, as CRAM's ``an``/``a`` drop
``NIL`` properties, so ``an.action(type="picking-up", arm=arm)`` with ``arm=None`` has no
``arm``.

The description never changes; the *chain* does. ``reference()`` resolves the first solution
and caches it; ``next_solution()`` returns a new designator equated to this one (its
successor) whose solution is the next element of the same lazy solution stream;
``current()`` is the newest member of the chain; ``newest_effective()`` the newest one that
has been referenced. Resolution uses the rules of the environment active when the stream is
first needed, and the stream keeps that environment for every later solution (it runs its
generators in a copy of the creator's ``contextvars`` context, as CRAM's
``with-lazy-list-dynamic-environment``).

Deliberate differences from CRAM: ``==`` is identity (designators carry chain state); use
:meth:`Designator.same_description` to compare descriptions. Invalid values (a NaN) are
reported by ``reference()`` with :class:`executive.DesignatorError`, not at construction.
"""

from __future__ import annotations

import contextvars
import math
from collections.abc import Iterator, Mapping
from typing import TYPE_CHECKING, Any, ClassVar, Final, Self, cast

from cpl import LazyList
from cpl._scheduling import CURRENT_TASK

from ._environment import Environment, current_environment
from ._pose import Pose, Transform
from ._rules import WILDCARD, Rule
from ._solutions import ActionGrounding, MotionCommand
from .failures import DesignatorError, DesignatorInputError

if TYPE_CHECKING:
    from rich.text import Text

__all__ = [
    "ActionDesignator",
    "Designator",
    "LocationDesignator",
    "MotionDesignator",
    "ObjectDesignator",
    "a",
    "an",
    "cram_key",
    "equate",
]

Pair = tuple[str, Any]


def cram_key(key: str) -> str:
    """CRAM's spelling of a property key: ``range_invert`` -> ``range-invert``,
    ``in_`` -> ``in``; CRAM spellings pass unchanged."""
    if not isinstance(key, str) or not key:
        raise TypeError(f"a designator property key must be a non-empty string, got {key!r}")
    if key.endswith("_") and len(key) > 1:
        key = key.rstrip("_")
    return key.replace("_", "-") if "_" in key else key


def _freeze(value: Any) -> Any:
    if isinstance(value, list):
        return tuple(_freeze(v) for v in value)
    return value


def _build(pairs: tuple[Any, ...], kw: Mapping[str, Any]) -> tuple[Pair, ...]:
    out: list[Pair] = []
    for pair in pairs:
        if not isinstance(pair, tuple) or len(pair) != 2:
            raise TypeError(
                f"positional designator properties are (key, value) pairs, got {pair!r}; "
                "e.g. a.location(('side', 'left'), ('side', 'front'), on=table)"
            )
        key, value = pair
        if value is not None:
            out.append((cram_key(key), _freeze(value)))
    for key, value in kw.items():  # the hot path: keys are str, most without "_"
        if value is not None:
            if "_" in key:
                key = cram_key(key)
            out.append((key, tuple(map(_freeze, value)) if type(value) is list else value))
    return tuple(out)


# -------------------------------------------------------------------------------- stream
_NONE: Any = object()  # no solution yet


class _SolutionStream:
    """A memoised, multi-consumer stream of solutions, generated in the context (and so the
    environment) of its creator. A generator error is remembered and re-raised on every later
    access past the solutions already produced."""

    __slots__ = ("_ctx", "_error", "_first", "_it", "_more")

    def __init__(self, it: Iterator[Any]) -> None:
        # The solutions so far: _first, then _more (a list created at the second solution:
        # most streams only ever give one, and a designator in the task tree keeps its
        # stream, so one object less here is one less for the garbage collector to scan).
        self._first: Any = _NONE
        self._more: list[Any] | None = None
        self._it: Iterator[Any] | None = it
        # The creator's context (the environment, the timeline of a projection), without
        # the creator's task: the rules run outside the task tree, and a designator kept
        # by a plan must not keep the task (and, through it, the tree) that referenced it.
        self._ctx = contextvars.copy_context()
        self._ctx.run(CURRENT_TASK.set, None)
        self._error: Exception | None = None

    def _count(self) -> int:
        if self._first is _NONE:
            return 0
        return 1 if self._more is None else 1 + len(self._more)

    def get(self, i: int) -> tuple[bool, Any]:
        if i == 0 and self._first is not _NONE:
            return True, self._first
        while self._count() <= i:
            it = self._it
            if it is None:
                if self._error is not None:
                    raise self._error
                return False, None
            try:
                value = self._ctx.run(next, it)
            except StopIteration:
                self._it = None
                continue
            except Exception as exc:
                self._it = None
                self._error = exc
                raise
            if self._first is _NONE:
                self._first = value
            elif self._more is None:
                self._more = [value]
            else:
                self._more.append(value)
        if i == 0:
            return True, self._first
        assert self._more is not None
        return True, self._more[i - 1]

    def iter_from(self, i: int) -> Iterator[Any]:
        while True:
            found, value = self.get(i)
            if not found:
                return
            yield value
            i += 1


# ---------------------------------------------------------------------------- validation
def _invalid(value: Any, depth: int = 0) -> str | None:
    """Why ``value`` is not a valid property value (non-finite numbers), or ``None``."""
    if isinstance(value, float):
        return None if math.isfinite(value) else f"the non-finite number {value!r}"
    if isinstance(value, (int, str, bool, Pose, Transform)) or value is None:
        return None
    if depth > 20:
        return None
    if isinstance(value, Designator):
        for _, v in value._props:
            why = _invalid(v, depth + 1)
            if why is not None:
                return f"{why} inside {value.short()}"
        return None
    if isinstance(value, (tuple, list)):
        for v in value:
            why = _invalid(v, depth + 1)
            if why is not None:
                return (
                    why if isinstance(v, (tuple, list, Designator)) else (f"{why} in {_fmt(value)}")
                )
        return None
    dtype = getattr(value, "dtype", None)
    if dtype is not None and getattr(dtype, "kind", "") in "fc":
        import numpy as np

        if not np.all(np.isfinite(value)):
            return f"non-finite numbers in {value!r}"
    return None


# ----------------------------------------------------------------------------- display
def _fmt(value: Any) -> str:
    if isinstance(value, Designator):
        return repr(value)
    if isinstance(value, str):
        if value and not any(c.isspace() or c in "()" for c in value):
            return value
        return repr(value)
    if isinstance(value, float):
        return f"{value:g}"
    if isinstance(value, tuple):
        return "(" + " ".join(_fmt(v) for v in value) + ")"
    if callable(value) and hasattr(value, "__name__"):
        return str(value.__name__)
    return repr(value)


# --------------------------------------------------------------------------- designators
class Designator:
    """Base class of the four designator kinds. Build them with ``an``/``a``.

    ``get(key, default)``/``desig[key]`` give the first value of a key, ``get_all(key)`` all
    of them, ``properties`` the ordered pairs. Resolution (``reference()``,
    ``solutions()``, ``next_solution()``) raises :class:`executive.DesignatorError` naming the
    designator and what to fix when it cannot be resolved.
    """

    kind: ClassVar[str] = "designator"
    article: ClassVar[str] = "a"

    __slots__ = (
        "__weakref__",
        "_data",
        "_has_data",
        "_index",
        "_parent",
        "_props",
        "_repr",
        "_stream",
        "_successor",
    )

    _props: tuple[Pair, ...]
    #: the repr, cached once computed when every property value is immutable (see
    #: :func:`_stable`): the event log renders each designator at every task event
    _repr: str | None
    _stream: _SolutionStream | None
    _index: int
    _data: Any
    _has_data: bool
    _parent: Designator | None
    _successor: Designator | None

    def __init__(self, *pairs: Pair, **properties: Any) -> None:
        _init(self, _build(pairs, properties))

    def __setattr__(self, name: str, value: Any) -> None:
        raise AttributeError(
            f"designators are immutable; use copy({name}=...) to describe something else"
        )

    # -- properties -------------------------------------------------------------------
    @property
    def properties(self) -> tuple[Pair, ...]:
        """The ``(key, value)`` pairs, in order, keys in CRAM's spelling."""
        return self._props

    @property
    def type(self) -> Any:
        """The ``type`` property (``None`` if absent)."""
        for k, v in self._props:
            if k == "type":
                return v
        return None

    def get(self, key: str, default: Any = None) -> Any:
        """The first value of ``key`` (either spelling), or ``default`` (desig-prop-value)."""
        if type(key) is not str or "_" in key:
            key = cram_key(key)
        for k, v in self._props:
            if k == key:
                return v
        return default

    def get_all(self, key: str) -> tuple[Any, ...]:
        """Every value of ``key``, in order."""
        key = cram_key(key)
        return tuple(v for k, v in self._props if k == key)

    def __getitem__(self, key: str) -> Any:
        ck = cram_key(key)
        for k, v in self._props:
            if k == ck:
                return v
        raise KeyError(f"{self.short()} has no {ck!r} property")

    def __contains__(self, key: object) -> bool:
        return isinstance(key, str) and any(k == cram_key(key) for k, _ in self._props)

    def keys(self) -> tuple[str, ...]:
        """The distinct keys, in first-appearance order."""
        return tuple(dict.fromkeys(k for k, _ in self._props))

    def copy(self, *pairs: Pair, **changes: Any) -> Self:
        """A new, unresolved, unchained designator of the same kind. Keyword ``changes``
        replace every value of their key (at the key's first position; new keys go last;
        ``None`` removes the key); positional ``pairs`` are appended (repeats)."""
        replaced = {cram_key(k): _freeze(v) for k, v in changes.items()}
        props: list[Pair] = []
        done: set[str] = set()
        for k, v in self._props:
            if k in replaced:
                if k not in done and replaced[k] is not None:
                    props.append((k, replaced[k]))
                done.add(k)
            else:
                props.append((k, v))
        props += [(k, v) for k, v in replaced.items() if k not in done and v is not None]
        props += _build(pairs, {})
        new = object.__new__(type(self))
        _init(new, tuple(props))
        return new

    def same_description(self, other: Designator) -> bool:
        """True if both are of the same kind and give every key the same values in the same
        order (the order *between* different keys does not matter)."""
        if type(self) is not type(other):
            return False
        mine, theirs = self._props, other._props
        if len(mine) != len(theirs):
            return False
        return all(self.get_all(k) == other.get_all(k) for k in self.keys()) and set(
            self.keys()
        ) == set(other.keys())

    # -- resolution -------------------------------------------------------------------
    def _ensure_stream(self) -> _SolutionStream:
        stream = self._stream
        if stream is None:
            for key, value in self._props:
                why = _invalid(value)
                if why is not None:
                    raise DesignatorInputError(
                        f"{self.short()} has an invalid {key!r} property: {why}; give finite "
                        "numbers (poses as executive.Pose)",
                        self,
                    )
            stream = _SolutionStream(self._generate(current_environment()))
            object.__setattr__(self, "_stream", stream)
            object.__setattr__(self, "_index", 0)
        return stream

    def _generate(self, env: Environment) -> Iterator[Any]:
        return _rule_solutions(self, env)

    def _no_solution(self) -> str:
        return "its rules yielded no solution; check its properties"

    def reference(self) -> Any:
        """The first solution, resolved once and cached (CRAM's ``reference``).

        Raises :class:`executive.DesignatorError` when the designator cannot be resolved
        (unknown type, missing or invalid property, no solution).
        """
        if self._has_data:
            return self._data
        stream = self._ensure_stream()
        found, value = stream.get(self._index)
        if not found:
            raise DesignatorError(f"{self.short()} cannot be resolved: {self._no_solution()}", self)
        object.__setattr__(self, "_data", value)
        object.__setattr__(self, "_has_data", True)
        return value

    @property
    def effective(self) -> bool:
        """True once this designator has been referenced."""
        return self._has_data

    def solutions(self) -> LazyList[Any]:
        """All solutions from this designator's own on, as a memoised ``cpl.LazyList``
        (shared with the chain: forcing it does not re-run the rules)."""
        stream = self._ensure_stream()
        return LazyList(stream.iter_from(self._index))

    def next_solution(self) -> Self | None:
        """A new designator, equated to this one, whose solution is the next element of the
        solution stream; ``None`` when there is none (CRAM's ``next-solution``)."""
        stream = self._ensure_stream()
        index = self._index + 1
        found, value = stream.get(index)
        if not found:
            return None
        return self._successor_with(stream, index, value)

    def _successor_with(self, stream: _SolutionStream, index: int, value: Any) -> Self:
        new = object.__new__(type(self))
        _init(new, self._props)
        object.__setattr__(new, "_stream", stream)
        object.__setattr__(new, "_index", index)
        object.__setattr__(new, "_data", value)
        object.__setattr__(new, "_has_data", True)
        equate(self, new)
        return new

    # -- chain ------------------------------------------------------------------------
    def current(self) -> Self:
        """The newest designator of this chain (CRAM's ``current-desig``; a chain holds
        one kind of designator, see :func:`equate`)."""
        d: Designator = self
        while d._successor is not None:
            d = d._successor
        return cast(Self, d)

    def first(self) -> Self:
        """The oldest designator of this chain (CRAM's ``first-desig``)."""
        d: Designator = self
        while d._parent is not None:
            d = d._parent
        return cast(Self, d)

    def newest_effective(self) -> Designator | None:
        """The newest member of the chain that has been referenced, or ``None``."""
        d: Designator | None = self.current()
        while d is not None:
            if d._has_data:
                return d
            d = d._parent
        return None

    def chain(self) -> tuple[Designator, ...]:
        """Every member of the chain, oldest first."""
        out = []
        d: Designator | None = self.first()
        while d is not None:
            out.append(d)
            d = d._successor
        return tuple(out)

    @property
    def parent(self) -> Designator | None:
        return self._parent

    @property
    def successor(self) -> Designator | None:
        return self._successor

    # -- display ----------------------------------------------------------------------
    def short(self) -> str:
        """A one-line name for messages: ``motion (type going)``."""
        picked = [(k, v) for k, v in self._props if k in ("type", "name")]
        if not picked:
            picked = list(self._props[:2])
        text = " ".join(f"({k} {_fmt_short(v)})" for k, v in picked)
        more = " ..." if len(picked) < len(self._props) else ""
        return f"{self.kind} {text}{more}".rstrip() if text else f"{self.kind} (no properties)"

    def __repr__(self) -> str:
        cached = self._repr
        if cached is not None:
            return cached
        props = " ".join(f"({k} {_fmt(v)})" for k, v in self._props)
        text = f"<{self.article} {self.kind}{' ' + props if props else ''}>"
        if all(_stable(v) for _, v in self._props):
            object.__setattr__(self, "_repr", text)
        return text

    def __rich__(self) -> Text:
        from rich.text import Text

        text = Text()
        text.append("<")
        text.append(self.article + " ", style="dim")
        text.append(self.kind, style="bold magenta")
        for k, v in self._props:
            text.append(" (")
            text.append(k, style="cyan")
            text.append(" ")
            if isinstance(v, Designator):
                text.append_text(v.__rich__())
            else:
                text.append(_fmt(v), style="green" if isinstance(v, str) else "yellow")
            text.append(")")
        text.append(">")
        return text


_STABLE_TYPES: Final = (str, int, float, bool, Pose, Transform)


def _stable(value: Any) -> bool:
    """Whether ``value``'s display can never change: None, a number, a string, a pose, or
    a designator or tuple of such (designators are immutable)."""
    if value is None or isinstance(value, _STABLE_TYPES):
        return True
    if isinstance(value, Designator):
        return all(_stable(v) for _, v in value._props)
    return type(value) is tuple and all(_stable(v) for v in value)


def _fmt_short(value: Any) -> str:
    if isinstance(value, Designator):
        return f"<{value.short()}>"
    text = _fmt(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _init(d: Designator, props: tuple[Pair, ...]) -> None:
    object.__setattr__(d, "_props", props)
    object.__setattr__(d, "_repr", None)
    object.__setattr__(d, "_stream", None)
    object.__setattr__(d, "_index", 0)
    object.__setattr__(d, "_data", None)
    object.__setattr__(d, "_has_data", False)
    object.__setattr__(d, "_parent", None)
    object.__setattr__(d, "_successor", None)


def equate(parent: Designator, successor: Designator) -> Designator:
    """Append ``successor``'s chain after the newest member of ``parent``'s chain (CRAM's
    ``equate``). Equating two members of the same chain does nothing. Returns
    ``successor``. Raises ``TypeError`` for designators of different kinds."""
    if not isinstance(parent, Designator) or not isinstance(successor, Designator):
        raise TypeError(f"equate() needs two designators, got {parent!r} and {successor!r}")
    if parent.kind != successor.kind:
        raise TypeError(f"cannot equate {parent.short()} with {successor.short()}: different kinds")
    youngest = parent.current()
    oldest = successor.first()
    if youngest.first() is oldest:
        return successor
    object.__setattr__(youngest, "_successor", oldest)
    object.__setattr__(oldest, "_parent", youngest)
    return successor


class ActionDesignator(Designator):
    """An action: resolves to an :class:`ActionGrounding` ``(plan, arguments)``."""

    kind = "action"
    article = "an"
    __slots__ = ()

    def reference(self) -> ActionGrounding:
        return super().reference()  # type: ignore[no-any-return]


class MotionDesignator(Designator):
    """A motion: resolves to a :class:`MotionCommand` ``(command, arguments)``."""

    kind = "motion"
    article = "a"
    __slots__ = ()

    def reference(self) -> MotionCommand:
        return super().reference()  # type: ignore[no-any-return]


class ObjectDesignator(Designator):
    """An object: resolves to perceived-object data (:class:`ObjectData`)."""

    kind = "object"
    article = "an"
    __slots__ = ()

    def _no_solution(self) -> str:
        if "pose" not in self:
            return (
                "it has no pose yet; perceive it first (perform a detecting motion) or give "
                "pose=executive.Pose(...)"
            )
        return "its rules yielded no solution; check its properties"


class LocationDesignator(Designator):
    """A location: resolves to an :class:`executive.Pose` through the generator/validator
    pipeline (see ``executive._location``)."""

    kind = "location"
    article = "a"
    __slots__ = ()

    def reference(self) -> Pose:
        return super().reference()  # type: ignore[no-any-return]

    def _generate(self, env: Environment) -> Iterator[Any]:
        from ._location import location_solutions

        return location_solutions(self, env)

    def _no_solution(self) -> str:
        env = current_environment()
        names = ", ".join(r.name for r in env.rules.location_generators()) or "none"
        return (
            "no location generator produced an accepted pose (generators: "
            f"{names}); give (pose P) or (of an-object-with-a-pose), or register a generator "
            "for its keys"
        )

    def next_different_solution(
        self,
        distance_threshold: float = 0.05,
        angle_threshold: float = 0.1,
        max_skips: int | None = None,
    ) -> LocationDesignator | None:
        """Like :meth:`next_solution` but skips solutions within ``distance_threshold``
        metres *and* ``angle_threshold`` radians of this designator's pose (CRAM's
        ``next-different-location-solution``). Gives up (``None``) after ``max_skips``
        close solutions in a row (default: the rule set's 30-rejection cut-off), as CRAM's
        filter counts towards that cut-off."""
        if distance_threshold < 0 or angle_threshold < 0:
            raise ValueError("thresholds must be >= 0")
        stream = self._ensure_stream()
        found, here = stream.get(self._index)
        if not found:
            return None
        limit = (
            max_skips
            if max_skips is not None
            else current_environment().rules.location_max_rejections
        )
        index = self._index + 1
        skipped = 0
        while True:
            found, value = stream.get(index)
            if not found:
                return None
            if not _close(here, value, distance_threshold, angle_threshold):
                new = self._successor_with(stream, index, value)
                assert isinstance(new, LocationDesignator)
                return new
            skipped += 1
            if skipped >= limit:
                return None
            index += 1


def _close(p: Any, q: Any, dist: float, angle: float) -> bool:
    if not (isinstance(p, Pose) and isinstance(q, Pose)) or p.frame != q.frame:
        return False
    return p.distance_to(q) <= dist and p.angle_to(q) <= angle


# ------------------------------------------------------------------------ rule resolution
def _normalise_action(sol: Any, d: Designator, rule: Rule) -> ActionGrounding:
    if isinstance(sol, ActionGrounding):
        return sol
    if isinstance(sol, tuple) and len(sol) == 2 and callable(sol[0]):
        args = sol[1]
        if isinstance(args, Mapping):
            return ActionGrounding(sol[0], dict(args))
        if isinstance(args, (tuple, list)):
            return ActionGrounding(sol[0], tuple(args))
    raise TypeError(
        f"action rule {rule.name} for {d.short()} yielded {sol!r}; yield "
        "(plan_function, {argument: value}) pairs"
    )


def _normalise_motion(sol: Any, d: Designator, rule: Rule) -> MotionCommand:
    if isinstance(sol, MotionCommand):
        return sol
    if isinstance(sol, tuple) and len(sol) == 2 and isinstance(sol[0], str):
        if isinstance(sol[1], Mapping):
            return MotionCommand(sol[0], sol[1])
    raise TypeError(
        f"motion rule {rule.name} for {d.short()} yielded {sol!r}; yield "
        "(command, {argument: value}) pairs, e.g. ('move-base', {'pose': pose})"
    )


def _same(sol: Any, d: Designator, rule: Rule) -> Any:
    return sol


_NORMALISE: Final = {"action": _normalise_action, "motion": _normalise_motion, "object": _same}


def _rule_solutions(d: Designator, env: Environment) -> Iterator[Any]:
    kind = d.kind
    type_ = d.type
    if type_ is None:
        if kind != "object":
            raise DesignatorInputError(
                f"{d.short()} has no type property: give type=..., e.g. "
                f"{'an' if kind == 'action' else 'a'}.{kind}(type=...)",
                d,
            )
        type_ = WILDCARD
    elif not isinstance(type_, str):
        raise DesignatorInputError(f"{d.short()}: its type must be a string, got {type_!r}", d)
    rules, known = env.rules.lookup(kind, type_)
    if not rules:
        types = ", ".join(env.rules.known_types(kind)) or "none"
        raise DesignatorInputError(
            f"{d.short()} cannot be resolved: no {kind} rule for type {type_!r} (known "
            f"{kind} types: {types}); register one with executive.register_rule("
            f"{kind!r}, {type_!r}, fn)",
            d,
        )
    if known is not None:
        _check_keys(d, kind, type_, known)
    return _chain_rules(d, env, rules, _NORMALISE[kind])


def _check_keys(d: Designator, kind: str, type_: str, known: frozenset[str]) -> None:
    """DesignatorError for a key no rule of ``d``'s kind and type reads, when they all
    declare their keys (``known``; see :meth:`executive.RuleSet.register`)."""
    for k, _ in d._props:
        if k not in known:
            break
    else:
        return
    unknown = list(dict.fromkeys(k for k, _ in d.properties if k not in known))
    if unknown:
        article = "an" if kind in ("action", "object") else "a"
        raise DesignatorInputError(
            f"{d.short()}: unknown key{'s' if len(unknown) > 1 else ''} "
            f"{', '.join(repr(k) for k in unknown)} for {article} {kind} of type {type_!r}; "
            f"known keys: {', '.join(sorted(known))}",
            d,
        )


def _chain_rules(
    d: Designator, env: Environment, rules: tuple[Rule, ...], normalise: Any
) -> Iterator[Any]:
    # by index: a suspended stream then holds no tuple iterator (one object less per
    # designator kept in the task tree for the garbage collector to scan)
    i, n = 0, len(rules)
    while i < n:
        rule = rules[i]
        i += 1
        out = rule.call(d, env)
        if out is None:
            continue
        try:
            it = iter(out)
        except TypeError:
            raise TypeError(
                f"{d.kind} rule {rule.name} must yield (or return an iterable of) "
                f"solutions, it returned {out!r}"
            ) from None
        for sol in it:
            yield normalise(sol, d, rule)


# ------------------------------------------------------------------------- constructors
class _Article:
    """``an``/``a``: ``an.action(...)``, ``a.motion(...)``, ``a.location(...)``,
    ``an.object(...)``. Positional ``(key, value)`` pairs first, then keywords."""

    __slots__ = ("word",)

    def __init__(self, word: str) -> None:
        self.word = word

    def action(self, *pairs: Pair, **properties: Any) -> ActionDesignator:
        return ActionDesignator(*pairs, **properties)

    def motion(self, *pairs: Pair, **properties: Any) -> MotionDesignator:
        return MotionDesignator(*pairs, **properties)

    def location(self, *pairs: Pair, **properties: Any) -> LocationDesignator:
        return LocationDesignator(*pairs, **properties)

    def object(self, *pairs: Pair, **properties: Any) -> ObjectDesignator:
        return ObjectDesignator(*pairs, **properties)

    def __repr__(self) -> str:
        return f"executive.{self.word}"


an: Final = _Article("an")
a: Final = _Article("a")
