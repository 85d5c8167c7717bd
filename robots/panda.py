"""A mobile Franka Panda: pybullet_data's ``franka_panda/panda.urdf`` (the arm, its hand and
its parallel gripper, with the shipped meshes; Apache-2.0, installed with pybullet) mounted
on a holonomic base with a torso lift and a pan-tilt camera mast, as a
:class:`executive.RobotDescription`.

:func:`urdf_text` generates the combined URDF: the shipped file's links and joints
unchanged (mesh paths made absolute, so the file loads from anywhere), plus

- ``base_footprint`` (the root on the floor, moved by the world: x, y, yaw, as the PR2-like
  robot's base) and ``base_link``, a 0.60 x 0.60 x 0.30 box with a fixed inner column;
- ``torso_lift_joint``: prismatic, 0..0.40 m, lifting ``torso_lift_link`` (a sleeve over the
  column) whose origin is 0.60 m over the floor at 0, 0.12 m ahead of the base's centre;
- ``arm_mount_joint``: fixed, ``panda_link0`` on the torso's origin, facing forward;
- a mast on the torso 0.30 m behind the arm: ``head_pan_joint`` (yaw) 0.55 m over the torso,
  ``head_tilt_joint`` (pitch), a camera box and ``camera_optical_frame`` (z forward, x
  right, y down): 1.20 m over the floor at torso 0, 1.60 m at 0.40.

Collision shapes: the shipped collision meshes are single-group OBJs, each of which PyBullet
turns into one convex hull; the added parts are boxes.

The generated file is written once per content into :func:`robots._urdf_tools.cache_dir`
when the robot is loaded (``DESCRIPTION.urdf()``), never committed.

Deliberate difference from CRAM: CRAM has no mobile Panda (PyCRAM's Panda is a fixed arm
with MuJoCo Menagerie names); this one keeps pybullet_data's ``panda_*`` names and its tool
frame ``panda_grasptarget`` (0.105 m ahead of the hand, between the finger pads).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path

from executive import (
    ArmDescription,
    CameraDescription,
    GripperDescription,
    NeckDescription,
    Reach,
    RobotDescription,
    TorsoDescription,
)

from ._urdf_tools import absolute_meshes, element, write_cached

__all__ = [
    "ARM_JOINTS",
    "DESCRIPTION",
    "STANDARD_TO_TOOL",
    "TORSO_RANGE",
    "shipped_urdf",
    "urdf_path",
    "urdf_text",
]

#: The Panda's 7 arm joints, root to tip (pybullet_data's names).
ARM_JOINTS = tuple(f"panda_joint{i}" for i in range(1, 8))
#: The hand approaches along its z axis and its fingers move along its y axis: the standard
#: gripper (z approach, x finger to finger) is the hand frame turned by -90 degrees about z.
STANDARD_TO_TOOL = ((0.0, 1.0, 0.0), (-1.0, 0.0, 0.0), (0.0, 0.0, 1.0))
TORSO_RANGE = (0.0, 0.40)

_BASE_SIZE = (0.60, 0.60, 0.30)
_BASE_LINK_Z = 0.051  # base_link over base_footprint (as the PR2-like robot)
_TORSO_XYZ = (0.12, 0.0, 0.60 - _BASE_LINK_Z)  # torso origin in base_link at torso 0
_MAST_X = -0.30  # mast behind the arm, in the torso frame
_PAN_Z = 0.55  # pan joint over the torso origin
_CAMERA_XYZ = (0.05, 0.0, 0.05)  # camera in the tilt link
_DARK = "0.2 0.2 0.22 1"
_GREY = "0.55 0.55 0.6 1"


def shipped_urdf() -> Path:
    """pybullet_data's Panda URDF (its meshes next to it); not installed -> an error
    naming what to install."""
    try:
        import pybullet_data
    except ImportError as e:  # pragma: no cover - pybullet is a dependency
        raise FileNotFoundError(
            "the Panda's URDF ships with pybullet (pybullet_data): pip install pybullet"
        ) from e
    path = Path(pybullet_data.getDataPath()) / "franka_panda" / "panda.urdf"
    if not path.is_file():
        raise FileNotFoundError(f"pybullet_data has no franka_panda/panda.urdf at {path}")
    return path


def _v(values: tuple[float, ...]) -> str:
    return " ".join(format(v, ".6g") for v in values)


def _box_link(
    name: str, size: tuple[float, ...], xyz: tuple[float, ...], rgba: str, mass: float
) -> ET.Element:
    link = element("link", name=name)
    inertial = ET.SubElement(link, "inertial")
    ET.SubElement(inertial, "origin", xyz="0 0 0", rpy="0 0 0")
    ET.SubElement(inertial, "mass", value=format(mass, ".6g"))
    x, y, z = size
    ET.SubElement(
        inertial,
        "inertia",
        ixx=format(mass * (y * y + z * z) / 12, ".6g"),
        ixy="0",
        ixz="0",
        iyy=format(mass * (x * x + z * z) / 12, ".6g"),
        iyz="0",
        izz=format(mass * (x * x + y * y) / 12, ".6g"),
    )
    for tag in ("visual", "collision"):
        el = ET.SubElement(link, tag)
        ET.SubElement(el, "origin", xyz=_v(xyz), rpy="0 0 0")
        geometry = ET.SubElement(el, "geometry")
        ET.SubElement(geometry, "box", size=_v(size))
        if tag == "visual":
            material = ET.SubElement(el, "material", name=f"{name}_c")
            ET.SubElement(material, "color", rgba=rgba)
    return link


def _frame_link(name: str) -> ET.Element:
    link = element("link", name=name)
    inertial = ET.SubElement(link, "inertial")
    ET.SubElement(inertial, "mass", value="0.01")
    ET.SubElement(
        inertial, "inertia", ixx="1e-6", ixy="0", ixz="0", iyy="1e-6", iyz="0", izz="1e-6"
    )
    return link


def _joint(
    name: str,
    kind: str,
    parent: str,
    child: str,
    xyz: tuple[float, ...] = (0.0, 0.0, 0.0),
    rpy: tuple[float, ...] = (0.0, 0.0, 0.0),
    axis: tuple[float, ...] | None = None,
    limits: tuple[float, float, float, float] | None = None,  # lower, upper, effort, velocity
) -> ET.Element:
    joint = element("joint", name=name, type=kind)
    ET.SubElement(joint, "origin", xyz=_v(xyz), rpy=_v(rpy))
    ET.SubElement(joint, "parent", link=parent)
    ET.SubElement(joint, "child", link=child)
    if axis is not None:
        ET.SubElement(joint, "axis", xyz=_v(axis))
    if limits is not None:
        lo, hi, effort, velocity = limits
        ET.SubElement(
            joint,
            "limit",
            lower=_v((lo,)),
            upper=_v((hi,)),
            effort=_v((effort,)),
            velocity=_v((velocity,)),
        )
    return joint


def urdf_text() -> str:
    """The mobile Panda's URDF (see the module docstring), mesh paths absolute."""
    shipped = shipped_urdf()
    arm = ET.parse(shipped).getroot()
    absolute_meshes(arm, shipped.parent)
    robot = element("robot", name="panda")
    robot.append(ET.Comment(" generated by robots.panda from pybullet_data's franka_panda "))
    column_h = 0.60 - 0.32  # from the base's top to the torso origin at torso 0
    parts = [
        _frame_link("base_footprint"),
        _box_link(
            "base_link",
            _BASE_SIZE,
            (0.0, 0.0, 0.17 - _BASE_LINK_Z),
            _DARK,
            50.0,
        ),
        _box_link("base_column_link", (0.12, 0.12, column_h), (0.0, 0.0, column_h / 2), _GREY, 5.0),
        _box_link("torso_lift_link", (0.16, 0.16, 0.30), (0.0, 0.0, -0.17), _GREY, 10.0),
        _box_link("mast_link", (0.05, 0.05, _PAN_Z), (0.0, 0.0, _PAN_Z / 2), _GREY, 1.0),
        _frame_link("head_pan_link"),
        _box_link("head_tilt_link", (0.06, 0.16, 0.06), (0.02, 0.0, 0.05), _DARK, 0.5),
        _frame_link("camera_link"),
        _frame_link("camera_optical_frame"),
        _joint(
            "base_footprint_joint", "fixed", "base_footprint", "base_link", (0, 0, _BASE_LINK_Z)
        ),
        _joint(
            "base_column_joint",
            "fixed",
            "base_link",
            "base_column_link",
            (_TORSO_XYZ[0], 0.0, 0.32 - _BASE_LINK_Z),
        ),
        _joint(
            "torso_lift_joint",
            "prismatic",
            "base_link",
            "torso_lift_link",
            _TORSO_XYZ,
            axis=(0.0, 0.0, 1.0),
            limits=(*TORSO_RANGE, 1000.0, 0.1),
        ),
        _joint("arm_mount_joint", "fixed", "torso_lift_link", "panda_link0"),
        _joint("mast_joint", "fixed", "torso_lift_link", "mast_link", (_MAST_X, 0.0, 0.0)),
        _joint(
            "head_pan_joint",
            "revolute",
            "mast_link",
            "head_pan_link",
            (0.0, 0.0, _PAN_Z),
            axis=(0.0, 0.0, 1.0),
            limits=(-2.8, 2.8, 10.0, 1.0),
        ),
        _joint(
            "head_tilt_joint",
            "revolute",
            "head_pan_link",
            "head_tilt_link",
            axis=(0.0, 1.0, 0.0),
            limits=(-0.5, 1.4, 10.0, 1.0),
        ),
        _joint("camera_joint", "fixed", "head_tilt_link", "camera_link", _CAMERA_XYZ),
        _joint(
            "camera_optical_joint",
            "fixed",
            "camera_link",
            "camera_optical_frame",
            rpy=(-math.pi / 2, 0.0, -math.pi / 2),
        ),
    ]
    robot.extend(parts)
    robot.extend(el for el in arm if el.tag in ("link", "joint"))
    ET.indent(robot)
    return '<?xml version="1.0"?>\n' + ET.tostring(robot, encoding="unicode") + "\n"


def urdf_path() -> Path:
    """Generate the URDF (once per content) and return its path."""
    return write_cached(urdf_text(), "panda")


DESCRIPTION = RobotDescription(
    name="panda",
    urdf=urdf_path,
    base_frame="base_footprint",
    base_link="base_link",
    arms=(
        ArmDescription(
            name="left",  # CRAM's name for a one-armed robot's arm
            joints=ARM_JOINTS,
            tool_frame="panda_grasptarget",
            hand_link="panda_hand",
            standard_to_tool=STANDARD_TO_TOOL,
            gripper=GripperDescription(
                joints=("panda_finger_joint1", "panda_finger_joint2"),
                max_opening=0.08,  # 0.04 m per finger
                open_position=0.04,
                closed_position=0.0,
                effort=20.0,  # the URDF's finger effort limit (N)
            ),
            # pybullet_data's Panda reaches 0.95 m from its joint1 axis (sampled); scaled
            # like the PR2-like robot's 0.7 m of its ~0.95 m, from a mount 0.12 m ahead
            reach=Reach(in_reach_distance=0.8, minimal_distance=0.2),
            states={
                # folded over the base, the hand down in front of the torso
                "park": (0.0, -1.76, 0.0, -3.0, 0.0, 1.5, 0.785),
                # a held object in front of the torso, hand level
                "carry": (0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785),
            },
        ),
    ),
    torso=TorsoDescription(joint="torso_lift_joint", lower=0.0, upper=0.40, default=0.20),
    neck=NeckDescription(
        pan_joint="head_pan_joint",
        tilt_joint="head_tilt_joint",
        camera=CameraDescription(
            frame="camera_optical_frame",
            vertical_fov=math.radians(50.0),
            horizontal_fov=2.0 * math.atan(320.0 / 200.0 * math.tan(math.radians(25.0))),
        ),
        states={"forward": (0.0, 0.0)},
    ),
)
