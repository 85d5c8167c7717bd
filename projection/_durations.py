"""How long a projected motion takes: the duration model of projected time.

A projected motion teleports (as in CRAM); what it costs in time is read off the robot's
state before and after it, at the simulated real robot's speed limits
(:mod:`projection._real_body`): the base at :data:`BASE_VELOCITY` and
:data:`BASE_ANGULAR_VELOCITY` along the straight line, each arm joint at
:data:`ARM_JOINT_VELOCITY`, the torso at :data:`TORSO_VELOCITY`, the head at
:data:`HEAD_JOINT_VELOCITY`, each finger at :data:`FINGER_VELOCITY`; the parts move at
once, so a motion takes as long as its slowest part. A detection takes
:data:`DETECTION_TIME`. A motion that fails takes no time (the world is unchanged).

The real robot's base follows a path that may be longer than the straight line, so the
projected time of a drive is a lower bound of the real one.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from projection._real_body import (
    ARM_JOINT_VELOCITY,
    BASE_ANGULAR_VELOCITY,
    BASE_VELOCITY,
    DETECTION_TIME,
    FINGER_VELOCITY,
    HEAD_JOINT_VELOCITY,
    TORSO_VELOCITY,
)
from projection._trajectories import wrap_angle
from projection._world import World

__all__ = ["DETECTION_TIME", "RobotState", "motion_seconds", "robot_state"]


@dataclass(frozen=True)
class RobotState:
    """The robot's moving parts: base ``(x, y, yaw)``, torso height, head ``(pan, tilt)``,
    every arm joint and every finger joint (one flat tuple each, in a fixed order)."""

    base: tuple[float, float, float]
    torso: float
    head: tuple[float, float]
    arms: tuple[float, ...]
    fingers: tuple[float, ...]


def robot_state(world: World) -> RobotState:
    """The projected robot's state now (a few joint reads)."""
    world._check()
    arms = [j for arm in sorted(world._arm_joints) for j in world._arm_joints[arm]]
    fingers = [j for arm in sorted(world._fingers) for j in world._fingers[arm]]
    torso, pan, tilt, *rest = world._get_joints(
        [world._torso, world._pan, world._tilt, *arms, *fingers]
    )
    return RobotState(
        base=world._base,
        torso=torso,
        head=(pan, tilt),
        arms=tuple(rest[: len(arms)]),
        fingers=tuple(rest[len(arms) :]),
    )


def _largest(before: tuple[float, ...], after: tuple[float, ...]) -> float:
    return max((abs(b - a) for a, b in zip(before, after, strict=True)), default=0.0)


def motion_seconds(before: RobotState, after: RobotState) -> float:
    """Seconds the real robot needs to go from ``before`` to ``after`` (its slowest part)."""
    (x0, y0, yaw0), (x1, y1, yaw1) = before.base, after.base
    return max(
        math.hypot(x1 - x0, y1 - y0) / BASE_VELOCITY,
        abs(wrap_angle(yaw1 - yaw0)) / BASE_ANGULAR_VELOCITY,
        abs(after.torso - before.torso) / TORSO_VELOCITY,
        _largest(before.head, after.head) / HEAD_JOINT_VELOCITY,
        _largest(before.arms, after.arms) / ARM_JOINT_VELOCITY,
        _largest(before.fingers, after.fingers) / FINGER_VELOCITY,
    )
