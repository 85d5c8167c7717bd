"""Plan-level input errors are typed errors raised before anything moves (real PyBullet
projection), and the demo's placing targets work for any subset and order of objects."""

from __future__ import annotations

import pytest

from executive import DesignatorError, Pose, a, an, perform
from kitchens.iai import DESCRIPTION as KITCHEN
from plans.demo import fetch_location, place_location

projection = pytest.importorskip("projection")


def _state(world):
    return (
        world.robot_pose().position,
        world.robot_pose().orientation,
        world.arm_joints("left"),
        world.arm_joints("right"),
        world.gripper_opening("left"),
        {n: world.object_pose(n).position for n in world.objects},
    )


def _run(mrun, world, action):
    async def main():
        async with projection.with_projected_robot(world):
            await perform(action)

    return mrun(main)


@pytest.fixture
def world():
    w = projection.World(seed=3)
    w.spawn_object("bowl-1", "bowl", Pose((1.4, 0.8, 0.87)))
    yield w
    w.close()


def test_setting_gripper_out_of_range_is_an_error_not_ignored(mrun, world):
    before = _state(world)
    with pytest.raises(DesignatorError, match=r"from 0 to 0\.1; got 5"):
        _run(mrun, world, an.action(type="setting-gripper", gripper="left", position=5))
    assert _state(world) == before


def test_unknown_surface_fails_before_the_robot_moves(mrun, world):
    nowhere = an.object(type="counter-top", urdf_name="nowhere_surface", part_of="kitchen")
    before = _state(world)
    transport = an.action(
        type="transporting",
        object=an.object(type="bowl"),
        location=fetch_location("bowl", KITCHEN),
        target=a.location(on=nowhere),
    )
    with pytest.raises(DesignatorError, match="'nowhere_surface', which this world does not"):
        _run(mrun, world, transport)
    assert _state(world) == before
    searching = an.action(
        type="searching", object=an.object(type="bowl"), location=a.location(on=nowhere)
    )
    with pytest.raises(DesignatorError, match="nowhere_surface"):
        _run(mrun, world, searching)
    assert _state(world) == before


def test_unknown_action_key_fails_before_the_robot_moves(mrun, world):
    before = _state(world)
    with pytest.raises(DesignatorError, match=r"unknown key 'objekt'.*known keys: location"):
        _run(
            mrun,
            world,
            an.action(type="searching", objekt=an.object(type="bowl"), location=Pose()),
        )
    assert _state(world) == before


@pytest.mark.parametrize("object_type", ["cup", "spoon", "milk"])
def test_placing_targets_need_the_bowl_only_once_it_is_placed(object_type):
    alone = place_location(object_type, bowl_placed=False, kitchen=KITCHEN)
    beside = place_location(object_type, bowl_placed=True, kitchen=KITCHEN)

    def mentions_bowl(loc) -> bool:
        return any(
            getattr(v, "get", lambda _k: None)("name") == "bowl-1" for _k, v in loc.properties
        )

    assert not mentions_bowl(alone)
    assert alone.get("context") == "table-setting"
    assert mentions_bowl(beside)


def test_opening_a_drawer_too_far_fails_before_the_arm_moves(mrun, world):
    from kitchens.iai import DESCRIPTION as kitchen
    from plans.demo import container

    DRAWER = container(kitchen)

    before = _state(world)
    with pytest.raises(DesignatorError, match=r"opened by at most 0\.480 m"):
        _run(mrun, world, an.action(type="opening", object=DRAWER, arm="left", distance=5))
    assert _state(world) == before
    with pytest.raises(DesignatorError, match="distance must be a number of metres > 0"):
        _run(mrun, world, an.action(type="opening", object=DRAWER, arm="left", distance=-1))
    assert _state(world) == before


def test_importing_plans_keeps_unknown_location_keys_an_error() -> None:
    """Every location generator plans registers declares its keys, so a misspelt key
    still fails with the known keys listed (a generator without keys= would accept any)."""
    import pytest

    import plans
    from executive import DesignatorError, a, an

    del plans
    with pytest.raises(DesignatorError, match=r"unknown key 'on-top-of' for a location"):
        a.location(on_top_of=an.object(type="table")).reference()


def test_a_misspelt_surface_name_surfaces_with_its_hint_before_the_robot_moves(mrun, world):
    """(on "nosuch_surface") is bad input: the "did you mean" DesignatorError reaches the
    caller, neither retried nor translated into object-nowhere-to-be-found."""
    from executive import ObjectNowhereToBeFound
    from plans.search import search_for_object

    before = _state(world)
    searching = an.action(
        type="searching", object=an.object(type="bowl"), location=a.location(on="nosuch_surface")
    )
    with pytest.raises(DesignatorError, match="did you mean sink_area_surface") as caught:
        _run(mrun, world, searching)
    assert not isinstance(caught.value, ObjectNowhereToBeFound)
    assert _state(world) == before

    # the plan called directly (no rule checks its input first): the location's own error
    async def direct():
        async with projection.with_projected_robot(world):
            await search_for_object(an.object(type="bowl"), a.location(on="nosuch_surface"))

    with pytest.raises(DesignatorError, match="did you mean sink_area_surface"):
        mrun(direct)
    assert _state(world) == before


@pytest.mark.parametrize("action_type", ["transporting", "searching", "fetching"])
def test_an_unknown_object_type_names_the_known_types_before_the_robot_moves(
    mrun, world, action_type
):
    before = _state(world)
    keys = {} if action_type == "fetching" else {"location": fetch_location("bowl", KITCHEN)}
    if action_type == "transporting":
        keys["target"] = place_location("bowl", kitchen=KITCHEN)
    action = an.action(type=action_type, object=an.object(type="bwol"), **keys)
    with pytest.raises(
        DesignatorError, match=r"unknown object type 'bwol'; did you mean bowl\?.*known types"
    ):
        _run(mrun, world, action)
    assert _state(world) == before


@pytest.mark.parametrize(
    ("values", "message"),
    [
        ((5.0,) * 7, r"outside its limits \["),
        ((0.0, 0.0, 0.0), r"7 finite joint values \(l_shoulder_pan_joint"),
        ((0.0,) * 8, "7 finite joint values"),
    ],
)
def test_bad_arm_joint_values_are_refused_before_the_arm_moves(mrun, world, values, message):
    """position-arms ignores manipulation failures, so bad values used to return None
    and move nothing without a word."""
    before = _state(world)
    action = an.action(type="positioning-arm", left_configuration=values)
    with pytest.raises(DesignatorError, match=message) as caught:
        _run(mrun, world, action)
    if "limits" in message:
        lo, hi = world.arm_joint_limits("left")[0][1:]
        assert f"l_shoulder_pan_joint = 5.0 is outside its limits [{lo:.4f}, {hi:.4f}]" in str(
            caught.value
        )
    assert _state(world) == before


@pytest.mark.parametrize("action_type", ["transporting", "fetching", "picking-up"])
def test_an_unknown_arm_is_reported_at_the_action_given_it(mrun, world, action_type):
    """Not by an inner setting-gripper action, after the robot has driven and reached."""
    before = _state(world)
    keys = {"arm": "middle", "object": an.object(type="bowl")}
    if action_type == "transporting":
        keys.update(
            location=fetch_location("bowl", KITCHEN), target=place_location("bowl", kitchen=KITCHEN)
        )
    if action_type == "picking-up":
        keys["object"] = an.object(type="bowl", name="bowl-1", pose=Pose((1.4, 0.8, 0.87)))
    with pytest.raises(
        DesignatorError,
        match=rf"action \(type {action_type}\).*unknown arm 'middle'; known arms: right, left",
    ):
        _run(mrun, world, an.action(type=action_type, **keys))
    assert _state(world) == before


def test_a_misspelt_container_fails_before_the_robot_moves(mrun, world):
    # a drawer the world does not know is the programmer's error, named at once; not
    # "environment manipulation impossible" after the robot drove to ten base poses
    from executive import DesignatorInputError

    drawr = an.object(type="drawer", urdf_name="sink_area_left_upper_drawr_main")
    before = _state(world)
    for verb in ("accessing", "sealing"):
        with pytest.raises(DesignatorInputError, match="'sink_area_left_upper_drawr_main'"):
            _run(mrun, world, an.action(type=verb, location=a.location(in_=drawr)))
    assert _state(world) == before
