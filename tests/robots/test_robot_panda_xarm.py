"""The mobile Panda from pybullet_data's URDF, a third robot described as a user would
(pybullet_data's xArm6 with its gripper on the same base), and ``aiocram robot check``."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pybullet as pb
import pybullet_data
import pytest
from PIL import Image

from aiocram.cli import main
from aiocram.robot_check import RobotCheckFailed, check_robot
from executive import (
    GripperDescription,
    KinematicTree,
    RobotDescriptionError,
)
from projection import kinematic_tree, load_robot
from robots import panda
from tests.xarm_robot import GRIPPER as XARM_GRIPPER
from tests.xarm_robot import xarm_description

PANDA = panda.DESCRIPTION


@pytest.fixture(autouse=True)
def _cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("AIOCRAM_ROBOT_CACHE", str(tmp_path / "cache"))


@pytest.fixture
def client():
    c = pb.connect(pb.DIRECT)
    yield c
    pb.disconnect(physicsClientId=c)


def test_the_generated_urdf_refers_to_the_shipped_meshes() -> None:
    path = PANDA.urdf()
    meshes = [m.get("filename") for m in ET.parse(path).getroot().iter("mesh")]
    assert meshes and all(m is not None and Path(m).is_absolute() for m in meshes)
    shipped = Path(pybullet_data.getDataPath()) / "franka_panda"
    assert all(Path(str(m)).is_file() and shipped in Path(str(m)).parents for m in meshes)
    assert PANDA.urdf() == path  # written once per content


def test_the_panda_loads_and_each_chain_moves(client: int) -> None:
    robot = load_robot(PANDA, client, base=(0.5, 0.2, 0.3))
    tree = kinematic_tree(client, robot.body)
    assert tree == KinematicTree.from_urdf(PANDA.urdf())
    (arm,) = PANDA.arms
    assert arm.name == "left" and len(arm.joints) == 7
    # the arm: a pose reached by forward kinematics is reached again by IK from park
    robot.set_joints(dict(zip(arm.joints, arm.state("carry"))))
    goal_pos, goal_orn = robot.link_pose(arm.tool_frame)
    robot.set_state("park")
    tip = robot.link_index[arm.tool_frame]
    movable = [
        i
        for i in range(pb.getNumJoints(robot.body))
        if pb.getJointInfo(robot.body, i)[2] != pb.JOINT_FIXED
    ]
    names = [pb.getJointInfo(robot.body, i)[1].decode() for i in movable]
    # only the arm's joints move: the torso and neck are frozen by a huge damping
    damping = [0.01 if n in arm.joints else 1e6 for n in names]
    for _ in range(50):
        q = pb.calculateInverseKinematics(
            robot.body,
            tip,
            goal_pos,
            goal_orn,
            jointDamping=damping,
            maxNumIterations=200,
            physicsClientId=client,
        )
        for i, v in zip(movable, q):
            name = pb.getJointInfo(robot.body, i)[1].decode()
            if name in arm.joints:
                robot.set_joints({name: v})
        if math.dist(robot.link_pose(arm.tool_frame)[0], goal_pos) < 1e-3:
            break
    assert math.dist(robot.link_pose(arm.tool_frame)[0], goal_pos) < 1e-3
    # the torso lifts the arm by exactly its stroke
    low = robot.link_pose("panda_link0")[0][2]
    robot.set_torso(PANDA.torso.upper)
    robot_high = robot.link_pose("panda_link0")[0][2]
    robot.set_torso(PANDA.torso.lower)
    assert robot_high - robot.link_pose("panda_link0")[0][2] == pytest.approx(0.40)
    assert low > 0.0
    # the neck pans the camera's view about the vertical, with the base's heading
    robot.set_neck(0.5, 0.0)
    rot = np.array(pb.getMatrixFromQuaternion(robot.link_pose(PANDA.neck.camera.frame)[1])).reshape(
        3, 3
    )
    assert math.atan2(rot[1, 2], rot[0, 2]) == pytest.approx(0.3 + 0.5, abs=1e-5)
    # the gripper opens to 0.08 m between the finger frames and closes to 0
    fingers = [tree.joints[j].child for j in arm.gripper.joints]
    for opening in (0.0, 0.05, 0.08):
        robot.set_gripper("left", opening)
        a, b = (robot.link_pose(f)[0] for f in fingers)
        assert math.dist(a, b) == pytest.approx(opening, abs=1e-6)
    with pytest.raises(ValueError, match=r"0 to 0\.08"):
        robot.set_gripper("left", 0.1)


def test_the_pandas_named_states_keep_the_arm_over_the_base_and_clear_of_it(
    client: int,
) -> None:
    robot = load_robot(PANDA, client)
    (arm,) = PANDA.arms
    tree = kinematic_tree(client, robot.body)
    shoulder = tree.joints[arm.joints[0]].child
    moving = {i for name, i in robot.link_index.items() if tree.is_below(name, shoulder)}
    assert len(moving) == 12  # link1..7, link8, hand, two fingers, grasp target
    body = robot.body
    half = 0.30  # the base box's half width
    for torso in (PANDA.torso.lower, PANDA.torso.upper):
        robot.set_torso(torso)
        for state in arm.states:
            robot.set_state(state)
            x, y, _ = robot.link_pose(arm.tool_frame)[0]
            assert abs(x) < half and abs(y) < half, (state, x, y)
            hits = [
                (c[3], c[4])
                for c in pb.getClosestPoints(body, body, 0.0, physicsClientId=client)
                if c[8] < -0.002 and ((c[3] in moving) != (c[4] in moving))
            ]
            assert not hits, (state, torso, hits)


def test_the_panda_renders_and_checks(tmp_path: Path) -> None:
    lines: list[str] = []
    png = tmp_path / "panda.png"
    check_robot(PANDA, png, lines.append)
    assert lines[0].startswith("robot panda: description fits its URDF")
    assert any("opening 0..0.080 m moves the finger links 0.000..0.080 m apart" in x for x in lines)
    pixels = np.asarray(Image.open(png).convert("RGB"), dtype=float)
    assert pixels.shape == (240, 320, 3) and pixels.std() > 10.0


def test_the_panda_collision_shapes_are_convex_meshes(client: int) -> None:
    robot = load_robot(PANDA, client)
    for link in ("panda_link3", "panda_hand"):
        shapes = pb.getCollisionShapeData(
            robot.body, robot.link_index[link], physicsClientId=client
        )
        assert shapes and all(s[2] == pb.GEOM_MESH for s in shapes)


# ------------------------------------------------------------------------ a third robot


def test_a_third_robot_from_another_shipped_urdf(tmp_path: Path, client: int) -> None:
    xarm = xarm_description(tmp_path)
    robot = load_robot(xarm, client)
    (arm,) = xarm.arms
    assert len(arm.joints) == 6 and len(arm.gripper.joints) == 6
    # closing drives every gripper joint to the closed value (mimic joints set explicitly)
    robot.set_gripper("left", 0.0)
    assert robot.joint_values(arm.gripper.joints) == pytest.approx((0.85,) * 6)
    lines: list[str] = []
    check_robot(xarm, tmp_path / "xarm.png", lines.append)
    assert lines[0].startswith("robot xarm6: description fits its URDF")
    assert any(x.startswith("arm left: 6 joints each move xarm_tcp") for x in lines)
    assert any(x.startswith("gripper left: 6 joints") for x in lines)


def test_the_third_robots_errors(tmp_path: Path, client: int) -> None:
    six = ("joint1", "joint2", "joint3", "joint4", "joint5", "joint7")
    with pytest.raises(RobotDescriptionError) as info:
        load_robot(xarm_description(tmp_path, joints=six), client)
    assert info.value.field == "arms['left'].joints[5]" and "no joint 'joint7'" in str(info.value)
    with pytest.raises(RobotDescriptionError) as info:
        load_robot(xarm_description(tmp_path, tool_frame="link5"), client)
    assert info.value.field == "arms['left'].tool_frame"
    assert "not rigidly attached" in str(info.value)
    assert pb.getNumBodies(physicsClientId=client) == 0


def test_a_check_that_fails_says_so(tmp_path: Path) -> None:
    # an opening whose joint values close the gripper as it "opens"
    xarm = xarm_description(
        tmp_path, gripper=GripperDescription(XARM_GRIPPER, 0.085, 0.85, 0.0, 50.0)
    )
    with pytest.raises(RobotCheckFailed, match="does not move its fingers apart"):
        check_robot(xarm, None, lambda line: None)


def test_the_command_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    png = tmp_path / "pr2.png"
    assert main(["robot", "check", "robots.pr2", "--png", str(png)]) == 0
    out = capsys.readouterr().out
    assert "robot pr2: description fits its URDF" in out and png.is_file()
    assert main(["robot", "check", "robots"]) == 2
    err = capsys.readouterr().err
    assert "robots.DESCRIPTION is not an executive.RobotDescription" in err
