"""Poses and rigid transforms.

Built on numpy and :class:`scipy.spatial.transform.Rotation` rather than a hand-rolled
quaternion module: scipy is a well-kept dependency we need for costmap statistics anyway,
its ``Rotation`` handles normalisation, composition and Euler conversions robustly, and it
vectorises when a costmap needs many orientations. (pytransform3d would add a dependency
for the same maths.)

Quaternions are ``(x, y, z, w)`` everywhere, as in PyBullet and ROS. Both types are
immutable; non-finite numbers, a zero quaternion or a wrong length raise ``ValueError`` at
construction, naming the bad value.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING, Any, NoReturn, cast

import numpy as np

if TYPE_CHECKING:
    from scipy.spatial.transform import Rotation

__all__ = ["Pose", "Transform", "yaw_quaternion"]


def _rotation_type() -> type[Rotation]:
    """scipy's ``Rotation``, imported on first use: ``scipy.spatial`` costs ~0.2 s to
    import (sparse matrices, k-d trees, qhull), more than the rest of ``import plans,
    projection``, and most runs never build a ``Rotation``."""
    from scipy.spatial.transform import Rotation

    return cast("type[Rotation]", Rotation)


def _vector(values: Iterable[float], n: int, what: str) -> tuple[float, ...]:
    try:
        out = tuple(map(float, values))
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{what} must be {n} numbers, got {values!r}") from exc
    if len(out) != n:
        raise ValueError(f"{what} must have {n} components, got {len(out)}: {out!r}")
    if not all(map(math.isfinite, out)):
        raise ValueError(f"{what} must be finite, got {out!r}")
    return out


def _quaternion(values: Iterable[float], what: str) -> tuple[float, float, float, float]:
    q = _vector(values, 4, what)
    norm = math.sqrt(sum(v * v for v in q))
    if norm < 1e-9:
        raise ValueError(f"{what} must not be the zero quaternion, got {q!r}")
    x, y, z, w = (v / norm for v in q)
    return (x, y, z, w)


def yaw_quaternion(yaw: float) -> tuple[float, float, float, float]:
    """The (x, y, z, w) quaternion of a rotation by ``yaw`` radians about z."""
    return (0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0))


class Transform:
    """A rigid transform ``frame -> child_frame`` (CRAM's ``transform-stamped``).

    ``T * p`` maps a pose expressed in ``child_frame`` into ``frame``; ``T1 * T2`` composes
    (``T1.child_frame`` should equal ``T2.frame``; mismatches raise ``ValueError``).
    """

    __slots__ = ("_rotation", "child_frame", "frame", "rotation", "translation")

    translation: tuple[float, float, float]
    rotation: tuple[float, float, float, float]
    frame: str
    child_frame: str
    _rotation: Rotation | None

    def __init__(
        self,
        translation: Sequence[float] = (0.0, 0.0, 0.0),
        rotation_xyzw: Sequence[float] = (0.0, 0.0, 0.0, 1.0),
        frame: str = "map",
        child_frame: str = "",
    ) -> None:
        object.__setattr__(self, "translation", _vector(translation, 3, "translation"))
        object.__setattr__(self, "rotation", _quaternion(rotation_xyzw, "rotation"))
        object.__setattr__(self, "frame", str(frame))
        object.__setattr__(self, "child_frame", str(child_frame))
        object.__setattr__(self, "_rotation", None)

    def __setattr__(self, name: str, value: Any) -> None:
        raise AttributeError("Transform is immutable; build a new one")

    # -- conversions ----------------------------------------------------------------
    def as_rotation(self) -> Rotation:
        """The rotation as a scipy ``Rotation`` (cached)."""
        rot = self._rotation
        if rot is None:
            rot = _rotation_type().from_quat(self.rotation)
            object.__setattr__(self, "_rotation", rot)
        return rot

    def matrix(self) -> np.ndarray:
        """The homogeneous 4x4 matrix."""
        m = np.eye(4)
        m[:3, :3] = self.as_rotation().as_matrix()
        m[:3, 3] = self.translation
        return m

    @classmethod
    def from_matrix(cls, m: np.ndarray, frame: str = "map", child_frame: str = "") -> Transform:
        m = np.asarray(m, dtype=float)
        if m.shape != (4, 4):
            raise ValueError(f"a homogeneous transform is 4x4, got shape {m.shape}")
        quat = _rotation_type().from_matrix(m[:3, :3]).as_quat()
        return cls(tuple(float(v) for v in m[:3, 3]), quat, frame, child_frame)

    def to_pose(self) -> Pose:
        """The pose of ``child_frame`` expressed in ``frame``."""
        return Pose(self.translation, self.rotation, self.frame)

    # -- algebra --------------------------------------------------------------------
    def inverse(self) -> Transform:
        inv = self.as_rotation().inv()
        t = -inv.apply(self.translation)
        return Transform(t, inv.as_quat(), self.child_frame, self.frame)

    def __mul__(self, other: Transform | Pose) -> Any:
        if isinstance(other, Transform):
            if other.frame and self.child_frame and other.frame != self.child_frame:
                raise ValueError(
                    f"cannot compose {self.frame}->{self.child_frame} with "
                    f"{other.frame}->{other.child_frame}: frames do not chain"
                )
            rot = self.as_rotation() * other.as_rotation()
            t = np.add(self.as_rotation().apply(other.translation), self.translation)
            return Transform(t, rot.as_quat(), self.frame, other.child_frame)
        if isinstance(other, Pose):
            if self.child_frame and other.frame != self.child_frame:
                raise ValueError(
                    f"cannot apply a {self.frame}->{self.child_frame} transform to a pose "
                    f"in frame {other.frame!r}"
                )
            rot = self.as_rotation() * other.as_rotation()
            t = np.add(self.as_rotation().apply(other.position), self.translation)
            return Pose(t, rot.as_quat(), self.frame)
        return NotImplemented

    def apply_point(self, point: Sequence[float]) -> tuple[float, float, float]:
        p = np.add(self.as_rotation().apply(_vector(point, 3, "point")), self.translation)
        return (float(p[0]), float(p[1]), float(p[2]))

    # -- comparison and display -----------------------------------------------------
    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Transform):
            return NotImplemented
        return (
            self.translation == other.translation
            and self.rotation == other.rotation
            and self.frame == other.frame
            and self.child_frame == other.child_frame
        )

    def __hash__(self) -> int:
        return hash((self.translation, self.rotation, self.frame, self.child_frame))

    def __repr__(self) -> str:
        t = ", ".join(f"{v:.3f}" for v in self.translation)
        q = ", ".join(f"{v:.3f}" for v in self.rotation)
        return f"<Transform {self.frame}->{self.child_frame} t=({t}) q=({q})>"


class Pose:
    """A position and an orientation in a named frame (CRAM's ``pose-stamped``).

    ``Pose((x, y, z), (qx, qy, qz, qw), frame="map")``; the quaternion is normalised.
    Non-finite values raise ``ValueError`` naming them.
    """

    __slots__ = ("_rotation", "frame", "orientation", "position")

    position: tuple[float, float, float]
    orientation: tuple[float, float, float, float]
    frame: str
    _rotation: Rotation | None

    if TYPE_CHECKING:  # the signature calls are checked against

        def __init__(
            self,
            position: Sequence[float] = (0.0, 0.0, 0.0),
            orientation_xyzw: Sequence[float] = (0.0, 0.0, 0.0, 1.0),
            frame: str = "map",
        ) -> None: ...

    else:  # the same at run time, where a wrong keyword gets a hint (at no cost)

        def __init__(
            self,
            position=(0.0, 0.0, 0.0),
            orientation_xyzw=(0.0, 0.0, 0.0, 1.0),
            frame="map",
            **unknown,
        ):
            if unknown:
                _unknown_keywords("Pose", list(unknown))
            if not isinstance(frame, str) or not frame:
                raise ValueError(f"a pose needs a frame name, got {frame!r}")
            object.__setattr__(self, "position", _vector(position, 3, "position"))
            object.__setattr__(self, "orientation", _quaternion(orientation_xyzw, "orientation"))
            object.__setattr__(self, "frame", frame)
            object.__setattr__(self, "_rotation", None)

    def __setattr__(self, name: str, value: Any) -> None:
        raise AttributeError("Pose is immutable; use copy(...) or build a new one")

    @classmethod
    def from_xyz_yaw(
        cls, x: float, y: float, z: float = 0.0, yaw: float = 0.0, frame: str = "map"
    ) -> Pose:
        """A pose from a position and a rotation about z."""
        return cls((x, y, z), yaw_quaternion(yaw), frame)

    def copy(
        self,
        position: Sequence[float] | None = None,
        orientation_xyzw: Sequence[float] | None = None,
        frame: str | None = None,
    ) -> Pose:
        return Pose(
            self.position if position is None else position,
            self.orientation if orientation_xyzw is None else orientation_xyzw,
            self.frame if frame is None else frame,
        )

    def as_rotation(self) -> Rotation:
        rot = self._rotation
        if rot is None:
            rot = _rotation_type().from_quat(self.orientation)
            object.__setattr__(self, "_rotation", rot)
        return rot

    @property
    def yaw(self) -> float:
        """Rotation about z in radians (from the z-y-x Euler decomposition)."""
        x, y, z, w = self.orientation
        return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))

    def to_transform(self, child_frame: str = "") -> Transform:
        """The transform ``frame -> child_frame`` that this pose describes."""
        return Transform(self.position, self.orientation, self.frame, child_frame)

    def matrix(self) -> np.ndarray:
        return self.to_transform().matrix()

    def distance_to(self, other: Pose) -> float:
        """Euclidean distance between the positions (frames must agree)."""
        if other.frame != self.frame:
            raise ValueError(f"poses in different frames: {self.frame!r} vs {other.frame!r}")
        return math.dist(self.position, other.position)

    def angle_to(self, other: Pose) -> float:
        """The angle (radians, in [0, pi]) of the rotation between the two orientations."""
        dot = abs(sum(a * b for a, b in zip(self.orientation, other.orientation)))
        return 2.0 * math.acos(min(1.0, dot))

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Pose):
            return NotImplemented
        return (
            self.position == other.position
            and self.orientation == other.orientation
            and self.frame == other.frame
        )

    def __hash__(self) -> int:
        return hash((self.position, self.orientation, self.frame))

    def isclose(self, other: Pose, pos_tol: float = 1e-6, angle_tol: float = 1e-6) -> bool:
        return (
            self.frame == other.frame
            and self.distance_to(other) <= pos_tol
            and self.angle_to(other) <= angle_tol
        )

    def __repr__(self) -> str:
        p = " ".join(map(_shown, self.position))
        q = " ".join(map(_shown, self.orientation))
        return f"<Pose {self.frame} ({p}) ({q})>"


def _shown(v: float) -> str:
    """A coordinate for display: millimetres, or 6 significant digits when huge (a
    1e300 m typo must not print 300 digits). A value that rounds to zero shows as
    ``0.000`` whatever its sign: ``-0.000`` is floating-point noise (it flipped with the
    order of a computation), not information."""
    shown = f"{v:.3f}" if abs(v) < 1e9 else f"{v:.6g}"
    return "0.000" if shown == "-0.000" else shown


_POSE_KEYWORDS = ("position", "orientation_xyzw", "frame")


def _unknown_keywords(where: str, unknown: Sequence[str]) -> NoReturn:
    """``TypeError`` for keywords a pose does not take, suggesting the one meant (a pose's
    orientation is ``orientation_xyzw``: the name says the quaternion's order)."""
    name = unknown[0]
    close = difflib.get_close_matches(name, _POSE_KEYWORDS, n=1, cutoff=0.5)
    hint = f"; did you mean {close[0]}?" if close else ""
    raise TypeError(
        f"{where}() got an unexpected keyword argument {name!r}{hint} (a pose takes "
        f"{', '.join(_POSE_KEYWORDS)}; the orientation is a quaternion (x, y, z, w))"
    )
