"""A holonomic mobile base with a torso lift and a pan-tilt camera mast, onto which
:func:`mount_arm` mounts an arm from its own URDF (the arm's links, joints and meshes
unchanged, mesh paths made absolute): how :mod:`robots.panda` is built, and how a user
puts their own arm on a base (docs/robots.md).

The base and mast:

- ``base_footprint`` (the root on the floor, moved by the world: x, y, yaw, as the PR2-like
  robot's base) and ``base_link``, a 0.60 x 0.60 x 0.30 box with a fixed inner column;
- ``torso_lift_joint``: prismatic, 0..0.40 m (:data:`TORSO_RANGE`), lifting
  ``torso_lift_link`` (a sleeve over the column) whose origin is 0.60 m over the floor at 0,
  0.12 m ahead of the base's centre;
- ``arm_mount_joint``: fixed, the arm's root link on the torso's origin, facing forward;
- a mast on the torso 0.10 m behind and 0.22 m to the right of the arm's base (clear of
  an arm folded back): ``head_pan_joint`` (yaw) 0.55 m over the torso,
  ``head_tilt_joint`` (pitch), a camera box and ``camera_optical_frame`` (z forward, x
  right, y down): 1.20 m over the floor at torso 0, 1.60 m at 0.40.

The added parts are boxes (convex collision shapes).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from pathlib import Path

from ._urdf_tools import absolute_meshes, element

__all__ = ["CAMERA_FRAME", "NECK_JOINTS", "TORSO_JOINT", "TORSO_RANGE", "mount_arm"]

TORSO_JOINT = "torso_lift_joint"
TORSO_RANGE = (0.0, 0.40)
NECK_JOINTS = ("head_pan_joint", "head_tilt_joint")
CAMERA_FRAME = "camera_optical_frame"
_BASE_SIZE = (0.60, 0.60, 0.30)
_BASE_LINK_Z = 0.051  # base_link over base_footprint (as the PR2-like robot)
_TORSO_XYZ = (0.12, 0.0, 0.60 - _BASE_LINK_Z)  # torso origin in base_link at torso 0
#: the mast in the torso frame: behind the arm's base and to its right, so that an arm
#: folded back (elbow behind the shoulder) clears it, and the camera sees past the arm
_MAST_XY = (-0.10, -0.22)
_PAN_Z = 0.55  # pan joint over the torso origin
_CAMERA_XYZ = (0.05, 0.0, 0.05)  # camera in the tilt link
_DARK = "0.2 0.2 0.22 1"
_GREY = "0.55 0.55 0.6 1"


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


def mount_arm(name: str, arm_urdf: Path, arm_root: str, extra: Sequence[ET.Element] = ()) -> str:
    """A URDF named ``name``: the base, torso lift and camera mast of the module docstring
    with the links and joints of ``arm_urdf`` (mesh paths made absolute) mounted by their
    root link ``arm_root`` on the torso's origin, facing forward, plus the ``extra``
    ``<link>``/``<joint>`` elements (e.g. a tool frame the arm's URDF lacks)."""
    arm = ET.parse(arm_urdf).getroot()
    absolute_meshes(arm, arm_urdf.parent)
    links = {str(el.get("name")) for el in arm.findall("link")}
    if arm_root not in links:
        raise ValueError(
            f"{arm_urdf} has no link {arm_root!r} to mount; its links: {sorted(links)}"
        )
    robot = element("robot", name=name)
    robot.append(ET.Comment(f" generated by robots.mobile_base from {arm_urdf.name} "))
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
        _joint("arm_mount_joint", "fixed", "torso_lift_link", arm_root),
        _joint("mast_joint", "fixed", "torso_lift_link", "mast_link", (*_MAST_XY, 0.0)),
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
    robot.extend(extra)
    ET.indent(robot)
    return '<?xml version="1.0"?>\n' + ET.tostring(robot, encoding="unicode") + "\n"
