"""World construction, registry, snapshots, reproducibility, bad input and the demo
geometry (kitchen layout agrees with CRAM's demo poses)."""

from __future__ import annotations

import math
from collections.abc import Iterator

import pybullet as pb
import pytest

from executive import knowledge
from executive._pose import Pose
from projection import World
from projection._objects import OBJECT_TYPES
from robots.pr2 import DESCRIPTION as PR2
from robots.pr2 import STANDARD_TO_TOOL as PR2_TOOL

SINK_NAV = Pose.from_xyz_yaw(0.75, 0.70, 0.0, 0.0)
ISLAND_NAV = Pose.from_xyz_yaw(-0.2, 1.5, 0.0, math.pi)
DEMO_SPAWN = {  # CRAM demo (map): name -> (type, x, y, z, yaw)
    "breakfast-cereal": ("breakfast-cereal", 1.4, 0.4, 0.85, 0.0),
    "cup": ("cup", 1.3, 0.6, 0.9, 0.0),
    "bowl": ("bowl", 1.4, 0.8, 0.87, 0.0),
    "milk": ("milk", 1.4, 0.62, 0.95, math.pi),
}
ISLAND_PLACES = {
    "breakfast-cereal": (-0.78, 0.9, 0.95),
    "cup": (-0.79, 1.35, 0.9),
    "bowl": (-0.76, 1.19, 0.88),
    "spoon": (-0.78, 1.5, 0.86),
    "milk": (-0.75, 1.7, 0.95),
}


@pytest.fixture()
def world() -> Iterator[World]:
    with World(seed=0) as w:
        yield w


def test_new_world_defaults(world: World) -> None:
    assert world.robot_pose().isclose(Pose(), 1e-9, 1e-9)
    assert world.torso_height == pytest.approx(0.15)
    assert world.arm_joints("left") == pytest.approx(PR2.arm("left").state("park"))
    assert world.joint_position("sink_area_left_upper_drawer_main_joint") == 0.0
    assert world.gripper_opening("right") == pytest.approx(0.10)
    assert not world.robot_in_collision()
    assert dict(world.objects) == {}


def test_close_is_idempotent_and_closed_world_refuses_use() -> None:
    w = World()
    w.close()
    w.close()
    with pytest.raises(RuntimeError, match="closed"):
        w.robot_pose()
    with pytest.raises(RuntimeError):
        w.drive(SINK_NAV)


def test_gui_without_display_is_a_clear_error(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    with pytest.raises(RuntimeError, match="display"):
        World(gui=True)


def test_spawn_remove_and_frames(world: World) -> None:
    world.drive(Pose.from_xyz_yaw(0.5, 0.0, 0.0, math.pi / 2))
    assert world.spawn_object("c", "cup", Pose((1.3, 0.6, 0.9))) == "c"
    assert world.objects == {"c": "cup"}
    base = world.object_pose("c", "base_footprint")
    assert base.position == pytest.approx((0.6, -0.8, 0.9), abs=1e-6)
    assert world.object_pose("c").position == pytest.approx((1.3, 0.6, 0.9), abs=1e-6)
    world.remove_object("c")
    assert dict(world.objects) == {}


def test_bad_input_is_a_clear_error_and_changes_nothing(world: World) -> None:
    world.spawn_object("c", "cup", Pose((1.3, 0.6, 0.9)))
    before = world.snapshot()
    n_bodies = pb.getNumBodies(physicsClientId=world.client)
    with pytest.raises(LookupError, match=r"known types: .*breakfast-cereal"):
        world.spawn_object("t", "teapot", Pose((1.3, 0.2, 0.9)))
    with pytest.raises(ValueError, match="already exists"):
        world.spawn_object("c", "cup", Pose((1.3, 0.2, 0.9)))
    with pytest.raises(ValueError, match="finite"):
        Pose((math.nan, 0.0, 0.9))
    with pytest.raises(ValueError, match="known frames"):
        world.spawn_object("d", "cup", Pose((0.1, 0.0, 0.9), frame="odom"))
    with pytest.raises(LookupError, match="sink_area_surface"):
        world.link_pose("sink_area_surfac")
    with pytest.raises(LookupError, match="no object"):
        world.object_pose("nothing")
    with pytest.raises(ValueError, match="known arms"):
        world.gripper("open", "middle")
    with pytest.raises(ValueError, match="7 joint values"):
        world.move_joints(left=[0.0] * 6)
    with pytest.raises(ValueError, match="finite"):
        world.move_torso(math.nan)
    assert pb.getNumBodies(physicsClientId=world.client) == n_bodies
    assert world.snapshot() == before
    assert dict(world.objects) == {"c": "cup"}


def test_snapshot_restore_is_exact(world: World) -> None:
    world.spawn_object("cup", "cup", Pose((1.3, 0.6, 0.9)))
    world.spawn_object("spoon", "spoon", Pose.from_xyz_yaw(1.4, 1.0, 0.7413, math.pi))
    world.attach("spoon", "sink_area_left_upper_drawer_main")
    world.drive(SINK_NAV)
    snap = world.snapshot()
    cup0 = world.object_pose("cup")
    world.open_container("sink_area_left_upper_drawer_main", 0.2)
    world.move_torso(0.3)
    world.look_at(Pose((1.3, 0.6, 0.9)))
    world.set_arm_configuration("carry")
    world.detach("spoon", settle_steps=0)
    world.remove_object("cup")
    world.spawn_object("milk", "milk", Pose((1.4, 0.0, 0.95)))
    world.drive(Pose.from_xyz_yaw(0.2, 0.3, 0.0, 1.0))
    world.restore(snap)
    assert world.snapshot() == snap
    assert dict(world.objects) == {"cup": "cup", "spoon": "spoon"}
    assert world.object_pose("cup").isclose(cup0, 1e-9, 1e-6)
    assert world.attachments == {"spoon": "sink_area_left_upper_drawer_main"}
    world.open_container("sink_area_left_upper_drawer_main", 0.1)  # attachment restored
    assert world.object_pose("spoon").position[0] == pytest.approx(1.3, abs=1e-6)


def test_snapshot_of_another_world_is_refused(world: World) -> None:
    with World() as other, pytest.raises(ValueError, match="not taken from this world"):
        world.restore(other.snapshot())


def _random_run(seed: int) -> list[tuple[float, ...]]:
    with World(seed=seed) as w:
        out: list[tuple[float, ...]] = []
        for k in range(3):
            x, y = w.rng.uniform([1.25, 0.0], [1.6, 0.9])
            # random spawns may overlap: allowed here, the physics that sorts them out is
            # what must be reproducible
            w.spawn_object(
                f"o{k}",
                "cup",
                Pose((x, y, 0.905), (0, 0, math.sin(k), math.cos(k))),
                allow_overlap=True,
            )
            w.attach(f"o{k}", "r_gripper_tool_frame")
            w.detach(f"o{k}", settle_steps=30)
        for k in range(3):
            p = w.object_pose(f"o{k}")
            out.append(p.position + p.orientation)
        return out


def test_runs_are_reproducible_under_a_seed() -> None:
    a, b, c = _random_run(5), _random_run(5), _random_run(6)
    assert a == b
    assert a != c


# ------------------------------------------------------------------ demo geometry
def test_robot_at_sink_nav_goal_is_collision_free_in_park_and_carry(world: World) -> None:
    world.drive(SINK_NAV)
    world.set_arm_configuration("carry")
    world.drive(ISLAND_NAV)
    world.drive(SINK_NAV)
    assert not world.robot_in_collision()


def test_park_and_carry_are_self_collision_free_and_in_the_footprint(world: World) -> None:
    robot, c = world.robot_body, world.client
    arm_links = {n for n in world.link_names if n[:2] in ("l_", "r_")}
    for config in ("park", "carry"):
        world.set_arm_configuration(config)
        world.move_torso(0.0)
        for name in arm_links:
            lo, hi = world.link_aabb(name)
            assert max(abs(lo[0]), abs(hi[0]), abs(lo[1]), abs(hi[1])) < 0.325, (config, name)
            assert lo[2] > 0.32, (config, name)  # above the base
            index = world._link(name)[1]
            for other in world.link_names:
                body, j = world._link(other)
                if body != robot:
                    continue
                if other in arm_links and other[0] == name[0]:
                    continue  # same arm: adjacent links touch by construction
                if j == pb.getJointInfo(robot, index, physicsClientId=c)[16]:
                    continue  # the arm's parent link
                pts = pb.getClosestPoints(robot, robot, 0.0, index, j, physicsClientId=c)
                assert not pts, (config, name, other)


def test_camera_height_range(world: World) -> None:
    world.move_torso(0.0)
    assert world.link_pose("head_mount_kinect_rgb_optical_frame").position[2] == pytest.approx(
        1.27, abs=0.005
    )
    world.move_torso(0.33)
    assert world.link_pose("head_mount_kinect_rgb_optical_frame").position[2] == pytest.approx(
        1.60, abs=0.005
    )


def test_demo_spawn_poses_are_on_the_sink_counter(world: World) -> None:
    lo, hi = world.link_aabb("sink_area_surface")
    top = hi[2]
    assert top == pytest.approx(0.85, abs=0.005)
    for name, (t, x, y, z, yaw) in DEMO_SPAWN.items():
        sx, sy, sz = OBJECT_TYPES[t].size
        assert lo[0] < x - sx / 2 and x + sx / 2 < hi[0], name
        assert lo[1] < y - sy / 2 and y + sy / 2 < hi[1], name
        rest = top + sz / 2
        assert abs(rest - z) < 0.15, name  # CRAM's spawn heights, mesh origins aside
        assert world.placing_pose_stable(t, Pose.from_xyz_yaw(x, y, rest + 0.002, yaw)), name
    # the spoon lies in the closed drawer, the drawer is under the counter top
    dlo, dhi = world.link_aabb("sink_area_left_upper_drawer_main")
    assert dlo[0] < 1.4 - 0.08 and 1.4 + 0.08 < dhi[0] and dlo[1] < 1.0 < dhi[1]
    assert dhi[2] < lo[2] + 0.01
    assert world.placing_pose_stable("spoon", Pose.from_xyz_yaw(1.4, 1.0, 0.7413, math.pi))
    # nothing from the demo collides with the robot at the sink
    world.drive(SINK_NAV)
    for name, (t, x, y, _, yaw) in DEMO_SPAWN.items():
        world.spawn_object(
            name, t, Pose.from_xyz_yaw(x, y, top + OBJECT_TYPES[t].size[2] / 2 + 0.001, yaw)
        )
    assert not world.robot_in_collision()


def test_island_surface_covers_the_placing_poses(world: World) -> None:
    lo, hi = world.link_aabb("kitchen_island_surface")
    assert hi[2] == pytest.approx(0.85, abs=0.005)
    for x, y, _ in ISLAND_PLACES.values():
        assert lo[0] < x < hi[0] and lo[1] < y < hi[1]
    world.drive(ISLAND_NAV)
    assert not world.robot_in_collision()


def _reachable(world: World, obj_type: str, pose: Pose, waypoints: tuple[int, ...]) -> bool:
    base = world.robot_pose()
    obj_in_base = Pose(*_rel(base, pose), frame="base_footprint").to_transform("obj")
    for arm in PR2.arm_names:
        for g in knowledge.grasps(obj_type):
            poses = knowledge.grasp_poses(obj_type, g, obj_in_base, PR2_TOOL)
            snap = world.snapshot()
            try:
                for k in waypoints:
                    world.move_tcp(**{arm: poses[k]})
            except Exception:
                continue
            finally:
                world.restore(snap)
            return True
    return False


def _rel(base: Pose, pose: Pose) -> tuple[tuple[float, ...], tuple[float, ...]]:
    t = base.to_transform("base_footprint").inverse() * pose
    return t.position, t.orientation


def test_ik_reaches_the_demo_cup_from_the_sink_nav_goal(world: World) -> None:
    world.drive(SINK_NAV)
    assert _reachable(world, "cup", Pose((1.3, 0.6, 0.9)), (0, 1, 2, 3, 4))


def test_ik_reaches_the_island_placing_poses(world: World) -> None:
    world.drive(ISLAND_NAV)
    for t, xyz in ISLAND_PLACES.items():
        assert _reachable(world, t, Pose(xyz), (2,)), t


def test_robot_links_are_the_robot_bodys_links_below_its_base() -> None:
    """``World.robot_links``: what a held object can hang from (the truth checks and the
    world models tell a hand from the kitchen by it, never by a link's name)."""
    with World(seed=0) as w:
        links = w.robot_links
        for arm in PR2.arms:
            assert arm.hand_link in links and arm.tool_frame in links
        assert PR2.base_frame not in links  # the root link: nothing hangs from it
        for name, index in links.items():
            info = pb.getJointInfo(w.robot_body, index, physicsClientId=w.client)
            assert info[12].decode() == name
        kitchen = {
            pb.getJointInfo(w.kitchen_body, i, physicsClientId=w.client)[12].decode()
            for i in range(pb.getNumJoints(w.kitchen_body, physicsClientId=w.client))
        }
        assert w.kitchen.container.link in kitchen and not kitchen & set(links)
        w.spawn_object("cup-1", "cup", Pose((1.3, 0.6, 0.9)))
        w.attach("cup-1", w.kitchen.container.link)
        assert w.attachments["cup-1"] not in links
