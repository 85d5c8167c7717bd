"""Property tests: random trees of forms with random delays, failures and evaporations.

Invariants after every run: no task alive, every status transition legal, every started
leaf's ``finally`` ran exactly once, and outcomes match an oracle where one is cheap.
"""

from __future__ import annotations

import collections

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import cpl
from cpl._status import LEGAL_TRANSITIONS
from cpl.testing import MockClock, run_guarded

FORMS = {
    "seq": cpl.seq,
    "par": cpl.par,
    "pursue": cpl.pursue,
    "try_all": cpl.try_all,
    "try_in_order": cpl.try_in_order,
}

leaf = st.tuples(st.just("leaf"), st.integers(0, 5), st.sampled_from(["ok", "ok", "fail"]))
# An orphan: a leaf that spawns a child which outlives the leaf's body (left running, with
# a cleanup that awaits); the leaf's teardown evaporates it and waits for that cleanup.
orphan = st.tuples(
    st.just("orphan"), st.integers(0, 5), st.sampled_from(["ok", "ok", "fail"]), st.integers(0, 3)
)
trees = st.recursive(
    st.one_of(leaf, orphan),
    lambda kids: st.one_of(
        st.tuples(st.sampled_from(sorted(FORMS)), st.lists(kids, min_size=1, max_size=4)),
        # a spawned subtree: a task whose body returns while the subtree still runs
        st.tuples(st.just("spawn"), kids, st.integers(0, 3)),
        # a joined child (with_task: runs inline in the parent's asyncio task)
        st.tuples(st.just("with"), kids),
    ),
    max_leaves=12,
)


class Recorder(cpl.Instrument):
    def __init__(self):
        self.tasks = []
        self.illegal = []

    def run_started(self, root):
        self.tasks.append(root)

    def task_spawned(self, task):
        self.tasks.append(task)

    def task_status_changed(self, task, old, new):
        if new not in LEGAL_TRANSITIONS[old]:
            self.illegal.append((task, old, new))


def build(spec, counts, ids):
    if spec[0] == "orphan":
        _, delay, outcome, cleanup = spec
        n = next(ids)
        m = next(ids)

        async def lingering():
            counts[m] += 0
            try:
                await cpl.sleep(1000)
            finally:
                await cpl.shielded(cpl.sleep(cleanup))
                counts[m] += 1

        async def run_orphan():
            counts[n] += 0
            try:
                cpl.spawn(lingering(), name="orphan")
                await cpl.sleep(delay)
                if outcome == "fail":
                    raise cpl.PlanFailure(f"leaf {n}")
                return n
            finally:
                counts[n] += 1

        return run_orphan
    if spec[0] == "spawn":
        _, kid, linger = spec
        child = build(kid, counts, ids)

        async def run_spawner():
            sub = cpl.spawn(child(), name="spawned")
            await cpl.sleep(linger)
            if sub.dead:
                return await sub.join()
            return None  # the subtree outlives the body: teardown evaporates it

        return run_spawner
    if spec[0] == "with":
        inner = build(spec[1], counts, ids)

        async def run_with():
            return await cpl.with_task(inner(), name="with")

        return run_with
    if spec[0] == "leaf":
        _, delay, outcome = spec
        n = next(ids)

        async def run_leaf():
            counts[n] += 0  # mark as started
            try:
                await cpl.sleep(delay)
                if outcome == "fail":
                    raise cpl.PlanFailure(f"leaf {n}")
                return n
            finally:
                counts[n] += 1

        return run_leaf
    form, kids = spec
    children = [build(k, counts, ids) for k in kids]

    async def run_form():
        return await FORMS[form](*(c() for c in children))

    return run_form


def oracle(spec):
    """Whether the tree succeeds without evaporations: True, False, or None when timing
    decides (pursue of mixed outcomes)."""
    if spec[0] in ("leaf", "orphan"):
        return spec[2] == "ok"
    if spec[0] == "spawn":
        return None  # timing decides whether the subtree's outcome is joined
    if spec[0] == "with":
        return oracle(spec[1])
    form, kids = spec
    outs = [oracle(k) for k in kids]
    if form in ("seq", "par"):
        if False in outs:
            return False
        return None if None in outs else True
    if form in ("try_all", "try_in_order"):
        if True in outs:
            return True
        return None if None in outs else False
    return None if len(set(outs)) > 1 else outs[0]  # pursue: timing decides


@settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    spec=trees,
    kills=st.lists(st.tuples(st.integers(0, 6), st.integers(0, 50)), max_size=3),
)
def test_random_trees_keep_invariants(spec, kills):
    """Random trees with orphans, spawned subtrees, nested teardowns and up to three
    evaporations at random times (also of tasks already tearing down). Each example is
    guarded: a hang fails with the task tree instead of blocking the suite."""
    counts: collections.Counter[int] = collections.Counter()
    rec = Recorder()
    ids = iter(range(10_000))
    body = build(spec, counts, ids)

    async def main():
        tree_task = cpl.spawn(body(), name="tree")
        now = 0
        for at, victim in sorted(kills):
            await cpl.sleep(at - now)
            now = at
            alive = [
                t
                for t in rec.tasks
                if t.alive
                and t is not cpl.current_task()
                and t.kind not in ("par", "pursue", "try-all")
            ]
            if alive:
                alive[victim % len(alive)].evaporate("random evaporation")
        try:
            return ("ok", await tree_task.join())
        except cpl.PlanFailure as f:
            return ("failed", f)

    outcome = run_guarded(main, clock=MockClock(), instruments=[rec], wall_timeout=20.0)
    started = set(counts)
    assert rec.illegal == []
    assert [t for t in rec.tasks if t.alive] == []
    assert all(counts[n] == 1 for n in started), counts
    expected = oracle(spec)
    if not kills and expected is not None:
        assert (outcome[0] == "ok") == expected, (spec, outcome)
