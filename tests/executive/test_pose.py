"""Pose and Transform (executive._pose)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from executive import Pose, Transform, yaw_quaternion


def test_pose_normalises_and_validates() -> None:
    p = Pose((1, 2, 3), (0, 0, 0, 2))
    assert p.orientation == (0.0, 0.0, 0.0, 1.0)
    assert p.frame == "map"
    with pytest.raises(ValueError, match="finite"):
        Pose((math.nan, 0, 0))
    with pytest.raises(ValueError, match="zero quaternion"):
        Pose((0, 0, 0), (0, 0, 0, 0))
    with pytest.raises(ValueError, match="3 components"):
        Pose((0, 0))
    with pytest.raises(ValueError, match="frame"):
        Pose(frame="")
    with pytest.raises(AttributeError, match="immutable"):
        p.frame = "odom"


def test_yaw_and_angles() -> None:
    p = Pose.from_xyz_yaw(1, 2, yaw=0.5)
    assert p.yaw == pytest.approx(0.5)
    assert p.angle_to(Pose.from_xyz_yaw(1, 2, yaw=0.2)) == pytest.approx(0.3)
    assert p.distance_to(Pose((1, 3, 0))) == pytest.approx(1.0)
    with pytest.raises(ValueError, match="different frames"):
        p.distance_to(Pose(frame="base_footprint"))
    assert p.copy(frame="odom").frame == "odom"
    assert p.isclose(Pose.from_xyz_yaw(1, 2, yaw=0.5 + 1e-9))


def test_transform_algebra() -> None:
    map_T_base = Transform((1, 0, 0), yaw_quaternion(math.pi / 2), "map", "base_footprint")
    obj_in_base = Pose((1, 0, 0), frame="base_footprint")
    obj_in_map = map_T_base * obj_in_base
    assert obj_in_map.frame == "map"
    assert obj_in_map.position == pytest.approx((1.0, 1.0, 0.0))
    back = map_T_base.inverse() * obj_in_map
    assert back.isclose(obj_in_base, 1e-9, 1e-9)
    ident = map_T_base * map_T_base.inverse()
    assert np.allclose(ident.matrix(), np.eye(4))
    with pytest.raises(ValueError, match="frames do not chain"):
        map_T_base * Transform(frame="odom", child_frame="x")
    with pytest.raises(ValueError, match="cannot apply"):
        map_T_base * Pose()
    rebuilt = Transform.from_matrix(map_T_base.matrix(), "map", "base_footprint")
    assert rebuilt.child_frame == "base_footprint"
    assert np.allclose(rebuilt.matrix(), map_T_base.matrix())


_coord = st.floats(-10, 10, allow_nan=False)


@given(_coord, _coord, _coord, st.floats(-math.pi, math.pi))
def test_pose_transform_round_trip(x: float, y: float, z: float, yaw: float) -> None:
    pose = Pose.from_xyz_yaw(x, y, z, yaw)
    m = pose.matrix()
    again = Transform.from_matrix(m).to_pose()
    assert again.isclose(pose, 1e-9, 1e-6)
    assert hash(pose) == hash(Pose(pose.position, pose.orientation))


def test_a_misnamed_keyword_suggests_the_right_one() -> None:
    with pytest.raises(TypeError, match=r"'orientation'; did you mean orientation_xyzw\?"):
        Pose((0.0, 0.0, 0.0), orientation=(0.0, 0.0, 0.0, 1.0))  # type: ignore[call-arg]
    with pytest.raises(TypeError, match=r"'pos'; did you mean position\?"):
        Pose(pos=(1.0, 0.0, 0.0))  # type: ignore[call-arg]


def test_a_huge_position_is_shown_briefly() -> None:
    assert (
        repr(Pose((1e300, 1.0, 2.0))) == "<Pose map (1e+300 1.000 2.000) (0.000 0.000 0.000 1.000)>"
    )


def test_a_value_rounding_to_zero_is_shown_without_its_sign() -> None:
    # -0.000 is floating-point noise whose sign flips with the order of a computation;
    # docs that show poses must not change with it
    assert (
        repr(Pose((-0.0001, -0.0, 0.3), (-0.0002, 0.0, -0.0, 1.0)))
        == "<Pose map (0.000 0.000 0.300) (0.000 0.000 0.000 1.000)>"
    )
    assert repr(Pose((-0.0006, 0.0, 0.0))).startswith("<Pose map (-0.001 ")
