"""What a resolution rule documents about itself: its keys, the failures it raises, the
retries it makes. Declared where the rule is registered (``rule(..., doc=RuleDoc(...))``),
so the designator reference (``aiocram reference``) is generated from the registry and
cannot drift from the code: the keys a rule declares are the keys the executive accepts
(:meth:`executive.RuleSet.register` takes them from the doc), and the tests compare the
retry counts with the plans' retry counters.

Deliberate difference from CRAM: CRAM's designators are documented nowhere but in the
Prolog rules; a robot programmer read the source to learn a key.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Final

__all__ = ["Key", "Retry", "RuleDoc"]

_KEY_NAME: Final = re.compile(r"^[a-z][a-z0-9-]*$")


def _text(value: object, what: str) -> str:
    if not isinstance(value, str) or not value.strip():
        raise TypeError(f"{what} must be a non-empty string, got {value!r}")
    return value


def _failures(values: object, what: str) -> tuple[type[BaseException], ...]:
    if isinstance(values, type):
        values = (values,)
    if not isinstance(values, Iterable) or isinstance(values, str):
        raise TypeError(f"{what} must be a tuple of exception classes, got {values!r}")
    out = tuple(values)
    for v in out:
        if not (isinstance(v, type) and issubclass(v, BaseException)):
            raise TypeError(f"{what} must hold exception classes, got {v!r}")
    return out


def _names(values: object, what: str) -> tuple[str, ...]:
    if isinstance(values, str) or not isinstance(values, Iterable):
        raise TypeError(f"{what} must be a tuple of designator types, got {values!r}")
    return tuple(_text(v, what) for v in values)


@dataclass(frozen=True, slots=True)
class Key:
    """One property key a rule reads: ``Key("arm", "'left' | 'right'", "the arm to use",
    default="both, right first")``.

    ``name`` is the designator spelling (``joint-angle``; ``joint_angle`` is accepted and
    converted). ``type`` says in words what the value is; ``doc`` what the key does.
    ``required=True``: the rule raises ``DesignatorError`` without it; otherwise
    ``default`` says what happens without it (empty: the key is simply not used)."""

    name: str
    type: str
    doc: str
    default: str = ""
    #: True: the rule cannot ground a designator without this key (then ``default`` is "")
    required: bool = False

    def __post_init__(self) -> None:
        name = _text(self.name, "Key name").replace("_", "-")
        if not _KEY_NAME.match(name):
            raise ValueError(f"Key name {self.name!r}: use lower-case words joined by '-'")
        object.__setattr__(self, "name", name)
        _text(self.type, f"Key {name!r}: type")
        _text(self.doc, f"Key {name!r}: doc")
        if not isinstance(self.default, str):
            raise TypeError(f"Key {name!r}: default is text (what happens without the key)")
        if self.required and self.default:
            raise ValueError(f"Key {name!r} is required, so it has no default {self.default!r}")


@dataclass(frozen=True, slots=True)
class Retry:
    """A retry scope of the rule's plan: ``count`` retries when one of ``on`` is raised,
    each doing ``then`` (e.g. "the next base pose of robot-location"). ``counter`` is the
    name of the plan's :class:`plans.CountedRetries` (the tests check that the plan's
    counter of that name grants ``count`` retries); ``note`` qualifies the count."""

    count: int
    on: tuple[type[BaseException], ...]
    then: str
    counter: str | None = None
    note: str = ""
    #: True: the retries are probes in the belief (a ``plans.check_*`` trying the next
    #: solution; nothing moves), and ``on`` is what is raised when none works.
    probes: bool = False

    def __post_init__(self) -> None:
        if isinstance(self.count, bool) or not isinstance(self.count, int) or self.count < 0:
            raise TypeError(f"Retry count must be an int >= 0, got {self.count!r}")
        object.__setattr__(self, "on", _failures(self.on, "Retry on"))
        if not self.on:
            raise ValueError("Retry on: name at least one failure class that is retried")
        _text(self.then, "Retry then")
        if self.counter is not None:
            _text(self.counter, "Retry counter")


@dataclass(frozen=True, slots=True)
class RuleDoc:
    """The documentation of one rule, for the generated designator reference.

    ``summary``: what performing (or resolving) the designator does. ``keys``: every key
    the rule reads (the registration takes its ``keys`` from here). ``raises``: the
    failures that leave the action or motion (a motion's: what its process modules
    raise). ``retries``: the retry scopes of its plan. ``ignores``: failures its plan
    swallows on purpose (``note`` says where). ``performs``/``motions``: the action and
    motion types its plan performs (their own retries apply inside). ``any_key``: the
    rule accepts every key (e.g. the object fallback, which keeps them all)."""

    summary: str
    keys: tuple[Key, ...] = ()
    raises: tuple[type[BaseException], ...] = ()
    retries: tuple[Retry, ...] = ()
    ignores: tuple[type[BaseException], ...] = ()
    performs: tuple[str, ...] = ()
    motions: tuple[str, ...] = ()
    note: str = field(default="")
    #: True: the rule reads any key (it declares none, so no key is refused); ``keys``
    #: then documents the ones it interprets.
    any_key: bool = False

    def __post_init__(self) -> None:
        _text(self.summary, "RuleDoc summary")
        keys = tuple(self.keys)
        if not all(isinstance(k, Key) for k in keys):
            raise TypeError(f"RuleDoc keys must be executive.Key objects, got {keys!r}")
        names = [k.name for k in keys]
        twice = sorted({n for n in names if names.count(n) > 1})
        if twice:
            raise ValueError(f"RuleDoc declares the key(s) {', '.join(twice)} twice")
        object.__setattr__(self, "keys", keys)
        object.__setattr__(self, "raises", _failures(self.raises, "RuleDoc raises"))
        object.__setattr__(self, "ignores", _failures(self.ignores, "RuleDoc ignores"))
        retries = tuple(self.retries)
        if not all(isinstance(r, Retry) for r in retries):
            raise TypeError(f"RuleDoc retries must be executive.Retry objects, got {retries!r}")
        object.__setattr__(self, "retries", retries)
        object.__setattr__(self, "performs", _names(self.performs, "RuleDoc performs"))
        object.__setattr__(self, "motions", _names(self.motions, "RuleDoc motions"))
        if not isinstance(self.note, str):
            raise TypeError(f"RuleDoc note must be a string, got {self.note!r}")

    @property
    def key_names(self) -> frozenset[str]:
        """The names of the keys (what the registration declares)."""
        return frozenset(k.name for k in self.keys)
