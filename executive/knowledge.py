"""Robot-independent object knowledge (CRAM's ``kr-pp`` grasping tables at HEAD). What is
robot-specific (arms, tool frames, the standard-gripper -> tool rotation, named arm
configurations) is in the robot's :class:`executive.RobotDescription`.

Per object type: its grasps in CRAM's enumeration order, each with the grasp translation
and the *standard-gripper* rotation (CRAM's standard rotations table: the matrix's third
column is the approach axis in the object frame), and the pregrasp / 2nd-pregrasp / lift /
2nd-lift offsets, all in the **object frame** and *added* to the grasp translation; the
gripping effort (Nm) and the gripper opening (m).

:func:`grasp_poses` computes CRAM's five waypoints ``bTg = bTo · oTg′ · g′Tg`` where
``oTg′`` is the standard gripper in the object frame and ``g′Tg`` the standard-gripper ->
tool-frame rotation of the arm that grasps, passed in from the robot's description
(:attr:`executive.ArmDescription.standard_to_tool`). Unknown types or grasps raise
:class:`LookupError` naming the known ones. Everything here is immutable.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from types import MappingProxyType

import numpy as np

from executive._pose import Pose, Transform

__all__ = [
    "LIFT_OFFSET",
    "LYING_APPROACH_CONE",
    "LYING_TILT",
    "OVERHANG_APPROACH_CONE",
    "ROTATIONALLY_SYMMETRIC",
    "STANDARD_ROTATIONS",
    "TOPPLED_TILT",
    "Grasp",
    "ObjectKnowledge",
    "approach_down",
    "approach_extent",
    "closing_width",
    "fits_lying",
    "fits_overhanging",
    "grasp",
    "grasp_poses",
    "grasps",
    "gripper_opening",
    "gripping_effort",
    "is_lying",
    "known_types",
    "object_knowledge",
]

Vec3 = tuple[float, float, float]
Mat3 = tuple[Vec3, Vec3, Vec3]

#: The global lift offset (object frame), CRAM HEAD.
LIFT_OFFSET: Vec3 = (0.0, 0.0, 0.15)

#: CRAM's standard grasp rotations (rows), keyed by grasp; the third column is the approach.
STANDARD_ROTATIONS: Mapping[str, Mat3] = MappingProxyType(
    {
        # approach +x: the gripper starts on the object's -x side (towards a robot at -x)
        "back": ((0.0, 0.0, 1.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0)),
        # approach -x
        "front": ((0.0, 0.0, -1.0), (-1.0, 0.0, 0.0), (0.0, 1.0, 0.0)),
        # approach -y: the gripper starts on the +y side
        "left-side": ((1.0, 0.0, 0.0), (0.0, 0.0, -1.0), (0.0, 1.0, 0.0)),
        # approach +y
        "right-side": ((-1.0, 0.0, 0.0), (0.0, 0.0, 1.0), (0.0, 1.0, 0.0)),
        # approach -z, fingers closing along the object's y (across x)
        "top-across-x": ((0.0, 1.0, 0.0), (1.0, 0.0, 0.0), (0.0, 0.0, -1.0)),
        # approach -z, fingers closing along the object's x (across y)
        "top-across-y": ((1.0, 0.0, 0.0), (0.0, -1.0, 0.0), (0.0, 0.0, -1.0)),
    }
)


#: Types whose grasps ignore the object's orientation (CRAM's rotationally symmetric
#: types: picking replaces the object's rotation in the base frame by the identity, so a
#: grasp is computed as if the object faced the robot). CRAM HEAD declares none;
#: deliberate: the bowl is a ring here, and its random yaw otherwise put the rim grasp
#: where no arm could reach it without sweeping over the neighbouring objects.
ROTATIONALLY_SYMMETRIC: frozenset[str] = frozenset({"bowl"})


@dataclass(frozen=True)
class Grasp:
    """One grasp of an object type; vectors in the object frame (metres)."""

    name: str
    translation: Vec3
    rotation: Mat3  # standard gripper in the object frame (rows)
    pregrasp_offset: Vec3
    second_pregrasp_offset: Vec3
    lift_offset: Vec3 = LIFT_OFFSET
    second_lift_offset: Vec3 = LIFT_OFFSET

    def offsets(self) -> tuple[Vec3, Vec3, Vec3, Vec3, Vec3]:
        """Offsets of the five waypoints [pregrasp, 2nd-pregrasp, grasp, lift, 2nd-lift]."""
        zero = (0.0, 0.0, 0.0)
        return (
            self.pregrasp_offset,
            self.second_pregrasp_offset,
            zero,
            self.lift_offset,
            self.second_lift_offset,
        )


@dataclass(frozen=True)
class ObjectKnowledge:
    """What the robot knows about a type: grasps (enumeration order), effort, opening,
    and its ``size``: the extents (m) along the object frame's x, y and z (its bounding
    box standing upright; which of them the fingers close across depends on how it lies,
    see :func:`closing_width`)."""

    type: str
    grasps: tuple[Grasp, ...]
    effort: float
    opening: float
    size: Vec3  # invariant: the projection world's model of the type has these extents

    def grasp(self, name: str) -> Grasp:
        for g in self.grasps:
            if g.name == name:
                return g
        raise LookupError(
            f"object type {self.type!r} has no grasp {name!r}; "
            f"known grasps: {', '.join(g.name for g in self.grasps)}"
        )


def _side_grasps(
    back: Vec3, front: Vec3, left: Vec3 | None, right: Vec3 | None, order: tuple[str, ...]
) -> tuple[Grasp, ...]:
    """Side grasps with CRAM's cup-like pregrasp offsets, in the given order."""
    table: dict[str, Grasp] = {
        "back": Grasp("back", back, STANDARD_ROTATIONS["back"], (-0.15, 0, 0.15), (-0.15, 0, 0)),
        "front": Grasp("front", front, STANDARD_ROTATIONS["front"], (0.15, 0, 0.15), (0.15, 0, 0)),
    }
    if left is not None:
        table["left-side"] = Grasp(
            "left-side", left, STANDARD_ROTATIONS["left-side"], (0, 0.15, 0.15), (0, 0.15, 0)
        )
    if right is not None:
        table["right-side"] = Grasp(
            "right-side", right, STANDARD_ROTATIONS["right-side"], (0, -0.15, 0.15), (0, -0.15, 0)
        )
    return tuple(_float_grasp(table[name]) for name in order)


def _float_grasp(g: Grasp) -> Grasp:
    def f(v: tuple[float, ...]) -> Vec3:
        return (float(v[0]), float(v[1]), float(v[2]))

    return Grasp(
        g.name,
        f(g.translation),
        g.rotation,
        f(g.pregrasp_offset),
        f(g.second_pregrasp_offset),
        f(g.lift_offset),
        f(g.second_lift_offset),
    )


def _top(name: str, translation: Vec3, rotation: str, offset: float = 0.20) -> Grasp:
    up = (0.0, 0.0, offset)
    return Grasp(name, translation, STANDARD_ROTATIONS[rotation], up, up, up, up)


def _plate_rotation(side: str) -> Mat3:
    """A side rotation rolled by π/2 about the approach axis (fingers close vertically
    around the rim) and tilted by π/6: an approximation of CRAM's plate grasp."""
    base = np.array(STANDARD_ROTATIONS[side])
    roll = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    c, s = math.cos(math.pi / 6), math.sin(math.pi / 6)
    tilt = np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])
    m = base @ roll @ tilt
    rows = tuple(tuple(float(round(v, 12)) for v in row) for row in m)
    return rows  # type: ignore[return-value]


def _build() -> Mapping[str, ObjectKnowledge]:
    cup_like_order = ("back", "front", "left-side", "right-side")
    # The cup's top grasp (CRAM defines it; HEAD leaves it off, v0.8.1's demo pins it, the
    # seed's walkthrough picks with it) comes after the side grasps, so plans that try the
    # grasps in order keep HEAD's choice. Deliberate difference: our cup is a solid
    # cylinder, so the fingers close across its body at the centre (CRAM's (-0.03, 0, 0.02)
    # pinches a hollow mug's rim), and its approach and lift offsets are v0.8.1's 0.07 m lift
    # offset: HEAD's 0.15-0.20 m above a cup held 1.0 m high at 0.5 m (the seed's pick)
    # puts a downward tool beyond the PR2 arm's reach.
    cup = (
        *_side_grasps(
            (0.02, 0.0, 0.03),
            (-0.02, 0.0, 0.03),
            (0.0, -0.02, 0.03),
            (0.0, 0.02, 0.03),
            cup_like_order,
        ),
        _float_grasp(_top("top", (0.0, 0.0, 0.02), "top-across-x", offset=0.07)),
    )
    milk = _side_grasps(
        (0.01, 0.0, 0.0),
        (-0.01, 0.0, 0.0),
        (0.0, -0.01, 0.0),
        (0.0, 0.01, 0.0),
        ("back", "left-side", "right-side", "front"),
    )
    cereal = _side_grasps((-0.03, 0.0, 0.04), (0.03, 0.0, 0.04), None, None, ("back", "front"))
    spoon = (_top("top", (0.0, 0.0, 0.015), "top-across-x"),)
    bowl = (_top("top", (-0.07, 0.0, 0.01), "top-across-y"),)
    plate = (
        _float_grasp(
            Grasp(
                "left-side",
                (0.0, 0.115, 0.01),
                _plate_rotation("left-side"),
                (0, 0.15, 0.15),
                (0, 0.15, 0),
            )
        ),
        _float_grasp(
            Grasp(
                "right-side",
                (0.0, -0.115, 0.01),
                _plate_rotation("right-side"),
                (0, -0.15, 0.15),
                (0, -0.15, 0),
            )
        ),
    )
    # sizes: extents along the object's x, y, z (the cup's x includes its handle)
    spoon_size = (0.16, 0.03, 0.015)
    cereal_size = (0.19, 0.07, 0.29)
    table = {
        "bowl": ObjectKnowledge("bowl", bowl, 100.0, 0.10, (0.16, 0.16, 0.055)),
        "spoon": ObjectKnowledge("spoon", spoon, 100.0, 0.04, spoon_size),
        "cutlery": ObjectKnowledge("cutlery", spoon, 100.0, 0.04, spoon_size),
        "fork": ObjectKnowledge("fork", spoon, 100.0, 0.04, spoon_size),
        "knife": ObjectKnowledge("knife", spoon, 100.0, 0.04, spoon_size),
        "cup": ObjectKnowledge("cup", cup, 50.0, 0.10, (0.105, 0.08, 0.10)),
        "milk": ObjectKnowledge("milk", milk, 15.0, 0.10, (0.06, 0.095, 0.2)),
        "breakfast-cereal": ObjectKnowledge("breakfast-cereal", cereal, 20.0, 0.10, cereal_size),
        "cereal": ObjectKnowledge("cereal", cereal, 15.0, 0.10, cereal_size),
        "plate": ObjectKnowledge("plate", plate, 100.0, 0.02, (0.26, 0.26, 0.02)),
    }
    return MappingProxyType(table)


_KNOWLEDGE: Mapping[str, ObjectKnowledge] = _build()


def known_types() -> tuple[str, ...]:
    """Every object type with grasp knowledge, sorted."""
    return tuple(sorted(_KNOWLEDGE))


def object_knowledge(object_type: str) -> ObjectKnowledge:
    """The knowledge of ``object_type``; unknown -> :class:`LookupError` naming the known."""
    try:
        return _KNOWLEDGE[object_type]
    except (KeyError, TypeError):
        raise LookupError(
            f"unknown object type {object_type!r}; known types: {', '.join(known_types())}"
        ) from None


def grasps(object_type: str) -> tuple[str, ...]:
    """Grasp names of a type in CRAM's enumeration order."""
    return tuple(g.name for g in object_knowledge(object_type).grasps)


def grasp(object_type: str, name: str) -> Grasp:
    """One grasp; unknown type or grasp -> :class:`LookupError` naming the known ones."""
    return object_knowledge(object_type).grasp(name)


def gripping_effort(object_type: str) -> float:
    return object_knowledge(object_type).effort


def gripper_opening(object_type: str) -> float:
    return object_knowledge(object_type).opening


#: An object whose z axis is tilted more than this (rad) from the vertical lies: its grasp
#: offsets' z components go along the vertical (see :func:`grasp_poses`).
LYING_TILT = 0.35
#: A lying object is grasped only from above: a grasp whose approach points down, within
#: this angle (rad) of the vertical, as it lies (see :func:`fits_lying`).
LYING_APPROACH_CONE = math.pi / 4


#: An object whose z axis is tilted more than this (rad) from the vertical lies on one of
#: its sides (toppled), not just leaning: only grasps from above are tried (see
#: :func:`fits_lying`). Between :data:`LYING_TILT` and this, an object leans (against a
#: counter, a neighbour) and every grasp is tried, as before.
TOPPLED_TILT = math.pi / 4


def is_lying(object_transform: Transform | Pose) -> bool:
    """Whether the object lies on one of its sides: its z axis more than
    :data:`TOPPLED_TILT` from the parent frame's vertical, up or down (the parent frame
    is upright: the map or a robot's base). Upside down (a spoon on its back) is not
    lying on a side: it keeps its grasps, as before."""
    return bool(abs(object_transform.matrix()[2, 2]) < math.cos(TOPPLED_TILT))


def closing_width(object_type: str, grasp_name: str) -> float:
    """How far apart (m) the fingers are when they hold the object by this grasp: the
    type's extent along the axis the standard gripper's fingers close along (its x axis,
    the first column of the grasp's rotation, in the object frame)."""
    info = object_knowledge(object_type)
    g = info.grasp(grasp_name)
    axis = np.array(g.rotation)[:, 0]
    return float(np.abs(axis) @ np.array(info.size))


def approach_down(object_type: str, grasp_name: str, object_transform: Transform | Pose) -> float:
    """The cosine between the grasp's approach (the standard gripper's z, in the object
    frame) and straight down, with the object as ``object_transform`` has it."""
    g = grasp(object_type, grasp_name)
    approach = object_transform.matrix()[:3, :3] @ np.array(g.rotation)[:, 2]
    return float(-approach[2])


def fits_lying(
    object_type: str, grasp_name: str, object_transform: Transform | Pose, opening: float
) -> bool:
    """Whether a lying object can be held by this grasp with a gripper that opens
    ``opening`` metres: the grasp approaches from above (within
    :data:`LYING_APPROACH_CONE`; from the side, one finger would have to go under the
    object, into what it lies on) and the fingers close across no more than ``opening``.
    Deliberate addition: CRAM's grasps assume an upright object."""
    return (
        approach_down(object_type, grasp_name, object_transform) >= math.cos(LYING_APPROACH_CONE)
        and closing_width(object_type, grasp_name) <= opening
    )


#: A lying object overhanging its support's edge is grasped from the side: a grasp whose
#: approach is within this angle (rad) of the horizontal and whose fingers close within
#: it of the vertical, as it lies (see :func:`fits_overhanging`).
OVERHANG_APPROACH_CONE = math.pi / 9


def approach_extent(object_type: str, grasp_name: str) -> float:
    """The type's extent (m) along the grasp's approach (the standard gripper's z, the
    third column of the grasp's rotation, in the object frame)."""
    info = object_knowledge(object_type)
    axis = np.array(info.grasp(grasp_name).rotation)[:, 2]
    return float(np.abs(axis) @ np.array(info.size))


def fits_overhanging(
    object_type: str, grasp_name: str, object_transform: Transform | Pose, opening: float
) -> bool:
    """Whether this grasp could hold a lying object by an end that sticks out over the
    edge of what it lies on, with a gripper that opens ``opening`` metres: the approach
    horizontal and the fingers closing vertically (each within
    :data:`OVERHANG_APPROACH_CONE`), across no more than ``opening``. Whether the end
    does stick out far enough is the plan's to measure (:mod:`plans.overhang`).
    Deliberate addition: CRAM's grasps assume an upright object."""
    g = grasp(object_type, grasp_name)
    rotation = object_transform.matrix()[:3, :3] @ np.array(g.rotation)
    closing, approach = rotation[:, 0], rotation[:, 2]
    return bool(
        abs(approach[2]) <= math.sin(OVERHANG_APPROACH_CONE)
        and abs(closing[2]) >= math.cos(OVERHANG_APPROACH_CONE)
        and closing_width(object_type, grasp_name) <= opening
    )


def _moved_along(g: Grasp, column: int, value: float) -> Grasp:
    """``g`` with the component of its translation along its rotation's ``column`` (the
    standard gripper's axis: 2 the approach, 1 across the fingers) set to ``value`` (m)."""
    axis = np.array(g.rotation)[:, column]
    t = np.array(g.translation)
    t = t - (t @ axis) * axis + value * axis
    return replace(g, translation=(float(t[0]), float(t[1]), float(t[2])))


def grasp_poses(
    object_type: str,
    grasp_name: str,
    object_transform_in_base: Transform | Pose,
    standard_to_tool: Sequence[Sequence[float]],
    depth: float | None = None,
    across: float | None = None,
) -> list[Pose]:
    """The five tool-frame waypoints [pregrasp, 2nd-pregrasp, grasp, lift, 2nd-lift] as
    poses in the transform's parent frame (normally the robot's base frame):
    ``bTg = bTo · oTg′ · g′Tg`` with the offsets added to the grasp translation in the
    object frame. ``standard_to_tool`` is ``g′Tg``, the rotation (rows) from the standard
    gripper to the arm's tool frame (:attr:`executive.ArmDescription.standard_to_tool`):
    the object knowledge is robot-independent and combines with it. Unknown type or grasp
    -> :class:`LookupError`; a ``standard_to_tool`` that is not a 3x3 matrix ->
    :class:`ValueError`.

    A lying object (its z axis more than :data:`LYING_TILT` from the vertical, e.g. a milk
    carton knocked over): the grasp itself stays in the object frame, so the side grasp
    whose approach now points down reaches it from above, fingers across the carton; but
    the offsets' z components (the "up" of the pregrasps and of the lift) go along the
    parent frame's z, never sideways along the lying object's axis; where the backing-off
    along the approach now points up too, the waypoint rises by the larger of the two, not
    their sum. Deliberate difference:
    CRAM's grasps assume an upright object, so a toppled one could not be picked up; the
    placing (:mod:`plans.pick_place`) then puts the object down upright, holding it by the
    same grasp, now horizontal.

    ``depth``: the tool frame this far (m) inside the face the grasp approaches, along the
    approach, instead of where the grasp's translation puts it (the other components of
    the translation kept); None: the grasp's own. ``across``: likewise, the tool frame this
    far (m) from the object's centre along the axis that is neither the approach nor the
    fingers' closing axis (the standard gripper's y). The overhang grasp
    (:mod:`plans.overhang`) holds only the end that sticks out, where it sticks out most."""
    g = grasp(object_type, grasp_name)
    if depth is not None:
        extent = approach_extent(object_type, grasp_name)
        if not (math.isfinite(depth) and 0.0 <= depth <= extent):
            raise ValueError(
                f"grasp depth must be 0 to {extent:.3f} m "
                f"(the {object_type}'s extent along the {grasp_name} approach), got {depth!r}"
            )
        g = _moved_along(g, 2, depth - extent / 2)
    if across is not None:
        if not math.isfinite(across):
            raise ValueError(f"grasp across must be a finite distance (m), got {across!r}")
        g = _moved_along(g, 1, across)
    g_prime_t_g = np.array(standard_to_tool, dtype=float)
    if g_prime_t_g.shape != (3, 3):
        raise ValueError(
            f"standard_to_tool must be a 3x3 rotation (rows), got {standard_to_tool!r}: pass "
            "the arm's executive.ArmDescription.standard_to_tool"
        )
    b_t_o = object_transform_in_base.matrix()
    frame = object_transform_in_base.frame
    rot = np.array(g.rotation) @ g_prime_t_g
    lying = b_t_o[2, 2] < math.cos(LYING_TILT)
    grasp_m = b_t_o @ _homogeneous(rot, g.translation)
    out: list[Pose] = []
    for off in g.offsets():
        up = off[2] if lying else 0.0  # the part of the offset along the parent's z
        m = b_t_o @ _homogeneous(rot, np.add(g.translation, (off[0], off[1], off[2] - up)))
        if lying:
            # the backing-off along the approach, now vertical, and the "up" are one
            # direction: the higher of the two, not their sum (0.3 m above a cereal box
            # on its side is out of the arm's reach)
            rise = m[2, 3] - grasp_m[2, 3]
            m[2, 3] = grasp_m[2, 3] + (max(rise, up) if rise >= 0.0 else rise + up)
        out.append(Transform.from_matrix(m, frame).to_pose())
    return out


def _homogeneous(rotation: np.ndarray, translation: Sequence[float] | np.ndarray) -> np.ndarray:
    m = np.eye(4)
    m[:3, :3] = rotation
    m[:3, 3] = translation
    return m
