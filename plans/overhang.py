"""The overhang grasp (issue 26): a box lying flat on a counter, wider than the gripper on
every side that faces up, is pushed over the counter's edge until one end sticks out, and
that end is grasped from outside the counter, from the side, the fingers closing
vertically across the box's thickness.

A side grasp of the type whose approach is horizontal and whose fingers close vertically
as the box lies (:func:`executive.knowledge.fits_overhanging`: the breakfast-cereal box
on its 0.19 x 0.29 m face, held by its ``back`` or ``front`` grasp across its 0.07 m)
would put the lower finger under the box, into the counter. It fits once the end the
gripper approaches sticks out over the counter's edge by :data:`OVERHANG_HOLD` (what
the fingers hold) plus :data:`OVERHANG_MARGIN` (the lower fingertip clear of the edge),
measured from the box's believed pose and the footprint of the kitchen surface it lies
on (:func:`overhang_geometry`, the belief's kitchen surfaces of
:func:`plans.pushing.counter_footprints`), with its centre still
:data:`OVERHANG_KEEP` inside the edge (it must not tip over the edge). The grasp then
reaches :data:`OVERHANG_HOLD` deep into that end
(:func:`overhang_grasp_depth`: less the arm's
:attr:`executive.GripperDescription.finger_reach`).

:func:`push_until_overhanging` gets it there: of the grasps, arms and directions the
geometry allows, the shortest push (the direction against the grasp's approach, towards
the edge) is made with :func:`plans.pushing.push_object` (only along that direction: a
push at an angle would turn the end away from the edge; the belief's probe, the object's
own path checked clear, re-perceived after; performed as a ``pushing-object`` action, so
the box is the push's own object and its moving is no knock), then measured again; at most
:data:`OVERHANG_PUSHES` pushes. Where it cannot (no kitchen surface under it, no edge
within reach of a push that keeps its centre on the counter, every push blocked or
unreachable) :class:`plans.toppled.ObjectToppledUngraspable` names why, logged and
counted (``toppled-ungraspable``). The placing then holds it by the same grasp, now
horizontal, and puts it down upright (:mod:`plans.pick_place`).

In an imagined run (a projecting environment whose world can spawn objects,
:class:`executive.ObjectSpawning`) a push moves nothing (no contacts are simulated
there): the imagination puts the object where the push was planned to leave it, so that
the imagined fetch goes on as the real one would.

Deliberate addition (beyond CRAM): CRAM's grasps assume an upright object and its plans
never push an object to make it graspable; a box lying flat was lost for good.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from executive import (
    ObjectDesignator,
    ObjectSpawning,
    Pose,
    Transform,
    an,
    current_environment,
    knowledge,
    perform,
)

from ._common import arm_description, arm_names, object_label, tally
from .pushing import ObjectUnpushable, counter_footprints, push_path_clear
from .toppled import ObjectToppledUngraspable

__all__ = [
    "OVERHANG_ACROSS",
    "OVERHANG_HALF_WIDTH",
    "OVERHANG_HOLD",
    "OVERHANG_KEEP",
    "OVERHANG_MARGIN",
    "OVERHANG_MIN_PUSH",
    "OVERHANG_PUSHES",
    "OVERHANG_SLACK",
    "Overhang",
    "OverhangFit",
    "overhang_geometry",
    "overhang_grasp_depth",
    "overhang_options",
    "overhanging_grasps",
    "push_until_overhanging",
]

log = logging.getLogger(__name__)

#: How much of the box (m, along the approach) the fingers hold.
OVERHANG_HOLD = 0.03
#: How far (m) beyond what the fingers hold the end sticks out: the lower fingertip clears
#: the counter's edge by this.
OVERHANG_MARGIN = 0.02
#: A push aims this much (m) beyond the overhang needed: a push that falls a little short,
#: or a box re-perceived a little off, still leaves enough.
OVERHANG_SLACK = 0.015
#: The shortest push (m): a shorter one moves the box by little more than the hand's give
#: (measured: pushes of 0.02 and 0.03 m moved it 0.01 m each).
OVERHANG_MIN_PUSH = 0.04
#: The box's centre stays at least this far (m) inside the edge, along the push: it
#: rests on the counter, never tips over the edge (measured: a 0.245 m push overshot by
#: 0.008 m).
OVERHANG_KEEP = 0.02
#: Half the width (m) across the overhanging end that must stick out, either side of where
#: the grasp holds it: the fingers and a margin.
OVERHANG_HALF_WIDTH = 0.04
#: How far (m) from the middle of the end, across it, the fingers may hold it (the
#: farther, the more the box turns in the hand when lifted).
OVERHANG_ACROSS = 0.07
#: Pushes made before giving up.
OVERHANG_PUSHES = 2
#: The object's lowest point within this (m) of the surface's top: it lies on it.
ON_SURFACE = 0.05
#: A box whose centre a push left on the counter's edge, or this far (m) beyond it, but
#: that rests on the counter still (its lowest point at the top: measured, one pushed
#: 0.04 m farther than planned balanced there) is held by its overhanging end as well.
ON_EDGE = 0.02

Footprint = tuple[float, float, float, float]


@dataclass(frozen=True)
class Overhang:
    """How one grasp of one arm could hold a lying object by an end that overhangs the
    surface it lies on. ``direction``: unit, map x/y, against the grasp's approach (the
    end the gripper comes to, and the way to push it); ``overhang``: how far (m) that end
    sticks out over the edge now (negative: short of it); ``push``: how far to push it
    (0: it sticks out enough now); ``inset``: how far its centre is inside the edge after
    that push; ``across``: where across the end the fingers hold it
    (:func:`executive.knowledge.grasp_poses`); ``depth``: how deep the tool frame goes
    into it (:func:`overhang_grasp_depth`); ``why``: None if this works, else why not."""

    arm: str
    grasp: str
    surface: str
    direction: tuple[float, float]  # invariant: unit length
    overhang: float
    push: float  # invariant: >= 0; 0 exactly when overhang >= needed
    inset: float
    across: float
    depth: float
    why: str | None

    @property
    def ready(self) -> bool:
        """It sticks out enough to be grasped now."""
        return self.why is None and self.push == 0.0


def _exit(p: Sequence[float], u: Sequence[float], box: Footprint) -> float | None:
    """How far along ``u`` from ``p`` the line through ``p`` leaves the rectangle ``box``
    (negative: ``p`` is that far beyond it); None: the line misses it."""
    lo, hi = (box[0], box[1]), (box[2], box[3])
    t_in, t_out = -math.inf, math.inf
    for i in range(2):
        if abs(u[i]) < 1e-12:
            if not lo[i] <= p[i] <= hi[i]:
                return None
            continue
        a, b = (lo[i] - p[i]) / u[i], (hi[i] - p[i]) / u[i]
        t_in, t_out = max(t_in, min(a, b)), min(t_out, max(a, b))
    return None if t_in > t_out else t_out


def _needed() -> float:
    return OVERHANG_HOLD + OVERHANG_MARGIN


@dataclass(frozen=True)
class OverhangFit:
    """The geometry of an overhang grasp (see :func:`overhang_geometry`)."""

    direction: tuple[float, float]  # invariant: unit; against the approach, map x/y
    overhang: float  # how far (m) the held part of the end sticks out (negative: short)
    push: float  # how far (m) to push it along direction; 0: it sticks out enough now
    inset: float  # how far (m) its centre is inside the edge after that push
    across: float  # where across the end it is held (m, see knowledge.grasp_poses)


def overhang_geometry(
    object_type: str, grasp: str, object_pose: Pose | Transform, footprint: Footprint
) -> OverhangFit:
    """For a lying object of ``object_type`` at ``object_pose`` (map) on a surface whose
    footprint is ``footprint`` (map x_lo, y_lo, x_hi, y_hi): the direction (unit, map x/y)
    against ``grasp``'s approach; how far (m) the end of the object on that side sticks
    out over the footprint's edge along it where the fingers go in, the strip
    :data:`OVERHANG_HALF_WIDTH` either side of where across the end it is held (the
    lesser of its two sides); where across the end to hold it: of the grasp's own
    place, the middle and :data:`OVERHANG_ACROSS` to either side, the one that sticks
    out farthest (a box turned on the counter sticks out more at one corner); how far to
    push it along the direction so that it sticks out :data:`OVERHANG_HOLD` +
    :data:`OVERHANG_MARGIN` + :data:`OVERHANG_SLACK`, at least :data:`OVERHANG_MIN_PUSH`
    (0 when it sticks out the first two already); and how far its centre is then inside
    the edge, along the direction
    (negative: beyond). Geometry only: whether the grasp fits the gripper is
    :func:`executive.knowledge.fits_overhanging`'s. A centre outside the footprint by
    more than :data:`ON_EDGE`: :class:`ValueError`."""
    m = object_pose.matrix()
    rotation = m[:3, :3]
    g = knowledge.grasp(object_type, grasp)
    approach = rotation @ np.array(g.rotation)[:, 2]
    norm = math.hypot(approach[0], approach[1])
    if norm < 1e-6:
        raise ValueError(f"the {grasp} grasp approaches the {object_type} vertically as it lies")
    u = (-approach[0] / norm, -approach[1] / norm)
    size = np.array(knowledge.object_knowledge(object_type).size)
    along = float(np.abs(rotation.T @ np.array((u[0], u[1], 0.0))) @ size)
    # across the end: the grasp's third axis (neither approach nor closing), in the map
    axis = np.array(g.rotation)[:, 1]
    b = rotation @ axis
    width = float(np.abs(axis) @ size)
    c = (float(m[0, 3]), float(m[1, 3]))
    inside = _exit(c, u, footprint)
    if inside is None or inside < -ON_EDGE or not _within(c, _grown(footprint, ON_EDGE)):
        raise ValueError(f"the {object_type}'s centre {c} is not over the footprint {footprint}")
    reach = max(0.0, min(OVERHANG_ACROSS, width / 2 - OVERHANG_HALF_WIDTH))
    own = float(np.array(g.translation) @ axis)
    best: tuple[float, float] | None = None  # (sticks out, across)
    for across in dict.fromkeys((own, 0.0, reach, -reach)):
        sticks_out = math.inf
        for k in (-1.0, 1.0):
            f = across + k * OVERHANG_HALF_WIDTH
            q = (c[0] + u[0] * along / 2 + b[0] * f, c[1] + u[1] * along / 2 + b[1] * f)
            out = _exit(q, u, footprint)
            sticks_out = min(sticks_out, math.inf if out is None else -out)
        if math.isinf(sticks_out):  # both lines miss the footprint: off it entirely
            sticks_out = along / 2 - inside
        if best is None or sticks_out > best[0] + 1e-3:
            best = (sticks_out, across)
    assert best is not None
    sticks_out, across = best
    push = (
        0.0
        if sticks_out >= _needed()
        else max(OVERHANG_MIN_PUSH, _needed() + OVERHANG_SLACK - sticks_out)
    )
    after = _exit((c[0] + u[0] * push, c[1] + u[1] * push), u, footprint)
    return OverhangFit(
        (float(u[0]), float(u[1])),
        float(sticks_out),
        float(push),
        -math.inf if after is None else float(after),
        float(across),
    )


def _grown(box: Footprint, by: float) -> Footprint:
    return (box[0] - by, box[1] - by, box[2] + by, box[3] + by)


def _within(p: Sequence[float], box: Footprint) -> bool:
    return box[0] <= p[0] <= box[2] and box[1] <= p[1] <= box[3]


def _world() -> Any:
    return current_environment().world


def _surface_under(name: str) -> tuple[str, Footprint] | None:
    """The kitchen surface (the belief's: :func:`plans.pushing.counter_footprints`) the
    object ``name`` lies on: its centre over the footprint (or beyond its edge by no more
    than :data:`ON_EDGE`), its lowest point within :data:`ON_SURFACE` of the surface's
    top. None: on none of them."""
    world = _world()
    x, y, _z = world.object_pose(name).position
    (_lx, _ly, lz), _hi = world.object_aabb(name)
    for link, box in counter_footprints():
        top = float(world.link_aabb(link)[1][2])
        if _within((x, y), _grown(box, ON_EDGE)) and abs(lz - top) <= ON_SURFACE:
            return link, box
    return None


def overhang_options(name: str, object_type: str) -> tuple[Overhang, ...]:
    """Every (arm, grasp) by which the object ``name`` (known to the belief by name, of
    ``object_type``, lying) could be held by an overhanging end
    (:func:`executive.knowledge.fits_overhanging` with the arm's gripper opening), with
    the push each needs on the surface it lies on (:func:`overhang_geometry`); ``why``
    set where the push would leave its centre less than :data:`OVERHANG_KEEP` inside the
    edge. Empty: no grasp of the type fits that way, or it lies on no kitchen surface."""
    world = _world()
    pose = world.object_pose(name)
    surface = _surface_under(name)
    if surface is None:
        return ()
    link, box = surface
    out = []
    for arm in arm_names():
        opening = arm_description(arm).gripper.max_opening
        for grasp in knowledge.grasps(object_type):
            if not knowledge.fits_overhanging(object_type, grasp, pose, opening):
                continue
            fit = overhang_geometry(object_type, grasp, pose, box)
            why = None
            if fit.push > 0.0 and fit.inset < OVERHANG_KEEP:  # resting there already: stays
                why = (
                    f"to stick out {_needed():.2f} m over the edge of {link} its centre "
                    f"would be {fit.inset:.3f} m inside it (at least {OVERHANG_KEEP:.2f} m)"
                )
            out.append(
                Overhang(
                    arm,
                    grasp,
                    link,
                    fit.direction,
                    fit.overhang,
                    fit.push,
                    fit.inset,
                    fit.across,
                    overhang_grasp_depth(arm),
                    why,
                )
            )
    return tuple(out)


def _no_options(name: str) -> str:
    """Why :func:`overhang_options` has none for ``name``, for the failure's message."""
    world = _world()
    x, y, _z = world.object_pose(name).position
    (_lx, _ly, lz), _hi = world.object_aabb(name)
    if _surface_under(name) is None:
        return f"it lies on no kitchen surface (at {x:.2f}, {y:.2f}, its lowest point {lz:.2f} m)"
    return "no grasp of its type holds it from the side as it lies (tilted)"


def overhang_grasp_depth(arm: str) -> float:
    """How deep (m) into the overhanging end the ``arm``'s tool frame goes: the fingers
    hold :data:`OVERHANG_HOLD` of it (:attr:`executive.GripperDescription.finger_reach`
    less, never negative)."""
    return max(0.0, OVERHANG_HOLD - arm_description(arm).gripper.finger_reach)


def overhanging_grasps(name: str | None, object_type: str, arm: str) -> tuple[Overhang, ...]:
    """How ``arm`` can hold the lying object ``name`` now, by the end that sticks out
    over the surface's edge enough (:attr:`Overhang.ready`), one per grasp. An object
    the belief does not know by name, or whose extent it cannot tell: none."""
    if not isinstance(name, str):
        return ()
    try:
        options = overhang_options(name, object_type)
    except LookupError:
        return ()
    return tuple(o for o in options if o.arm == arm and o.ready)


def _imagine_pushed(name: str, object_type: str, before: Pose, expected: Pose) -> None:
    """In an imagined run, put the object where the push was planned to leave it (no
    contacts are simulated there); on a real robot: nothing."""
    env = current_environment()
    world = env.world
    if not env.projecting or not isinstance(world, ObjectSpawning):
        return
    world.remove_object(name)
    try:
        world.spawn_object(name, object_type, expected)
    except ValueError as refused:
        # where it would reach into something: imagined where it was (counted, logged)
        log.info("imagined push of %s not applied: %s", name, refused)
        tally("overhang-imagined-unmoved")
        world.spawn_object(name, object_type, before)


async def push_until_overhanging(
    object_designator: ObjectDesignator, ungraspable: str = ""
) -> ObjectDesignator:
    """Push the perceived lying object over the edge of the kitchen surface it lies on
    until an end sticks out enough for an overhang grasp (see the module docstring);
    returns the newest designator. Already: nothing moves. Cannot:
    :class:`plans.toppled.ObjectToppledUngraspable` naming why (logged at WARNING,
    counted ``toppled-ungraspable``; ``ungraspable``: why no grasp fits from above, put
    first); every push made counted (``overhang-pushes``)."""
    name = object_designator.current().get("name")
    otype = object_designator.current().get("type")
    label = object_label(object_designator)
    why: list[str] = []
    if not isinstance(name, str) or not isinstance(otype, str):
        why.append("the designator names no object the belief knows")
    else:
        for attempt in range(OVERHANG_PUSHES + 1):
            try:
                options = overhang_options(name, otype)
            except LookupError as unknown:
                why.append(f"the belief cannot tell its extent ({unknown})")
                break
            for o in options:
                log.info(
                    "%s by its %s end with the %s arm: sticks out %.3f m, push %.3f m, "
                    "centre then %.3f m inside (%s)",
                    name,
                    o.grasp,
                    o.arm,
                    o.overhang,
                    o.push,
                    o.inset,
                    o.why or "fits",
                )
            if any(o.ready for o in options):
                return object_designator
            if not options:
                why.append(_no_options(name))
                break
            why = [f"{o.arm} {o.grasp}: {o.why}" for o in options if o.why is not None]
            if attempt == OVERHANG_PUSHES:
                why.append(f"{OVERHANG_PUSHES} pushes left it short of the edge")
                break
            pushed = False
            tried: set[tuple[float, float]] = set()
            for o in sorted((o for o in options if o.why is None), key=lambda o: o.push):
                key = (round(o.direction[0], 3), round(o.direction[1], 3))
                if key in tried:
                    continue
                tried.add(key)
                blocked = push_path_clear(name, o.direction, o.push)
                if blocked is not None:
                    why.append(f"towards the edge of {o.surface} ({o.grasp} grasp): {blocked}")
                    continue
                before = _world().object_pose(name)
                try:
                    # performed as an action: the box is the push's own object, so
                    # moving it is not a knock (aiocram.knocks)
                    object_designator = await perform(
                        an.action(
                            type="pushing-object",
                            object=object_designator,
                            direction=o.direction,
                            distance=o.push,
                            angles=(0.0,),
                        )
                    )
                except ObjectUnpushable as failure:
                    why.append(f"towards the edge of {o.surface} ({o.grasp} grasp): {failure}")
                    continue
                tally("overhang-pushes")
                pushed = True
                moved = Pose(
                    (
                        before.position[0] + o.direction[0] * o.push,
                        before.position[1] + o.direction[1] * o.push,
                        before.position[2],
                    ),
                    before.orientation,
                )
                _imagine_pushed(name, otype, before, moved)
                break
            if not pushed:
                break
    reason = f"no end of it can be pushed over a counter's edge: {'; '.join(why)}"
    if ungraspable:
        reason = f"{ungraspable}; {reason}"
    log.warning("%s cannot be picked as it lies: %s", label, reason)
    tally("toppled-ungraspable")
    raise ObjectToppledUngraspable(reason, object=label)
