"""A finished run as store rows: plain, picklable, JSON-able dicts.

Read after the run, off the control path, from the run's recorded task tree (the live
tasks the run left: every real task and every imagined run's subtree, with the action
designators and their groundings the tasks carry as annotations) and the demo's report
(the outcome per object measured on the true world). :func:`run_rows` is called by the
demo where it writes its outputs and by each campaign run; :mod:`._writer` inserts them.
"""

from __future__ import annotations

import datetime as _dt
import functools
import math
import subprocess
import uuid
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

import cpl

__all__ = ["current_commit", "robot_name", "run_rows"]

_PARAMETER_ACTIONS = ("picking-up", "placing")
_TEXT_LIMIT = 500


@functools.lru_cache(maxsize=1)
def current_commit() -> str | None:
    """The git commit of the code that runs (``None`` outside a git checkout)."""
    here = Path(__file__).resolve().parent
    try:
        done = subprocess.run(
            ["git", "rev-parse", "HEAD"],
            cwd=here,
            capture_output=True,
            text=True,
            timeout=5,
            check=False,
        )
    except (OSError, subprocess.SubprocessError):
        return None
    rev = done.stdout.strip()
    return rev if done.returncode == 0 and len(rev) == 40 else None


def robot_name(robot: Any) -> str:
    """The name recorded with a run (the ``robot`` column): ``robot`` is the run's
    :class:`executive.RobotDescription` (its ``name``) or that name already. Anything
    else is a :class:`TypeError` naming what to pass: a run is never recorded under a
    robot it did not run."""
    from executive import RobotDescription

    if isinstance(robot, RobotDescription):
        return robot.name
    if isinstance(robot, str) and robot:
        return robot
    raise TypeError(f"robot_name() takes the run's RobotDescription or its name, got {robot!r}")


def _now() -> str:
    return _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")


def _number(value: Any) -> float | None:
    return float(value) if isinstance(value, int | float) and math.isfinite(value) else None


def run_rows(
    record: Mapping[str, Any],
    root: cpl.Task | None,
    *,
    robot: str,
    source: str,
    campaign: str | None = None,
    faults: str | None = None,
    commit: str | None = None,
) -> dict[str, list[dict[str, Any]]]:
    """The rows of one run: ``record`` is the demo's JSON record
    (:meth:`aiocram.demo.DemoReport.to_json`, or a campaign's record of a crashed run,
    with ``error``), ``root`` the run's root task (``None`` when the harness crashed)."""
    run_id = str(uuid.uuid4())
    objects = record.get("objects") or {}
    planned = record.get("planned") or list(objects)
    run = {
        "id": run_id,
        "campaign": campaign,
        "source": source,
        "robot": robot,
        "seed": int(record["seed"]),
        "fault_rate": _number(record.get("fault_rate")),
        "faults": faults,
        "commit": commit if commit is not None else current_commit(),
        "projection": bool(record["projection"]),
        "objects": max(len(planned), len(objects)),
        "delivered": sum(1 for o in objects.values() if o.get("delivered")),
        "claimed": sum(1 for o in objects.values() if o.get("claimed")),
        "sim_time_s": _number(record.get("real_time_s")),
        "wall_time_s": _number(record.get("wall_time_s")),
        "error": record.get("error"),
        "recorded_at": _now(),
    }
    object_rows, retry_rows = [], []
    for otype, o in objects.items():
        spent = {str(k): int(v) for k, v in (o.get("retries") or {}).items() if v}
        object_rows.append(
            {
                "run_id": run_id,
                "object": otype,
                "name": o.get("name"),
                "delivered": bool(o.get("delivered")),
                "claimed": bool(o.get("claimed")),
                "phantom": bool(o.get("phantom")),
                "place": o.get("where"),
                "toppled": bool(o.get("toppled")),
                "failure": o.get("failure"),
                "retries": sum(spent.values()),
            }
        )
        retry_rows += [
            {"run_id": run_id, "object": otype, "recovery": kind, "count": n}
            for kind, n in spent.items()
        ]
    nodes, params = ([], []) if root is None else _tree_rows(run_id, root)
    return {
        "runs": [run],
        "run_objects": object_rows,
        "retries": retry_rows,
        "nodes": nodes,
        "parameters": params,
    }


def _object_type(action: Any) -> str | None:
    obj = action.get("object")
    kind = obj.get("type") if obj is not None and hasattr(obj, "get") else None
    return None if kind is None else str(kind)


def _walk(root: cpl.Task) -> Iterator[tuple[cpl.Task, int, int | None, bool, Any, Any]]:
    """Pre-order: (task, index, parent index, imagined, nearest action, nearest object
    action) — the ancestors' context is carried down, so each task is visited once."""
    stack: list[tuple[cpl.Task, int | None, bool, Any, Any]] = [(root, None, False, None, None)]
    index = 0
    from executive import action_of

    while stack:
        task, parent, imagined, step, with_object = stack.pop()
        imagined = imagined or task.subtree is cpl.Subtree.IMAGINED
        action = action_of(task)
        if action is not None:
            step = action
            if action.get("object") is not None:
                with_object = action
        yield task, index, parent, imagined, action, (step, with_object)
        mine = index
        index += 1
        stack.extend((c, mine, imagined, step, with_object) for c in reversed(task.children))


def _tree_rows(run_id: str, root: cpl.Task) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    nodes: list[dict[str, Any]] = []
    params: list[dict[str, Any]] = []
    for task, index, parent, imagined, action, (step, with_object) in _walk(root):
        failure = task.failure
        failure_class = None if failure is None else type(failure).__name__
        origin = failure is not None and not isinstance(failure, cpl.CompositeFailure)
        if origin:  # the same failure object in a child: it arose there
            origin = not any(c.failure is failure for c in task.children)
        message = None
        if failure is not None:
            message = str(getattr(failure, "message", None) or failure)[:_TEXT_LIMIT]
        nodes.append(
            {
                "run_id": run_id,
                "idx": index,
                "parent_idx": parent,
                "imagined": imagined,
                "name": task.name[:128],
                "kind": task.kind,
                "action": None if action is None else str(action.type),
                "step": None if step is None else str(step.type),
                "object": None if with_object is None else _object_type(with_object),
                "status": task.state.name,
                "start_time": _number(task.start_time),
                "end_time": _number(task.end_time),
                "failure_class": failure_class,
                "failure_message": message,
                "origin": origin,
            }
        )
        if action is not None and action.type in _PARAMETER_ACTIONS:
            params.append(
                {
                    "run_id": run_id,
                    "node_idx": index,
                    "imagined": imagined,
                    "action": str(action.type),
                    "status": task.state.name,
                    "failure_class": failure_class,
                    **_parameters(task, action),
                }
            )
    return nodes, params


def _surface(task: cpl.Task, key: str) -> str | None:
    """The surface named by the enclosing transport's ``key`` location (``location`` for
    the pick, ``target`` for the place): its ``urdf-name``."""
    from executive import action_of

    t: cpl.Task | None = task
    while t is not None:
        action = action_of(t)
        if action is not None and action.type == "transporting":
            loc = action.get(key)
            on = loc.get("on") if loc is not None and hasattr(loc, "get") else None
            name = on.get("urdf-name") if on is not None and hasattr(on, "get") else None
            return None if name is None else str(name)
        t = t.parent
    return None


def _xyz_yaw(pose: Any) -> tuple[float, float, float, float] | None:
    try:
        return (
            float(pose.position[0]),
            float(pose.position[1]),
            float(pose.position[2]),
            float(pose.yaw),
        )
    except (AttributeError, TypeError, IndexError, ValueError):
        return None


def _parameters(task: cpl.Task, action: Any) -> dict[str, Any]:
    """Arm, grasp, base pose (map) and the object (pick) or placing pose (place) in the
    base frame, as the action's grounding and designators give them; ``None`` where a
    value is unknown (e.g. the action failed before resolving it)."""
    from executive import Pose, Transform, newest_effective, previous_performed

    resolved = (task.annotations or {}).get("resolved")
    arguments = resolved[1] if isinstance(resolved, tuple) and len(resolved) == 2 else {}
    if not isinstance(arguments, Mapping):
        arguments = {}
    arm, grasp = arguments.get("arm"), arguments.get("grasp")
    newest = newest_effective(action) or action
    rel = None
    if action.type == "picking-up":
        obj = newest.get("object")
        transform = obj.get("transform") if obj is not None and hasattr(obj, "get") else None
        if isinstance(transform, Transform):
            rel = _xyz_yaw(transform.to_pose())
        surface = _surface(task, "location")
    else:
        target = newest.get("target")
        pose = target.get("pose") if target is not None and hasattr(target, "get") else None
        if isinstance(pose, Pose):
            rel = _xyz_yaw(pose)
        surface = _surface(task, "target")
    base = None
    navigation = previous_performed(task, "navigating")
    if navigation is not None:
        nav = newest_effective(navigation[1]) or navigation[1]
        location = nav.get("location")
        if isinstance(location, Pose):
            base = _xyz_yaw(location)
        elif location is not None and hasattr(location, "newest_effective"):
            located = newest_effective(location)
            if located is not None:
                try:
                    base = _xyz_yaw(located.reference())
                except Exception:  # a location that no longer resolves: unknown base
                    base = None
    return {
        "object": _object_type(action),
        "surface": surface,
        "arm": None if arm is None else str(arm),
        "grasp": None if grasp is None else str(grasp),
        "base_x": None if base is None else base[0],
        "base_y": None if base is None else base[1],
        "base_yaw": None if base is None else base[3],
        "rel_x": None if rel is None else rel[0],
        "rel_y": None if rel is None else rel[1],
        "rel_z": None if rel is None else rel[2],
        "rel_yaw": None if rel is None else rel[3],
    }
