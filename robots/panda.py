"""A mobile Franka Panda: pybullet_data's ``franka_panda/panda.urdf`` (the arm, its hand and
its parallel gripper, with the shipped meshes; Apache-2.0, installed with pybullet) mounted
on a holonomic base with a torso lift and a pan-tilt camera mast, as a
:class:`executive.RobotDescription`.

:func:`urdf_text` generates the combined URDF: the shipped file's links and joints
unchanged (mesh paths made absolute, so the file loads from anywhere), mounted by
``panda_link0`` on the base, torso lift (0..0.40 m) and pan-tilt camera mast of
:mod:`robots.mobile_base`.

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

from ._urdf_tools import write_cached
from .mobile_base import mount_arm

__all__ = [
    "ARM_JOINTS",
    "DESCRIPTION",
    "STANDARD_TO_TOOL",
    "shipped_urdf",
    "urdf_path",
    "urdf_text",
]

#: The Panda's 7 arm joints, root to tip (pybullet_data's names).
ARM_JOINTS = tuple(f"panda_joint{i}" for i in range(1, 8))
#: The hand approaches along its z axis and its fingers move along its y axis: the standard
#: gripper (z approach, x finger to finger) is the hand frame turned by -90 degrees about z.
STANDARD_TO_TOOL = ((0.0, 1.0, 0.0), (-1.0, 0.0, 0.0), (0.0, 0.0, 1.0))


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


def urdf_text() -> str:
    """The mobile Panda's URDF (see the module docstring), mesh paths absolute."""
    return mount_arm("panda", shipped_urdf(), "panda_link0")


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
                # the finger links' bounding boxes end 0.011 m beyond panda_grasptarget
                # along its z (measured with pybullet_data's URDF, the gripper open)
                finger_reach=0.01,
            ),
            # pybullet_data's Panda reaches 0.95 m from its joint1 axis (sampled); scaled
            # like the PR2-like robot's 0.7 m of its ~0.95 m, from a mount 0.12 m ahead
            reach=Reach(in_reach_distance=0.8, minimal_distance=0.2),
            states={
                # folded over the base, the hand down in front of the torso (both
                # states: the tool over the base, no part of the arm in the base, torso
                # or mast; tested). Known cost: the hand (1.15 m high at torso 0.2) is
                # in a fifth of the mast camera's rays to table-height points 0.5-1.4 m
                # ahead (35 of 180 sampled; carry 46), so detection retries often (445
                # retries over 80 objects in a 16-run campaign) and the seed
                # walkthrough's cup is hidden. A park folded up over the base's centre
                # (-0.2, -1.7, 0, -2.3, 0, 0.5, 0.785) hides 1 of 180 but lost more
                # deliveries (67 of 80 against 76 in the same campaign), so it is not
                # used
                "park": (0.0, -1.7, 0.0, -3.0, 0.0, 1.3, 0.785),
                # a held object over the front of the base, the hand pointing down
                "carry": (0.0, -1.4, 0.0, -2.9, 0.0, 1.5, 0.785),
            },
            # IK seeds (after the arm's current joints, nearest tool first): the two
            # states and three self-collision-free configurations chosen greedily from 60
            # random ones for the most solutions free of self- and mast collisions over
            # 72 back and top grasps 0.45-0.75 m ahead of the base, 0.8-1.1 m high (44
            # clean against 31 with projection's generated seeds)
            ik_seeds=(
                (0.0, -1.7, 0.0, -3.0, 0.0, 1.3, 0.785),
                (0.0, -1.4, 0.0, -2.9, 0.0, 1.5, 0.785),
                (-0.57, 0.66, 0.73, -1.74, 1.74, 2.28, 1.47),
                (1.04, 0.98, -1.04, -2.29, 0.66, 2.82, 2.2),
                (1.37, 0.01, -1.3, -2.59, 1.94, 2.66, -1.53),
            ),
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
