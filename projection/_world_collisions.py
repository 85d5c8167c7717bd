"""Collision queries of a :class:`projection.World`: contacts of a body, and the robot's
collisions (with what it carries) against everything else."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import pybullet as pb

from projection._world_base import KITCHEN, WorldBase

__all__ = ["COLLISION_TOLERANCE", "Collisions", "Contact"]

COLLISION_TOLERANCE = 0.002  #: penetration (m) beyond which a contact is a collision


@dataclass(frozen=True)
class Contact:
    """One contact between two named bodies (links by name; ``distance`` < 0 =
    penetration)."""

    body_a: str
    link_a: str
    body_b: str
    link_b: str
    distance: float


class Collisions(WorldBase):
    """Contacts and robot collisions (a mixin of :class:`projection.World`)."""

    def contacts(self, name: str, tolerance: float = COLLISION_TOLERANCE) -> list[Contact]:
        """Current contacts of ``name`` (object, ``"pr2"`` or ``"kitchen"``) penetrating
        more than ``tolerance``; runs collision detection first."""
        c = self._check()
        body = self.body_of(name)
        pb.performCollisionDetection(physicsClientId=c)
        return [
            self._contact(q)
            for q in pb.getContactPoints(bodyA=body, physicsClientId=c)
            if q[8] < -tolerance
        ]

    def _contact(self, q: Sequence[Any]) -> Contact:
        def lname(body: int, index: int) -> str:
            if body in (self._robot, self._kitchen):
                return self._link_names.get((body, index), str(index))
            return "object"

        def bname(body: int) -> str:
            return "floor" if body == self._floor else self._bodies.get(body, str(body))

        return Contact(bname(q[1]), lname(q[1], q[3]), bname(q[2]), lname(q[2], q[4]), float(q[8]))

    def robot_collisions(self, ignore: Iterable[str] = ()) -> list[Contact]:
        """Collisions of the robot, and of objects attached to robot links, with anything
        except each other and the names in ``ignore``."""
        c = self._check()
        pb.performCollisionDetection(physicsClientId=c)
        return self._collisions(set(ignore), first_only=False)

    def robot_in_collision(self, ignore: Iterable[str] = ()) -> bool:
        """Whether :meth:`robot_collisions` is non-empty (faster: stops at the first)."""
        c = self._check()
        pb.performCollisionDetection(physicsClientId=c)
        return bool(self._collisions(set(ignore), first_only=True))

    def _collisions(self, ignore: set[str], first_only: bool) -> list[Contact]:
        c = self._c
        robot = self._robot
        carried = {
            self._objects[n].body
            for n, (link, _) in self._attached.items()
            if self._links[link][0] == robot
        }
        skip = (
            carried
            | {robot}
            | {self.body_of(n) for n in ignore if n in self._objects or n == KITCHEN}
        )
        out: list[Contact] = []
        tol = -COLLISION_TOLERANCE
        for q in pb.getContactPoints(bodyA=robot, physicsClientId=c):
            if q[8] < tol and q[2] not in skip:
                out.append(self._contact(q))
                if first_only:
                    return out
        for b in carried:
            for q in pb.getContactPoints(bodyA=b, physicsClientId=c):
                if q[8] < tol and q[2] not in skip:
                    out.append(self._contact(q))
                    if first_only:
                        return out
        return out
