"""The simulated real robot: motions take simulated time on the true world, perception
teaches the belief world, seeded faults raise typed failures, probes stay in the belief."""

from __future__ import annotations

import asyncio
import contextlib
import math
from collections.abc import Iterator
from typing import Any

import pytest

import cpl
import executive
from cpl.testing import MockClock
from executive import Designator, PMStatus, Pose, a, an, knowledge, perform
from executive.events import ObjectAttached, ObjectDetached, emit
from executive.failures import (
    GripperClosedCompletely,
    ManipulationPoseUnreachable,
    NavigationGoalNotReached,
    PerceptionObjectNotFound,
    PtuGoalNotReached,
)
from projection import (
    FaultProfile,
    RealWorldModel,
    World,
    make_world_pair,
    real_robot_clock,
    set_up_scene,
    with_real_robot,
)
from projection._real_body import (
    ARM_JOINT_VELOCITY,
    BASE_VELOCITY,
    DETECTION_TIME,
    TORSO_VELOCITY,
)
from robots.pr2 import DESCRIPTION as PR2
from robots.pr2 import STANDARD_TO_TOOL as PR2_TOOL

SINK_NAV = Pose.from_xyz_yaw(0.75, 0.70, 0.0, 0.0)
CUP = "cup-1"
CUP_LOOK = Pose((1.3, 0.6, 0.9))


@pytest.fixture()
def pair() -> Iterator[tuple[World, World]]:
    true, belief = make_world_pair(0)
    try:
        yield true, belief
    finally:
        true.close()
        belief.close()


def run(fn: Any, *args: Any) -> Any:
    return cpl.run(fn, *args, clock=MockClock())


def now() -> float:
    return asyncio.get_running_loop().time()


async def go(pose: Pose) -> None:
    await perform(a.motion(type="going", pose=pose))


async def look_and_detect(object_type: str = "cup") -> Designator:
    await perform(a.motion(type="looking", pose=CUP_LOOK))
    result: Designator = await perform(
        a.motion(type="detecting", object=an.object(type=object_type))
    )
    return result


def real(true: World, belief: World, faults: FaultProfile | None = None, **kw: Any) -> Any:
    return with_real_robot(true, belief, faults or FaultProfile.none(), rules=None, **kw)


# ----------------------------------------------------------------------------- motion
def test_going_takes_distance_over_velocity_and_belief_follows(pair: tuple[World, World]) -> None:
    true, belief = pair

    async def main() -> float:
        async with real(true, belief):
            t0 = now()
            await go(SINK_NAV)
            return now() - t0

    elapsed = run(main)
    assert elapsed == pytest.approx(math.hypot(0.75, 0.70) / BASE_VELOCITY, abs=1e-6)
    assert true.robot_pose().isclose(SINK_NAV, 1e-6, 1e-6)
    assert belief.robot_pose().isclose(true.robot_pose(), 1e-9, 1e-9)
    assert belief.objects == {}  # the robot knows where it is, not what is around


def test_turning_on_the_spot_takes_angle_over_angular_velocity(pair: tuple[World, World]) -> None:
    true, belief = pair

    async def main() -> float:
        async with real(true, belief):
            t0 = now()
            await go(Pose.from_xyz_yaw(0.0, 0.0, 0.0, math.pi / 2))
            return now() - t0

    assert run(main) == pytest.approx(math.pi / 2, abs=1e-6)  # 1 rad/s
    assert true.robot_pose().yaw == pytest.approx(math.pi / 2)


def test_driving_through_the_counter_stops_before_it(pair: tuple[World, World]) -> None:
    true, belief = pair

    async def main() -> float:
        async with real(true, belief):
            await go(SINK_NAV)
            t0 = now()
            with pytest.raises(NavigationGoalNotReached):
                await go(Pose.from_xyz_yaw(2.5, 0.7, 0.0, 0.0))
            return now() - t0

    elapsed = run(main)
    x = true.robot_pose().position[0]
    assert 0.75 < x < 1.3  # moved, and stopped in front of the counter (it starts ~1.5 m)
    assert elapsed < (2.5 - 0.75) / BASE_VELOCITY
    assert not true.robot_in_collision()
    assert belief.robot_pose().isclose(true.robot_pose(), 1e-9, 1e-9)


def test_torso_and_arm_motions_take_delta_over_velocity(pair: tuple[World, World]) -> None:
    true, belief = pair
    true.arm_motion_planning = False  # planned motions follow the planner's timing
    carry = PR2.arm("left").state("carry")

    async def main() -> tuple[float, float]:
        async with real(true, belief):
            t0 = now()
            await perform(a.motion(type="moving-torso", joint_angle=0.25))
            t1 = now()
            await perform(a.motion(type="moving-arm-joints", left_joint_states=carry))
            return t1 - t0, now() - t1

    torso_time, arm_time = run(main)
    assert torso_time == pytest.approx(0.10 / TORSO_VELOCITY, abs=1e-6)
    park = PR2.arm("left").state("park")
    # the continuous joints (the forearm and wrist roll: limits -inf, inf) the short way
    limits = true.arm_joint_limits("left")
    delta = max(
        abs(math.remainder(p - q, 2 * math.pi)) if math.isinf(hi) else abs(p - q)
        for p, q, (_j, _lo, hi) in zip(park, carry, limits)
    )
    assert arm_time == pytest.approx(delta / ARM_JOINT_VELOCITY, abs=1e-6)
    assert true.torso_height == pytest.approx(0.25)
    assert true.arm_joints("left") == pytest.approx(carry)
    assert belief.arm_joints("left") == pytest.approx(carry)
    assert belief.torso_height == pytest.approx(0.25)


def test_an_evaporated_motion_stops_the_robot_where_it_is(pair: tuple[World, World]) -> None:
    true, belief = pair
    goal = Pose.from_xyz_yaw(0.0, -1.2, 0.0, 0.0)

    async def main() -> None:
        async with real(true, belief) as env:
            task = cpl.spawn(go(goal), name="drive")
            await cpl.sleep(1.0)
            task.evaporate("test")
            with contextlib.suppress(Exception):
                await task.join()
            assert task.status.value is cpl.Status.EVAPORATED
            y = true.robot_pose().position[1]
            assert -0.61 < y < -0.5  # ~0.6 m after 1 s
            await cpl.sleep(1.0)
            assert true.robot_pose().position[1] == y  # stopped
            assert belief.robot_pose().isclose(true.robot_pose(), 1e-9, 1e-9)
            pms = env.process_modules
        assert all(pm.status.value is PMStatus.OFFLINE and pm.pending == 0 for pm in pms)

    run(main)


# ------------------------------------------------------------------------- perception
def _detect_once(seed: int, noise: tuple[float, float]) -> tuple[Pose, Pose, Pose]:
    true, belief = make_world_pair(0)
    try:

        async def main() -> Pose:
            faults = FaultProfile(detection_noise=noise, seed=seed)
            async with real(true, belief, faults):
                await go(SINK_NAV)
                perceived = await look_and_detect()
                assert perceived.get("name") == CUP
                pose: Pose = perceived.get("pose")
                return pose

        pose = run(main)
        return pose, true.object_pose(CUP), belief.object_pose(CUP)
    finally:
        true.close()
        belief.close()


def test_detect_is_noisy_reproducible_and_teaches_the_belief() -> None:
    perceived, truth, believed = _detect_once(seed=7, noise=(0.02, 0.05))
    error = math.dist(perceived.position[:2], truth.position[:2])
    assert 1e-4 < error < 5 * 0.02 * math.sqrt(2)
    assert perceived.position[2] == pytest.approx(truth.position[2])
    assert 1e-5 < abs(perceived.yaw - truth.yaw) < 5 * 0.05
    assert believed.isclose(perceived, 1e-6, 1e-6)  # the belief learnt the perceived pose
    again, _, _ = _detect_once(seed=7, noise=(0.02, 0.05))
    assert again.isclose(perceived, 1e-12, 1e-12)
    other, _, _ = _detect_once(seed=8, noise=(0.02, 0.05))
    assert not other.isclose(perceived, 1e-6, 1e-6)
    exact, truth, _ = _detect_once(seed=7, noise=(0.0, 0.0))
    assert exact.isclose(truth, 1e-9, 1e-6)


def test_detection_takes_time_and_a_hidden_object_is_not_found(pair: tuple[World, World]) -> None:
    true, belief = pair

    async def main() -> float:
        async with real(true, belief):
            t0 = now()
            with pytest.raises(PerceptionObjectNotFound):  # the spoon is in the closed drawer
                await perform(a.motion(type="detecting", object=an.object(type="spoon")))
            return now() - t0

    assert run(main) == pytest.approx(DETECTION_TIME)
    assert belief.objects == {}


def test_miss_rate_one_never_sees_anything(pair: tuple[World, World]) -> None:
    true, belief = pair

    async def main() -> None:
        async with real(true, belief, FaultProfile(miss_rate=1.0)):
            await go(SINK_NAV)
            with pytest.raises(PerceptionObjectNotFound):
                await look_and_detect()

    run(main)
    assert belief.objects == {}


# ------------------------------------------------------------------------------ faults
def test_navigation_fault_stops_part_of_the_way(pair: tuple[World, World]) -> None:
    true, belief = pair

    async def main() -> None:
        async with real(true, belief, FaultProfile(navigation=1.0)):
            with pytest.raises(NavigationGoalNotReached):
                await go(Pose.from_xyz_yaw(0.0, -1.0))

    run(main)
    y = true.robot_pose().position[1]
    assert -0.8 - 1e-9 <= y <= -0.2 + 1e-9
    assert belief.robot_pose().isclose(true.robot_pose(), 1e-9, 1e-9)


def test_ptu_perception_and_ik_faults_raise_their_failures(pair: tuple[World, World]) -> None:
    true, belief = pair

    async def main() -> None:
        async with real(true, belief, FaultProfile.uniform(1.0, detection_noise=(0, 0))):
            with pytest.raises(PtuGoalNotReached):
                await perform(a.motion(type="looking", pose=Pose((1.0, 0.5, 0.5))))
            with pytest.raises(PerceptionObjectNotFound):
                await perform(a.motion(type="detecting", object=an.object(type="cup")))
            arm = true.arm_joints("right")
            with pytest.raises(ManipulationPoseUnreachable):
                await perform(
                    a.motion(
                        type="moving-tcp", right_pose=Pose((0.5, -0.2, 1.0), frame="base_footprint")
                    )
                )
            assert true.arm_joints("right") == arm  # refused before moving

    run(main)
    assert true.joint_position("head_pan_joint") != 0.0  # the head stopped on the way


def test_rate_zero_never_fails_and_the_same_seed_repeats_the_faults() -> None:
    def outcomes(faults: FaultProfile) -> list[bool]:
        true, belief = make_world_pair(0)
        out: list[bool] = []

        async def main() -> None:
            async with real(true, belief, faults):
                for k in range(12):
                    try:
                        await go(Pose.from_xyz_yaw(0.2 * (k % 2), 0.0))
                        await perform(a.motion(type="looking", direction="forward"))
                        out.append(True)
                    except (NavigationGoalNotReached, PtuGoalNotReached):
                        out.append(False)

        try:
            run(main)
        finally:
            true.close()
            belief.close()
        return out

    assert outcomes(FaultProfile.uniform(0.0)) == [True] * 12
    first = outcomes(FaultProfile(navigation=0.5, ptu=0.3, seed=11))
    assert first == outcomes(FaultProfile(navigation=0.5, ptu=0.3, seed=11))
    assert True in first and False in first


# ------------------------------------------------------------------------------ picking
async def _pick(true: World, belief: World) -> str:
    """Go to the sink, detect the cup, choose an arm and grasp the belief's probe accepts
    (the belief knows the cup's neighbours, as perceived), and pick it up as CRAM's
    pick-up does (open, reach, grasp, grip, attach, lift). Returns the arm."""
    await go(SINK_NAV)
    cup = await look_and_detect()
    model = executive.current_environment().world
    assert isinstance(model, RealWorldModel)
    transform = cup.get("transform")
    for arm, grasp in ((arm, g) for arm in ("left", "right") for g in knowledge.grasps("cup")):
        poses = knowledge.grasp_poses("cup", grasp, transform, PR2_TOOL)
        if model.probe_arm_trajectory(arm, poses, allowed_contacts=[CUP]).ok:
            break
    else:
        pytest.fail("no grasp of the cup is reachable")
    opening = knowledge.gripper_opening("cup")
    await perform(a.motion(type="moving-gripper-joint", gripper=arm, joint_angle=opening))
    # with the pick-up's collision modes: the reach avoids everything, the grasp may
    # touch the cup (allow-all), the lift leaves with it (allow-hand)
    for pose in poses[:2]:
        await perform(a.motion(type="moving-tcp", **{f"{arm}_pose": pose}))
    await perform(
        a.motion(type="moving-tcp", **{f"{arm}_pose": poses[2]}, collision_mode="allow-all")
    )
    await perform(a.motion(type="gripping", gripper=arm))
    emit(ObjectAttached(CUP, arm, f"{arm[0]}_wrist_roll_link"))
    for pose in poses[3:]:
        await perform(
            a.motion(type="moving-tcp", **{f"{arm}_pose": pose}, collision_mode="allow-hand")
        )
    return arm


def test_a_pick_attaches_in_both_worlds(pair: tuple[World, World]) -> None:
    true, belief = pair
    z0 = true.object_pose(CUP).position[2]
    arms = []

    async def main() -> None:
        async with real(true, belief, FaultProfile()):  # default detection noise
            arms.append(await _pick(true, belief))
            await cpl.sleep(2.0)
            await perform(a.motion(type="moving-torso", joint_angle=true.torso_height))

    run(main)
    wrist = f"{arms[0][0]}_wrist_roll_link"
    assert true.attachments.get(CUP) == wrist
    assert belief.attachments.get(CUP) == wrist
    assert true.object_pose(CUP).position[2] > z0 + 0.05  # lifted in the true world
    assert math.dist(true.object_pose(CUP).position, belief.object_pose(CUP).position) < 0.05


def test_grasp_slip_fails_the_grip_and_nothing_is_attached(pair: tuple[World, World]) -> None:
    true, belief = pair

    async def main() -> None:
        async with real(true, belief, FaultProfile(grasp_slip=1.0, detection_noise=(0, 0))):
            with pytest.raises(GripperClosedCompletely):
                await _pick(true, belief)

    run(main)
    assert true.attachments.get(CUP) is None
    assert belief.attachments.get(CUP) is None


def test_a_drop_during_the_lift_leaves_the_object_on_the_counter(pair: tuple[World, World]) -> None:
    true, belief = pair

    async def main() -> None:
        async with real(true, belief, FaultProfile(drop=1.0, detection_noise=(0, 0))):
            with pytest.raises(GripperClosedCompletely):
                await _pick(true, belief)
            await cpl.sleep(3.0)  # the cup falls and settles while time passes
            await perform(a.motion(type="moving-torso", joint_angle=true.torso_height))
            emit(ObjectDetached(CUP, "left"))

    run(main)
    assert CUP not in true.attachments
    z = true.object_pose(CUP).position[2]
    assert z < 1.0  # on (or below) the counter top, not in the hand
    assert true.gripper_opening("left") == pytest.approx(0.0)


# ----------------------------------------------------------------------- belief, probes
def test_probes_restore_the_belief_and_never_touch_the_truth(pair: tuple[World, World]) -> None:
    true, belief = pair

    async def main() -> None:
        async with real(true, belief):
            await go(SINK_NAV)
            await look_and_detect()
            model = executive.current_environment().world
            assert isinstance(model, RealWorldModel)
            before_true, before_belief = true.snapshot(), belief.snapshot()
            transform = belief.object_pose(CUP, "base_footprint").to_transform(CUP)
            poses = knowledge.grasp_poses("cup", knowledge.grasps("cup")[0], transform, PR2_TOOL)
            model.probe_arm_trajectory("left", poses, robot_pose=SINK_NAV, gripper_opening=0.1)
            model.probe_base_pose(Pose.from_xyz_yaw(2.0, 0.7))
            model.probe_placing_stability("cup", Pose((-0.79, 1.35, 0.9)))
            assert true.snapshot() == before_true
            assert _same(belief.snapshot(), before_belief)
            assert model.robot_pose() == belief.robot_pose()
            assert model.object_pose(CUP) == belief.object_pose(CUP)

    run(main)


def _same(s1: Any, s2: Any) -> bool:
    """Snapshots equal up to float rounding (PyBullet renormalises quaternions)."""
    return bool(s1.isclose(s2))


def test_world_model_events_apply_to_both_worlds(pair: tuple[World, World]) -> None:
    true, belief = pair
    model = RealWorldModel(true, belief)
    with pytest.raises(executive.PerceptionObjectNotInWorld):
        model.object_pose(CUP)  # the belief knows no objects yet
    model.handle_event(
        executive.events.ObjectPerceived(an.object(type="cup", name=CUP, pose=CUP_LOOK))
    )
    assert model.object_pose(CUP) == CUP_LOOK
    model.handle_event(ObjectAttached(CUP, "left"))  # the true gripper is far away
    assert belief.attachments[CUP] == "l_wrist_roll_link" and CUP not in true.attachments
    drawer = "sink_area_left_upper_drawer_main"
    model.handle_event(executive.events.ContainerOpened(drawer, 0.2))
    assert true.joint_position(f"{drawer}_joint") == pytest.approx(0.2)
    assert belief.joint_position(f"{drawer}_joint") == pytest.approx(0.2)
    with pytest.raises(ValueError, match="different"):
        RealWorldModel(true, true)
    assert isinstance(model, executive.ProjectionWorld)


# ----------------------------------------------------------------- clocks, profiles, pairs
def test_clock_and_speed() -> None:
    for fast in (None, math.inf):
        clock = real_robot_clock(fast)
        assert isinstance(clock, cpl.ScaledClock) and clock.rate == math.inf
    scaled = real_robot_clock(4.0)
    assert isinstance(scaled, cpl.ScaledClock) and scaled.factor == 4.0
    true, belief = make_world_pair(0)
    try:

        async def main(speed: float) -> None:
            async with real(true, belief, speed=speed):
                pass

        run(main, math.inf)
        with pytest.raises(ValueError, match="real_robot_clock"):
            run(main, 2.0)
        cpl.run(main, 1.0)  # the loop's own time is real time
    finally:
        true.close()
        belief.close()


def test_fault_profiles() -> None:
    assert FaultProfile.parse("0.1") == FaultProfile.uniform(0.1)
    parsed = FaultProfile.parse("navigation=0.05,grasp_slip=0.1,detection_noise=0.02:0.1,seed=3")
    assert parsed.navigation == 0.05 and parsed.grasp_slip == 0.1 and parsed.ik == 0.0
    assert parsed.detection_noise == (0.02, 0.1) and parsed.seed == 3
    assert FaultProfile.parse("0.2,ik=0.5").rates == {**FaultProfile.uniform(0.2).rates, "ik": 0.5}
    assert FaultProfile.none().rates == dict.fromkeys(FaultProfile.KINDS, 0.0)
    assert FaultProfile.none().detection_noise == (0.0, 0.0)
    for bad in ("", "teleport=0.1", "ik=x", "ik=0.1,0.2"):
        with pytest.raises(ValueError):
            FaultProfile.parse(bad)
    with pytest.raises(ValueError):
        FaultProfile(navigation=1.5)
    with pytest.raises(ValueError):
        FaultProfile(detection_noise=(-0.1, 0.0))


def test_world_pairs() -> None:
    for mode in ("none", "exact", "noisy"):
        true, belief = make_world_pair(3, belief_objects=mode)
        try:
            assert set(true.objects) == {
                "breakfast-cereal-1",
                "cup-1",
                "bowl-1",
                "milk-1",
                "spoon-1",
            }
            assert true.attachments == {"spoon-1": "sink_area_left_upper_drawer_main"}
            assert belief.robot_pose() == true.robot_pose()
            if mode == "none":
                assert belief.objects == {}
                continue
            assert belief.objects == true.objects
            error = max(
                math.dist(true.object_pose(n).position, belief.object_pose(n).position)
                for n in true.objects
            )
            assert (error < 1e-9) if mode == "exact" else (0 < error < 0.15)
        finally:
            true.close()
            belief.close()
    with pytest.raises(ValueError):
        make_world_pair(0, belief_objects="some")  # type: ignore[arg-type]


# ------------------------------------------------------------------------------ plans
def test_a_bowl_transport_plan_succeeds_on_the_real_robot(mrun: Any) -> None:
    plans = pytest.importorskip("plans")
    true, belief = make_world_pair(0, objects={})
    try:

        async def main() -> Any:
            async with with_real_robot(true, belief, FaultProfile(seed=1)):
                return await plans.table_setting(("bowl",))

        set_up_scene(true, ("bowl",), random=False, settle_steps=0)
        outcome = mrun(main)["bowl"]
        assert outcome.success, outcome.failure
        assert true.attachments == {} and belief.attachments == {}
        # the belief learnt the bowl by perception and put it on the island
        assert belief.objects == {"bowl-1": "bowl"}
        (lx, ly, _), (hx, hy, hz) = belief.link_aabb("kitchen_island_surface")
        x, y, z = belief.object_pose("bowl-1").position
        assert lx < x < hx and ly < y < hy and hz < z < hz + 0.1
        # the true bowl is on the island too (the controller routes the final park
        # motion around it instead of sweeping the hand through it)
        x, y, z = true.object_pose("bowl-1").position
        assert lx < x < hx and ly < y < hy and hz < z < hz + 0.1
        assert belief.robot_pose() == true.robot_pose()
    finally:
        true.close()
        belief.close()
