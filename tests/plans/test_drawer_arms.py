"""A drawer the asked-for arm cannot open is opened with the other arm (issue 26: "the
spoon not found in the drawer"; traced on seeds 16 and 17, where the left arm's ten base
poses in front of the sink drawer all failed: the pulled handle out of its reach, or the
drawer front pulled into the robot, and the spoon stayed in the closed drawer). The
failure is injected into the belief's check of the left arm's opening, so nothing moves
for it; everything else runs on the simulated real robot and is measured in its true
world."""

from __future__ import annotations

from typing import Any

import pytest
from conftest import transport_for_real

import plans.checks  # the action rules too
import plans.environment_access as access
from executive import EnvironmentManipulationImpossible, EnvironmentUnreachable
from plans import retry_ledger
from plans.environment_access import OTHER_ARM_RELOCATIONS
from projection import make_world_pair

_real_check = plans.checks.check_environment_manipulation_collisions


def _blocking(arms: tuple[str, ...], checked: list[str]) -> Any:
    """The belief's check of an opening, failing for ``arms`` (the injected failure);
    records the arm of every opening checked (closings pass unrecorded)."""

    def check(action: Any, allowed: tuple[str, ...] = ()) -> Any:
        arm = action.get("arm")
        if action.type != "opening":
            return _real_check(action, allowed)
        checked.append(arm)
        if arm in arms:
            raise EnvironmentUnreachable(f"injected: the {arm} arm cannot open the drawer")
        return _real_check(action, allowed)

    return check


def _spoon_transport(mrun: Any, monkeypatch: pytest.MonkeyPatch, blocked: tuple[str, ...]) -> Any:
    checked: list[str] = []
    monkeypatch.setattr(
        access, "check_environment_manipulation_collisions", _blocking(blocked, checked)
    )
    true, belief = make_world_pair(0, belief_objects="exact")
    drawer = true.kitchen.container.link
    try:

        async def main() -> Any:
            with retry_ledger() as ledger:
                try:
                    result: Any = await transport_for_real(true, belief, "spoon", "spoon-1")
                except EnvironmentManipulationImpossible as failure:
                    result = failure
                return result, dict(ledger)

        result, ledger = mrun(main)
        spoon = true.object_pose("spoon-1").position
        island = true.link_aabb(true.kitchen.table_surface)
        position, lower, _upper = true.container_state(drawer)
        return result, ledger, checked, spoon, island, position - lower
    finally:
        true.close()
        belief.close()


def test_a_drawer_the_left_arm_cannot_open_is_opened_with_the_right(
    mrun: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    result, ledger, checked, spoon, island, opening = _spoon_transport(mrun, monkeypatch, ("left",))
    assert not isinstance(result, BaseException), result
    (lx, ly, _), (hx, hy, hz) = island
    assert lx < spoon[0] < hx and ly < spoon[1] < hy and hz < spoon[2] < hz + 0.1  # delivered
    assert opening < 0.01  # and the drawer closed again
    assert ledger["environment-arms"] == 1
    assert checked.count("left") == 11  # the left arm's ten relocations, checked only
    assert "right" in checked


def test_a_drawer_no_arm_can_open_is_a_typed_failure_naming_the_arms_tried(
    mrun: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    result, ledger, checked, spoon, _island, opening = _spoon_transport(
        mrun, monkeypatch, ("left", "right")
    )
    assert isinstance(result, EnvironmentManipulationImpossible)
    assert ledger["environment-arms"] == 1
    assert "arms tried: left, right" in str(result)
    assert checked.count("right") == OTHER_ARM_RELOCATIONS + 1
    assert opening < 0.01  # nothing opened it
    assert spoon[2] < 0.85  # the spoon is still in the drawer
