"""The third robot of the tests: pybullet_data's xArm6 with its gripper on
:mod:`robots.mobile_base`, described the way docs/robots.md teaches a user (a TCP link
0.16 m ahead of the gripper base; six arm joints; six gripper joints that close at the
larger value). One builder for every test that needs it (``from tests.xarm_robot import
xarm_description``)."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path

import pybullet_data

from executive import (
    ArmDescription,
    CameraDescription,
    GripperDescription,
    NeckDescription,
    Reach,
    RobotDescription,
    TorsoDescription,
)
from robots import mobile_base

__all__ = ["GRIPPER", "JOINTS", "SHIPPED", "xarm_description", "xarm_urdf"]

SHIPPED = Path(pybullet_data.getDataPath()) / "xarm" / "xarm6_with_gripper.urdf"
JOINTS = ("joint1", "joint2", "joint3", "joint4", "joint5", "joint6")
GRIPPER = (
    "drive_joint",
    "left_finger_joint",
    "left_inner_knuckle_joint",
    "right_outer_knuckle_joint",
    "right_finger_joint",
    "right_inner_knuckle_joint",
)


def xarm_urdf(directory: Path) -> Path:
    """What a user does: their arm on the mobile base, plus the tool frame the shipped URDF
    lacks (0.16 m ahead of the gripper base, between the finger pads); written into
    ``directory``."""
    tcp = ET.Element("link", name="xarm_tcp")
    joint = ET.Element("joint", name="xarm_tcp_joint", type="fixed")
    ET.SubElement(joint, "origin", xyz="0 0 0.16", rpy="0 0 0")
    ET.SubElement(joint, "parent", link="xarm_gripper_base_link")
    ET.SubElement(joint, "child", link="xarm_tcp")
    path = directory / "xarm6.urdf"
    path.write_text(mobile_base.mount_arm("xarm6", SHIPPED, "world", (tcp, joint)))
    return path


def xarm_description(directory: Path, **arm_changes: object) -> RobotDescription:
    """docs/robots.md's xArm6 (its URDF written into ``directory``); ``arm_changes``
    replace fields of its one arm (for the error tests)."""
    path = xarm_urdf(directory)
    fields: dict[str, object] = {
        "name": "left",  # CRAM's name for a one-armed robot's arm
        "joints": JOINTS,
        "tool_frame": "xarm_tcp",
        "hand_link": "xarm_gripper_base_link",  # a held object hangs from it
        "standard_to_tool": ((0.0, 1.0, 0.0), (-1.0, 0.0, 0.0), (0.0, 0.0, 1.0)),
        "gripper": GripperDescription(
            joints=GRIPPER, max_opening=0.085, open_position=0.0, closed_position=0.85, effort=50.0
        ),
        "reach": Reach(in_reach_distance=0.75, minimal_distance=0.2),
        "states": {
            # folded up and back over the base, out of the camera's view
            "park": (0.0, -1.75, -1.4, 0.0, 0.5, 0.0),
            # the hand over the front of the base, pointing forward, above the camera's
            # lines of sight to the counters
            "carry": (0.0, -1.5, -0.9, 0.0, 0.8, 0.0),
        },
    }
    fields.update(arm_changes)
    return RobotDescription(
        name="xarm6",  # the URDF's <robot name>
        urdf=lambda: path,
        base_frame="base_footprint",
        base_link="base_link",
        arms=(ArmDescription(**fields),),  # type: ignore[arg-type]
        torso=TorsoDescription(mobile_base.TORSO_JOINT, *mobile_base.TORSO_RANGE, default=0.2),
        neck=NeckDescription(
            *mobile_base.NECK_JOINTS,
            camera=CameraDescription(
                mobile_base.CAMERA_FRAME, math.radians(45.0), math.radians(60.0)
            ),
            states={"forward": (0.0, 0.0)},
        ),
    )
