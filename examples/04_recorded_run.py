"""Record a run as a JSON-lines event log and render it back.

Run: ``python examples/04_recorded_run.py [LOG]`` (default ``out/04_run.jsonl``), then
``aiocram show LOG`` renders the same tree from the file.
"""

from __future__ import annotations

import sys
from pathlib import Path

import cpl
from cpl.display import render_text
from cpl.testing import MockClock


class Slipped(cpl.PlanFailure):
    """The grasp slipped."""


@cpl.plan
async def grasp(attempt: int) -> str:
    await cpl.sleep(0.5)
    if attempt < 2:
        raise Slipped(f"attempt {attempt} slipped")
    return "holding"


async def main() -> str:
    attempts = 0
    counter = cpl.RetryCounter(2)

    async def body() -> str:
        nonlocal attempts
        attempts += 1
        got, _ = await cpl.par(grasp(attempts), cpl.tag("watch-force", cpl.sleep(0.2)))
        return str(got)

    def on_slip(f: Slipped) -> None:
        if counter.do_retry():
            cpl.retry()

    return await cpl.with_failure_handling(body, [(Slipped, on_slip)])


if __name__ == "__main__":
    path = Path(sys.argv[1] if len(sys.argv) > 1 else "out/04_run.jsonl")
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("")
    print(cpl.run(main, name="recorded", clock=MockClock(), instruments=[cpl.EventLog(path)]))
    print(f"wrote {sum(1 for _ in path.open())} events to {path}\n")
    replayed = cpl.tree_from_log(path)
    print(render_text(replayed, ascii=False, width=100))
    assert replayed == cpl.task_tree("recorded"), "the log must rebuild the same tree"
    print(f"\nrender it again any time with: aiocram show {path}")
