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
from cpl.testing import MockClock

FORMS = {
    "seq": cpl.seq,
    "par": cpl.par,
    "pursue": cpl.pursue,
    "try_all": cpl.try_all,
    "try_in_order": cpl.try_in_order,
}

leaf = st.tuples(st.just("leaf"), st.integers(0, 5), st.sampled_from(["ok", "ok", "fail"]))
trees = st.recursive(
    leaf,
    lambda kids: st.tuples(st.sampled_from(sorted(FORMS)), st.lists(kids, min_size=1, max_size=4)),
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
    if spec[0] == "leaf":
        return spec[2] == "ok"
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


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(spec=trees, kill_at=st.one_of(st.none(), st.integers(0, 6)), victim=st.integers(0, 50))
def test_random_trees_keep_invariants(spec, kill_at, victim):
    counts = collections.Counter()
    started = set()
    rec = Recorder()
    ids = iter(range(10_000))
    body = build(spec, counts, ids)

    async def main():
        tree_task = cpl.spawn(body(), name="tree")
        if kill_at is not None:
            await cpl.sleep(kill_at)
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

    outcome = cpl.run(main, clock=MockClock(), instruments=[rec])
    started = set(counts)
    assert rec.illegal == []
    assert [t for t in rec.tasks if t.alive] == []
    assert all(counts[n] == 1 for n in started), counts
    expected = oracle(spec)
    if kill_at is None and expected is not None:
        assert (outcome[0] == "ok") == expected, (spec, outcome)
