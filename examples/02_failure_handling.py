"""CRAM-style failure handling: nested retry scopes with counters, as a fetch plan has.

Outer scope: relocate the base (3 retries) when the object is unreachable.
Inner scope: regrasp once when the grasp slips; when regrasping is exhausted, the inner
scope turns the slip into "unreachable", which the outer scope handles by relocating.

Run: ``python examples/02_failure_handling.py``.
"""

from __future__ import annotations

import cpl
from cpl.display import render_text
from cpl.testing import MockClock


class GraspSlipped(cpl.PlanFailure):
    """The object slipped out of the gripper."""


class ObjectUnreachable(cpl.PlanFailure):
    """No grasp works from this base pose."""


class ObjectUnfetchable(cpl.PlanFailure):
    """Relocation retries exhausted."""


BASE_POSES = ["near-left", "near-right", "far-left", "far-right"]
#: From which base pose, on which grasp attempt, the grasp holds (the 'world').
GRASP_HOLDS = {("far-left", 2)}


@cpl.plan
async def go_to(pose: str) -> None:
    await cpl.sleep(1.0)


@cpl.plan
async def grasp(pose: str, attempt: int) -> str:
    await cpl.sleep(0.3)
    if (pose, attempt) not in GRASP_HOLDS:
        cpl.fail(GraspSlipped(f"slipped at {pose}, attempt {attempt}"))
    return f"cup held (from {pose})"


async def fetch() -> str:
    relocations = cpl.RetryCounter(3, name="relocations")
    poses = iter(BASE_POSES)
    base = next(poses)

    async def from_base() -> str:
        await go_to(base)
        regrasps = cpl.RetryCounter(1, name="regrasps")
        attempt = 0

        async def try_grasp() -> str:
            nonlocal attempt
            attempt += 1
            return await grasp(base, attempt)

        def on_slip(failure: GraspSlipped) -> None:
            print(f"  {failure}; regrasps left: {regrasps.remaining}")
            if regrasps.do_retry():
                cpl.retry()
            raise ObjectUnreachable(f"cannot grasp from {base}")

        return await cpl.with_failure_handling(try_grasp, [(GraspSlipped, on_slip)])

    def on_unreachable(failure: ObjectUnreachable) -> None:
        nonlocal base
        print(f"{failure}; relocations left: {relocations.remaining}")
        if relocations.do_retry():
            base = next(poses)
            cpl.retry()
        raise ObjectUnfetchable("no base pose worked")

    return await cpl.with_failure_handling(from_base, [(ObjectUnreachable, on_unreachable)])


if __name__ == "__main__":
    print(cpl.run(fetch, name="fetch", clock=MockClock()))
    print()
    print(render_text(cpl.task_tree("fetch"), ascii=False, width=110))
