"""Looking at the table before leaving it (issue 26): the objects the plan delivered are
perceived once more, and one found displaced or toppled since its placing is fixed or no
longer claimed.

Deliberate difference from CRAM: its demo claims an object delivered once its placing
returned and never looks back; an object knocked by a later placing, or toppled after its
release, was still reported delivered (a *phantom*). Here :func:`check_placed` looks at
the table once (one navigation and one head turn for all the objects, then one
``detecting`` per object, which moves nothing) and compares each perceived pose with
where the plan placed it. Only perception is read, never the world: a simulated real robot
sees the true world through its camera, a projection run its own.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping
from dataclasses import dataclass
from enum import Enum

import cpl
from executive import (
    DesignatorError,
    NavigationGoalInCollision,
    ObjectDesignator,
    Pose,
    a,
    an,
    perform,
)
from executive.retry import SolutionCursor, retry_scope

from ._common import CountedRetries, tally
from ._designators import robot_name
from .search import arms_out_of_view

__all__ = [
    "NEAR_PLACED",
    "UPRIGHT_DEG",
    "Placed",
    "PlacedState",
    "check_placed",
    "tilt_deg",
]

log = logging.getLogger(__name__)

#: Horizontal distance (m) between the perceived pose and the placing pose within which an
#: object is where the plan put it (the delivery tolerance of ``aiocram.truth``).
NEAR_PLACED = 0.12
#: Tilt (degrees from upright) beyond which a perceived object counts as toppled (the
#: ``aiocram.truth`` threshold).
UPRIGHT_DEG = 15.0


class PlacedState(Enum):
    """What one look found of a placed object."""

    IN_PLACE = "in place"  # seen upright within NEAR_PLACED of its placing pose
    DISPLACED = "displaced"  # seen upright, farther than NEAR_PLACED
    TOPPLED = "toppled"  # seen tilted more than UPRIGHT_DEG
    UNSEEN = "unseen"  # not perceived from the table's viewpoint


@dataclass(frozen=True, slots=True)
class Placed:
    """The verdict on one placed object: ``state``; ``perceived`` the designator perception
    returned (None when unseen)."""

    name: str
    state: PlacedState
    perceived: ObjectDesignator | None = None


def tilt_deg(pose: Pose) -> float:
    """Degrees between ``pose``'s z axis and the vertical."""
    return math.degrees(math.acos(max(-1.0, min(1.0, float(pose.matrix()[2, 2])))))


def _verdict(name: str, placed: Pose, perceived: ObjectDesignator) -> Placed:
    pose = perceived.get("pose")
    if not isinstance(pose, Pose):
        return Placed(name, PlacedState.UNSEEN, perceived)
    if tilt_deg(pose) > UPRIGHT_DEG:
        return Placed(name, PlacedState.TOPPLED, perceived)
    (x, y, _), (px, py, _) = pose.position, placed.position
    if math.hypot(float(x) - float(px), float(y) - float(py)) > NEAR_PLACED:
        return Placed(name, PlacedState.DISPLACED, perceived)
    return Placed(name, PlacedState.IN_PLACE, perceived)


#: Height (m) above the highest placing pose that the look aims at: a point among the
#: objects, not inside one (``visible-for`` rays to a point inside an object are blocked
#: by that object, and no viewpoint is found).
LOOK_ABOVE = 0.10


#: Further viewpoints tried when the base cannot get to one (``table-look`` retries).
LOOK_RETRIES = 3


def _centre(poses: Mapping[str, Pose]) -> Pose:
    """The point the look aims at: above the middle of the placing poses."""
    n = len(poses)
    sx = sum(float(p.position[0]) for p in poses.values())
    sy = sum(float(p.position[1]) for p in poses.values())
    top = max(float(p.position[2]) for p in poses.values())
    return Pose((sx / n, sy / n, top + LOOK_ABOVE))


@cpl.plan(name="check-table")
async def check_placed(placed: Mapping[str, tuple[str, Pose]]) -> dict[str, Placed]:
    """Look at the placed objects once and say where each is.

    ``placed``: object name -> (its type, the map pose the plan placed it at). The robot
    goes where the centre of those poses is visible, moves empty arms out of view, turns
    its head there and detects each object (``detecting``, by type and name). An object
    not detected from there gets one more head turn, towards its own placing pose.
    Returns name -> :class:`Placed`. A failure of the look itself (no viewpoint, the
    navigation failed) is logged and counted (``island-check-failed``) and the objects
    are reported ``UNSEEN``: the plan then cannot vouch for them."""
    if not placed:
        return {}
    for name, entry in placed.items():
        if not (
            isinstance(entry, tuple)
            and len(entry) == 2
            and isinstance(entry[0], str)
            and isinstance(entry[1], Pose)
        ):
            raise TypeError(
                f"check_placed takes {{name: (type, placing Pose)}}, got {name!r}: {entry!r}"
            )
    centre = _centre({n: p for n, (_, p) in placed.items()})
    failures = (cpl.PlanFailure, DesignatorError)

    async def look() -> bool:
        views = SolutionCursor(
            a.location(visible_for=robot_name(), location=a.location(pose=centre))
        )

        @retry_scope(NavigationGoalInCollision, views, CountedRetries(LOOK_RETRIES, "table-look"))
        async def go() -> None:
            await perform(an.action(type="navigating", location=views.current))

        await go()
        await arms_out_of_view()
        await perform(an.action(type="turning-towards", target=a.location(pose=centre)))
        return True

    def look_failed(failure: BaseException) -> None:
        log.warning("could not look at the placed objects: %s", failure)
        tally("island-check-failed")
        cpl.return_(False)

    looked = await cpl.with_failure_handling(look, [(failures, look_failed)])
    verdicts: dict[str, Placed] = {}
    for name, (otype, pose) in placed.items():
        if not looked:
            verdicts[name] = Placed(name, PlacedState.UNSEEN)
            continue
        verdicts[name] = await _detect(name, otype, pose)
    return verdicts


async def _detect(name: str, otype: str, pose: Pose) -> Placed:
    failures = (cpl.PlanFailure, DesignatorError)
    for attempt in range(2):

        async def detect(turn: bool = attempt > 0) -> ObjectDesignator | None:
            if turn:
                await perform(an.action(type="turning-towards", target=a.location(pose=pose)))
            found: ObjectDesignator = await perform(
                an.action(type="detecting", object=an.object(type=otype, name=name))
            )
            return found

        perceived = await cpl.with_failure_handling(
            detect, [(failures, lambda _f: cpl.return_(None))]
        )
        if perceived is not None:
            return _verdict(name, pose, perceived)
    return Placed(name, PlacedState.UNSEEN)
