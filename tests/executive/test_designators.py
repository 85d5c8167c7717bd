"""Designator construction, properties, spelling, copying and display."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st
from rich.console import Console

from executive import (
    ActionDesignator,
    LocationDesignator,
    MotionDesignator,
    ObjectDesignator,
    Pose,
    a,
    an,
    cram_key,
)


def test_constructors_make_the_four_kinds() -> None:
    assert isinstance(an.action(type="picking-up"), ActionDesignator)
    assert isinstance(a.motion(type="going"), MotionDesignator)
    assert isinstance(a.location(pose=Pose()), LocationDesignator)
    assert isinstance(an.object(type="cup"), ObjectDesignator)
    # the article does not matter
    assert isinstance(a.action(type="x"), ActionDesignator)
    assert isinstance(an.motion(type="x"), MotionDesignator)


def test_repeated_properties_keep_order_and_get_returns_first() -> None:
    counter = an.object(type="counter", urdf_name="sink_area_surface")
    loc = a.location(("side", "left"), ("side", "front"), on=counter, range=0.5)
    assert loc.properties == (
        ("side", "left"),
        ("side", "front"),
        ("on", counter),
        ("range", 0.5),
    )
    assert loc.get("side") == "left"
    assert loc["side"] == "left"
    assert loc.get_all("side") == ("left", "front")
    assert loc.get_all("missing") == ()
    assert loc.keys() == ("side", "on", "range")


def test_keyword_spelling_maps_to_cram_spelling() -> None:
    drawer = an.object(type="drawer")
    loc = a.location(in_=drawer, range_invert=0.5, reachable_for="pr2", for_=an.object(type="cup"))
    assert [k for k, _ in loc.properties] == ["in", "range-invert", "reachable-for", "for"]
    # both spellings work for lookups
    assert loc.get("range_invert") == 0.5
    assert loc.get("range-invert") == 0.5
    assert loc["in_"] is drawer
    assert loc["in"] is drawer
    assert "reachable_for" in loc and "reachable-for" in loc
    assert "nope" not in loc
    # positional keys are normalised too
    assert a.location(("range_invert", 1.0)).properties == (("range-invert", 1.0),)


@pytest.mark.parametrize(
    ("given", "expected"),
    [
        ("in_", "in"),
        ("for_", "for"),
        ("urdf_name", "urdf-name"),
        ("side", "side"),
        ("range-invert", "range-invert"),
        ("left_joint_states", "left-joint-states"),
    ],
)
def test_cram_key(given: str, expected: str) -> None:
    assert cram_key(given) == expected


def test_list_value_is_one_value_and_is_frozen() -> None:
    p1, p2 = Pose((1, 0, 0)), Pose((2, 0, 0))
    act = an.action(type="reaching", left_poses=[p1, p2])
    assert act.get_all("left-poses") == ((p1, p2),)
    assert act["left_poses"] == (p1, p2)


def test_none_values_are_dropped() -> None:
    arm = None
    act = an.action(type="picking-up", arm=arm, object=an.object(type="cup"))
    assert "arm" not in act
    assert act.keys() == ("type", "object")


def test_nesting() -> None:
    cup = an.object(type="cup", name="cup-1")
    act = an.action(type="picking-up", object=cup, arm="left")
    assert act["object"] is cup
    assert act["object"]["name"] == "cup-1"
    assert act.type == "picking-up"
    assert cup.type == "cup"
    assert a.location(pose=Pose()).type is None


def test_missing_key_raises_keyerror_naming_the_designator() -> None:
    act = an.action(type="picking-up")
    with pytest.raises(KeyError, match=r"action \(type picking-up\) has no 'arm' property"):
        act["arm"]
    assert act.get("arm", "right") == "right"


def test_bad_construction_is_a_typeerror() -> None:
    with pytest.raises(TypeError, match="pairs"):
        a.location(("side",))  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="pairs"):
        a.location("side")  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="non-empty string"):
        a.location(("", 1))


def test_designators_are_immutable() -> None:
    act = an.action(type="going")
    with pytest.raises(AttributeError, match="immutable"):
        act.type = "x"  # type: ignore[misc]
    with pytest.raises(AttributeError):
        act.colour = "red"


def test_copy_replaces_removes_and_appends() -> None:
    act = an.action(type="picking-up", arm="left", grasp="top")
    moved = act.copy(arm="right", grasp=None, effort=30)
    assert moved.properties == (("type", "picking-up"), ("arm", "right"), ("effort", 30))
    assert act.properties == (("type", "picking-up"), ("arm", "left"), ("grasp", "top"))
    loc = a.location(("side", "left"))
    more = loc.copy(("side", "front"))
    assert more.get_all("side") == ("left", "front")
    assert type(more) is LocationDesignator
    # a copy starts a new, unresolved chain
    loc2 = a.location(pose=Pose())
    loc2.reference()
    fresh = loc2.copy()
    assert not fresh.effective and fresh.current() is fresh


def test_repr_reads_like_cram() -> None:
    cup = an.object(type="cup", name="cup-1")
    act = an.action(type="picking-up", object=cup, arm="left")
    assert repr(act) == (
        "<an action (type picking-up) (object <an object (type cup) (name cup-1)>) (arm left)>"
    )
    assert repr(a.location(("side", "left"), range=0.5)) == "<a location (side left) (range 0.5)>"
    assert repr(a.motion(type="moving-arm-joints", left_joint_states=[0.1, 2])) == (
        "<a motion (type moving-arm-joints) (left-joint-states (0.1 2))>"
    )
    assert repr(an.object()) == "<an object>"
    assert act.short() == "action (type picking-up) ..."
    assert cup.short() == "object (type cup) (name cup-1)"


def test_repr_is_cached_only_when_every_value_is_immutable() -> None:
    class Gauge:  # a mutable value: its display can change
        def __init__(self) -> None:
            self.level = 1

        def __repr__(self) -> str:
            return f"gauge-{self.level}"

    gauge = Gauge()
    loose = an.action(type="checking", gauge=gauge, nested=a.location(thing=gauge))
    assert "gauge-1" in repr(loose)
    gauge.level = 2
    assert repr(loose) == (
        "<an action (type checking) (gauge gauge-2) (nested <a location (thing gauge-2)>)>"
    )
    fixed = an.action(type="placing", target=a.location(pose=Pose((1.0, 2.0, 0.0))), arm="left")
    first = repr(fixed)
    assert repr(fixed) is first  # cached: the event log renders it at every task event
    assert first == (
        "<an action (type placing) (target <a location (pose <Pose map (1.000 2.000 0.000) "
        "(0.000 0.000 0.000 1.000)>)>) (arm left)>"
    )


def test_rich_rendering() -> None:
    cup = an.object(type="cup", name="cup-1")
    act = an.action(type="picking-up", object=cup, arm="left")
    console = Console(width=200, record=True, color_system=None)
    console.print(act)
    assert console.export_text().strip() == repr(act)


def test_equality_is_identity_and_same_description_compares_descriptions() -> None:
    d1 = an.action(type="x", arm="left")
    d2 = an.action(type="x", arm="left")
    assert d1 != d2
    assert d1.same_description(d2)
    assert not d1.same_description(an.action(type="x", arm="right"))
    assert not d1.same_description(a.motion(type="x", arm="left"))
    assert len({d1, d2}) == 2


_keys = st.sampled_from(["side", "on", "range", "arm", "type", "in", "for"])
_values = st.one_of(st.integers(-5, 5), st.sampled_from(["left", "right", "front", "back"]))


@given(st.lists(st.tuples(_keys, _values), max_size=8), st.randoms())
def test_reordering_distinct_keys_keeps_the_description(
    pairs: list[tuple[str, object]], rnd: object
) -> None:
    """Moving properties of different keys around keeps get/get_all; the relative order
    of repeats of one key is what matters."""
    original = a.location(*pairs)
    # a stable shuffle by key: group by a random key order, keep repeats in order
    keys = list(dict.fromkeys(k for k, _ in pairs))
    rnd.shuffle(keys)  # type: ignore[attr-defined]
    reordered = a.location(*[p for k in keys for p in pairs if p[0] == k])
    assert original.same_description(reordered)
    for k in keys:
        assert original.get(k) == reordered.get(k)
        assert original.get_all(k) == reordered.get_all(k)


@given(st.dictionaries(st.sampled_from(["side", "on", "range_invert", "in_", "for_"]), _values))
def test_keyword_and_positional_spellings_describe_the_same(props: dict[str, object]) -> None:
    by_keyword = a.location(**props)
    by_pairs = a.location(*[(cram_key(k), v) for k, v in props.items()])
    assert by_keyword.same_description(by_pairs)
    assert by_keyword.copy().same_description(by_keyword)
    assert by_keyword.properties == by_pairs.properties
