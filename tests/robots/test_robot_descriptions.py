"""Robot descriptions as data: the PR2-like robot's description agrees with what the
projection and ``executive.knowledge`` use today; a description that does not fit its
URDF is a typed error naming the field, raised before the robot is loaded."""

from __future__ import annotations

import dataclasses
import math

import pybullet as pb
import pytest

from executive import (
    ArmDescription,
    KinematicTree,
    RobotDescription,
    RobotDescriptionError,
)
from projection import (
    _costmaps,
    _urdf,
    _world_base,
    _world_perception,
    kinematic_tree,
    load_robot,
)
from robots import pr2

PR2 = pr2.DESCRIPTION


@pytest.fixture
def client():
    c = pb.connect(pb.DIRECT)
    yield c
    pb.disconnect(physicsClientId=c)


def test_pr2_description_holds_the_pr2_facts_and_agrees_with_the_projection() -> None:
    """The PR2-like robot's facts (they were executive.knowledge's constants before the
    robot became data): CRAM's arm order, l_/r_ names, the tool and wrist links, the
    standard-gripper -> tool rotation, the 0.10 m gripper, park and carry."""
    assert PR2.arm_names == ("right", "left")
    assert PR2.urdf() == _world_base.ASSETS / "pr2.urdf"
    for arm in PR2.arms:
        p = arm.name[0]
        assert arm.joints == tuple(f"{p}_{j}" for j in pr2.ARM_JOINTS)
        assert len(arm.joints) == 7
        assert arm.tool_frame == f"{p}_gripper_tool_frame"
        assert arm.hand_link == f"{p}_wrist_roll_link"
        assert arm.standard_to_tool == ((0.0, 1.0, 0.0), (0.0, 0.0, 1.0), (1.0, 0.0, 0.0))
        assert arm.gripper.max_opening == 0.10
        assert arm.gripper.open_position == _urdf.FINGER_MAX
        assert set(arm.states) == {"park", "carry"}
        assert all(len(arm.state(name)) == 7 for name in arm.states)
        assert arm.reach.in_reach_distance == _costmaps.IN_REACH_DISTANCE
        assert arm.reach.minimal_distance == _costmaps.REACH_MINIMAL_DISTANCE
    # the two arms mirror each other: the shoulder pan of park is +-0.116
    assert PR2.arm("left").state("park")[0] == -PR2.arm("right").state("park")[0] == 0.116
    assert PR2.torso.default == _world_base.DEFAULT_TORSO
    camera = PR2.neck.camera
    assert camera.vertical_fov == pytest.approx(_world_perception._CAMERA_FOV_Y)
    aspect = math.tan(camera.horizontal_fov / 2) / math.tan(camera.vertical_fov / 2)
    assert aspect == pytest.approx(_world_perception._CAMERA_ASPECT)
    tree = KinematicTree.from_urdf(PR2.urdf())
    torso = tree.joints[PR2.torso.joint]
    assert (PR2.torso.lower, PR2.torso.upper) == (torso.lower, torso.upper)
    PR2.validate(tree)


def test_the_tree_pybullet_loads_is_the_urdfs(client: int) -> None:
    robot = load_robot(PR2, client)
    assert kinematic_tree(client, robot.body) == KinematicTree.from_urdf(PR2.urdf())


def _arm(description: RobotDescription, which: str, **changes: object) -> RobotDescription:
    arms = tuple(
        dataclasses.replace(a, **changes) if a.name == which else a  # type: ignore[arg-type]
        for a in description.arms
    )
    return dataclasses.replace(description, arms=arms)


def _error(description: RobotDescription) -> RobotDescriptionError:
    with pytest.raises(RobotDescriptionError) as info:
        description.validate(KinematicTree.from_urdf(PR2.urdf()))
    return info.value


def test_a_missing_joint_names_the_field_and_the_close_names() -> None:
    left = PR2.arm("left")
    joints = (*left.joints[:3], "l_elbow_flx_joint", *left.joints[4:])
    e = _error(_arm(PR2, "left", joints=joints))
    assert e.field == "arms['left'].joints[3]" and e.robot == "pr2"
    assert "no joint 'l_elbow_flx_joint'" in str(e)
    assert "did you mean 'l_elbow_flex_joint'" in str(e)


def test_a_missing_link_names_the_field() -> None:
    e = _error(_arm(PR2, "right", tool_frame="r_gripper_tool_frme"))
    assert e.field == "arms['right'].tool_frame"
    assert "did you mean 'r_gripper_tool_frame'" in str(e)
    e = _error(_arm(PR2, "left", hand_link="l_wrist_link"))
    assert e.field == "arms['left'].hand_link"
    e = _error(dataclasses.replace(PR2, base_link="base"))
    assert e.field == "base_link" and "did you mean 'base_link'" in str(e)


def test_a_wrong_chain_is_an_error() -> None:
    left = PR2.arm("left")
    swapped = (left.joints[0], left.joints[2], left.joints[1], *left.joints[3:])
    e = _error(_arm(PR2, "left", joints=swapped))
    assert e.field == "arms['left'].joints[1]" and "does not follow" in str(e)
    # a chain that ends elsewhere than its tool frame (the other arm's)
    e = _error(_arm(PR2, "left", tool_frame="r_gripper_tool_frame"))
    assert e.field == "arms['left'].tool_frame" and "not rigidly attached" in str(e)
    # the other arm's object link
    e = _error(_arm(PR2, "left", hand_link="r_wrist_roll_link"))
    assert e.field == "arms['left'].hand_link"
    # a chain missing its last joint does not reach the tool frame
    e = _error(
        _arm(
            PR2, "left", joints=left.joints[:-1], states={k: v[:-1] for k, v in left.states.items()}
        )
    )
    assert e.field == "arms['left'].tool_frame"
    # the other arm's fingers
    right_fingers = PR2.arm("right").gripper.joints
    gripper = dataclasses.replace(left.gripper, joints=right_fingers)
    e = _error(_arm(PR2, "left", gripper=gripper))
    assert e.field == "arms['left'].gripper.joints[0]"
    assert "does not hang below" in str(e) or "already" in str(e)
    # the neck out of order
    neck = dataclasses.replace(PR2.neck, pan_joint="head_tilt_joint", tilt_joint="head_pan_joint")
    e = _error(dataclasses.replace(PR2, neck=neck))
    assert e.field == "neck.tilt_joint" and "does not follow" in str(e)


def test_an_unknown_named_state_is_an_error_when_the_description_is_made() -> None:
    with pytest.raises(RobotDescriptionError) as info:
        dataclasses.replace(PR2, initial_state="parked")
    assert info.value.field == "initial_state"
    assert "unknown named state 'parked'" in str(info.value)
    assert "did you mean 'park'" in str(info.value)
    left = PR2.arm("left")
    with pytest.raises(RobotDescriptionError) as info:
        _arm(PR2, "left", states={"park": left.state("park")})
    assert info.value.field == "arms['left'].states" and "'carry'" in str(info.value)
    with pytest.raises(LookupError, match="did you mean 'carry'"):
        left.state("cary")


def test_values_outside_the_urdf_limits_are_errors() -> None:
    left = PR2.arm("left")
    states = {**left.states, "carry": (9.0, *left.state("carry")[1:])}
    e = _error(_arm(PR2, "left", states=states))
    assert e.field == "arms['left'].states['carry']" and "outside the limits" in str(e)
    e = _error(dataclasses.replace(PR2, torso=dataclasses.replace(PR2.torso, upper=0.5)))
    assert e.field == "torso"
    gripper = dataclasses.replace(left.gripper, effort=150.0)
    e = _error(_arm(PR2, "left", gripper=gripper))
    assert e.field == "arms['left'].gripper.effort" and "effort limit 100" in str(e)


def test_records_check_what_needs_no_urdf() -> None:
    with pytest.raises(RobotDescriptionError, match="'left' or 'right'"):
        _arm(PR2, "left", name="middle")
    with pytest.raises(RobotDescriptionError, match="reflection"):
        mirrored = ((0.0, 1.0, 0.0), (1.0, 0.0, 0.0), (0.0, 0.0, 1.0))
        _arm(PR2, "left", standard_to_tool=mirrored)
    with pytest.raises(RobotDescriptionError, match="one or two arms"):
        dataclasses.replace(PR2, arms=())
    with pytest.raises(RobotDescriptionError, match="has 6 values for 7 joints"):
        left = PR2.arm("left")
        _arm(PR2, "left", states={**left.states, "carry": left.state("carry")[:6]})


def test_a_misfit_stops_before_the_robot_is_loaded(client: int) -> None:
    bad = _arm(PR2, "left", tool_frame="l_tool")
    with pytest.raises(RobotDescriptionError):
        load_robot(bad, client)
    assert pb.getNumBodies(physicsClientId=client) == 0


def test_the_urdfs_name_is_the_robots_name() -> None:
    e = _error(dataclasses.replace(PR2, name="pr3"))
    assert e.field == "name" and "'pr2'" in str(e)


def test_load_robot_puts_the_robot_in_its_initial_state(client: int) -> None:
    robot = load_robot(PR2, client, base=(1.0, -0.5, math.pi / 2))
    for arm in PR2.arms:
        assert robot.joint_values(arm.joints) == pytest.approx(arm.state("park"), abs=1e-9)
        fingers = robot.joint_values(arm.gripper.joints)
        assert fingers == pytest.approx((arm.gripper.open_position,) * 2)
    assert robot.joint_values((PR2.torso.joint,)) == pytest.approx((PR2.torso.default,))
    pos, orn = robot.link_pose(PR2.base_frame)
    assert pos == pytest.approx((1.0, -0.5, 0.0), abs=1e-9)
    assert pb.getEulerFromQuaternion(orn)[2] == pytest.approx(math.pi / 2)
    assert isinstance(PR2.arm("left"), ArmDescription)


def test_a_document_that_is_not_one_urdf_tree_is_refused() -> None:
    with pytest.raises(ValueError, match="not a URDF document"):
        KinematicTree.from_urdf("<sdf/>")
    two_roots = '<robot name="r"><link name="a"/><link name="b"/></robot>'
    with pytest.raises(ValueError, match="exactly one root link"):
        KinematicTree.from_urdf(two_roots)
    orphan = (
        '<robot name="r"><link name="a"/><joint name="j" type="fixed">'
        '<parent link="a"/><child link="missing"/></joint></robot>'
    )
    with pytest.raises(ValueError, match="unknown link 'missing'"):
        KinematicTree.from_urdf(orphan)
