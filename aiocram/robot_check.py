"""``aiocram robot check MODULE``: load a robot description, validate it against its URDF,
move each chain, open and close each gripper, and render the robot to a PNG.

``MODULE`` is an importable module holding a :class:`executive.RobotDescription` as
``DESCRIPTION`` (``robots.panda``), or ``MODULE:NAME`` for another attribute. Every check
prints one line of measured numbers; a check that fails raises :class:`RobotCheckFailed`
(exit 1) naming what is wrong. A description that does not fit its URDF stops before the
robot is loaded (:class:`executive.RobotDescriptionError`, exit 2).
"""

from __future__ import annotations

import argparse
import importlib
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

from executive import RobotDescription, RobotDescriptionError

__all__ = ["RobotCheckFailed", "add_parser", "check_robot", "resolve_description"]

#: A joint is "moving" its chain's tip if the tip moves at least this much (m, or rad/1 m).
_MOVES = 1e-4
_PICTURE = (320, 240)


class RobotCheckFailed(RuntimeError):
    """A loaded robot does not behave as its description says (a joint that does not move
    its chain's tip, a gripper that does not open, a blank picture)."""


def resolve_description(spec: str) -> RobotDescription:
    """``module`` or ``module:attribute`` -> the description it holds; otherwise
    :class:`ValueError` saying what to write."""
    module_name, _, attr = spec.partition(":")
    try:
        module = importlib.import_module(module_name)
    except ImportError as e:
        raise ValueError(f"cannot import {module_name!r} ({e}); give an importable module") from e
    attr = attr or "DESCRIPTION"
    value = getattr(module, attr, None)
    if not isinstance(value, RobotDescription):
        raise ValueError(
            f"{module_name}.{attr} is not an executive.RobotDescription: define "
            f"{attr} = RobotDescription(...) in {module_name}, or pass MODULE:NAME"
        )
    return value


def _distance(a: tuple[float, ...], b: tuple[float, ...]) -> float:
    return math.dist(a, b)


def _angle(q1: tuple[float, ...], q2: tuple[float, ...]) -> float:
    dot = abs(sum(x * y for x, y in zip(q1, q2)))
    return 2.0 * math.acos(min(1.0, dot))


def _v(p: tuple[float, ...]) -> str:
    return "(" + ", ".join(f"{round(x, 3) + 0.0:.3f}" for x in p) + ")"


def check_robot(
    description: RobotDescription,
    png: Path | None = None,
    out: Callable[[str], None] = print,
) -> None:
    """Run every check on ``description`` in a fresh PyBullet DIRECT client, printing one
    line per check through ``out``; ``png``: where to write the picture (none: no file)."""
    import numpy as np
    import pybullet as pb

    from projection import kinematic_tree, load_robot

    c = pb.connect(pb.DIRECT)
    try:
        robot = load_robot(description, c)
        tree = kinematic_tree(c, robot.body)
        movable = sum(1 for j in tree.joints.values() if j.movable)
        out(
            f"robot {description.name}: description fits its URDF "
            f"({len(tree.links)} links, {len(tree.joints)} joints, {movable} movable)"
        )
        # --- torso and camera height
        t, neck = description.torso, description.neck
        cam = neck.camera.frame
        heights = []
        for h in (t.lower, t.upper):
            robot.set_torso(h)
            heights.append(robot.link_pose(cam)[0][2])
        if not heights[1] - heights[0] > _MOVES:
            raise RobotCheckFailed(f"torso joint {t.joint!r} does not lift the camera {cam!r}")
        out(
            f"torso {t.joint}: {t.lower:.3f}..{t.upper:.3f} m lifts the camera "
            f"{heights[0]:.3f}..{heights[1]:.3f} m over the floor"
        )
        robot.set_torso(t.default)
        # --- neck: forward looks ahead; pan turns, tilt pitches the view
        robot.set_neck(*neck.states["forward"])
        rot = np.array(pb.getMatrixFromQuaternion(robot.link_pose(cam)[1])).reshape(3, 3)
        ahead = tuple(float(v) for v in rot[:, 2])
        for joint, (pan, tilt) in ((neck.pan_joint, (0.3, 0.0)), (neck.tilt_joint, (0.0, 0.3))):
            before = robot.link_pose(cam)[1]
            robot.set_neck(pan, tilt)
            turned = _angle(before, robot.link_pose(cam)[1])
            robot.set_neck(*neck.states["forward"])
            if turned < 0.1:
                raise RobotCheckFailed(f"neck joint {joint!r} does not turn the camera {cam!r}")
        out(f"neck {neck.pan_joint}, {neck.tilt_joint}: forward looks along {_v(ahead)}")
        # --- arms: named states, every joint moves the tool frame, the gripper
        for arm in description.arms:
            tips = []
            for state in arm.states:
                robot.set_joints(dict(zip(arm.joints, arm.states[state])))
                tips.append(f"{state} {_v(robot.link_pose(arm.tool_frame)[0])}")
            robot.set_joints(dict(zip(arm.joints, arm.states[description.initial_state])))
            for jn in arm.joints:
                j = tree.joints[jn]
                (q,) = robot.joint_values((jn,))
                step = 0.2 if q + 0.2 <= j.upper else -0.2
                start = robot.link_pose(arm.tool_frame)
                robot.set_joints({jn: q + step})
                moved = robot.link_pose(arm.tool_frame)
                robot.set_joints({jn: q})
                if _distance(start[0], moved[0]) + _angle(start[1], moved[1]) < _MOVES:
                    raise RobotCheckFailed(
                        f"arm {arm.name!r}: joint {jn!r} does not move the tool frame "
                        f"{arm.tool_frame!r}"
                    )
            out(
                f"arm {arm.name}: {len(arm.joints)} joints each move {arm.tool_frame}; "
                f"tool at {'; '.join(tips)}"
            )
            g = arm.gripper
            fingers = [tree.joints[jn].child for jn in g.joints]
            spans = []
            for opening in (0.0, g.max_opening):
                robot.set_gripper(arm.name, opening)
                points = [robot.link_pose(f)[0] for f in fingers]
                spans.append(max(_distance(a, b) for a in points for b in points))
            if not spans[1] > spans[0] + _MOVES:
                raise RobotCheckFailed(
                    f"arm {arm.name!r}: opening the gripper does not move its fingers apart"
                )
            out(
                f"gripper {arm.name}: {len(g.joints)} joints, opening 0..{g.max_opening:.3f} m "
                f"moves the finger links {spans[0]:.3f}..{spans[1]:.3f} m apart"
            )
        # --- picture
        width, height = _PICTURE
        base = robot.link_pose(description.base_frame)[0]
        target = (base[0], base[1], 0.5 * heights[1])
        view = pb.computeViewMatrix(
            (base[0] + 2.2, base[1] + 1.6, 1.6), target, (0.0, 0.0, 1.0), physicsClientId=c
        )
        proj = pb.computeProjectionMatrixFOV(50.0, width / height, 0.1, 10.0, physicsClientId=c)
        _, _, rgba, _, seg = pb.getCameraImage(
            width,
            height,
            view,
            proj,
            renderer=pb.ER_TINY_RENDERER,
            physicsClientId=c,
        )
        pixels = np.asarray(rgba, dtype=np.uint8).reshape(height, width, 4)[:, :, :3]
        robot_share = float(np.mean(np.asarray(seg).reshape(height, width) == robot.body))
        spread = float(pixels.std())
        if robot_share < 0.02 or spread < 5.0:
            raise RobotCheckFailed(
                f"the picture shows little of the robot ({robot_share:.1%} of the pixels, "
                f"spread {spread:.1f})"
            )
        where = ""
        if png is not None:
            from PIL import Image

            Image.fromarray(pixels).save(png)
            where = f" -> {png}"
        out(f"picture: {width}x{height}, the robot covers {robot_share:.0%} of it{where}")
    finally:
        pb.disconnect(physicsClientId=c)


# --------------------------------------------------------------------- command line
def add_parser(subparsers: Any) -> None:
    from aiocram._help import HelpFormatter

    p = subparsers.add_parser(
        "robot",
        help="check a robot description against its URDF",
        description="Robot descriptions (docs/robots.md).",
        formatter_class=HelpFormatter,
    )
    sub = p.add_subparsers(dest="robot_command", required=True, metavar="COMMAND")
    check = sub.add_parser(
        "check",
        help="load, validate, move each chain, open the grippers, render",
        description="Load a robot description's URDF in PyBullet (DIRECT), validate the "
        "description, move each chain and gripper, and render the robot.",
        formatter_class=HelpFormatter,
    )
    check.add_argument(
        "description",
        metavar="MODULE[:NAME]",
        help="module holding the description as DESCRIPTION (e.g. robots.panda)",
    )
    check.add_argument(
        "--png", type=Path, default=None, metavar="FILE", help="write the picture to FILE"
    )
    check.set_defaults(handler=_run_check)


def _run_check(args: argparse.Namespace) -> int:
    import sys

    try:
        description = resolve_description(args.description)
        check_robot(description, args.png)
    except (ValueError, RobotDescriptionError) as e:
        print(f"aiocram robot check: {e}", file=sys.stderr)
        return 2
    except RobotCheckFailed as e:
        print(f"aiocram robot check: FAILED: {e}", file=sys.stderr)
        return 1
    return 0
