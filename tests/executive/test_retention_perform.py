"""Performing actions under a retention policy (issue 28): bounded tree, executive
queries, and ``next_solution`` reachable from the plan's own designator."""

from __future__ import annotations

import gc
import weakref
from collections.abc import Iterator
from typing import Any

import pytest

import cpl
from executive import Pose, RuleSet, a, an, environment, perform, performed
from executive.testing import FakeProcessModule

P = Pose((1.0, 2.0, 0.0))
Q = Pose((3.0, 4.0, 0.0))


async def go_to(pose: Pose) -> Pose:
    await perform(a.motion(type="going", pose=pose))
    return pose


def two_places(d: Any) -> Iterator[Any]:
    yield go_to, {"pose": P}
    yield go_to, {"pose": Q}


def rules() -> RuleSet:
    r = RuleSet()
    r.register("action", "moving", two_places)
    return r


def test_tree_stays_bounded_over_5000_performs() -> None:
    counts: list[int] = []
    fake = FakeProcessModule("nav", history=10)

    async def main() -> None:
        root = cpl.current_task()
        assert root is not None
        async with environment(rules=rules(), process_modules=[fake]):
            for i in range(5000):
                await perform(an.action(type="moving"))
                if i % 1000 == 999:
                    counts.append(sum(1 for _ in cpl.walk(root)))

    cpl.run(main, name="soak", retention=cpl.KeepRecent(20, records=50))
    # the root, 20 performs kept whole (the plan's task and its goal's): flat
    assert counts == [41] * 5
    assert fake.goals == 5000 and len(fake.calls) < 20


def test_next_solution_after_the_perform_was_compacted() -> None:
    fake = FakeProcessModule("nav")

    async def main() -> tuple[Pose, Pose, list[Any]]:
        async with environment(rules=rules(), process_modules=[fake]):
            d = an.action(type="moving")
            first = await perform(d)
            for _ in range(30):  # the first perform's subtree is retired long since
                await perform(an.action(type="moving"))
            root = cpl.current_task()
            assert root is not None
            compacted = [n.arguments for n in cpl.retired(root)]
            gc.collect()
            nxt = d.next_solution()  # from the plan's own variable, not the tree
            assert nxt is not None
            second = await perform(nxt)
            return first, second, compacted

    first, second, compacted = cpl.run(main, name="svc", retention=cpl.KeepRecent(2))
    assert (first, second) == (P, Q)
    assert compacted[0] == {"pose": repr(P)}


@pytest.mark.parametrize(
    "policy",
    [cpl.KeepAll(), cpl.KeepRecent(3), cpl.KeepRecent(3, records=0)],
    ids=["keep-all", "keep-recent", "keep-recent-no-records"],
)
def test_performed_sees_what_is_kept_in_full(policy: cpl.Retention) -> None:
    async def main() -> tuple[list[Any], int, Any]:
        async with environment(rules=rules(), process_modules=[FakeProcessModule("nav")]):
            for _ in range(8):
                await perform(an.action(type="moving"))
            root = cpl.current_task()
            assert root is not None
            found = performed(root, "moving")
            snap = root.snapshot()
            return [d.type for _, d in found], len(snap.find_all("moving")), snap

    types, in_snapshot, snap = cpl.run(main, name="svc", retention=policy)
    if isinstance(policy, cpl.KeepAll):
        assert types == ["moving"] * 8 and in_snapshot == 8
    else:
        assert types == ["moving"] * 3
        kept = 8 if policy.records is None else 3  # type: ignore[attr-defined]
        assert in_snapshot == kept
        # the records keep the designator as its short repr
        assert all("moving" in str(n.annotations["designator"]) for n in snap.children)
    assert sum(1 + n.collapsed for n in snap.walk()) == 1 + 8 * 2


def test_a_kept_designator_does_not_keep_its_retired_task() -> None:
    kept: list[Any] = []  # the plan keeps its motion designators (to ask them later)
    plan_tasks: list[Any] = []

    async def go_and_keep() -> None:
        me = cpl.current_task()
        plan_tasks.append(weakref.ref(me))
        motion = a.motion(type="going", pose=P)
        kept.append(motion)
        await perform(motion)

    def rule(d: Any) -> Iterator[Any]:
        yield go_and_keep, {}

    r = RuleSet()
    r.register("action", "keeping", rule)

    async def main() -> None:
        async with environment(rules=r, process_modules=[FakeProcessModule("nav", history=1)]):
            for _ in range(10):
                await perform(an.action(type="keeping"))

    gc.disable()
    try:
        cpl.run(main, name="svc", retention=cpl.KeepRecent(0, records=0))
        alive = [ref() is not None for ref in plan_tasks]
    finally:
        gc.enable()
    assert alive == [False] * 10
    assert all(m.reference()[0] == "move-base" for m in kept)  # still usable


def test_fake_history_keeps_the_newest_and_counts_every_goal() -> None:
    fake = FakeProcessModule("nav", history=3, fail_on={7: RuntimeError})

    async def main() -> None:
        async with environment(process_modules=[fake]):
            for _ in range(6):
                await perform(a.motion(type="going", pose=P))
            with pytest.raises(RuntimeError):  # the 7th goal, counted past the trimming
                await perform(a.motion(type="going", pose=P))

    cpl.run(main)
    assert fake.goals == 7 and 3 <= len(fake.calls) < 6
    with pytest.raises(ValueError, match="history"):
        FakeProcessModule("nav", history=0)
