"""A robot loaded into PyBullet from its :class:`executive.RobotDescription`, validated
before it is loaded and once more against the body PyBullet made of it.

:func:`load_robot` parses the description's URDF, checks the description against it
(:meth:`executive.RobotDescription.validate`: a missing joint or link, a wrong chain or an
unknown named state is an :class:`executive.RobotDescriptionError`) and only then loads the
body, fixed-base (the world moves the base frame), in the description's initial state.
:func:`kinematic_tree` reads the joints and links of a loaded body.

A :class:`RobotBody` sets joints by name, named states, torso, neck and gripper openings,
and reads link poses (forward kinematics): what the world's robot will be built on.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from types import MappingProxyType

import pybullet as pb

from executive import JointInfo, KinematicTree, RobotDescription

__all__ = ["RobotBody", "kinematic_tree", "load_robot"]

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]

_KINDS = {
    pb.JOINT_REVOLUTE: "revolute",
    pb.JOINT_PRISMATIC: "prismatic",
    pb.JOINT_SPHERICAL: "spherical",
    pb.JOINT_PLANAR: "planar",
    pb.JOINT_FIXED: "fixed",
}


def kinematic_tree(client: int, body: int) -> KinematicTree:
    """The joints and links of the loaded PyBullet ``body``, by name."""
    root = pb.getBodyInfo(body, physicsClientId=client)
    root_link, name = root[0].decode(), root[1].decode()
    links = {root_link}
    index_name = {-1: root_link}
    joints: dict[str, JointInfo] = {}
    infos = [
        pb.getJointInfo(body, i, physicsClientId=client)
        for i in range(pb.getNumJoints(body, physicsClientId=client))
    ]
    for i, info in enumerate(infos):
        index_name[i] = info[12].decode()
    for info in infos:
        kind = _KINDS.get(info[2], "unknown")
        lower, upper = float(info[8]), float(info[9])
        if kind == "revolute" and lower > upper:  # PyBullet's continuous joint
            kind, lower, upper = "continuous", -math.inf, math.inf
        if kind == "fixed":
            lower = upper = 0.0
        child = info[12].decode()
        links.add(child)
        joints[info[1].decode()] = JointInfo(
            info[1].decode(), kind, index_name[info[16]], child, lower, upper, float(info[10])
        )
    return KinematicTree(name, root_link, frozenset(links), joints)


class RobotBody:
    """A robot body in a PyBullet client, addressed by the names of its description."""

    def __init__(self, description: RobotDescription, client: int, body: int) -> None:
        self.description = description
        self.client = client
        self.body = body
        joints: dict[str, int] = {}
        links: dict[str, int] = {pb.getBodyInfo(body, physicsClientId=client)[0].decode(): -1}
        for i in range(pb.getNumJoints(body, physicsClientId=client)):
            info = pb.getJointInfo(body, i, physicsClientId=client)
            joints[info[1].decode()] = i
            links[info[12].decode()] = i
        # invariant: every joint and link of the body by name (index; the root link is -1)
        self.joint_index: Mapping[str, int] = MappingProxyType(joints)
        self.link_index: Mapping[str, int] = MappingProxyType(links)

    # ------------------------------------------------------------------ joints
    def set_joints(self, values: Mapping[str, float]) -> None:
        """Reset the named joints (kinematically: no physics step)."""
        for name, value in values.items():
            pb.resetJointState(
                self.body, self.joint_index[name], float(value), 0.0, physicsClientId=self.client
            )

    def joint_values(self, names: tuple[str, ...]) -> tuple[float, ...]:
        return tuple(
            float(pb.getJointState(self.body, self.joint_index[n], physicsClientId=self.client)[0])
            for n in names
        )

    def set_state(self, name: str) -> None:
        """Every arm in its named configuration ``name``; unknown -> LookupError."""
        self.set_joints(self.description.joint_state(name))

    def set_torso(self, height: float) -> None:
        t = self.description.torso
        if not t.lower <= height <= t.upper:
            raise ValueError(f"torso height must be {t.lower} to {t.upper} m, got {height}")
        self.set_joints({t.joint: height})

    def set_neck(self, pan: float, tilt: float) -> None:
        neck = self.description.neck
        self.set_joints({neck.pan_joint: pan, neck.tilt_joint: tilt})

    def set_gripper(self, arm: str, opening: float) -> None:
        """Open ``arm``'s gripper to ``opening`` metres (all its finger joints)."""
        g = self.description.arm(arm).gripper
        q = g.joint_position(opening)
        self.set_joints(dict.fromkeys(g.joints, q))

    def set_base(self, x: float, y: float, yaw: float) -> None:
        """Put the base frame at (x, y) with heading ``yaw`` on the floor."""
        # PyBullet poses a body by its base's inertial frame, not the URDF root link's
        dyn = pb.getDynamicsInfo(self.body, -1, physicsClientId=self.client)
        quat = pb.getQuaternionFromEuler((0.0, 0.0, yaw))
        pos, orn = pb.multiplyTransforms((x, y, 0.0), quat, dyn[3], dyn[4])
        pb.resetBasePositionAndOrientation(self.body, pos, orn, physicsClientId=self.client)

    # ---------------------------------------------------------------- poses
    def link_pose(self, link: str) -> tuple[Vec3, Quat]:
        """World position and quaternion (x, y, z, w) of the URDF frame of ``link``."""
        i = self.link_index[link]
        c = self.client
        if i < 0:
            pos, orn = pb.getBasePositionAndOrientation(self.body, physicsClientId=c)
            dyn = pb.getDynamicsInfo(self.body, -1, physicsClientId=c)
            inv = pb.invertTransform(dyn[3], dyn[4])
            pos, orn = pb.multiplyTransforms(pos, orn, *inv)
        else:
            state = pb.getLinkState(self.body, i, computeForwardKinematics=True, physicsClientId=c)
            pos, orn = state[4], state[5]
        return (
            (float(pos[0]), float(pos[1]), float(pos[2])),
            (float(orn[0]), float(orn[1]), float(orn[2]), float(orn[3])),
        )


def load_robot(
    description: RobotDescription, client: int, base: Vec3 = (0.0, 0.0, 0.0)
) -> RobotBody:
    """Validate ``description`` against its URDF, load the body into ``client`` (fixed
    base, at ``base`` = (x, y, yaw)), validate against the loaded body and put it in its
    initial state: arms in ``initial_state``, torso at its default, neck forward, grippers
    open. A misfit -> :class:`executive.RobotDescriptionError` before the body is loaded
    (or, if only PyBullet's reading differs, with the body removed again)."""
    path = description.urdf()
    description.validate(KinematicTree.from_urdf(path))
    body = int(pb.loadURDF(str(path), useFixedBase=True, physicsClientId=client))
    try:
        description.validate(kinematic_tree(client, body))
    except Exception:
        pb.removeBody(body, physicsClientId=client)
        raise
    robot = RobotBody(description, client, body)
    robot.set_base(*base)
    robot.set_state(description.initial_state)
    robot.set_torso(description.torso.default)
    robot.set_neck(*description.neck.states["forward"])
    for arm in description.arms:
        robot.set_gripper(arm.name, arm.gripper.max_opening)
    return robot
