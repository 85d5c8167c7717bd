"""A projection world built from a robot description other than the PR2-like robot's: the
one-armed mobile Franka Panda of ``robots.panda`` (issue 25). Everything the world does
with the robot (its body, arm, gripper, torso, neck and camera) comes from the
description; nothing may assume a ``right`` arm."""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterator
from typing import Any

import numpy as np
import pybullet as pb
import pytest

from executive import (
    GripperGoalNotReached,
    PerceptionObjectNotFound,
    Pose,
    Resource,
    RobotDescriptionError,
    TorsoGoalNotReached,
    a,
    an,
    perform,
)
from executive.events import ObjectAttached, emit
from projection import World, with_projected_robot
from projection._process_modules import projection_process_modules
from robots import panda

PANDA = panda.DESCRIPTION
ARM = PANDA.arm("left")
#: CRAM's demo cup on the sink counter
CUP = (1.3, 0.6, 0.9)
#: facing the counter, 0.55 m from the cup: inside the Panda's reach annulus
#: (0.2 .. 0.8 m) of the ``reachable-for`` costmap, the base's front 7 cm off the counter
SINK_NAV = Pose.from_xyz_yaw(0.75, 0.6, 0.0, 0.0)
_S = math.sqrt(0.5)
#: a grasp from the back: the hand's z (approach) along map x, the fingers along map y
BACK = (0.0, _S, 0.0, _S)


@pytest.fixture()
def world() -> Iterator[World]:
    with World(seed=0, robot=PANDA) as w:
        yield w


@pytest.fixture()
def sink(world: World) -> World:
    world.drive(SINK_NAV)
    world.spawn_object("cup-1", "cup", Pose(CUP))
    return world


def _self_contacts(world: World) -> list[tuple[str, str]]:
    """Pairs of robot links (not parent and child) closer than 1 mm."""
    c, body = world.client, world.robot_body
    n = pb.getNumJoints(body, physicsClientId=c)
    parent = {i: pb.getJointInfo(body, i, physicsClientId=c)[16] for i in range(n)}
    name = {-1: "base_footprint"} | {
        i: pb.getJointInfo(body, i, physicsClientId=c)[12].decode() for i in range(n)
    }
    arm = world.arm_links("left")
    out = []
    for i in range(-1, n):
        for k in range(i + 1, n):
            if parent[k] == i or (i >= 0 and parent[i] == k):
                continue
            if name[i] not in arm and name[k] not in arm:
                continue  # base, torso and mast are built apart
            if name[i] in arm and name[k] in arm:
                continue  # the arm's own links: pybullet_data's hand touches link7
            if pb.getClosestPoints(body, body, 0.001, i, k, physicsClientId=c):
                out.append((name[i], name[k]))
    return out


def _camera_error(world: World, point: tuple[float, float, float]) -> float:
    cam = world.link_pose(PANDA.neck.camera.frame)
    z = cam.as_rotation().apply([0.0, 0.0, 1.0])
    d = np.subtract(point, cam.position)
    return float(math.acos(min(1.0, np.dot(z, d) / np.linalg.norm(d))))


# ------------------------------------------------------------------ the body
def test_a_new_panda_world_is_the_description_parked_and_collision_free(world: World) -> None:
    assert world.robot is PANDA and world.arms == ("left",)
    assert world.body_of("panda") == world.robot_body
    assert world.link_names.count("panda_grasptarget") == 1
    assert "r_gripper_tool_frame" not in world.link_names  # not the PR2 body
    assert world.arm_joints("left") == pytest.approx(ARM.state("park"))
    assert world.torso_height == pytest.approx(PANDA.torso.default)
    assert world.gripper_opening("left") == pytest.approx(0.08)
    assert world.robot_collisions() == []
    assert _self_contacts(world) == []
    assert world.robot_pose().position == pytest.approx((0.0, 0.0, 0.0))
    assert world.link_pose("base_footprint").position == pytest.approx((0.0, 0.0, 0.0))
    # the hand's links are the gripper; the arm's are everything from panda_link1 down
    assert world.gripper_links("left") == {
        "panda_leftfinger",
        "panda_rightfinger",
        "panda_grasptarget",
    }
    assert "panda_link1" in world.arm_links("left") and "panda_link0" not in world.arm_links("left")
    world.set_arm_configuration("carry")
    assert world.arm_joints("left") == pytest.approx(ARM.state("carry"))
    assert world.robot_collisions() == [] and _self_contacts(world) == []


def test_a_one_armed_robot_has_no_right_arm(world: World) -> None:
    before = world.arm_joints("left")
    with pytest.raises(ValueError, match="known arms: left"):
        world.arm_joints("right")
    with pytest.raises(ValueError, match="known arms: left"):
        world.move_joints(right=ARM.state("park"))
    with pytest.raises(ValueError, match="known arms: left"):
        world.move_tcp(right=Pose((0.5, 0.0, 1.0), frame="base_footprint"))
    with pytest.raises(ValueError, match="known arms: left"):
        world.gripper("open", "right")
    with pytest.raises(ValueError, match="needs 7 joint values"):
        world.move_joints(left=(0.0,) * 6)
    assert world.arm_joints("left") == before
    world.park_arms()  # every arm the robot has
    world.park_arms("carry")
    assert world.arm_joints("left") == pytest.approx(ARM.state("carry"))


def test_a_description_that_misfits_its_urdf_is_refused_before_loading() -> None:
    import dataclasses

    bad = dataclasses.replace(
        PANDA, arms=(dataclasses.replace(ARM, tool_frame="panda_grasp_target"),)
    )
    with pytest.raises(RobotDescriptionError, match="did you mean 'panda_grasptarget'"):
        World(robot=bad)
    seeds = dataclasses.replace(PANDA, arms=(dataclasses.replace(ARM, ik_seeds=((0.0,) * 6,)),))
    with pytest.raises(RobotDescriptionError, match=r"ik_seeds\[0\]: has 6 values for 7"):
        World(robot=seeds)


# ------------------------------------------------------------------ drive, torso, head
def test_drive_torso_and_head(world: World) -> None:
    world.drive(SINK_NAV)
    assert world.robot_pose().position == pytest.approx((0.75, 0.6, 0.0))
    assert world.link_pose("base_footprint").position == pytest.approx((0.75, 0.6, 0.0))
    cam0 = world.link_pose(PANDA.neck.camera.frame).position[2]
    world.move_torso(0.35)
    assert world.torso_height == pytest.approx(0.35)
    assert world.link_pose(PANDA.neck.camera.frame).position[2] == pytest.approx(cam0 + 0.15)
    with pytest.raises(TorsoGoalNotReached):
        world.move_torso(0.45)  # the Panda base's torso stops at 0.40
    world.move_torso(0.40)  # the PR2-like robot's would stop at 0.33
    for point in (CUP, (0.9, 1.4, 1.6), (1.6, -0.2, 0.2)):
        world.look_at(Pose(point))
        assert _camera_error(world, point) < 2e-3
    world.look_at("forward")
    assert world.joint_position("head_pan_joint") == 0.0


# ------------------------------------------------------------------ arm, gripper, hand
def test_ik_reaches_the_demo_cup_on_the_sink_counter(sink: World) -> None:
    pre = Pose((1.2, 0.6, 0.9), BACK)
    grasp = Pose(CUP, BACK)
    sink.move_tcp(left=pre)
    tool = sink.link_pose(ARM.tool_frame)
    assert tool.distance_to(pre) < 0.01
    # the hand's approach axis (z) points at the cup, along map x
    assert tool.as_rotation().apply([0.0, 0.0, 1.0]) == pytest.approx((1.0, 0.0, 0.0), abs=0.1)
    sink.move_tcp(left=grasp)
    assert sink.link_pose(ARM.tool_frame).distance_to(grasp) < 0.01
    # and in base_footprint, from a parked arm, as the plans give goals
    sink.park_arms()
    goal = Pose((0.55, 0.0, 0.95), BACK, "base_footprint")
    sink.move_tcp(left=goal)
    assert sink.link_pose(ARM.tool_frame, "base_footprint").distance_to(goal) < 0.01


def test_the_gripper_opens_to_8_cm_and_closes_on_the_cup(sink: World) -> None:
    sink.gripper("close", "left")
    assert sink.gripper_opening("left") == 0.0
    sink.gripper(0.05, "left")
    assert sink.gripper_opening("left") == pytest.approx(0.05)
    assert sink.joint_position("panda_finger_joint2") == pytest.approx(0.025)
    with pytest.raises(GripperGoalNotReached, match=r"outside \[0, 0.08\]"):
        sink.gripper(0.09, "left")  # the PR2-like robot's would open that far
    sink.gripper("open", "left")
    assert sink.gripper_opening("left") == pytest.approx(0.08)
    sink.move_tcp(left=Pose(CUP, BACK))
    sink.gripper("grip", "left")
    # stopped on the cup: neither open nor closed
    assert 0.04 < sink.gripper_opening("left") < 0.08
    assert sink._gripper_touches("left")


def test_an_attached_cup_follows_the_hand(sink: World) -> None:
    sink.move_tcp(left=Pose(CUP, BACK))
    sink.gripper("grip", "left")
    sink.attach("cup-1", ARM.hand_link)
    in_hand = sink.object_pose("cup-1", "base_footprint")
    sink.move_tcp(left=Pose((1.3, 0.6, 1.05), BACK))
    assert sink.object_pose("cup-1").position == pytest.approx((1.3, 0.6, 1.05), abs=0.01)
    sink.set_arm_configuration("carry")
    carried = sink.object_pose("cup-1", "base_footprint")
    assert carried.distance_to(in_hand) > 0.2
    sink.drive(Pose.from_xyz_yaw(0.0, 0.6, 0.0, math.pi / 2))
    assert sink.object_pose("cup-1", "base_footprint").distance_to(carried) < 1e-6
    assert sink.robot_collisions() == []


def test_perception_sees_the_cup_in_front_of_the_camera(sink: World) -> None:
    sink.look_at(Pose(CUP))
    assert _camera_error(sink, CUP) < 2e-3  # the Panda's camera frame points at it
    (cup,) = sink.detect({"type": "cup"})
    assert cup.name == "cup-1"
    assert cup.pose.position == pytest.approx((0.55, 0.0, 0.9), abs=1e-4)
    sink.look_at("forward")
    sink.drive(Pose.from_xyz_yaw(0.75, 0.6, 0.0, math.pi))  # back to the counter
    with pytest.raises(PerceptionObjectNotFound):
        sink.detect({"type": "cup"})


# ------------------------------------------------------------------ process modules
def test_the_process_modules_claim_the_robots_parts(world: World) -> None:
    modules = {pm.name: pm for pm in projection_process_modules(world)}
    assert modules["arms"].resources == {Resource.arm("left")}
    assert modules["grippers"].resources == {Resource.gripper("left")}


def test_a_pick_through_the_projection_process_modules(mrun: Any, world: World) -> None:
    world.spawn_object("cup-1", "cup", Pose(CUP))

    async def body() -> Any:
        async with with_projected_robot(world):
            await perform(a.motion(type="going", target=a.location(pose=SINK_NAV)))
            await perform(a.motion(type="moving-torso", joint_angle=0.3))
            await perform(a.motion(type="looking", pose=Pose(CUP)))
            cup = await perform(a.motion(type="detecting", object=an.object(type="cup")))
            pose = cup.reference().pose
            assert pose.position == pytest.approx(CUP, abs=1e-4)
            await perform(a.motion(type="opening-gripper", gripper="left"))
            pre = Pose((1.2, 0.6, 0.9), BACK)
            await perform(a.motion(type="moving-tcp", left_pose=pre))
            await perform(a.motion(type="moving-tcp", left_pose=Pose(CUP, BACK)))
            await perform(a.motion(type="gripping", gripper="left", effort=20))
            emit(ObjectAttached(cup, "left"))
            lift = Pose((1.3, 0.6, 1.05), BACK)
            await perform(a.motion(type="moving-tcp", left_pose=lift))
            await perform(a.motion(type="moving-arm-joints", left_joint_states=ARM.state("carry")))
            return cup

    mrun(body, name="panda-pick")
    assert world.attachments == {"cup-1": ARM.hand_link}
    assert 0.04 < world.gripper_opening("left") < 0.08
    assert world.torso_height == pytest.approx(0.3)
    carried = world.object_pose("cup-1", "base_footprint").position
    # held over the front of the base, lifted off the counter
    assert carried[2] > 1.0 and abs(carried[1]) < 0.1


# ------------------------------------------------------------------ costmaps
def _resolve(world: World, fn: Any) -> Any:
    """Call ``fn`` inside an environment with the costmap rules of ``world``."""
    import asyncio

    import executive
    from projection._locations import location_rules

    async def main() -> Any:
        async with executive.environment(rules=location_rules(world)):
            return fn()

    return asyncio.run(main())


def test_reachable_for_uses_the_pandas_reach_and_its_poses_reach_the_cup(world: World) -> None:
    world.spawn_object("cup-1", "cup", Pose(CUP))
    d = a.location(reachable_for="panda", location=a.location(pose=Pose(CUP)))

    def samples() -> list[Pose]:
        out, cur = [], d
        for _ in range(12):
            out.append(cur.reference())
            nxt = cur.next_solution()
            assert nxt is not None
            cur = nxt
        return out

    poses = _resolve(world, samples)
    dists = [math.dist(p.position[:2], CUP[:2]) for p in poses]
    assert all(0.2 < r < 0.8 for r in dists)
    assert max(dists) > 0.7  # beyond the PR2-like robot's 0.7 m: the Panda's 0.8 m
    reached = 0
    for p in poses:
        world.park_arms()
        world.drive(p)  # collision-free (else NavigationPoseUnreachable)
        facing = math.atan2(CUP[1] - p.position[1], CUP[0] - p.position[0])
        # the back grasp, the hand's z along the facing direction
        q = pb.getQuaternionFromEuler((0.0, math.pi / 2, facing))
        try:
            world.move_tcp(left=Pose(CUP, tuple(q)))
        except Exception:
            continue
        reached += 1
    assert reached == len(poses)


def test_visible_for_casts_from_the_pandas_camera_heights(world: World) -> None:
    assert world.camera_heights() == (1.2, 1.33, 1.47, 1.6)  # its torso: 0 .. 0.40 m
    assert world.shoulder_xy("left") == (0.12, 0.0)  # the arm on the base's axis
    d = a.location(visible_for="panda", location=a.location(pose=Pose(CUP)))
    pose = _resolve(world, d.reference)
    assert math.dist(pose.position[:2], CUP[:2]) < 2.0


# ------------------------------------------------------------------ IK reach pre-check
def test_the_reach_precheck_read_from_the_chain_is_sound(world: World) -> None:
    """Heights the pre-check skips are heights the solver cannot reach either; and it
    skips some (the bound is read from the Panda's chain, not the PR2-like robot's)."""
    from projection._world_ik import _wrist_point

    offset = world._wrist_offset["left"]
    assert offset == pytest.approx((0.0, 0.0, -0.212))  # panda_link7 behind the tool
    rng = np.random.default_rng(3)
    saved = world._get_joints(world._dofs)
    rejected = 0
    for _ in range(120):
        pos_b = tuple(float(v) for v in rng.uniform((-0.3, -1.2, 0.0), (1.3, 1.2, 2.2)))
        yaw, pitch = rng.uniform(-math.pi, math.pi), rng.uniform(-1.5, 1.5)
        orn_b = tuple(pb.getQuaternionFromEuler((0.0, pitch, yaw)))
        h = float(rng.choice([0.0, 0.2, 0.4]))
        local = world._in_base(*world._to_map(Pose(pos_b, orn_b, "base_footprint")))
        if world._in_reach("left", _wrist_point(*local, offset), h):
            continue
        rejected += 1
        world._set_joints([world._torso], [h])
        pos, orn = world._to_map(Pose(pos_b, orn_b, "base_footprint"))
        assert world._solve_arm("left", pos, orn, saved) is None, (pos_b, orn_b, h)
    world._set_joints(world._dofs, saved)
    assert rejected > 20


# ------------------------------------------------------------------ the simulated real robot
def test_the_simulated_real_panda_picks_the_cup() -> None:
    import cpl
    from cpl.testing import MockClock
    from projection import FaultProfile, make_world_pair, with_real_robot

    true, belief = make_world_pair(0, objects={"cup-1": ("cup", Pose(CUP))}, robot=PANDA)
    assert true.robot is PANDA and belief.robot is PANDA

    async def main() -> None:
        async with with_real_robot(true, belief, FaultProfile.none(), rules=None):
            await perform(a.motion(type="going", pose=SINK_NAV))
            await perform(a.motion(type="looking", pose=Pose(CUP)))
            cup = await perform(a.motion(type="detecting", object=an.object(type="cup")))
            await perform(a.motion(type="opening-gripper", gripper="left"))
            # the pick-up's collision modes: reach (avoid all), grasp (allow-all: the
            # fingers close around the cup), lift (allow-hand)
            await perform(a.motion(type="moving-tcp", left_pose=Pose((1.2, 0.6, 0.9), BACK)))
            grasp = Pose((CUP[0], 0.6, 0.9), BACK)
            await perform(a.motion(type="moving-tcp", left_pose=grasp, collision_mode="allow-all"))
            await perform(a.motion(type="gripping", gripper="left"))
            emit(ObjectAttached(cup, "left"))
            lift = Pose((1.3, 0.6, 1.05), BACK)
            await perform(a.motion(type="moving-tcp", left_pose=lift, collision_mode="allow-hand"))

    try:
        cpl.run(main, clock=MockClock())
        assert true.attachments == {"cup-1": ARM.hand_link}
        assert belief.attachments == {"cup-1": ARM.hand_link}
        assert true.object_pose("cup-1").position[2] > CUP[2] + 0.1  # lifted
        assert true.robot_pose().position == pytest.approx(SINK_NAV.position, abs=1e-6)
    finally:
        true.close()
        belief.close()


# ------------------------------------------------------------------ motion planning
def test_a_planned_arm_motion_around_a_box_the_straight_line_sweeps() -> None:
    """The arm planner's chain, touch links and collision model come from the description
    (the Panda's 7 joints, its fingers, its URDF with self-collision)."""
    from projection._arm_planner import _planner
    from projection._objects import object_type

    with World(seed=0, robot=PANDA) as world:
        world.drive(Pose.from_xyz_yaw(0.6, 0.6, 0.0, 0.0))
        world.spawn_object("cup-1", "cup", Pose(CUP))
        h = object_type("breakfast-cereal").size[2]
        world.spawn_object("cereal-9", "breakfast-cereal", Pose((1.2, 0.75, 0.85 + h / 2 + 1e-3)))
        start = world.arm_joints("left")
        world.move_tcp(left=Pose((1.2, 0.6, 0.9), BACK))
        goal = world.arm_joints("left")
        world.move_joints(left=start)
        planner = _planner(world, "left")  # closed with the world
        assert planner.chain.joints == ARM.joints
        a_, b_ = np.asarray(start), np.asarray(goal)
        hits = set()
        for f in np.linspace(0.0, 1.0, 101):
            hits |= set(planner.collisions(a_ + f * (b_ - a_)))
        assert ("panda_hand", "cereal-9") in hits  # the straight line sweeps the box
        t = planner.plan(start, goal, seed=3)
        assert t.planned
        assert tuple(t.positions[0]) == start and tuple(t.positions[-1]) == goal
        p = t.positions
        for u, v in itertools.pairwise(p):
            k = max(1, int(np.ceil(np.linalg.norm(v - u) / 0.01)))
            for j in range(k + 1):
                assert planner.collisions(u + (j / k) * (v - u)) == []


# ------------------------------------------------------------------ the base's inertial frame
def test_a_root_link_with_an_offset_inertial_frame_is_posed_by_its_link_frame(
    tmp_path: Any,
) -> None:
    """PyBullet poses a body by its base's inertial frame: a robot whose root link has
    its inertial origin off the link frame still stands with ``base_footprint`` on the
    floor where it is driven, and its links where the same robot's are without it."""
    import dataclasses

    text = panda.urdf_text().replace(
        '<link name="base_footprint">\n    <inertial>\n',
        '<link name="base_footprint">\n    <inertial>\n'
        '      <origin xyz="0.1 -0.05 0.2" rpy="0 0 0.3" />\n',
        1,
    )
    assert 'xyz="0.1 -0.05 0.2"' in text
    path = tmp_path / "panda_offset.urdf"
    path.write_text(text)
    offset = dataclasses.replace(PANDA, urdf=lambda: path)
    goal = Pose.from_xyz_yaw(0.3, 0.4, 0.0, 0.7)
    with World(seed=0, robot=offset) as w, World(seed=0, robot=PANDA) as ref:
        assert w._base_inertial is not None and ref._base_inertial is None
        for world in (w, ref):
            world.drive(goal)
        assert w.robot_pose().position == pytest.approx((0.3, 0.4, 0.0))
        assert w.link_pose("base_footprint").position == pytest.approx((0.3, 0.4, 0.0), abs=1e-6)
        for link in ("base_link", "panda_grasptarget", PANDA.neck.camera.frame):
            assert w.link_pose(link).distance_to(ref.link_pose(link)) < 1e-6, link
        assert w.robot_collisions() == []
