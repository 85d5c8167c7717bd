"""The plan language's forms on a toy robot: seq, par, pursue, try_all, try_in_order.

Run: ``python examples/01_forms.py``. It runs on a mock clock (simulated seconds pass
instantly) and prints the recorded task tree.
"""

from __future__ import annotations

import asyncio

import cpl
from cpl.display import render_text
from cpl.testing import MockClock


def now() -> float:
    return asyncio.get_running_loop().time()


@cpl.plan
async def move_base(goal: str, seconds: float) -> str:
    await cpl.sleep(seconds)
    return f"at {goal}"


@cpl.plan
async def move_head(target: str) -> str:
    await cpl.sleep(0.5)
    return f"looking at {target}"


@cpl.plan
async def detect(thing: str, visible: bool) -> str:
    await cpl.sleep(0.2)
    if not visible:
        cpl.fail(f"{thing} not in view", object=thing)
    return f"{thing}-1"


async def main() -> dict[str, object]:
    out: dict[str, object] = {}
    # seq: one after the other; the value of the last step
    out["seq"] = await cpl.seq(move_base("table", 2), move_head("table"))
    # par: concurrently; all values, in branch order
    out["par"] = await cpl.par(move_base("counter", 3), move_head("counter"))
    # pursue: the first to finish wins, the others are evaporated
    out["pursue"] = await cpl.pursue(cpl.tag("timeout", cpl.sleep(1.0)), move_base("far away", 60))
    # try_all: the first success wins; failures alone don't stop the others
    out["try_all"] = await cpl.try_all(detect("cup", False), detect("bowl", True))
    # try_in_order: one after another until one succeeds
    out["try_in_order"] = await cpl.try_in_order(detect("milk", False), detect("cereal", True))
    out["simulated seconds"] = round(now(), 3)
    return out


if __name__ == "__main__":
    result = cpl.run(main, name="forms", clock=MockClock())
    for key, value in result.items():
        print(f"{key:>18}: {value}")
    print()
    print(render_text(cpl.task_tree("forms"), ascii=False, width=110))
