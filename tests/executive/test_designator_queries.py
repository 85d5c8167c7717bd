"""Designator-aware task-tree queries: performed, previous_performed, action_of,
newest_effective."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import cpl
import executive
from cpl.testing import MockClock
from executive import (
    Pose,
    a,
    action_of,
    an,
    newest_effective,
    perform,
    performed,
    previous_performed,
)


async def moving(where: Any) -> None:
    await cpl.sleep(0.1)


async def grabbing(what: str) -> None:
    if what == "glass":
        raise executive.ObjectUnreachable(object=what)


async def doing_both(what: str) -> None:
    await perform(an.action(type="moving", where=1))
    try:
        await perform(an.action(type="grabbing", what="glass"))
    except executive.ObjectUnreachable:
        pass
    await perform(an.action(type="moving", where=2))
    await perform(an.action(type="grabbing", what=what))


def rules() -> executive.RuleSet:
    rs = executive.static_rules.child("queries")

    def ground(plan: Any, key: str) -> Any:
        def rule(d: executive.Designator) -> Iterator[Any]:
            yield plan, {key: d.get(key)}

        return rule

    rs.register("action", "moving", ground(moving, "where"))
    rs.register("action", "grabbing", ground(grabbing, "what"))
    rs.register("action", "doing-both", ground(doing_both, "what"))
    return rs


def run_tree() -> cpl.Task:
    async def main() -> cpl.Task:
        async with executive.environment(rules=rules()):
            await perform(an.action(type="doing-both", what="cup"))
        me = cpl.current_task()
        assert me is not None
        return me

    root: cpl.Task = cpl.run(main, clock=MockClock())
    return root


def test_performed_finds_actions_by_designator_type_and_state():
    root = run_tree()
    grabs = performed(root, "grabbing")
    assert [d.get("what") for _, d in grabs] == ["cup"]
    every = performed(root, "grabbing", state=None)
    assert [d.get("what") for _, d in every] == ["glass", "cup"]
    failed = performed(root, "grabbing", state={cpl.Status.FAILED})
    assert [t.state for t, _ in failed] == [cpl.Status.FAILED]
    assert [d.get("where") for _, d in performed(root, "moving")] == [1, 2]
    assert performed(root, "flying") == []
    (both, desig), *_ = performed(root, "doing-both")
    assert action_of(both) is desig and action_of(root) is None


def test_previous_performed_is_the_nearest_earlier_sibling():
    root = run_tree()
    (grab, _), *_ = performed(root, "grabbing")
    found = previous_performed(grab, "moving")
    assert found is not None and found[1].get("where") == 2
    (glass, _), *_ = performed(root, "grabbing", state=cpl.Status.FAILED)
    moved = previous_performed(glass, "moving")
    assert moved is not None and moved[1].get("where") == 1
    assert previous_performed(grab, "grabbing", state=cpl.Status.SUCCEEDED) is None
    grabbed = previous_performed(grab, "grabbing")
    assert grabbed is not None and grabbed[1].get("what") == "glass"


def test_newest_effective_follows_the_chain():
    location = a.location(pose=Pose((1.0, 0.0, 0.0)))
    assert newest_effective(None) is None
    assert newest_effective(location) is None
    location.reference()
    assert newest_effective(location) is location
    later = a.location(pose=Pose((2.0, 0.0, 0.0)))
    executive.equate(location, later)
    assert newest_effective(location) is location  # the successor is not referenced yet
    later.reference()
    assert newest_effective(location) is later
