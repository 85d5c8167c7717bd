"""Live task-tree queries: walk, find_tasks, previous_sibling, ancestors."""

from __future__ import annotations

import pytest

import cpl
from cpl._queries import ancestors, find_tasks, previous_sibling, walk
from cpl.testing import MockClock


async def leaf() -> None:
    await cpl.sleep(0.1)


async def boom() -> None:
    cpl.fail("boom")


def build() -> cpl.Task:
    async def main() -> cpl.Task:
        await cpl.tag("a", leaf())
        await cpl.tag("b", cpl.seq(cpl.tag("b1", leaf()), cpl.tag("b2", leaf())))
        try:
            await cpl.tag("c", boom())
        except cpl.PlanFailure:
            pass
        await cpl.tag("a", leaf())
        me = cpl.current_task()
        assert me is not None
        return me

    root: cpl.Task = cpl.run(main, name="root", clock=MockClock())
    return root


def test_walk_is_depth_first_in_creation_order():
    root = build()
    names = [t.name for t in walk(root)]
    assert names[0] == "root"
    assert names.index("a") < names.index("b") < names.index("b1") < names.index("b2")
    assert names.index("b2") < names.index("c")
    assert names.count("a") == 2


def test_find_tasks_by_name_kind_state_and_predicate():
    root = build()
    assert [t.path_entry for t in find_tasks(root, name="a")] == ["a", "a#2"]
    assert [t.name for t in find_tasks(root, state=cpl.Status.FAILED)] == ["c"]
    done = find_tasks(root, kind="tag", state={cpl.Status.SUCCEEDED})
    assert {t.name for t in done} == {"a", "b", "b1", "b2"}
    assert find_tasks(root, pred=lambda t: t.name.startswith("b2")) == find_tasks(root, name="b2")
    assert find_tasks(root, name="root") == [root]


def test_previous_sibling_scans_backwards():
    root = build()
    second_a = find_tasks(root, name="a")[1]
    assert previous_sibling(second_a, name="c") is find_tasks(root, name="c")[0]
    assert previous_sibling(second_a, name="a") is find_tasks(root, name="a")[0]
    assert previous_sibling(second_a, name="b1") is None  # not a sibling
    assert previous_sibling(find_tasks(root, name="a")[0], name="a") is None
    assert previous_sibling(root) is None
    done_before = previous_sibling(second_a, state=cpl.Status.SUCCEEDED)
    assert done_before is not None and done_before.name == "b"


def test_ancestors_go_up_to_the_top_level():
    root = build()
    (b2,) = find_tasks(root, name="b2")
    chain = list(ancestors(b2))
    assert chain[-1] is root and chain[0] is b2.parent
    assert [t.name for t in chain if t.kind == "tag"] == ["b"]
    assert list(ancestors(root)) == []


@pytest.mark.parametrize("state", [cpl.Status.CREATED, (cpl.Status.CREATED,)])
def test_find_tasks_state_may_be_one_or_several(state):
    assert find_tasks(build(), state=state) == []
