"""Object knowledge: grasp tables, grasp poses, arm configurations."""

from __future__ import annotations

import numpy as np
import pytest

from executive import knowledge
from executive._pose import Pose
from robots.pr2 import DESCRIPTION as PR2
from robots.pr2 import STANDARD_TO_TOOL as PR2_TOOL


def test_grasp_enumeration_order() -> None:
    assert knowledge.grasps("cup") == ("back", "front", "left-side", "right-side", "top")
    assert knowledge.grasps("milk") == ("back", "left-side", "right-side", "front")
    assert knowledge.grasps("breakfast-cereal") == ("back", "front")
    assert knowledge.grasps("bowl") == ("top",)
    assert PR2.arm_names == ("right", "left")


def test_unknown_type_and_grasp_name_the_known_ones() -> None:
    with pytest.raises(LookupError, match=r"known types: .*bowl"):
        knowledge.grasps("teapot")
    with pytest.raises(LookupError, match="known grasps: back, front"):
        knowledge.grasp("breakfast-cereal", "top")
    with pytest.raises(LookupError, match="park"):
        PR2.arm("left").state("dance")


def test_back_grasp_of_an_object_ahead_is_the_identity_tool_rotation() -> None:
    obj = Pose((0.6, 0.0, 0.9), frame="base_footprint").to_transform("cup")
    poses = knowledge.grasp_poses("cup", "back", obj, PR2_TOOL)
    assert len(poses) == 5 and all(p.frame == "base_footprint" for p in poses)
    pre, pre2, grasp, lift, lift2 = poses
    assert grasp.position == pytest.approx((0.62, 0.0, 0.93))
    assert grasp.angle_to(Pose()) == pytest.approx(0.0, abs=1e-9)
    assert pre.position == pytest.approx((0.47, 0.0, 1.08))
    assert pre2.position == pytest.approx((0.47, 0.0, 0.93))
    assert lift.position == pytest.approx((0.62, 0.0, 1.08))
    assert lift2.position == lift.position


def test_offsets_are_in_the_object_frame() -> None:
    # milk turned by pi: its back grasp comes from +x in base
    obj = Pose.from_xyz_yaw(0.6, 0.0, 0.95, np.pi, "base_footprint").to_transform("milk")
    pre, _, grasp, _, _ = knowledge.grasp_poses("milk", "back", obj, PR2_TOOL)
    assert grasp.position == pytest.approx((0.59, 0.0, 0.95), abs=1e-9)
    assert pre.position == pytest.approx((0.74, 0.0, 1.10), abs=1e-9)
    tool_x = grasp.as_rotation().apply([1.0, 0.0, 0.0])
    assert tool_x == pytest.approx([-1.0, 0.0, 0.0], abs=1e-9)  # approaching along -x


def test_top_grasp_points_the_tool_down() -> None:
    obj = Pose((0.5, 0.1, 0.8), frame="base_footprint").to_transform("bowl")
    grasp = knowledge.grasp_poses("bowl", "top", obj, PR2_TOOL)[2]
    assert grasp.as_rotation().apply([1.0, 0.0, 0.0]) == pytest.approx([0, 0, -1], abs=1e-9)
    assert grasp.position == pytest.approx((0.43, 0.1, 0.81))


def test_standard_rotations_are_proper() -> None:
    for name, rows in knowledge.STANDARD_ROTATIONS.items():
        m = np.array(rows)
        assert np.allclose(m @ m.T, np.eye(3)), name
        assert np.linalg.det(m) == pytest.approx(1.0), name


def test_arm_configurations_have_seven_values() -> None:
    for name in ("park", "carry"):
        for arm in PR2.arm_names:
            assert len(PR2.arm(arm).state(name)) == 7


def test_a_lying_carton_is_grasped_from_above_and_lifted_straight_up() -> None:
    """Milk on its side (its x axis pointing down): the back grasp (approach +x in the
    object frame) now comes from above, and the pregrasps and the lift go up, not along
    the carton's axis; the pregrasp's backing-off along the approach (now up) and its
    "up" are one direction: it rises by the larger, 0.15 m, not by their sum."""
    s = np.sqrt(0.5)
    lying = Pose((0.7, 0.0, 0.75), (0.0, s, 0.0, s), frame="base_footprint")
    pre, pre2, grasp, lift, lift2 = knowledge.grasp_poses(
        "milk", "back", lying.to_transform("milk"), PR2_TOOL
    )
    tool_x = grasp.matrix()[:3, 0]  # the PR2 tool's x axis is the approach
    assert np.allclose(tool_x, (0.0, 0.0, -1.0), atol=1e-9)
    for above, height in ((pre2, 0.15), (pre, 0.15), (lift, 0.15), (lift2, 0.15)):
        assert np.allclose(above.position[:2], grasp.position[:2], atol=1e-9)
        assert above.position[2] == pytest.approx(grasp.position[2] + height)


def test_an_upright_object_keeps_the_offsets_in_its_own_frame() -> None:
    tilted = Pose((0.7, 0.1, 0.8), (0.0, np.sin(0.1), 0.0, np.cos(0.1)), frame="base_footprint")
    poses = knowledge.grasp_poses("milk", "back", tilted.to_transform("milk"), PR2_TOOL)
    g = knowledge.grasp("milk", "back")
    b_t_o = tilted.matrix()
    for pose, off in zip(poses, g.offsets()):
        expected = b_t_o @ np.append(np.add(g.translation, off), 1.0)
        assert np.allclose(pose.position, expected[:3], atol=1e-9)
