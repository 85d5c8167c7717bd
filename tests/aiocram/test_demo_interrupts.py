"""Ctrl-C leaves the world safe (issue 23, item 3): the demo is interrupted the way Ctrl-C
does it (:class:`aiocram._interrupt.Interrupts` evaporates the plan's root task), at a
chosen simulated time, on the simulated real robot; the *true* world is checked after
the cleanup: nothing on the floor, the drawer closed, anything still held held safely.

The interrupt times are found from an uninterrupted reference run of the same seed (the
run is deterministic: its clock jumps, physics is stepped), so the tests follow the plans
if their timing changes."""

from __future__ import annotations

import asyncio
from typing import Any

import pytest

pytest.importorskip("projection")

import cpl
from aiocram._interrupt import Interrupts
from aiocram.demo import DemoConfig, DemoReport, run_demo

#: Where an object may be after a cleanup: held, or on a surface (never the floor).
SAFE = ("hand", "island", "sink", "drawer")


class TimedInterrupts(Interrupts):
    """An :class:`Interrupts` whose Ctrl-C comes ``at`` simulated seconds into the run
    (on the run's own clock), acted on exactly as the first SIGINT is."""

    def __init__(self, at: float) -> None:
        super().__init__()
        self.at = at

    def attach(self, root: Any) -> None:
        super().attach(root)
        loop = asyncio.get_running_loop()
        loop.call_at(loop.time() + self.at, self._press)

    def _press(self) -> None:
        root = self._root
        if root is not None and root.alive:
            self.count += 1
            self._evaporate()


def _demo(objects: tuple[str, ...], at: float | None, projection: bool = False) -> DemoReport:
    config = DemoConfig(objects=objects, seed=1, live=False, projection=projection)
    return run_demo(config, interrupts=None if at is None else TimedInterrupts(at))


def _tasks(root: cpl.Task, action_type: str) -> list[cpl.Task]:
    from executive import action_of

    out, stack = [], [root]
    while stack:
        task = stack.pop()
        action = action_of(task)
        if action is not None and action.type == action_type:
            out.append(task)
        stack.extend(task.children)
    return sorted(out, key=lambda t: t.start_time or 0.0)


def _succeeded(tasks: list[cpl.Task]) -> list[cpl.Task]:
    return [t for t in tasks if t.status.value is cpl.Status.SUCCEEDED]


def _assert_safe(report: DemoReport) -> None:
    assert report.interrupted
    truth = report.truth
    assert truth is not None
    for name, obj in truth.objects.items():
        assert obj.where in SAFE and not obj.toppled, (name, obj, truth.violations)
    for invariant in ("no_object_lost", "drawer_closed", "held_safely", "arms_parked"):
        assert truth.invariants[invariant], (invariant, truth.violations)


def test_ctrl_c_while_carrying_keeps_the_object_held() -> None:
    """Interrupted while it drives the bowl from the pick to the place, the robot keeps
    the bowl in its hand (the cleanup used to open the gripper where it stood: the bowl
    fell to the floor)."""
    reference = _demo(("bowl",), None)
    (picked,) = [
        t for t in _tasks(reference.root, "picking-up") if t.status.value is cpl.Status.SUCCEEDED
    ]
    placing = _tasks(reference.root, "placing")[0]
    assert picked.end_time is not None and placing.start_time is not None
    assert placing.start_time - picked.end_time > 1.0  # a drive with the bowl in hand
    at = (picked.end_time + placing.start_time) / 2

    report = _demo(("bowl",), at)
    truth = report.truth
    assert truth is not None
    # the interrupt came while the bowl was carried: held when the cleanup began
    assert "bowl-1" in truth.violations["nothing_attached_before_cleanup"]
    assert truth.objects["bowl-1"].where == "hand"
    assert any("kept holding bowl-1" in step for step in truth.cleanup_intervened)
    _assert_safe(report)


def test_ctrl_c_during_accessing_closes_the_drawer() -> None:
    """Interrupted after the drawer was pulled open but before ``accessing`` returned
    (releasing the handle, retracting), the cleanup closes the drawer (the transport's
    ``finally`` used to begin only after ``accessing`` returned)."""
    reference = _demo(("spoon",), None)
    accessing = _tasks(reference.root, "accessing")[0]
    pulled = _succeeded(_tasks(accessing, "pulling"))
    assert pulled and accessing.end_time is not None
    opened = pulled[-1].end_time
    assert opened is not None and accessing.end_time - opened > 0.2
    at = (opened + accessing.end_time) / 2

    report = _demo(("spoon",), at)
    accessing = _tasks(report.root, "accessing")[0]
    # the interrupt came inside accessing, once the drawer was open
    assert accessing.status.value is cpl.Status.EVAPORATED
    assert _succeeded(_tasks(accessing, "pulling"))
    _assert_safe(report)
    assert _tasks(report.root, "sealing"), "the cleanup sealed the drawer"


def test_ctrl_c_on_the_free_way_to_the_pregrasp_backs_out_through_nothing() -> None:
    """Interrupted early in the bowl's reach (the arm still on its planned free way to
    the first reach waypoint), the retreat moves the hand nowhere: it used to "back out"
    to the reach waypoints first, taking the hand towards the bowl (seed 1 with
    projection: the bowl toppled at the sink by the cleanup that followed)."""
    reference = _demo(("bowl",), None)
    (picked,) = _succeeded(_tasks(reference.root, "picking-up"))
    reaching = _tasks(picked, "reaching")[0]
    assert reaching.start_time is not None and reaching.end_time is not None
    assert reaching.end_time - reaching.start_time > 0.5
    at = reaching.start_time + 0.15 * (reaching.end_time - reaching.start_time)
    before = reference.truth
    assert before is not None

    report = _demo(("bowl",), at)
    (evaporated,) = _tasks(report.root, "picking-up")
    assert evaporated.status.value is cpl.Status.EVAPORATED
    assert _tasks(evaporated, "reaching")[0].status.value is cpl.Status.EVAPORATED
    # the retreat set the gripper and did not send the hand to the reach waypoints
    assert _tasks(evaporated, "setting-gripper")
    assert not _tasks(evaporated, "retracting")
    _assert_safe(report)
    truth = report.truth
    assert truth is not None
    assert truth.objects["bowl-1"].where == "sink"


#: How many evenly spaced interrupt times the sweep tries over the whole demo.
SWEEP = 12


@pytest.mark.slow
@pytest.mark.timeout(600)
def test_ctrl_c_anywhere_in_the_demo_leaves_nothing_on_the_floor() -> None:
    """The whole demo (seed 1, projection reasoning on, as ``aiocram demo`` runs it),
    interrupted at :data:`SWEEP` evenly spaced simulated times: every time, every object
    is held or on a surface, upright, the drawer closed and the arms safe."""
    objects = ("bowl", "cup", "spoon", "milk", "breakfast-cereal")
    reference = _demo(objects, None, projection=True)
    assert reference.truth is not None and all(reference.truth.invariants.values())
    length = reference.sim_time_s
    unsafe = {}
    for k in range(SWEEP):
        at = length * (k + 0.5) / SWEEP
        report = _demo(objects, at, projection=True)
        truth = report.truth
        assert truth is not None
        bad = {
            name: f"{o.where}{' toppled' if o.toppled else ''}"
            for name, o in truth.objects.items()
            if o.where not in SAFE or o.toppled
        }
        bad.update(
            {
                inv: truth.violations[inv]
                for inv in ("drawer_closed", "held_safely", "arms_parked")
                if not truth.invariants[inv]
            }
        )
        if bad:
            unsafe[round(at, 1)] = bad
    assert not unsafe, unsafe
