"""Location resolution: CRAM's generator / validator pipeline.

Generators (ascending priority) each yield candidate poses, possibly infinitely many; their
outputs are concatenated lazily. Every candidate goes through every validator (ascending
priority), each answering ``accept``, ``reject`` (or ``None``/``False``), ``maybe-reject`` or
``unknown``: a reject discards the candidate at once; otherwise it passes if the final state
is ``accept`` or ``unknown`` (``maybe-reject`` holds unless a later validator accepts). After
``location_max_rejections`` (30) rejections in a row the stream ends: that is how a costmap
designator "runs out of samples".

Built in, at priority 10 (CRAM's Prolog groundings): ``(pose P)`` -> P; ``(of obj)`` -> the
object designator's stored pose; ``(of-item-object obj)`` -> the object's current pose from the
environment's world model, by name. Costmaps plug in later with
``register_location_generator(fn, 20)``.
"""

from __future__ import annotations

import enum
from collections.abc import Iterator
from typing import TYPE_CHECKING, Any

from ._pose import Pose
from ._ruledoc import Key, RuleDoc
from ._rules import Rule, builtin_rules
from .failures import DesignatorError, DesignatorInputError

if TYPE_CHECKING:
    from ._designator import Designator
    from ._environment import Environment

__all__ = ["Validation", "location_solutions"]


class Validation(enum.Enum):
    """A validator's verdict on one candidate pose."""

    ACCEPT = "accept"
    REJECT = "reject"
    MAYBE_REJECT = "maybe-reject"
    UNKNOWN = "unknown"


_BY_TEXT = {v.value: v for v in Validation} | {"maybe_reject": Validation.MAYBE_REJECT}


def _verdict(result: Any, rule: Rule) -> Validation:
    if isinstance(result, Validation):
        return result
    if result is None or result is False:
        return Validation.REJECT
    if result is True:
        return Validation.ACCEPT
    if isinstance(result, str) and result.lower() in _BY_TEXT:
        return _BY_TEXT[result.lower()]
    raise TypeError(
        f"location validator {rule.name} returned {result!r}; return 'accept', 'reject', "
        "'maybe-reject', 'unknown' (or an executive.Validation)"
    )


def validate(d: Designator, pose: Pose, env: Environment, validators: tuple[Rule, ...]) -> bool:
    """Run the validators on one candidate; True if it is accepted."""
    state = Validation.UNKNOWN
    for rule in validators:
        verdict = _verdict(rule.call(d, pose, env), rule)
        if verdict is Validation.REJECT:
            return False
        if verdict is Validation.ACCEPT:
            state = Validation.ACCEPT
        elif verdict is Validation.MAYBE_REJECT and state is not Validation.ACCEPT:
            state = Validation.MAYBE_REJECT
    return state is not Validation.MAYBE_REJECT


def location_solutions(d: Designator, env: Environment) -> Iterator[Pose]:
    """The lazy stream of accepted poses for a location designator in ``env``."""
    rules = env.rules
    return _pipeline(
        d,
        env,
        rules.location_generators(),
        rules.location_validators(),
        rules.location_max_rejections,
    )


def _pipeline(
    d: Designator,
    env: Environment,
    generators: tuple[Rule, ...],
    validators: tuple[Rule, ...],
    limit: int,
) -> Iterator[Pose]:
    _check_location_keys(d, generators)
    rejected = 0
    for gen in generators:
        out = gen.call(d, env)
        if out is None:
            continue
        for pose in out:
            if not isinstance(pose, Pose):
                raise TypeError(
                    f"location generator {gen.name} yielded {pose!r} for {d.short()}; "
                    "location generators yield executive.Pose objects"
                )
            if not validators or validate(d, pose, env, validators):
                rejected = 0
                yield pose
            else:
                rejected += 1
                if rejected >= limit:
                    return


def _check_location_keys(d: Designator, generators: tuple[Rule, ...]) -> None:
    """DesignatorError for a key no generator understands, when all declare their keys."""
    declared = [g.keys for g in generators]
    if not declared or any(k is None for k in declared):
        return
    known = set().union(*(k for k in declared if k is not None))
    unknown = list(dict.fromkeys(k for k, _ in d.properties if k not in known))
    if unknown:
        raise DesignatorInputError(
            f"{d.short()}: unknown key{'s' if len(unknown) > 1 else ''} "
            f"{', '.join(repr(k) for k in unknown)} for a location: no location generator "
            f"of this environment understands it (known keys: {', '.join(sorted(known))}); "
            "fix the key, or register a generator for it with "
            "register_location_generator(fn, keys=...)",
            d,
        )


# ----------------------------------------------------------------------------- builtins
def _grounding_generator(d: Designator, env: Environment) -> Iterator[Pose]:
    """``(pose P)``, ``(of obj)`` and ``(of-item-object obj)`` (CRAM's Prolog groundings)."""
    from ._designator import Designator as _D

    for key, value in d.properties:
        if key == "pose":
            if not isinstance(value, Pose):
                raise DesignatorInputError(
                    f"{d.short()}: (pose ...) must be an executive.Pose, got {value!r}", d
                )
            yield value
        elif key == "of":
            if not isinstance(value, _D) or value.kind != "object":
                raise DesignatorInputError(
                    f"{d.short()}: (of ...) must be an object designator, got {value!r}", d
                )
            obj = value.current()
            pose = obj.get("pose")
            if not isinstance(pose, Pose):
                raise DesignatorError(
                    f"{d.short()}: {obj.short()} has no stored pose; perceive it first, or "
                    "use (of-item-object obj) to ask the world model",
                    d,
                )
            yield pose
        elif key == "of-item-object":
            name = value.current().get("name") if isinstance(value, _D) else value
            if not isinstance(name, str):
                raise DesignatorInputError(
                    f"{d.short()}: (of-item-object ...) needs an object designator with a name "
                    f"or an object name, got {value!r}",
                    d,
                )
            yield env.world.object_pose(name)


builtin_rules.register_location_generator(
    _grounding_generator,
    10,
    doc=RuleDoc(
        "CRAM's Prolog groundings: the given poses, in the order of the keys.",
        raises=(DesignatorError,),
        keys=(
            Key("pose", "executive.Pose", "this pose (repeat the key for several)", default="-"),
            Key(
                "of",
                "object designator (perceived)",
                "the object's stored pose; DesignatorError if it was never perceived",
                default="-",
            ),
            Key(
                "of-item-object",
                "object designator with a name, or a name",
                "the object's pose now, from the environment's world model",
                default="-",
            ),
        ),
    ),
)
