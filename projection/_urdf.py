"""Parameter tables -> URDF XML for the PR2-like robot, the kitchen and the household
objects. Primitive shapes only (boxes, cylinders): nothing is downloaded.

``python -m projection._urdf`` regenerates ``projection/assets/``; a test asserts the
shipped files equal :func:`generate`'s output. The numbers below are the contract the
world code relies on (camera geometry for ``look_at``, kitchen layout for the demo).

Robot (PR2 names, approximate PR2 dimensions): ``base_footprint`` on the floor;
``base_link`` a 0.65 x 0.65 x 0.30 box (0.02..0.32 m above the floor); ``torso_lift_link``
at (-0.05, 0, 0.7907) + the prismatic ``torso_lift_joint`` (0..0.33 m); shoulders at
y = ±0.188 in the torso frame, ``shoulder_lift`` 0.1 m ahead of the pan axis, upper arm
0.4 m, forearm 0.321 m, ``?_gripper_tool_frame`` 0.18 m past ``?_wrist_roll_link``;
the forearm and wrist roll joints are **continuous** (endless, as on the PR2); fingers
are **prismatic** ``?_gripper_l/r_finger_joint`` 0..0.05 m each (opening = 2 q,
0..0.10 m, CRAM's usual opening). Camera ``head_mount_kinect_rgb_optical_frame`` (z
forward, x right, y down) is 1.27 m above the floor at torso 0 and 1.60 m at 0.33.

Kitchen (map frame, fixed base, origin = map origin), after the IAI kitchen:
``sink_area`` cabinet x 1.12..1.90, y -0.65..1.25 with ``sink_area_surface`` (counter top,
z 0.82..0.85) on it; the hollow drawer ``sink_area_left_upper_drawer_main`` (x 1.12..1.70,
y 0.80..1.20, bottom top at z 0.7335) on the prismatic
``sink_area_left_upper_drawer_main_joint`` opening along -x (0..0.48 m) with its handle;
``kitchen_island`` x -1.20..-0.55, y 0.40..2.40 with ``kitchen_island_surface`` (top
0.85); four walls ``kitchen_wall_{east,west,south,north}`` as separate links (so a
costmap built from link AABBs does not cover the room). Link origins are the centres of
their boxes.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType

from kitchens import iai as kitchen
from projection._objects import OBJECT_TYPES, ObjectType, Shape

__all__ = [
    "ASSET_DIR",
    "CAMERA_XYZ",
    "HEAD_PAN_XYZ",
    "HEAD_TILT_XYZ",
    "KITCHEN_BOXES",
    "Joint",
    "Link",
    "generate",
    "kitchen_urdf",
    "main",
    "object_urdf",
    "robot_urdf",
    "write",
]

Vec3 = tuple[float, float, float]

ASSET_DIR = Path(__file__).resolve().parent / "assets"


@dataclass(frozen=True)
class Link:
    name: str
    shapes: tuple[Shape, ...] = ()
    mass: float = 0.1
    rgba: tuple[float, float, float, float] = (0.6, 0.6, 0.6, 1.0)


@dataclass(frozen=True)
class Joint:
    name: str
    kind: str  # fixed | revolute | prismatic | continuous (no lower/upper: endless)
    parent: str
    child: str
    xyz: Vec3 = (0.0, 0.0, 0.0)
    rpy: Vec3 = (0.0, 0.0, 0.0)
    axis: Vec3 = (0.0, 0.0, 1.0)
    lower: float = 0.0
    upper: float = 0.0


# ------------------------------------------------------------------------ XML writer
def _f(v: float) -> str:
    s = format(float(v), ".6g")
    return "0" if s == "-0" else s


def _v(vs: Sequence[float]) -> str:
    return " ".join(_f(v) for v in vs)


def _geometry(s: Shape) -> str:
    if s.kind == "box":
        return f'<box size="{_v(s.size)}"/>'
    if s.kind == "cylinder":
        return f'<cylinder radius="{_f(s.size[0])}" length="{_f(s.size[1])}"/>'
    raise ValueError(f"unknown shape kind {s.kind!r}; known: box, cylinder")


def _extent(shapes: Sequence[Shape]) -> Vec3:
    """A rough bounding box size of the shapes (for inertia only)."""
    if not shapes:
        return (0.05, 0.05, 0.05)
    lo = [math.inf] * 3
    hi = [-math.inf] * 3
    for s in shapes:
        half = (
            (s.size[0], s.size[0], s.size[1] / 2)
            if s.kind == "cylinder"
            else tuple(v / 2 for v in s.size)
        )
        r = max(half)
        for i in range(3):
            lo[i] = min(lo[i], s.xyz[i] - r)
            hi[i] = max(hi[i], s.xyz[i] + r)
    return (hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2])


def _link_xml(link: Link) -> str:
    x, y, z = _extent(link.shapes)
    m = link.mass
    ixx, iyy, izz = (m * (y * y + z * z) / 12, m * (x * x + z * z) / 12, m * (x * x + y * y) / 12)
    out = [f'  <link name="{link.name}">']
    out.append(
        f'    <inertial><origin xyz="0 0 0" rpy="0 0 0"/><mass value="{_f(m)}"/>'
        f'<inertia ixx="{_f(ixx)}" ixy="0" ixz="0" iyy="{_f(iyy)}" iyz="0" izz="{_f(izz)}"/>'
        "</inertial>"
    )
    for s in link.shapes:
        origin = f'<origin xyz="{_v(s.xyz)}" rpy="{_v(s.rpy)}"/>'
        out.append(
            f"    <visual>{origin}<geometry>{_geometry(s)}</geometry>"
            f'<material name="{link.name}_c"><color rgba="{_v(link.rgba)}"/></material></visual>'
        )
        out.append(f"    <collision>{origin}<geometry>{_geometry(s)}</geometry></collision>")
    out.append("  </link>")
    return "\n".join(out)


def _joint_xml(j: Joint) -> str:
    out = [f'  <joint name="{j.name}" type="{j.kind}">']
    out.append(f'    <parent link="{j.parent}"/><child link="{j.child}"/>')
    out.append(f'    <origin xyz="{_v(j.xyz)}" rpy="{_v(j.rpy)}"/>')
    if j.kind != "fixed":
        out.append(f'    <axis xyz="{_v(j.axis)}"/>')
        bounds = "" if j.kind == "continuous" else f'lower="{_f(j.lower)}" upper="{_f(j.upper)}" '
        out.append(f'    <limit {bounds}effort="100" velocity="1"/>')
    out.append("  </joint>")
    return "\n".join(out)


def _urdf(name: str, links: Sequence[Link], joints: Sequence[Joint]) -> str:
    parts = ['<?xml version="1.0"?>', "<!-- generated by python -m projection._urdf -->"]
    parts.append(f'<robot name="{name}">')
    parts.extend(_link_xml(link) for link in links)
    parts.extend(_joint_xml(j) for j in joints)
    parts.append("</robot>")
    return "\n".join(parts) + "\n"


# --------------------------------------------------------------------------- robot
BASE_LINK_Z = 0.051
TORSO_XYZ: Vec3 = (-0.05, 0.0, 0.739675)
HEAD_PAN_XYZ: Vec3 = (-0.01707, 0.0, 0.38145)
HEAD_TILT_XYZ: Vec3 = (0.068, 0.0, 0.0)
#: camera (kinect rgb) origin in ``head_tilt_link``: 1.27 m over the floor at torso 0
CAMERA_XYZ: Vec3 = (0.05, 0.0, 0.098)
OPTICAL_RPY: Vec3 = (-math.pi / 2, 0.0, -math.pi / 2)
SHOULDER_Y = 0.188
UPPER_ARM = 0.4
FOREARM = 0.321
TOOL_X = 0.18
FINGER_MAX = 0.05

_GREY = (0.55, 0.55, 0.6, 1.0)
_DARK = (0.2, 0.2, 0.22, 1.0)


def _box(size: Vec3, xyz: Vec3 = (0.0, 0.0, 0.0)) -> Shape:
    return Shape("box", size, xyz)


def _arm(side: str) -> tuple[list[Link], list[Joint]]:
    s = 1.0 if side == "l" else -1.0
    p = f"{side}_"
    pan = (-0.714602, 2.2854) if side == "l" else (-2.2854, 0.714602)
    roll = (-0.8, 3.9) if side == "l" else (-3.9, 0.8)
    links = [
        Link(p + "shoulder_pan_link", (_box((0.16, 0.16, 0.22), (0.02, 0.0, -0.02)),), 2.0, _GREY),
        Link(p + "shoulder_lift_link", (_box((0.09, 0.09, 0.09)),), 1.0, _DARK),
        Link(p + "upper_arm_roll_link", (_box((0.30, 0.09, 0.09), (0.21, 0.0, 0.0)),), 1.5, _GREY),
        Link(p + "elbow_flex_link", (_box((0.07, 0.07, 0.07)),), 0.5, _DARK),
        Link(p + "forearm_roll_link", (_box((0.23, 0.075, 0.07), (0.17, 0.0, 0.0)),), 1.0, _GREY),
        Link(p + "wrist_flex_link", (_box((0.05, 0.05, 0.05)),), 0.3, _DARK),
        Link(p + "wrist_roll_link", (), 0.1),
        Link(p + "gripper_palm_link", (_box((0.09, 0.07, 0.045), (0.065, 0.0, 0.0)),), 0.5, _DARK),
        Link(
            p + "gripper_l_finger_link", (_box((0.09, 0.01, 0.02), (0.0, 0.005, 0.0)),), 0.05, _GREY
        ),
        Link(
            p + "gripper_r_finger_link",
            (_box((0.09, 0.01, 0.02), (0.0, -0.005, 0.0)),),
            0.05,
            _GREY,
        ),
        Link(p + "gripper_tool_frame", (), 0.01),
    ]
    y_axis = (0.0, 1.0, 0.0)
    x_axis = (1.0, 0.0, 0.0)
    joints = [
        Joint(
            p + "shoulder_pan_joint",
            "revolute",
            "torso_lift_link",
            p + "shoulder_pan_link",
            (0.0, s * SHOULDER_Y, 0.0),
            lower=pan[0],
            upper=pan[1],
        ),
        Joint(
            p + "shoulder_lift_joint",
            "revolute",
            p + "shoulder_pan_link",
            p + "shoulder_lift_link",
            (0.1, 0.0, 0.0),
            axis=y_axis,
            lower=-0.5236,
            upper=1.3963,
        ),
        Joint(
            p + "upper_arm_roll_joint",
            "revolute",
            p + "shoulder_lift_link",
            p + "upper_arm_roll_link",
            axis=x_axis,
            lower=roll[0],
            upper=roll[1],
        ),
        Joint(
            p + "elbow_flex_joint",
            "revolute",
            p + "upper_arm_roll_link",
            p + "elbow_flex_link",
            (UPPER_ARM, 0.0, 0.0),
            axis=y_axis,
            lower=-2.3213,
            upper=0.0,
        ),
        Joint(
            p + "forearm_roll_joint",
            "continuous",
            p + "elbow_flex_link",
            p + "forearm_roll_link",
            axis=x_axis,
        ),
        Joint(
            p + "wrist_flex_joint",
            "revolute",
            p + "forearm_roll_link",
            p + "wrist_flex_link",
            (FOREARM, 0.0, 0.0),
            axis=y_axis,
            lower=-2.0943,
            upper=0.0,
        ),
        Joint(
            p + "wrist_roll_joint",
            "continuous",
            p + "wrist_flex_link",
            p + "wrist_roll_link",
            axis=x_axis,
        ),
        Joint(p + "gripper_palm_joint", "fixed", p + "wrist_roll_link", p + "gripper_palm_link"),
        Joint(
            p + "gripper_l_finger_joint",
            "prismatic",
            p + "gripper_palm_link",
            p + "gripper_l_finger_link",
            (0.155, 0.0, 0.0),
            axis=(0.0, 1.0, 0.0),
            lower=0.0,
            upper=FINGER_MAX,
        ),
        Joint(
            p + "gripper_r_finger_joint",
            "prismatic",
            p + "gripper_palm_link",
            p + "gripper_r_finger_link",
            (0.155, 0.0, 0.0),
            axis=(0.0, -1.0, 0.0),
            lower=0.0,
            upper=FINGER_MAX,
        ),
        Joint(
            p + "gripper_tool_joint",
            "fixed",
            p + "gripper_palm_link",
            p + "gripper_tool_frame",
            (TOOL_X, 0.0, 0.0),
        ),
    ]
    return links, joints


def robot_urdf() -> str:
    """The PR2-like robot."""
    links = [
        Link("base_footprint", (), 0.1),
        Link("base_link", (_box((0.65, 0.65, 0.30), (0.0, 0.0, 0.17 - BASE_LINK_Z)),), 50.0, _DARK),
        Link("torso_lift_link", (_box((0.25, 0.26, 0.75), (0.0, 0.0, -0.075)),), 10.0, _GREY),
        Link("head_pan_link", (), 0.5),
        Link("head_tilt_link", (_box((0.12, 0.26, 0.10), (-0.05, 0.0, 0.07)),), 1.0, _DARK),
        Link("head_mount_kinect_rgb_link", (), 0.05),
        Link("head_mount_kinect_rgb_optical_frame", (), 0.01),
    ]
    joints = [
        Joint(
            "base_footprint_joint", "fixed", "base_footprint", "base_link", (0.0, 0.0, BASE_LINK_Z)
        ),
        Joint(
            "torso_lift_joint",
            "prismatic",
            "base_link",
            "torso_lift_link",
            TORSO_XYZ,
            lower=0.0,
            upper=0.33,
        ),
        Joint(
            "head_pan_joint",
            "revolute",
            "torso_lift_link",
            "head_pan_link",
            HEAD_PAN_XYZ,
            lower=-2.857,
            upper=2.857,
        ),
        Joint(
            "head_tilt_joint",
            "revolute",
            "head_pan_link",
            "head_tilt_link",
            HEAD_TILT_XYZ,
            axis=(0.0, 1.0, 0.0),
            lower=-0.471,
            upper=1.396,
        ),
        Joint(
            "head_mount_kinect_rgb_joint",
            "fixed",
            "head_tilt_link",
            "head_mount_kinect_rgb_link",
            CAMERA_XYZ,
        ),
        Joint(
            "head_mount_kinect_rgb_optical_frame_joint",
            "fixed",
            "head_mount_kinect_rgb_link",
            "head_mount_kinect_rgb_optical_frame",
            rpy=OPTICAL_RPY,
        ),
    ]
    for side in ("l", "r"):
        arm_links, arm_joints = _arm(side)
        links.extend(arm_links)
        joints.extend(arm_joints)
    return _urdf("pr2", links, joints)


# -------------------------------------------------------------------------- kitchen
def _span(lo: Vec3, hi: Vec3) -> tuple[Vec3, Vec3]:
    return (lo, hi)


_SINK = (
    _span((1.12, -0.65, 0.0), (1.90, 1.25, 0.705)),
    _span((1.12, -0.65, 0.705), (1.90, 0.795, 0.82)),
    _span((1.12, 1.205, 0.705), (1.90, 1.25, 0.82)),
    _span((1.705, 0.795, 0.705), (1.90, 1.205, 0.82)),
)
_SINK_SURFACE = (_span((1.12, -0.65, 0.82), (1.90, 1.25, 0.85)),)
_DRAWER = (
    _span((1.12, 0.80, 0.71), (1.70, 1.20, 0.7335)),  # bottom
    _span((1.12, 0.80, 0.7335), (1.135, 1.20, 0.815)),  # front
    _span((1.685, 0.80, 0.7335), (1.70, 1.20, 0.815)),  # back
    _span((1.135, 0.80, 0.7335), (1.685, 0.815, 0.815)),  # right side
    _span((1.135, 1.185, 0.7335), (1.685, 1.20, 0.815)),  # left side
)
_HANDLE = (_span((1.095, 0.925, 0.765), (1.12, 1.075, 0.785)),)
#: The island starts at y 0.40, so the robot stands clear of it at the seed's (-0.5, 0, 0)
#: (its 0.65 m base then ends at y 0.325) while every CRAM placing pose (y 0.8..1.7) is on it.
_ISLAND = (_span((-1.20, 0.40, 0.0), (-0.55, 2.40, 0.82)),)
_ISLAND_SURFACE = (_span((-1.20, 0.40, 0.82), (-0.55, 2.40, 0.85)),)
_WALLS = {
    "kitchen_wall_east": (_span((2.00, -1.70, 0.0), (2.10, 3.10, 2.0)),),
    "kitchen_wall_west": (_span((-2.10, -1.70, 0.0), (-2.00, 3.10, 2.0)),),
    "kitchen_wall_south": (_span((-2.00, -1.70, 0.0), (2.00, -1.60, 2.0)),),
    "kitchen_wall_north": (_span((-2.00, 3.00, 0.0), (2.00, 3.10, 2.0)),),
}
DRAWER_LINK = kitchen.DRAWER_LINK
DRAWER_JOINT = kitchen.DRAWER_JOINT
DRAWER_TRAVEL = 0.48

#: Axis-aligned boxes of the kitchen in the map frame: link -> ((lo xyz), (hi xyz)) pieces.
#: The drawer is given closed.
KITCHEN_BOXES: Mapping[str, tuple[tuple[Vec3, Vec3], ...]] = MappingProxyType(
    {
        "sink_area": _SINK,
        kitchen.SINK_SURFACE: _SINK_SURFACE,
        DRAWER_LINK: _DRAWER,
        kitchen.DRAWER_HANDLE: _HANDLE,
        "kitchen_island": _ISLAND,
        kitchen.ISLAND_SURFACE: _ISLAND_SURFACE,
        **_WALLS,
    }
)

_WOOD = (0.75, 0.6, 0.42, 1.0)
_TOP = (0.85, 0.85, 0.82, 1.0)
_WALL = (0.9, 0.9, 0.88, 1.0)


def _centre(pieces: Sequence[tuple[Vec3, Vec3]]) -> Vec3:
    lo = [min(p[0][i] for p in pieces) for i in range(3)]
    hi = [max(p[1][i] for p in pieces) for i in range(3)]
    return (
        round((lo[0] + hi[0]) / 2, 6),
        round((lo[1] + hi[1]) / 2, 6),
        round((lo[2] + hi[2]) / 2, 6),
    )


def _local_boxes(pieces: Sequence[tuple[Vec3, Vec3]], origin: Vec3) -> tuple[Shape, ...]:
    out = []
    for lo, hi in pieces:
        size = (round(hi[0] - lo[0], 6), round(hi[1] - lo[1], 6), round(hi[2] - lo[2], 6))
        c = tuple(round((lo[i] + hi[i]) / 2 - origin[i], 6) for i in range(3))
        out.append(Shape("box", size, (c[0], c[1], c[2])))
    return tuple(out)


def kitchen_urdf() -> str:
    """The kitchen: one fixed-base body rooted at the map origin."""
    colours = {
        "sink_area": _WOOD,
        kitchen.SINK_SURFACE: _TOP,
        DRAWER_LINK: _WOOD,
        kitchen.DRAWER_HANDLE: _DARK,
        "kitchen_island": _WOOD,
        kitchen.ISLAND_SURFACE: _TOP,
    }
    parents = {
        "sink_area": "kitchen_root",
        kitchen.SINK_SURFACE: "sink_area",
        DRAWER_LINK: "sink_area",
        kitchen.DRAWER_HANDLE: DRAWER_LINK,
        "kitchen_island": "kitchen_root",
        kitchen.ISLAND_SURFACE: "kitchen_island",
    }
    origins = {name: _centre(pieces) for name, pieces in KITCHEN_BOXES.items()}
    links = [Link("kitchen_root", (), 1.0)]
    joints = []
    for name, pieces in KITCHEN_BOXES.items():
        o = origins[name]
        links.append(Link(name, _local_boxes(pieces, o), 10.0, colours.get(name, _WALL)))
        parent = parents.get(name, "kitchen_root")
        po = origins.get(parent, (0.0, 0.0, 0.0))
        rel = (round(o[0] - po[0], 6), round(o[1] - po[1], 6), round(o[2] - po[2], 6))
        if name == DRAWER_LINK:
            joints.append(
                Joint(
                    DRAWER_JOINT,
                    "prismatic",
                    parent,
                    name,
                    rel,
                    axis=(-1.0, 0.0, 0.0),
                    lower=0.0,
                    upper=DRAWER_TRAVEL,
                )
            )
        else:
            joints.append(Joint(f"{name}_joint", "fixed", parent, name, rel))
    return _urdf("kitchen", links, joints)


# -------------------------------------------------------------------------- objects
def object_urdf(t: ObjectType) -> str:
    """A single-link URDF for a household object type."""
    return _urdf(t.name, [Link("object", t.shapes, t.mass, t.rgba)], [])


def generate() -> dict[str, str]:
    """Relative asset path -> URDF text for every shipped file."""
    out = {"pr2.urdf": robot_urdf(), "kitchen.urdf": kitchen_urdf()}
    for t in OBJECT_TYPES.values():
        out[f"objects/{t.urdf_name}"] = object_urdf(t)
    return out


def write(directory: Path = ASSET_DIR) -> list[Path]:
    """Write every generated file under ``directory``; returns the paths written."""
    written = []
    for rel, text in generate().items():
        path = directory / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text, encoding="utf-8")
        written.append(path)
    return written


def main(argv: Sequence[str] | None = None) -> int:
    for path in write():
        print(path)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
