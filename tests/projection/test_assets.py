"""The shipped URDFs equal the generator's output and load in PyBullet."""

from __future__ import annotations

from collections.abc import Iterator

import pybullet as pb
import pytest

from projection import _urdf
from projection._objects import OBJECT_TYPES


@pytest.fixture()
def client() -> Iterator[int]:
    cid = pb.connect(pb.DIRECT)
    yield cid
    pb.disconnect(physicsClientId=cid)


def test_shipped_files_equal_generator_output() -> None:
    generated = _urdf.generate()
    assert set(generated) >= {"pr2.urdf", "kitchen.urdf"}
    for rel, text in generated.items():
        shipped = (_urdf.ASSET_DIR / rel).read_text(encoding="utf-8")
        assert shipped == text, f"{rel} is stale: run python -m projection._urdf"


def _names(body: int, cid: int) -> tuple[set[str], set[str]]:
    links, joints = set(), set()
    for i in range(pb.getNumJoints(body, physicsClientId=cid)):
        info = pb.getJointInfo(body, i, physicsClientId=cid)
        joints.add(info[1].decode())
        links.add(info[12].decode())
    return links, joints


def test_robot_has_pr2_names_and_limits(client: int) -> None:
    body = pb.loadURDF(str(_urdf.ASSET_DIR / "pr2.urdf"), useFixedBase=True, physicsClientId=client)
    links, joints = _names(body, client)
    assert pb.getBodyInfo(body, physicsClientId=client)[0].decode() == "base_footprint"
    for side in "lr":
        for j in (
            "shoulder_pan",
            "shoulder_lift",
            "upper_arm_roll",
            "elbow_flex",
            "forearm_roll",
            "wrist_flex",
            "wrist_roll",
        ):
            assert f"{side}_{j}_joint" in joints and f"{side}_{j}_link" in links
        assert {f"{side}_gripper_palm_link", f"{side}_gripper_tool_frame"} <= links
        assert {f"{side}_gripper_l_finger_joint", f"{side}_gripper_r_finger_joint"} <= joints
    assert {
        "base_link",
        "torso_lift_link",
        "head_pan_link",
        "head_tilt_link",
        "head_mount_kinect_rgb_optical_frame",
    } <= links
    index = {
        pb.getJointInfo(body, i, physicsClientId=client)[1].decode(): i
        for i in range(pb.getNumJoints(body, physicsClientId=client))
    }
    torso = pb.getJointInfo(body, index["torso_lift_joint"], physicsClientId=client)
    assert torso[2] == pb.JOINT_PRISMATIC and (torso[8], torso[9]) == (0.0, 0.33)
    lo, hi = pb.getAABB(body, 0, physicsClientId=client)  # base_link
    assert hi[0] - lo[0] == pytest.approx(0.65, abs=0.01)
    assert hi[2] - lo[2] == pytest.approx(0.30, abs=0.01)


def test_kitchen_names_and_drawer_joint(client: int) -> None:
    body = pb.loadURDF(
        str(_urdf.ASSET_DIR / "kitchen.urdf"), useFixedBase=True, physicsClientId=client
    )
    links, joints = _names(body, client)
    assert {
        "sink_area",
        "sink_area_surface",
        "sink_area_left_upper_drawer_main",
        "sink_area_left_upper_drawer_handle",
        "kitchen_island",
        "kitchen_island_surface",
    } <= links
    assert "sink_area_left_upper_drawer_main_joint" in joints


@pytest.mark.parametrize("name", sorted(OBJECT_TYPES))
def test_object_urdf_matches_type_size(client: int, name: str) -> None:
    t = OBJECT_TYPES[name]
    body = pb.loadURDF(str(_urdf.ASSET_DIR / "objects" / t.urdf_name), physicsClientId=client)
    lo, hi = pb.getAABB(body, -1, physicsClientId=client)
    for i in range(3):  # PyBullet pads AABBs by a small margin
        assert hi[i] - lo[i] == pytest.approx(t.size[i], abs=0.02)
    assert pb.getDynamicsInfo(body, -1, physicsClientId=client)[0] == pytest.approx(t.mass)
    assert t.grasps  # every type has grasp knowledge
