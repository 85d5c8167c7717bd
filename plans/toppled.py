"""Toppled objects: which grasps can hold an object that lies (a carton or box knocked on
its side), and the typed failure when none can.

An object lies (toppled, on one of its sides) when its z axis is tilted more than
:data:`executive.knowledge.TOPPLED_TILT` (45 degrees) from the vertical; one that only
leans keeps every grasp. A lying object is picked the way it lies, from above: of its type's grasps
only those whose approach points down as it lies and whose fingers close across no more
than the arm's gripper opens (:attr:`executive.GripperDescription.max_opening`; the
widths from the type's size in :mod:`executive.knowledge`) are tried; the placing then
puts it down upright, holding it by the same grasp, now horizontal
(:mod:`plans.pick_place`). That sets it upright on the way: nothing is set upright where
it lies first.

A box lying on its broad face (the cereal box on its 0.19 x 0.29 m face) is wider than
the gripper on every side that faces up: no grasp fits, and from the side one finger
would have to go under it, into the counter. ``fetch`` then pushes it over the edge of
the counter it lies on and grasps the end that sticks out from the side
(:mod:`plans.overhang`); where no push can do that, it fails with
:class:`ObjectToppledUngraspable`, naming the face it lies on, the widths and why no push
works, logged and counted (``toppled-ungraspable``), before anything moves: CRAM's plans
(and this project's before) spent every relocation and pick check on it.

Deliberate difference from CRAM: its grasps assume an upright object, so a toppled one
was probed (and failed) like an upright one; it never picked an object the way it lies,
nor told why a toppled one could not be picked.
"""

from __future__ import annotations

import logging

import numpy as np

from executive import ObjectUnfetchable, Pose, Transform, knowledge

from ._common import arm_description, arm_names, object_label, tally

__all__ = [
    "ObjectToppledUngraspable",
    "check_graspable_as_it_lies",
    "lying_grasps",
    "ungraspable_as_it_lies",
]

log = logging.getLogger(__name__)


class ObjectToppledUngraspable(ObjectUnfetchable):
    """An object lying (toppled) so that none of its grasps fits any of the robot's
    grippers from above: every face that faces up is wider than the gripper opens (an
    ``object-unfetchable``). Deliberate addition: CRAM could not tell."""

    default_message = "Object lies toppled with no grasp that fits the gripper."


def lying_grasps(
    object_type: str, object_transform: Transform | Pose, grasps: tuple[str, ...], arm: str
) -> tuple[str, ...]:
    """Of ``grasps`` (the type's, in order), those the robot's ``arm`` can hold the
    object by as ``object_transform`` (in an upright frame: the map or the base) has it:
    all of them for an upright object; for a lying one those that approach from above and
    close across no more than the arm's gripper opens
    (:func:`executive.knowledge.fits_lying`)."""
    if not knowledge.is_lying(object_transform):
        return grasps
    opening = arm_description(arm).gripper.max_opening
    return tuple(
        g for g in grasps if knowledge.fits_lying(object_type, g, object_transform, opening)
    )


def _face_up(object_type: str, object_transform: Transform | Pose) -> tuple[float, float]:
    """The extents (m) of the object's face that faces up, as it lies."""
    size = np.array(knowledge.object_knowledge(object_type).size)
    rotation = object_transform.matrix()[:3, :3]
    vertical = int(np.argmax(np.abs(rotation[2, :])))  # the object axis pointing up
    a, b = (float(size[i]) for i in range(3) if i != vertical)
    return a, b


def check_graspable_as_it_lies(
    object_designator: object, object_type: str, object_transform: Transform | Pose
) -> None:
    """Raise :class:`ObjectToppledUngraspable` (logged at WARNING, counted as
    ``toppled-ungraspable``) when the object lies and no grasp of its type fits any of
    the robot's arms (:func:`lying_grasps`), naming the face that faces up, the widths
    the fingers would close across, and the grippers' openings
    (:func:`ungraspable_as_it_lies`). An upright object, or a lying one with a grasp
    that fits: nothing happens."""
    why = ungraspable_as_it_lies(object_type, object_transform)
    if why is None:
        return
    log.warning("%s cannot be picked as it lies: %s", object_label(object_designator), why)
    tally("toppled-ungraspable")
    raise ObjectToppledUngraspable(why, object=object_label(object_designator))


def ungraspable_as_it_lies(object_type: str, object_transform: Transform | Pose) -> str | None:
    """Why no grasp of ``object_type`` fits any of the robot's arms from above as
    ``object_transform`` has it lying (see :func:`check_graspable_as_it_lies`); None for
    an upright object or a lying one with a grasp that fits. Nothing is logged."""
    grasps = knowledge.grasps(object_type)
    arms = arm_names()
    if any(lying_grasps(object_type, object_transform, grasps, arm) for arm in arms):
        return None
    from_above = [
        g
        for g in grasps
        if knowledge.approach_down(object_type, g, object_transform)
        >= np.cos(knowledge.LYING_APPROACH_CONE)
    ]
    widths = ", ".join(f"{g} {knowledge.closing_width(object_type, g):.3f} m" for g in from_above)
    openings = ", ".join(f"{arm} {arm_description(arm).gripper.max_opening:.3f} m" for arm in arms)
    a, b = _face_up(object_type, object_transform)
    widest = max(arm_description(arm).gripper.max_opening for arm in arms)
    if from_above:
        reason = f"the grasps from above close across {widths}"
    elif min(a, b) > widest:
        reason = (
            f"from above it is {a:.3f} and {b:.3f} m across, and from the side a finger "
            "would have to go under it"
        )
    else:
        reason = "none of its type's grasps approaches it from above as it lies"
    return (
        f"the {object_type} lies toppled on its {a:.2f} x {b:.2f} m face: {reason}; "
        f"the grippers open {openings}"
    )
