"""Resolution: rules, reference caching, chains, errors, builtin motions, the location
pipeline."""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Iterator
from typing import Any, cast

import pytest
from hypothesis import given
from hypothesis import strategies as st

import cpl
from executive import (
    ActionGrounding,
    DesignatorError,
    Environment,
    MotionCommand,
    NoWorldModel,
    ObjectData,
    Pose,
    RuleSet,
    Validation,
    a,
    an,
    builtin_rules,
    current_environment,
    environment,
    equate,
    register_rule,
    rule,
    static_rules,
)
from executive.testing import InMemoryWorld


def in_env(env_kwargs: dict[str, Any], fn: Callable[[], Any]) -> Any:
    """Run ``fn()`` (sync) inside an environment built from ``env_kwargs``."""

    async def main() -> Any:
        async with environment(**env_kwargs):
            return fn()

    return cpl.run(main, name="resolution-test")


def counting_rule(solutions: list[Any], forced: list[Any]) -> Callable[[Any], Iterator[Any]]:
    def gen(d: Any) -> Iterator[Any]:
        for s in solutions:
            forced.append(s)
            yield s

    return gen


def rules_with_objects(solutions: list[Any], forced: list[Any]) -> RuleSet:
    rules = RuleSet()
    rules.register("object", "thing", counting_rule(solutions, forced))
    return rules


# ------------------------------------------------------------------------- reference
def test_reference_resolves_once_and_caches() -> None:
    forced: list[Any] = []
    rules = rules_with_objects(["s1", "s2", "s3"], forced)

    def body() -> None:
        d = an.object(type="thing")
        assert not d.effective
        assert d.reference() == "s1"
        assert d.reference() == "s1"
        assert d.effective
        assert forced == ["s1"]  # lazy: only the first solution was generated

    in_env({"rules": rules}, body)


def test_solutions_is_a_shared_lazy_list() -> None:
    forced: list[Any] = []
    rules = rules_with_objects(["s1", "s2", "s3"], forced)

    def body() -> None:
        d = an.object(type="thing")
        sols = d.solutions()
        assert forced == []
        assert sols.first() == "s1"
        assert sols[1] == "s2"
        assert forced == ["s1", "s2"]
        assert d.reference() == "s1"
        assert sols.force() == ["s1", "s2", "s3"]
        assert forced == ["s1", "s2", "s3"]  # nothing generated twice
        assert d.next_solution().solutions().force() == ["s2", "s3"]  # type: ignore[union-attr]

    in_env({"rules": rules}, body)


def test_next_solution_builds_an_equated_chain() -> None:
    rules = rules_with_objects(["s1", "s2", "s3"], [])

    def body() -> None:
        d1 = an.object(type="thing")
        d2 = d1.next_solution()
        assert d2 is not None and d2 is not d1
        assert d2.reference() == "s2"
        assert d2.same_description(d1)
        d3 = d2.next_solution()
        assert d3 is not None and d3.reference() == "s3"
        assert d2.next_solution() is not None  # branching off d2 still works
        assert d1.chain()[:3] == (d1, d2, d3)
        assert d3.next_solution() is None
        assert d1.current() is d1.chain()[-1]
        assert d3.first() is d1
        assert d2.parent is d1 and d1.successor is d2

    in_env({"rules": rules}, body)


def test_newest_effective_skips_unreferenced_members() -> None:
    rules = rules_with_objects(["s1", "s2"], [])

    def body() -> None:
        d1 = an.object(type="thing")
        assert d1.newest_effective() is None
        d1.reference()
        assert d1.newest_effective() is d1
        fresh = an.object(type="thing")
        equate(d1, fresh)
        assert d1.current() is fresh
        assert d1.newest_effective() is d1  # fresh has not been referenced
        fresh.reference()
        assert d1.newest_effective() is fresh
        assert fresh.newest_effective() is fresh

    in_env({"rules": rules}, body)


def test_equate_appends_whole_chains_and_is_idempotent() -> None:
    x1, x2 = an.object(type="a"), an.object(type="a")
    y1, y2 = an.object(type="b"), an.object(type="b")
    equate(x1, x2)
    equate(y1, y2)
    assert equate(x2, y2) is y2  # attaches y's chain (from y1) after x2
    assert x1.chain() == (x1, x2, y1, y2)
    assert y1.current() is y2 and y2.first() is x1
    equate(x1, y2)  # same chain: nothing changes
    assert x1.chain() == (x1, x2, y1, y2)
    with pytest.raises(TypeError, match="different kinds"):
        equate(x1, a.location(pose=Pose()))
    with pytest.raises(TypeError):
        equate(x1, "cup")  # type: ignore[arg-type]


@given(st.integers(0, 6), st.integers(0, 10))
def test_chain_invariants(n_solutions: int, n_steps: int) -> None:
    """After k next_solution steps along a stream of n solutions the chain holds
    min(k, n-1) + 1 members, each the next solution, and current() is the last one."""
    rules = RuleSet(parent=None)
    rules.register("object", "thing", lambda d: iter(range(n_solutions)))

    def body() -> None:
        first = an.object(type="thing")
        d = first
        steps = 0
        for _ in range(n_steps):
            nxt = d.next_solution()
            if nxt is None:
                break
            d = nxt
            steps += 1
        assert steps == min(n_steps, max(n_solutions - 1, 0))
        chain = first.chain()
        assert len(chain) == steps + 1
        assert first.current() is d
        for i, member in enumerate(chain[1:], start=1):
            assert member.effective and member.reference() == i
            assert member.same_description(first)
        if n_solutions:
            assert first.reference() == 0
        else:
            with pytest.raises(DesignatorError):
                first.reference()

    in_env({"rules": rules}, body)


# ----------------------------------------------------------------------------- errors
def test_unknown_type_is_a_designator_error_naming_it() -> None:
    d = a.motion(type="flying")
    with pytest.raises(DesignatorError, match=r"motion \(type flying\).*no motion rule") as exc:
        d.reference()
    assert exc.value.designator is d
    assert "register_rule('motion', 'flying'" in str(exc.value)
    with pytest.raises(DesignatorError, match="no action rule"):
        an.action(type="juggling").reference()


def test_missing_type() -> None:
    with pytest.raises(DesignatorError, match=r"has no type property"):
        an.action(object=an.object(type="cup")).reference()


def test_missing_property_says_what_to_fix() -> None:
    with pytest.raises(DesignatorError, match=r"motion \(type going\) needs a pose or target"):
        a.motion(type="going").reference()
    with pytest.raises(DesignatorError, match=r"needs a joint-angle property"):
        a.motion(type="moving-torso").reference()
    with pytest.raises(DesignatorError, match=r"needs a gripper property"):
        a.motion(type="opening-gripper").reference()
    with pytest.raises(DesignatorError, match=r"gripper must be 'left', 'right'"):
        a.motion(type="gripping", gripper="middle").reference()
    with pytest.raises(DesignatorError, match=r"needs a left-pose or a right-pose"):
        a.motion(type="moving-tcp").reference()
    with pytest.raises(DesignatorError, match=r"needs an object property"):
        a.motion(type="detecting").reference()
    with pytest.raises(DesignatorError, match=r"must be an executive.Pose"):
        a.motion(type="going", pose=(1.0, 2.0, 0.0)).reference()


@pytest.mark.parametrize(
    "bad",
    [
        a.motion(type="going", pose=(math.nan, 0.0, 0.0)),
        a.motion(type="moving-torso", joint_angle=math.inf),
        an.action(type="reaching", left_poses=[(0.0, math.nan, 1.0)]),
        a.location(of=an.object(type="cup", size=(0.1, math.nan))),
    ],
)
def test_non_finite_values_are_designator_errors(bad: Any) -> None:
    with pytest.raises(DesignatorError, match=r"invalid .* non-finite") as exc:
        bad.reference()
    assert exc.value.designator is bad
    assert bad.kind in str(exc.value)


def test_rule_errors_are_remembered_by_the_stream() -> None:
    def flaky(d: Any) -> Iterator[str]:
        yield "ok"
        raise DesignatorError("second solution is broken", d)

    rules = RuleSet(parent=None)
    rules.register("object", "flaky", flaky)

    def body() -> None:
        d = an.object(type="flaky")
        assert d.reference() == "ok"
        for _ in range(2):
            with pytest.raises(DesignatorError, match="second solution"):
                d.next_solution()

    in_env({"rules": rules}, body)


def test_a_rule_yielding_garbage_is_a_typeerror() -> None:
    rules = RuleSet(parent=None)
    rules.register("motion", "bad", lambda d: iter([42]))
    rules.register("action", "bad", lambda d: iter([("not-callable", {})]))
    rules.register("action", "none", lambda d: 7)

    def body() -> None:
        with pytest.raises(TypeError, match=r"\(command, \{argument: value\}\)"):
            a.motion(type="bad").reference()
        with pytest.raises(TypeError, match="plan_function"):
            an.action(type="bad").reference()
        with pytest.raises(TypeError, match="must yield"):
            an.action(type="none").reference()

    in_env({"rules": rules}, body)


# ------------------------------------------------------------------------------ rules
def test_rules_run_in_priority_order_and_concatenate() -> None:
    rules = RuleSet(parent=None)
    rules.register("object", "t", lambda d: iter(["late"]), priority=5)
    rules.register("object", "t", lambda d: iter(["early-1", "early-2"]), priority=-1)
    rules.register("object", "*", lambda d: iter(["wild"]), priority=0)
    rules.register("object", "t", lambda d: iter(["exact"]), priority=0)

    def body() -> None:
        assert an.object(type="t").solutions().force() == [
            "early-1",
            "early-2",
            "exact",
            "wild",
            "late",
        ]
        assert an.object(type="other").solutions().force() == ["wild"]

    in_env({"rules": rules}, body)


def test_restoring_undoes_registrations_and_their_cached_lookups() -> None:
    rules = RuleSet()
    rules.register("object", "kept", lambda d: iter(["kept"]))

    def kept() -> Any:
        return in_env({"rules": rules}, lambda: an.object(type="kept").reference())

    assert kept() == "kept"
    with rules.restoring():
        rules.register("object", "temporary", lambda d: iter(["t"]))
        rules.register_location_generator(lambda d: iter([Pose((1.0, 2.0, 0.0))]))
        assert in_env({"rules": rules}, lambda: a.location().reference()) == Pose((1, 2, 0))
        assert "temporary" in rules.known_types("object")
    assert "temporary" not in rules.known_types("object")
    assert kept() == "kept"
    with pytest.raises(DesignatorError):
        in_env({"rules": rules}, lambda: a.location().reference())


def test_child_rules_add_and_override() -> None:
    parent = RuleSet(parent=None, name="p")
    parent.register("object", "t", lambda d: iter(["parent"]))
    child = parent.child()
    child.register("object", "t", lambda d: iter(["child"]))
    replacing = parent.child()
    replacing.register("object", "t", lambda d: iter(["only"]), replace=True)

    def solutions(rules: RuleSet) -> list[Any]:
        return in_env({"rules": rules}, lambda: an.object(type="t").solutions().force())

    assert solutions(parent) == ["parent"]
    assert solutions(child) == ["child", "parent"]
    assert solutions(replacing) == ["only"]
    # the cache notices late registrations in the parent
    parent.register("object", "t", lambda d: iter(["parent-2"]))
    assert solutions(child) == ["child", "parent", "parent-2"]


def test_rules_may_take_the_environment() -> None:
    rules = RuleSet(parent=None)
    rules.register("object", "t", lambda d, env: iter([env.name]))
    assert in_env({"rules": rules, "name": "here"}, lambda: an.object(type="t").reference()) == (
        "here"
    )
    with pytest.raises(TypeError, match="positional argument"):
        rules.register("object", "t", lambda: iter([]))


def test_registration_errors() -> None:
    rules = RuleSet(parent=None)
    with pytest.raises(ValueError, match="register_location_generator"):
        rules.register("location", "x", lambda d: iter([]))
    with pytest.raises(ValueError, match="unknown designator kind"):
        rules.register("gesture", "x", lambda d: iter([]))
    with pytest.raises(TypeError, match="non-empty string"):
        rules.register("action", "", lambda d: iter([]))
    with pytest.raises(TypeError, match="callable"):
        rules.register("action", "x", cast(Any, 42))
    with pytest.raises(RuntimeError, match="frozen"):
        builtin_rules.register("action", "x", lambda d: iter([]))


async def _static_plan() -> str:
    return "ok"


@pytest.fixture()
def clean_static_rules() -> Iterator[None]:
    """Registrations on executive.static_rules made by the test are undone after it."""
    with static_rules.restoring():
        yield
    assert "test-static-object" not in static_rules.known_types("object")


@pytest.mark.usefixtures("clean_static_rules")
def test_static_rules_reach_every_environment() -> None:
    @rule("action", "test-static-decorated")
    def grounding(d: Any) -> Iterator[Any]:
        yield (_static_plan, {})

    register_rule("object", "test-static-object", lambda d: iter(["static"]))
    assert an.action(type="test-static-decorated").reference() == ActionGrounding(_static_plan, {})
    assert in_env({}, lambda: an.object(type="test-static-object").reference()) == "static"
    # a fresh RuleSet (builtins only) does not see them
    with pytest.raises(DesignatorError):
        in_env({"rules": RuleSet()}, lambda: an.object(type="test-static-object").reference())
    assert "test-static-object" in static_rules.known_types("object")


def test_environment_rules_stay_in_their_block() -> None:
    async def main() -> None:
        async with environment(name="outer") as outer:
            outer.register_rule("object", "test-env-only", lambda d: iter(["env"]))
            assert an.object(type="test-env-only").reference() == "env"
            assert outer.rules is not static_rules
        with pytest.raises(DesignatorError):
            an.object(type="test-env-only").reference()

    cpl.run(main, name="env-rules")
    with pytest.raises(RuntimeError, match="no executive environment is active"):
        current_environment().register_rule("object", "x", lambda d: iter([]))


def test_resolution_keeps_the_environment_of_the_stream() -> None:
    """Later solutions come from the environment where resolution started."""
    rules = RuleSet(parent=None)
    rules.register("object", "t", lambda d, env: (f"{env.name}-{i}" for i in itertools.count()))

    async def main() -> None:
        async with environment(name="first", rules=rules):
            d = an.object(type="t")
            assert d.reference() == "first-0"
        async with environment(name="second", rules=rules):
            nxt = d.next_solution()
            assert nxt is not None and nxt.reference() == "first-1"

    cpl.run(main, name="stream-env")


# --------------------------------------------------------------------- builtin motions
def test_builtin_motion_groundings() -> None:
    p = Pose((1.0, 2.0, 0.0))
    q = Pose((0.5, 0.1, 1.0), frame="base_footprint")
    cases = [
        (a.motion(type="going", pose=p), ("move-base", {"pose": p})),
        (
            a.motion(type="going", target=a.location(pose=p), speed=0.5),
            ("move-base", {"pose": p, "speed": 0.5}),
        ),
        (a.motion(type="moving-torso", joint_angle=0.3), ("move-torso", {"joint_angle": 0.3})),
        (a.motion(type="looking", target=a.location(pose=p)), ("move-head", {"pose": p})),
        (a.motion(type="looking", frame="kitchen"), ("move-head", {"frame": "kitchen"})),
        (a.motion(type="looking", direction="forward"), ("move-head", {"direction": "forward"})),
        (
            a.motion(type="opening-gripper", gripper="left"),
            ("move-gripper-joint", {"action": "open", "gripper": "left"}),
        ),
        (
            a.motion(type="opening", gripper=["left", "right"]),
            ("move-gripper-joint", {"action": "open", "gripper": ("left", "right")}),
        ),
        (
            a.motion(type="closing", gripper="right"),
            ("move-gripper-joint", {"action": "close", "gripper": "right"}),
        ),
        (
            a.motion(type="gripping", gripper="left", effort=30),
            ("move-gripper-joint", {"action": "grip", "gripper": "left", "effort": 30.0}),
        ),
        (
            a.motion(type="moving-gripper-joint", gripper="left", joint_angle=0.02),
            ("move-gripper-joint", {"action": "angle", "gripper": "left", "joint_angle": 0.02}),
        ),
        (
            a.motion(type="moving-tcp", left_pose=q),
            ("move-tcp", {"left": q, "right": None, "collision_mode": None}),
        ),
        (
            a.motion(type="moving-arm-joints", right_joint_states=[0, 1, 2, 3, 4, 5, 6]),
            ("move-joints", {"left": None, "right": (0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0)}),
        ),
    ]
    for motion, expected in cases:
        got = motion.reference()
        assert isinstance(got, MotionCommand)
        assert got == expected, motion
    cup = an.object(type="cup")
    command, args = a.motion(type="detecting", object=cup).reference()
    assert command == "detect" and args["object"] is cup


def test_going_uses_the_current_target_of_a_chain() -> None:
    p1, p2 = Pose((1, 0, 0)), Pose((2, 0, 0))
    loc = a.location(pose=p1)
    equate(loc, a.location(pose=p2))
    assert a.motion(type="going", target=loc).reference().arguments["pose"] == p2


def test_object_designators_resolve_to_their_data() -> None:
    p = Pose((1, 0, 0.8))
    data = an.object(type="cup", name="cup-1", pose=p, colour="red").reference()
    assert data == ObjectData(name="cup-1", type="cup", pose=p, extra={"colour": "red"})
    with pytest.raises(DesignatorError, match="perceive it first"):
        an.object(type="cup").reference()


# --------------------------------------------------------------------- location pipeline
def test_pose_and_of_locations() -> None:
    p = Pose((1, 2, 3))
    assert a.location(pose=p).reference() is p
    cup = an.object(type="cup", pose=p)
    assert a.location(of=cup).reference() == p
    with pytest.raises(DesignatorError, match="no stored pose"):
        a.location(of=an.object(type="cup")).reference()
    with pytest.raises(DesignatorError, match=r"\(pose \.\.\.\) must be an executive.Pose"):
        a.location(pose="here").reference()
    # no generator of the builtin rules understands (on ...): the error says so, up front
    with pytest.raises(DesignatorError, match=r"unknown key 'on' for a location.*known keys"):
        a.location(on=an.object(type="table")).reference()


def test_of_item_object_asks_the_world() -> None:
    world = InMemoryWorld({"cup-1": Pose((3, 0, 1))})
    got = in_env(
        {"world": world},
        lambda: a.location(of_item_object=an.object(name="cup-1")).reference(),
    )
    assert got == Pose((3, 0, 1))
    with pytest.raises(NoWorldModel):
        a.location(of_item_object="cup-1").reference()


def _gen(tag: str, n: int | None = None) -> Callable[[Any], Iterator[Pose]]:
    def gen(d: Any) -> Iterator[Pose]:
        for i in itertools.count() if n is None else range(n):
            yield Pose((float(i), 0.0, 0.0), frame=tag)

    gen.__qualname__ = f"gen-{tag}"
    return gen


def test_generators_are_concatenated_in_priority_order() -> None:
    rules = RuleSet(parent=None)
    rules.register_location_generator(_gen("late", 1), 20)
    rules.register_location_generator(_gen("early", 2), 10)
    poses = in_env({"rules": rules}, lambda: a.location(x=1).solutions().force())
    assert [(p.frame, p.position[0]) for p in poses] == [
        ("early", 0.0),
        ("early", 1.0),
        ("late", 0.0),
    ]


def test_validators_accept_reject_maybe_and_unknown() -> None:
    rules = RuleSet(parent=None)
    rules.register_location_generator(_gen("map", 6))
    calls: list[str] = []

    def odd_rejected(d: Any, p: Pose) -> Any:
        calls.append("first")
        i = int(p.position[0])
        return [None, "reject", Validation.MAYBE_REJECT, "maybe-reject", "unknown", True][i]

    def accepts_three(d: Any, p: Pose, env: Environment) -> Validation:
        calls.append("second")
        return Validation.ACCEPT if p.position[0] == 3 else Validation.UNKNOWN

    rules.register_location_validator(accepts_three, 5)
    rules.register_location_validator(odd_rejected, 1)
    poses = in_env({"rules": rules}, lambda: a.location(x=1).solutions().force())
    # 0: None -> reject; 1: reject; 2: maybe-reject stays; 3: maybe-reject then accept;
    # 4: unknown; 5: True -> accept
    assert [p.position[0] for p in poses] == [3.0, 4.0, 5.0]
    assert calls[:3] == ["first", "first", "first"]  # rejections stop the pipeline early
    bad = RuleSet(parent=None)
    bad.register_location_generator(_gen("map", 1))
    bad.register_location_validator(lambda d, p: "perhaps")
    with pytest.raises(TypeError, match="'accept', 'reject'"):
        in_env({"rules": bad}, lambda: a.location(x=1).reference())


def test_thirty_rejections_in_a_row_end_an_infinite_stream() -> None:
    rules = RuleSet(parent=None)
    rules.register_location_generator(_gen("map"))  # infinite
    seen: list[float] = []

    def only_first_two(d: Any, p: Pose) -> str:
        seen.append(p.position[0])
        return "accept" if p.position[0] < 2 else "reject"

    rules.register_location_validator(only_first_two)
    poses = in_env({"rules": rules}, lambda: a.location(x=1).solutions().force())
    assert [p.position[0] for p in poses] == [0.0, 1.0]
    assert len(seen) == 2 + 30
    # the counter resets on every accepted candidate
    rules2 = RuleSet(parent=None)
    rules2.register_location_generator(_gen("map"))
    rules2.register_location_validator(
        lambda d, p: "accept" if p.position[0] % 29 == 0 and p.position[0] < 100 else "reject"
    )
    poses2 = in_env({"rules": rules2}, lambda: a.location(x=1).solutions().force())
    assert [p.position[0] for p in poses2] == [0.0, 29.0, 58.0, 87.0]


def test_generators_must_yield_poses() -> None:
    rules = RuleSet(parent=None)
    rules.register_location_generator(lambda d: iter([(1, 2, 3)]))
    with pytest.raises(TypeError, match=r"yield executive\.Pose"):
        in_env({"rules": rules}, lambda: a.location(x=1).reference())


def test_next_different_solution_skips_close_poses() -> None:
    rules = RuleSet(parent=None)
    poses = [
        Pose((0, 0, 0)),
        Pose((0.01, 0, 0)),  # too close
        Pose.from_xyz_yaw(0.0, 0.0, yaw=0.05),  # too close in both
        Pose.from_xyz_yaw(0.0, 0.0, yaw=0.5),  # different orientation
        Pose((1, 0, 0)),
    ]
    rules.register_location_generator(lambda d: iter(poses))

    def body() -> None:
        loc = a.location(x=1)
        nxt = loc.next_different_solution()
        assert nxt is not None and nxt.reference() is poses[3]
        again = nxt.next_different_solution(distance_threshold=2.0, angle_threshold=1.0)
        assert again is None
        assert nxt.next_different_solution() is not None
        loc2 = a.location(x=1)
        assert loc2.next_different_solution(max_skips=2) is None

    in_env({"rules": rules}, body)
