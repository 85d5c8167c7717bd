"""Policies: a body run under a condition that is watched while it runs (CRAM's
``with-policy``, ``define-policy`` and ``timeout-policy``).

A policy is an object whose hooks the framework calls in a fixed order (override what you
need; each hook may be sync or async):

1. ``init()``: returning ``False`` fails the form with :class:`PolicyInitFailed`;
2. the body runs in a ``pursue`` against ``check()``: when ``check()`` returns, the
   condition is met and the body is evaporated;
3. in cleanup that survives evaporation (shielded): ``recover()`` if the condition was met,
   then ``clean_up()`` always;
4. if the condition was met, :meth:`Policy.condition_met` is raised: a
   :class:`PolicyConditionMet` plan failure the caller can handle and retry.

Deliberate differences from CRAM:

- ``check()`` *waits* for the condition (``await cpl.sleep(t)``, ``await cpl.wait_for(f)``)
  instead of being polled every 10 ms; a check that must poll writes the loop itself.
- A policy without a check never triggers (CRAM's pursue ends at once and evaporates the
  body, an edge case nobody relies on).
- The policy conditions are :class:`~cpl.PlanFailure` subclasses, so
  ``with_failure_handling`` clauses and ``try_in_order`` handle them like any other
  failure. In CRAM they are neither plan failures nor errors.
- Policies are objects made per use (their attributes are the per-use storage CRAM keeps
  in a storage fluent); there is no global registry of named policies.
"""

from __future__ import annotations

import asyncio
import inspect
from collections.abc import Awaitable, Callable, Sequence
from typing import Any

from ._failures import PlanFailure
from ._forms import pursue, tag
from ._task import as_coroutine
from ._waiting import shielded, sleep

__all__ = [
    "Policy",
    "PolicyConditionMet",
    "PolicyFailure",
    "PolicyInitFailed",
    "PolicyTimeout",
    "timeout_policy",
    "with_policies",
    "with_policy",
]


class PolicyFailure(PlanFailure):
    """Base of the failures a policy raises; ``policy`` is the policy object."""

    def __init__(self, message: str | None = None, *, policy: Policy | None = None) -> None:
        super().__init__(message)
        self.policy = policy


class PolicyInitFailed(PolicyFailure):
    """The policy's ``init()`` returned ``False``: the body did not run."""


class PolicyConditionMet(PolicyFailure):
    """The policy's check was met: the body was evaporated, recover and clean-up ran."""


class PolicyTimeout(PolicyConditionMet):
    """A :func:`timeout_policy` ran out: the body did not finish in time."""


async def _call(hook: Callable[[], Any]) -> Any:
    res = hook()
    if inspect.isawaitable(res):
        return await res
    return res


class Policy:
    """Base class of policies; override the hooks you need (sync or async)."""

    #: Shown in the task tree and in failures; defaults to the class name.
    name: str | None = None

    def init(self) -> Any:
        """Before the body; return ``False`` to refuse (the form fails)."""
        return True

    async def check(self) -> Any:
        """Return when the condition is met (the body is then evaporated). The default
        never returns: the policy never triggers."""
        await asyncio.get_running_loop().create_future()

    def recover(self) -> Any:
        """After the body was evaporated because the condition was met."""

    def clean_up(self) -> Any:
        """Always, after the body ended (and after ``recover``)."""

    def condition_met(self) -> PolicyConditionMet:
        """The failure raised when the condition was met."""
        return PolicyConditionMet(f"policy {self.label} triggered", policy=self)

    @property
    def label(self) -> str:
        return self.name or type(self).__name__

    def __repr__(self) -> str:
        return f"<policy {self.label}>"


class _TimeoutPolicy(Policy):
    def __init__(self, seconds: float) -> None:
        if not (isinstance(seconds, int | float) and seconds >= 0 and seconds != float("inf")):
            raise ValueError(
                f"timeout_policy needs a finite number of seconds >= 0, got {seconds!r}"
            )
        self.seconds = float(seconds)
        self.name = f"timeout {self.seconds:g} s"

    async def check(self) -> None:
        await sleep(self.seconds)

    def condition_met(self) -> PolicyConditionMet:
        return PolicyTimeout(
            f"the body did not finish within {self.seconds:g} s (timeout policy)", policy=self
        )


def timeout_policy(seconds: float) -> Policy:
    """CRAM's ``timeout-policy``: the body must finish within ``seconds`` of the current time
    (the current :class:`Timeline`'s, e.g. projected time, else the loop clock);
    otherwise it is evaporated and :class:`PolicyTimeout` (a plan failure) is raised."""
    return _TimeoutPolicy(seconds)


async def with_policy(policy: Policy, body: Callable[[], Awaitable[Any]] | Awaitable[Any]) -> Any:
    """Run ``body`` under ``policy`` (see the module docstring); the body's value.

    On failure of the body: its failure, after clean-up. On evaporation of the caller: the
    body is evaporated, clean-up still runs (shielded), then the evaporation propagates.
    """
    if not isinstance(policy, Policy):
        raise TypeError(
            f"with_policy takes a cpl.Policy (e.g. cpl.timeout_policy(5)), got "
            f"{type(policy).__name__}"
        )
    if await _call(policy.init) is False:
        if inspect.iscoroutine(body):
            body.close()
        raise PolicyInitFailed(f"policy {policy.label} refused to start", policy=policy)
    triggered = False

    async def watch() -> None:
        nonlocal triggered
        await _call(policy.check)
        triggered = True

    try:
        value = await pursue(tag(f"policy {policy.label}", watch), tag("body", as_coroutine(body)))
    finally:
        if triggered:
            await shielded(_call(policy.recover))
        await shielded(_call(policy.clean_up))
    if triggered:
        raise policy.condition_met()
    return value


async def with_policies(
    policies: Sequence[Policy], body: Callable[[], Awaitable[Any]] | Awaitable[Any]
) -> Any:
    """Nest :func:`with_policy` for each policy, the first outermost (CRAM's
    ``with-policies``)."""
    if not policies:
        return await as_coroutine(body)
    first, rest = policies[0], policies[1:]
    return await with_policy(first, lambda: with_policies(rest, body))
