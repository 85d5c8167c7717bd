"""A spoon at the back of the drawer is found by opening the drawer farther (issue 26:
"the spoon not found in the drawer"; no CRAM plan does this): ``accessing`` opens the
drawer by CRAM's 0.3 m, which leaves the back of this drawer inside the cabinet; a search
that finds nothing there opens it to the end of its travel and looks again. Set up and
measured in the simulated real robot's true world (the belief knows no objects, as in
the demo)."""

from __future__ import annotations

import logging
from typing import Any

import pytest
from conftest import transport_for_real

import plans.checks  # the action rules too
import plans.environment_access as access
from executive import EnvironmentUnreachable, ObjectNowhereToBeFound, Pose
from plans import retry_ledger
from plans.environment import DEFAULT_DISTANCE
from projection import World, make_world_pair

#: The spoon's x (map) at the back of the closed drawer (its front is at x 1.12, its back
#: at 1.70; the demo's spoon lies at 1.40).
AT_THE_BACK = 1.50


def _spoon_at_the_back(true: World) -> None:
    pose = true.object_pose("spoon-1")
    _x, y, z = pose.position
    back = Pose((AT_THE_BACK, y, z), pose.orientation)
    true.set_object_pose("spoon-1", back, allow_overlap=True)  # in the closed drawer


def test_a_spoon_at_the_back_of_the_drawer_is_found_and_delivered(mrun: Any) -> None:
    true, belief = make_world_pair(0)
    drawer = true.kitchen.container.link
    try:
        _spoon_at_the_back(true)

        async def main() -> Any:
            with retry_ledger() as ledger:
                result = await transport_for_real(true, belief, "spoon", "spoon-1")
                return result, dict(ledger)

        result, ledger = mrun(main)
        assert result is not None, ledger  # delivered, not dropped at the sink
        (lx, ly, _), (hx, hy, hz) = true.link_aabb(true.kitchen.table_surface)
        sx, sy, sz = true.object_pose("spoon-1").position
        assert lx < sx < hx and ly < sy < hy and hz < sz < hz + 0.1
        position, lower, _upper = true.container_state(drawer)
        assert position - lower < 0.01  # closed again
        assert ledger.get("drawer-farther") == 1
    finally:
        true.close()
        belief.close()


def test_a_drawer_that_will_not_open_farther_is_logged_counted_and_closed(
    mrun: Any, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    """The injected failure: the belief's check of every opening beyond CRAM's first one
    fails (no arm, no base pose opens it farther). The plan goes on to the floor search,
    fails with its typed failure, and the drawer is closed again in the true world."""
    real_check = plans.checks.check_environment_manipulation_collisions

    def check(action: Any, allowed: tuple[str, ...] = ()) -> Any:
        if action.type == "opening" and action.get("distance") != DEFAULT_DISTANCE:
            raise EnvironmentUnreachable("injected: the drawer will not open farther")
        return real_check(action, allowed)

    monkeypatch.setattr(access, "check_environment_manipulation_collisions", check)
    true, belief = make_world_pair(0)
    drawer = true.kitchen.container.link
    try:
        _spoon_at_the_back(true)
        counts: dict[str, int] = {}

        async def main() -> None:
            with retry_ledger() as ledger:
                try:
                    await transport_for_real(true, belief, "spoon", "spoon-1")
                finally:
                    counts.update(ledger)

        with caplog.at_level(logging.WARNING, logger="plans.environment_access"):
            with pytest.raises(ObjectNowhereToBeFound):
                mrun(main)
        assert counts["drawer-farther"] == 1 and counts["drawer-farther-failed"] == 1
        assert any("could not open" in r.getMessage() for r in caplog.records)
        position, lower, _upper = true.container_state(drawer)
        assert position - lower < 0.01  # closed again
        assert true.object_pose("spoon-1").position[0] > 1.12  # still inside the cabinet
    finally:
        true.close()
        belief.close()
