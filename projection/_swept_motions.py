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

import numpy as np
import pybullet as pb

from executive import Pose
from projection._arm_planner import (
    Config,
    cartesian_path,
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
    ``world.sweep_memo``. With ``World.arm_motion_planning`` on, OMPL is asked only when
    the router's path (the controller's without a planner) sweeps something: a planned
    path sweeps nothing the router's does not (see the code), so where that one is clear
    the answer is known without planning, and its duration is the router path's (a lower
    bound of the planned one's). Leaves the robot at the goal configuration."""
    goal_torso = world.torso_height
    goal = {a: world.arm_joints(a) for a in world.arms}
    free = sorted(n for n in world.objects if n not in world.attachments)
    base = world.robot_pose()
    key = (
        command,
        tuple(arms),
        _goal_key(args, arms),
        ("collision_mode" in args, args.get("collision_mode")),
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
    others = _within_reach(world, arms, set(free), torso, goal_torso)
    others -= touched_objects(world, others)
    if others:
        world.move_torso(torso)
        world.move_joints(**{a: start[a] for a in arms})
        others -= touched_objects(world, others)
        world.move_torso(goal_torso)
        world.move_joints(**{a: goal[a] for a in arms})
    if not others:
        # nothing in reach to sweep: the path is not computed (nor planned), the
        # projected time is the straight move's (a lower bound of a planned detour's)
        sweep = Sweep((), None, 2)
        memo.put(key, sweep)
        return sweep
    planning = world.arm_motion_planning
    try:
        # the router's path first (no OMPL): a planned path avoids every free object but
        # those touched where the motion starts or ends, and a failed plan falls back to
        # the router, so where the router's path sweeps nothing the planned one cannot
        # either: no plan needed to know it
        world.arm_motion_planning = False
        line = (
            _tool_line(world, arms, args, torso, start, others) if command == "move-tcp" else None
        )
        if line is not None:
            path, hits = line
        else:
            path = controller_path(world, command, arms, args, torso, dict(start))
            hits = swept_objects(world, path, others)
        if hits and planning:
            world.arm_motion_planning = True
            path = controller_path(world, command, arms, args, torso, dict(start))
            hits = swept_objects(world, path, others)
    finally:
        world.arm_motion_planning = planning
    seconds = sum(leg_seconds(u, v) for u, v in itertools.pairwise(path))
    world.move_torso(goal_torso)
    world.move_joints(**{a: goal[a] for a in arms})
    sweep = Sweep(tuple(sorted(hits)), seconds, len(path))
    memo.put(key, sweep)
    return sweep


def _tool_line(
    world: World,
    arms: Sequence[str],
    args: Mapping[str, Any],
    torso: float,
    start: Mapping[str, tuple[float, ...]],
    others: set[str],
) -> tuple[list[Config], set[str]] | None:
    """The router's path of a ``move-tcp`` and what it sweeps of ``others``, where that
    is known from the straight tool line alone; None otherwise (the robot is then back at
    the goal configuration, for :func:`controller_path`).

    :func:`controller_path` computes the tool line (:func:`cartesian_path`) and hands it
    to :func:`reroute_cartesian`, which keeps it (returns None) when the torso ends more
    than 1 mm from ``torso``, or when the line (sampled by :func:`swept_objects`, its
    configurations and the segments between them) sweeps no free object not touched at
    the start or end. So
    where the torso ends elsewhere the path is the line whatever it sweeps, and where the
    torso stays at ``torso`` all along and the line sweeps none of ``others`` (the free
    objects within the arm's reach that the start and goal do not touch; the rest is
    beyond reach of any configuration) the reroute would have found nothing either: the
    path is the line, and its sweep is empty. The reroute's own pass over the line is
    saved; the answer is the same. A line without
    IK along it (two configurations: the reroute then samples the joint-space segment
    differently) or one that sweeps something: None."""
    goal = {a: world.arm_joints(a) for a in arms}
    goal_torso = world.torso_height
    world.move_torso(torso)
    world.move_joints(**{a: start[a] for a in arms})
    first: Config = (torso, {a: start[a] for a in arms})
    line = cartesian_path(world, arms, args, first, (goal_torso, goal))
    known: tuple[list[Config], set[str]] | None = None
    if len(line) > 2:
        if abs(line[-1][0] - torso) > 1e-3:  # the reroute keeps such a line as it is
            known = (line, swept_objects(world, line, others))
        elif all(t == torso for t, _c in line[:-1]) and abs(line[-1][0] - torso) < 1e-12:
            hits = swept_objects(world, line, others)
            if not hits:
                known = (line, hits)
    if known is None:
        world.move_torso(goal_torso)
        world.move_joints(**goal)
    return known


def _within_reach(
    world: World, arms: Sequence[str], names: set[str], torso: float, goal_torso: float
) -> set[str]:
    """The objects of ``names`` that some configuration of ``arms`` could touch: those
    whose box comes within the arm's span (:func:`_span`) of its shoulder anywhere on
    the shoulder's way between the torso heights. A sound filter (no path computed can
    touch the others), cheap beside a path: most objects stand far from the arm."""
    if not names:
        return set()
    shoulders = []
    for a in arms:
        index = world._arm_joints[a][0]
        shoulder = np.array(world._link_tf(world._robot, index)[0])
        shoulders.append((shoulder, _span(world, a) + abs(goal_torso - torso)))
    out = set()
    for n in names:
        lo, hi = (np.array(v) for v in world.object_aabb(n))
        for shoulder, span in shoulders:
            gap = np.maximum(0.0, np.maximum(lo - shoulder, shoulder - hi))
            if float(np.linalg.norm(gap)) <= span:
                out.add(n)
                break
    return out


def _span(world: World, arm: str) -> float:
    """An upper bound (m) of how far any point of ``arm`` (its links and what they hold)
    can be from its shoulder (its first joint's link origin), whatever its joints: over
    its links, the sum of the origin-to-parent-origin distances down the tree to the
    link (the chain can stretch no further) plus the farthest corner of the link's box
    from its origin; plus the farthest corner of a held object from the link it hangs
    on, plus 5 cm. Kept per world, arm and held object types (a grasp of another type
    reaches further)."""
    held = [n for n, link in world.attachments.items() if link in world.arm_links(arm)]
    key = (arm, tuple(sorted(world.objects[n] for n in held)))
    spans = world.sweep_memo.spans
    if key in spans:
        return spans[key]
    robot = world._robot
    indices = sorted(
        i for n, (b, i) in world._links.items() if b == robot and n in world.arm_links(arm)
    )
    origin = {i: np.array(world._link_tf(robot, i)[0]) for i in indices}
    # along the tree (a parent's index is below its child's): how far each link's origin
    # can get from the first one's, plus the farthest corner of its box from its origin
    reach: dict[int, float] = {}
    radius = 0.0
    for i in indices:
        up = world._parent_link[i]
        reach[i] = reach[up] + float(np.linalg.norm(origin[i] - origin[up])) if up in reach else 0.0
        lo, hi = pb.getAABB(robot, i, physicsClientId=world.client)
        for corner in itertools.product(*zip(lo, hi)):
            radius = max(radius, reach[i] + float(np.linalg.norm(np.array(corner) - origin[i])))
    chain = 0.0
    extra = 0.0
    for n in held:  # its farthest corner from the link it hangs on
        link = np.array(world.link_pose(world.attachments[n]).position)
        for corner in itertools.product(*zip(*world.object_aabb(n))):
            extra = max(extra, float(np.linalg.norm(np.array(corner) - link)))
    spans[key] = span = chain + radius + extra + 0.05
    return span
