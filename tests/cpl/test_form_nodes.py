"""Form nodes are told apart by their type (``FormNode``), their kind comes from their
policy; and the one classification of how a body ended, shared by the three ways a task
runs its body (issue 24, part 3)."""

from __future__ import annotations

import asyncio
from typing import Any

import cpl
from cpl._forms import AllSucceed, _parallel
from cpl._task import FormNode


def test_a_form_node_is_a_form_node_by_type_and_its_kind_is_its_policys(mrun: Any) -> None:
    async def main() -> list[tuple[str, bool]]:
        async def leaf() -> None:
            await cpl.sleep(1)

        await cpl.par(leaf(), leaf())
        await cpl.pursue(leaf(), leaf())
        await cpl.try_all(leaf())
        me = cpl.current_task()
        assert me is not None
        return [(c.kind, isinstance(c, FormNode)) for c in me.children]

    assert mrun(main) == [("par", True), ("pursue", True), ("try-all", True)]


def test_a_task_that_only_has_a_forms_kind_is_no_form_node(mrun: Any) -> None:
    """Evaporating a never-started task ends it at once, whatever its kind says (a form's
    kind string used to make it wait for a form that does not exist)."""

    async def main() -> cpl.Status:
        async def work() -> None:
            await cpl.sleep(1)

        lookalike = cpl.Task(work(), name="par", kind="par")
        lookalike.evaporate("not wanted")
        return lookalike.state

    assert mrun(main) is cpl.Status.EVAPORATED


def test_a_form_of_a_new_policy_suspends_and_wakes_like_the_built_in_ones(mrun: Any) -> None:
    """A policy with a kind of its own (not one of the built-in forms' names): suspending
    the subtree suspends its branches, not the form node, and returns."""
    gather = AllSucceed("gather", "a sibling in gather failed")

    async def main() -> tuple[cpl.Status, list[cpl.Status]]:
        async def leaf() -> None:
            await cpl.sleep(5)

        worker = cpl.spawn(_parallel(gather, [leaf(), leaf()]), name="worker")
        await cpl.sleep(1)
        async with asyncio.timeout(30):
            await worker.suspend()
        (node,) = worker.children
        states = [b.state for b in node.children]
        worker.wake_up()
        await worker.join()
        return node.state, states

    node_state, branch_states = mrun(main)
    assert branch_states == [cpl.Status.SUSPENDED, cpl.Status.SUSPENDED]
    assert node_state is cpl.Status.SUCCEEDED
