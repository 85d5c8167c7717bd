"""What an arm motion sweeps: the free objects the simulated controller's path for one
arm motion (:func:`projection._arm_planner.controller_path`: the straight tool line or a
configuration move, rerouted or planned by OMPL when ``World.arm_motion_planning`` is on)
would push the robot, or what it holds, through, in a :class:`World`.

Both projection's plan-level probe (``ProjectedWorldModel.probe_arm_trajectory``) and
projection's arms process module (a motion executed in an imagined run) ask it, for the
same motions from the same states, so the answer is remembered per world
(:class:`projection._motion_memo.SweepMemo`, on ``World.sweep_memo``): a probe, then
the motion executed, then the same motion in the next imagined run cost one path
computation.
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping, Sequence
from typing import Any

from executive import Pose
from projection._arm_planner import (
    Config,
    controller_path,
    leg_seconds,
    swept_objects,
    touched_objects,
)
from projection._motion_memo import Sweep
from projection._world import World

__all__ = ["arm_motion_sweep"]

_DIGITS = 4  # rounding (m, rad) of the memo keys


def _rounded(*values: float) -> tuple[float, ...]:
    return tuple(round(float(v), _DIGITS) + 0.0 for v in values)


def _goal_key(args: Mapping[str, Any], arms: Sequence[str]) -> tuple[Any, ...]:
    out: list[Any] = []
    for a in arms:
        goal = args.get(a)
        if isinstance(goal, Pose):
            out.append((a, goal.frame, _rounded(*goal.position, *goal.orientation)))
        elif goal is not None:
            out.append((a, _rounded(*goal)))
    return tuple(out)


def arm_motion_sweep(
    world: World,
    command: str,
    arms: Sequence[str],
    args: Mapping[str, Any],
    torso: float,
    start: Mapping[str, tuple[float, ...]],
) -> Sweep:
    """With the robot at the goal configuration of an arm motion (``command``
    "move-tcp" or "move-joints" of ``arms`` with goals ``args``) that started at
    ``torso``/``start``: the :class:`Sweep` of the path the simulated controller follows
    (:func:`projection._arm_planner.controller_path`), remembered in
    ``world.sweep_memo``. Leaves the robot at the goal configuration."""
    goal_torso = world.torso_height
    goal = {a: world.arm_joints(a) for a in world.arms}
    free = sorted(n for n in world.objects if n not in world.attachments)
    base = world.robot_pose()
    key = (
        command,
        tuple(arms),
        _goal_key(args, arms),
        _rounded(torso, *(v for a in arms for v in start[a])),
        _rounded(goal_torso, *(v for a in world.arms for v in goal[a])),
        _rounded(*(world.gripper_opening(a) for a in world.arms)),
        _rounded(*base.position, *base.orientation),
        tuple(sorted(world.attachments.items())),
        tuple(
            (n, _rounded(*p.position, *p.orientation))
            for n in free
            for p in (world.object_pose(n),)
        ),
        world.arm_motion_planning,
    )
    memo = world.sweep_memo
    sweep = memo.get(key)
    if sweep is not None:
        return sweep
    others = set(free) - touched_objects(world, set(free))
    if others:
        world.move_torso(torso)
        world.move_joints(**{a: start[a] for a in arms})
        others -= touched_objects(world, others)
        world.move_torso(goal_torso)
        world.move_joints(**{a: goal[a] for a in arms})
    path: list[Config] = controller_path(world, command, arms, args, torso, dict(start))
    hits = swept_objects(world, path, others) if others else set()
    seconds = sum(leg_seconds(u, v) for u, v in itertools.pairwise(path))
    world.move_torso(goal_torso)
    world.move_joints(**{a: goal[a] for a in arms})
    sweep = Sweep(tuple(sorted(hits)), seconds, len(path))
    memo.put(key, sweep)
    return sweep
