"""Household object types of the projection world: primitive collision geometry, mass,
colour, their size (AABB extents at identity) and their grasps (from
:mod:`executive.knowledge`).

Object frames: the origin is the centre of the main body (box centre, cylinder axis
centre, bowl centre of its AABB), z up, so an object stands on a surface at
``z = top + size[2] / 2``. Unknown types raise :class:`LookupError` naming the known ones.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType

from executive import knowledge

__all__ = ["OBJECT_TYPES", "ObjectType", "Shape", "object_type"]

Vec3 = tuple[float, float, float]


@dataclass(frozen=True)
class Shape:
    """A primitive: ``box`` (size = full extents) or ``cylinder`` (size = (radius, length,
    0)), placed at ``xyz``/``rpy`` in the object frame."""

    kind: str
    size: Vec3
    xyz: Vec3 = (0.0, 0.0, 0.0)
    rpy: Vec3 = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class ObjectType:
    """A spawnable type. ``size``: AABB extents at identity (x, y, z) in metres."""

    name: str
    shapes: tuple[Shape, ...]
    mass: float
    rgba: tuple[float, float, float, float]
    size: Vec3

    @property
    def grasps(self) -> tuple[str, ...]:
        """Grasp names in CRAM's enumeration order (from :mod:`executive.knowledge`)."""
        return knowledge.grasps(self.name)

    @property
    def urdf_name(self) -> str:
        """File name of the generated URDF under ``assets/objects``."""
        return f"{self.name}.urdf"


def _ring(radius: float, thickness: float, height: float, z: float, n: int) -> tuple[Shape, ...]:
    """``n`` wall boxes forming a ring with outer radius ``radius``."""
    centre = radius - thickness / 2.0
    chord = 2.0 * radius * math.tan(math.pi / n) + 0.002
    out = []
    for k in range(n):
        a = 2.0 * math.pi * k / n
        out.append(
            Shape(
                "box",
                (thickness, round(chord, 6), height),
                (round(centre * math.cos(a), 6), round(centre * math.sin(a), 6), z),
                (0.0, 0.0, round(a, 6)),
            )
        )
    return tuple(out)


def _build() -> Mapping[str, ObjectType]:
    bowl_h, bowl_r, base_t = 0.055, 0.08, 0.01
    bowl = ObjectType(
        "bowl",
        (
            Shape("cylinder", (0.07, base_t, 0.0), (0.0, 0.0, -bowl_h / 2 + base_t / 2)),
            *_ring(bowl_r, 0.01, bowl_h - base_t, base_t / 2, 12),
        ),
        0.15,
        (0.9, 0.9, 0.85, 1.0),
        (0.16, 0.16, bowl_h),
    )
    cup = ObjectType(
        "cup",
        (
            Shape("cylinder", (0.04, 0.10, 0.0)),
            Shape("box", (0.025, 0.015, 0.06), (0.0525, 0.0, 0.0)),
        ),
        0.2,
        (0.8, 0.1, 0.1, 1.0),
        (0.105, 0.08, 0.10),
    )
    spoon = ObjectType(
        "spoon",
        (Shape("box", (0.16, 0.03, 0.015)),),
        0.03,
        (0.1, 0.2, 0.9, 1.0),
        (0.16, 0.03, 0.015),
    )
    cereal = ObjectType(
        "breakfast-cereal",
        (Shape("box", (0.19, 0.07, 0.29)),),
        0.4,
        (0.95, 0.75, 0.1, 1.0),
        (0.19, 0.07, 0.29),
    )
    milk = ObjectType(
        "milk",
        (Shape("box", (0.06, 0.095, 0.2)),),
        1.0,
        (0.95, 0.95, 1.0, 1.0),
        (0.06, 0.095, 0.2),
    )
    plate = ObjectType(
        "plate",
        (Shape("cylinder", (0.13, 0.02, 0.0)),),
        0.4,
        (0.7, 0.7, 0.7, 1.0),
        (0.26, 0.26, 0.02),
    )
    return MappingProxyType({t.name: t for t in (bowl, cup, spoon, cereal, milk, plate)})


#: Every spawnable type by name.
OBJECT_TYPES: Mapping[str, ObjectType] = _build()


def object_type(name: str) -> ObjectType:
    """The type called ``name``; unknown -> :class:`LookupError` naming the known types."""
    try:
        return OBJECT_TYPES[name]
    except (KeyError, TypeError):
        raise LookupError(
            f"unknown object type {name!r}; known types: {', '.join(sorted(OBJECT_TYPES))}"
        ) from None
