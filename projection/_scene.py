"""Scenes for the simulated real robot: a true world and a belief world built from the
same assets, the true one with CRAM's demo objects (:data:`DEMO_OBJECTS`, from
:mod:`executive.kitchen`) or the caller's."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Literal

import numpy as np

from executive import Pose, kitchen
from projection._objects import object_type
from projection._real_body import settle
from projection._world import World

__all__ = ["DEMO_OBJECTS", "SceneObject", "make_world_pair"]

SceneObject = tuple[str, Pose] | tuple[str, Pose, str]

#: CRAM's demo objects (map; z is replaced by the resting height on the sink counter; the
#: spoon lies in the drawer, attached to it): name -> (type, pose[, attached link]).
DEMO_OBJECTS: Mapping[str, SceneObject] = {
    f"{t}-1": (
        (t, kitchen.DEMO_POSES[t])
        if t not in kitchen.DEMO_ATTACHMENTS
        else (t, kitchen.DEMO_POSES[t], kitchen.DEMO_ATTACHMENTS[t])
    )
    for t in kitchen.DEMO_POSES  # in CRAM's fixed scene's spawning order
}


def make_world_pair(
    seed: int | None = 0,
    *,
    objects: Mapping[str, SceneObject] | None = None,
    belief_objects: Literal["none", "exact", "noisy"] = "none",
    noise: tuple[float, float] = (0.02, 0.1),
    gui: bool = False,
) -> tuple[World, World]:
    """Two worlds from the same assets: ``(true_world, belief_world)``, robot and kitchen
    identical. ``objects`` (default :data:`DEMO_OBJECTS`; name -> (type, pose[, link to
    attach to])) are spawned in the true world (types that rest on a surface get their z
    from the counter below), which then settles for 100 physics steps. The belief knows
    them not at all (``"none"``: perception teaches it), exactly (``"exact"``), or with
    Gaussian ``noise`` = (x/y std m, yaw std rad) drawn from ``seed`` (``"noisy"``).
    ``gui=True`` shows the true world in a PyBullet window (needs a display). The caller
    closes both worlds. Bad ``belief_objects``: ValueError."""
    if belief_objects not in ("none", "exact", "noisy"):
        raise ValueError(
            f"belief_objects must be 'none', 'exact' or 'noisy', got {belief_objects!r}"
        )
    true_world, belief_world = World(seed=seed, gui=gui), World(seed=seed)
    try:
        spec = DEMO_OBJECTS if objects is None else objects
        for name, entry in spec.items():
            otype, pose = entry[0], entry[1]
            if objects is None and len(entry) == 2:  # the demo: rest on the sink counter
                top = true_world.link_aabb(kitchen.SINK_SURFACE)[1][2]
                z = top + object_type(otype).size[2] / 2.0 + 0.001
                pose = Pose((pose.position[0], pose.position[1], z), pose.orientation)
            true_world.spawn_object(name, otype, pose)
            if len(entry) == 3:
                true_world.attach(name, entry[2])
        settle(true_world, 100)
        rng = np.random.default_rng(seed)
        if belief_objects != "none":
            for name, otype in true_world.objects.items():
                pose = true_world.object_pose(name)
                if belief_objects == "noisy":
                    d = rng.normal(0.0, 1.0, 3) * (noise[0], noise[0], noise[1])
                    x, y, z = pose.position
                    turn = Pose.from_xyz_yaw(0, 0, 0, float(d[2])).as_rotation()
                    pose = Pose(
                        (x + float(d[0]), y + float(d[1]), z),
                        (turn * pose.as_rotation()).as_quat(),
                    )
                belief_world.spawn_object(name, otype, pose)
                link = true_world.attachments.get(name)
                if link is not None:
                    belief_world.attach(name, link)
    except BaseException:
        true_world.close()
        belief_world.close()
        raise
    return true_world, belief_world
