"""Input errors a new user makes through the Python API, each a typed error that says
what to fix, raised before any process module moves."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest

from executive import (
    DesignatorError,
    NoProcessModule,
    Pose,
    RuleSet,
    a,
    an,
    environment,
    perform,
    with_process_modules,
)
from executive.testing import FakeProcessModule

HOME = Pose((0.0, 0.0, 0.0))


def test_unknown_motion_key_lists_the_known_ones(mrun: Any) -> None:
    torso = FakeProcessModule("torso", accepts="moving-torso", result="lifted")

    async def main() -> None:
        async with with_process_modules(torso):
            await perform(a.motion(type="moving-torso", joint_angel=0.2))

    with pytest.raises(DesignatorError) as info:
        mrun(main, name="typo")
    message = str(info.value)
    assert "unknown key 'joint-angel'" in message and "known keys: joint-angle, type" in message
    assert torso.calls == []  # nothing moved


def test_unknown_motion_type_lists_the_known_ones(mrun: Any) -> None:
    nav = FakeProcessModule("navigation", accepts="going", result="arrived")

    async def main() -> None:
        async with with_process_modules(nav):
            await perform(a.motion(type="flying", pose=HOME))

    with pytest.raises(DesignatorError) as info:
        mrun(main, name="flying")
    assert "no motion rule for type 'flying'" in str(info.value)
    assert "going" in str(info.value) and "moving-torso" in str(info.value)


def test_a_motion_without_process_modules_says_how_to_get_a_robot(mrun: Any) -> None:
    async def main() -> None:
        await perform(a.motion(type="going", pose=HOME))

    with pytest.raises(NoProcessModule) as info:
        mrun(main, name="no-robot")
    assert "with_projected_robot" in str(info.value)
    assert "with_real_robot" in str(info.value)


def test_rules_that_declare_keys_reject_others_and_undeclared_ones_allow_any(
    mrun: Any,
) -> None:
    rules = RuleSet()
    seen: list[Any] = []

    def strict(d: Any) -> Iterator[Any]:
        async def plan(x: Any) -> Any:
            seen.append(x)
            return x

        yield plan, {"x": d.get("x")}

    def loose(d: Any) -> Iterator[Any]:
        async def plan() -> str:
            return "loose"

        yield plan, {}

    rules.register("action", "strict", strict, keys=("x",))
    rules.register("action", "loose", loose)  # no keys declared: any key allowed

    async def main(action: Any) -> Any:
        async with environment(rules=rules):
            return await perform(action)

    assert mrun(main, an.action(type="strict", x=1), name="ok") == 1
    assert mrun(main, an.action(type="loose", anything=2), name="loose") == "loose"
    with pytest.raises(DesignatorError, match=r"unknown keys 'y', 'z'.*known keys: type, x"):
        mrun(main, an.action(type="strict", x=1, y=2, z=3), name="bad")
    assert seen == [1]  # the bad one never ran
    with pytest.raises(TypeError, match="collection of key names"):
        rules.register("action", "oops", strict, keys="x")


@pytest.mark.parametrize(
    ("motion", "message"),
    [
        (a.motion(type="going", pose=HOME, speed=-1.0), r"speed must be a number >= 0"),
        (a.motion(type="going", pose=HOME, speed=0), r"speed must be > 0"),
        (a.motion(type="gripping", gripper="left", effort=-5), r"effort must be a number >= 0"),
    ],
)
def test_negative_speeds_and_efforts_are_refused(mrun: Any, motion: Any, message: str) -> None:
    pm = FakeProcessModule("any", accepts=("going", "gripping"), result="done")

    async def main() -> None:
        async with with_process_modules(pm):
            await perform(motion)

    with pytest.raises(DesignatorError, match=message):
        mrun(main, name="negative")
    assert pm.calls == []  # nothing moved


def test_a_negative_gripping_effort_is_refused_at_the_action(mrun: Any) -> None:
    pm = FakeProcessModule("grippers", accepts="gripping", result="done")

    async def main() -> None:
        import plans  # noqa: F401 - registers the action rules

        async with with_process_modules(pm):
            await perform(an.action(type="gripping", gripper="left", effort=-5))

    with pytest.raises(DesignatorError, match=r"action \(type gripping\).*effort must be"):
        mrun(main, name="negative-effort")
    assert pm.calls == []
