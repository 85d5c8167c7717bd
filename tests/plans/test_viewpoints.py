"""Choosing where to look from by projection (issue 14, plans.viewpoints): the imagined
world knows the occluders perceived so far; a viewpoint it predicts to be occluded loses
to a clear one, and the real robot looks from the winner."""

from __future__ import annotations

import math
from typing import Any

import cpl
import plans  # noqa: F401 - registers the action rules
from cpl.testing import MockClock
from executive import Pose, a, an, current_environment
from plans.viewpoints import STAND_IN, look_from_best, navigate_to_best_viewpoint
from projection import FaultProfile, make_world_pair, with_real_robot

#: Where the cup is sought, on the sink counter; the cereal box stands in front of it.
SPOT = Pose((1.45, 0.60, 0.91))
OCCLUDER = Pose((1.25, 0.60, 0.95))  # in front of it, 0.19 m deep
BEHIND = Pose.from_xyz_yaw(0.55, 0.60, 0.0, 0.0)  # looks at the cup through the box
CLEAR = Pose.from_xyz_yaw(0.60, -0.10, 0.0, math.atan2(0.70, 0.85))  # from the side


def _ann(task: Any) -> dict[str, Any]:
    annotations = task.annotations
    assert annotations is not None
    return annotations


def _names(root: cpl.Task, prefix: str) -> dict[str, cpl.Task]:
    out: dict[str, cpl.Task] = {}
    stack = [root]
    while stack:
        t = stack.pop()
        if t.name.startswith(prefix):
            out[t.name] = t
        stack.extend(t.children)
    return out


def _run(fn: Any, occluder: bool = True) -> tuple[cpl.Task, Any, Pose]:
    """Run ``fn()`` on the real robot; the belief knows the cereal box (perceived before,
    unless not ``occluder``), not the cup. Returns the root task, the value and the true
    robot pose at the end."""
    true, belief = make_world_pair(
        0,
        objects={"cereal-1": ("breakfast-cereal", OCCLUDER)} if occluder else {},
        belief_objects="exact",
    )
    try:
        true.spawn_object("cup-1", "cup", SPOT)  # reality has the cup; the belief does not
        box: list[Any] = []

        async def main() -> None:
            async with with_real_robot(true, belief, FaultProfile.none()):
                box.append(cpl.current_task())
                box.append(await fn())

        cpl.run(main, clock=MockClock())
        # the imagined stand-ins left no trace in the belief (restored after imagining)
        assert not [n for n in belief.objects if n.startswith(STAND_IN)]
        return box[0], box[1], true.robot_pose()
    finally:
        true.close()
        belief.close()


def test_a_viewpoint_predicted_to_be_occluded_loses_to_a_clear_one():
    root, names, end = _run(
        lambda: look_from_best("cup", [BEHIND, CLEAR], [SPOT], SPOT, by_cost=True)
    )
    assert names == {"viewpoint-1": BEHIND, "viewpoint-2": CLEAR}
    imagined = _names(root, "imagine-viewpoint-")
    assert set(imagined) == {"imagine-viewpoint-1", "imagine-viewpoint-2"}
    seen = {n: _ann(t)["imagined"].value for n, t in imagined.items()}
    # the box hides the stand-in from behind it; from the side it is seen
    assert seen == {"imagine-viewpoint-1": 0, "imagine-viewpoint-2": 1}
    chosen = _names(root, "chosen-")
    assert list(chosen) == ["chosen-viewpoint-2"]  # although BEHIND is the shorter drive
    # the real robot drove to the clear viewpoint (true world)
    assert math.dist(end.position[:2], CLEAR.position[:2]) < 0.05


def test_the_clear_viewpoint_wins_whatever_the_order():
    root, _n, end = _run(lambda: look_from_best("cup", [CLEAR, BEHIND], [SPOT], SPOT))
    assert list(_names(root, "chosen-")) == ["chosen-viewpoint-1"]
    assert math.dist(end.position[:2], CLEAR.position[:2]) < 0.05


def test_the_search_chooses_its_viewpoint_by_projection_and_finds_the_cup():
    """Through the search's own entry: candidates from the visibility costmap, one
    imagined look each (nothing in the way here), the winner driven to, and the real
    search then finds the cup from there."""

    async def search() -> Any:
        from executive import perform

        return await perform(
            an.action(
                type="searching",
                object=an.object(type="cup"),
                location=a.location(pose=SPOT),
                viewpoint_reasoning=True,
            )
        )

    root, found, _end = _run(search, occluder=False)
    assert found.get("name") == "cup-1"
    imagined = _names(root, "imagine-viewpoint-")
    assert len(imagined) >= 2
    values = [_ann(t)["imagined"].value for t in imagined.values()]
    (chosen,) = _names(root, "chosen-viewpoint-").values()
    best = max(v for v in values if v is not None)
    assert best == 1
    winner = imagined["imagine-" + chosen.name.removeprefix("chosen-")]
    assert _ann(winner)["imagined"].value == best


def test_without_an_imagination_that_can_spawn_the_search_navigates_as_before():
    """Inside projection (or with a fake world) it is a pass-through: nothing imagined."""
    from projection import with_projected_robot

    true, belief = make_world_pair(0, objects={})
    try:

        async def main() -> Any:
            async with with_projected_robot(belief):
                robot = current_environment().robot.name
                view = a.location(visible_for=robot, location=a.location(pose=SPOT))
                return await navigate_to_best_viewpoint(
                    an.object(type="cup"), a.location(pose=SPOT), SPOT, view
                )

        assert cpl.run(main, clock=MockClock()) == {}
    finally:
        true.close()
        belief.close()


def test_a_search_retry_chooses_its_viewpoint_anew():
    """Composes with the search's retries: the first sample of the search location is
    empty (the cup is not there), so the search tries the next sample, which imagines its
    own viewpoints again; the cup is found there."""
    empty = Pose((-0.85, 1.40, 0.91))  # on the island, the cup is on the sink counter

    async def search() -> Any:
        from executive import perform

        return await perform(
            an.action(
                type="searching",
                object=an.object(type="cup"),
                location=a.location(among=(empty, SPOT)),
                viewpoint_reasoning=True,
            )
        )

    root, found, _end = _run(search, occluder=False)
    assert found.get("name") == "cup-1"

    def every(prefix: str) -> list[cpl.Task]:
        out, stack = [], [root]
        while stack:
            t = stack.pop()
            out += [t] if t.name.startswith(prefix) else []
            stack.extend(t.children)
        return out

    assert len(every("chosen-viewpoint-")) == 2  # one choice per sample looked at
    assert len(every("imagine-viewpoint-")) >= 4
