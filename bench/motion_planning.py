"""The OMPL arm planner (``projection._motion_planner``) on typical kitchen arm motions,
beside today's controller (``projection._arm_planner.controller_path``: the straight
joint line, rerouted through a raised via or lifts when it hits a free object) on the same
queries in the same run.

The queries: the robot at the sink counter with CRAM's demo objects (cereal, cup, bowl,
milk) standing on it, each arm from ``carry`` to the pregrasp of every grasp of every
object that the world's IK reaches. For each: planning time (median / p90 over the
queries and ``--seeds`` seeds), whether a sampling planner ran, checks, trajectory
duration, and the objects each path sweeps, checked independently by the world's own
contact check (``swept_objects``, the 2 mm tolerance of ``World.robot_collisions``).
Then the cost of one collision check (planner: padded model; world: ``move_joints`` +
``robot_in_collision``) and of building / syncing a planner.

With ``--transport``: one bowl transport (CRAM's table setting with the bowl only),
projected (teleporting robot, swept probes in the world) and on the simulated real
robot (its controller in the true world, probes in the belief), with
``World.arm_motion_planning`` off (today) and on, twice each (the first run warms up).

    python bench/motion_planning.py [--seeds 3] [--transport]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
from _timing import median_us

from executive import Pose, knowledge
from executive.failures import ManipulationPoseUnreachable
from projection import World, make_world_pair
from projection._arm_planner import Config, controller_path, swept_objects
from projection._motion_planner import ArmMotionPlanner, _Checker
from projection._objects import object_type

SINK_NAV = Pose.from_xyz_yaw(0.75, 0.70, 0.0, 0.0)
OBJECTS = ("breakfast-cereal-1", "cup-1", "bowl-1", "milk-1")


def queries(world: World) -> list[tuple[str, str, tuple[float, ...], tuple[float, ...]]]:
    """(arm, label, carry, pregrasp configuration) for every reachable pregrasp."""
    out = []
    for arm in ("right", "left"):
        start = world.arm_joints(arm)
        for name in OBJECTS:
            otype = world.objects[name]
            tf = world.object_pose(name, "base_footprint").to_transform(name)
            for grasp in object_type(otype).grasps:
                try:
                    tool = world.robot.arm(arm).standard_to_tool
                    world.move_tcp(**{arm: knowledge.grasp_poses(otype, grasp, tf, tool)[0]})
                except ManipulationPoseUnreachable:
                    continue
                goal = world.arm_joints(arm)
                world.move_joints(**{arm: start})
                out.append((arm, f"{arm} -> {name} {grasp}", start, goal))
    return out


def pct(xs: list[float], q: float) -> float:
    return float(np.percentile(xs, q))


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--transport", action="store_true")
    args = parser.parse_args()
    seeds = args.seeds
    if args.transport:
        print("one bowl transport, wall time (MockClock):")
        for flag in (False, True, False, True):
            transport(flag)
    true, world = make_world_pair(0, belief_objects="exact")
    true.close()
    world.park_arms("carry")
    world.drive(SINK_NAV)
    qs = queries(world)
    free = {n for n in world.objects if n not in world.attachments}
    planners = {}
    for arm in ("right", "left"):
        desc = world.robot.arm(arm)
        touch = [n for n in world.link_names if n.startswith(f"{arm[0]}_gripper")]
        planners[arm] = ArmMotionPlanner.for_world(world, desc.joints, desc.tool_frame, touch)
    print(f"{len(qs)} queries (carry -> pregrasp at the sink counter), seeds 0..{seeds - 1}")
    ours_t: list[float] = []
    base_t: list[float] = []
    sampled = failed = 0
    ours_swept = base_swept = 0
    checks: list[int] = []
    durations: list[float] = []
    torso = world.torso_height
    refused = [q for q in qs if planners[q[0]].collisions(q[3])]
    for arm, label, _s, goal in refused:
        print(f"  {label}: the IK goal is in collision: {planners[arm].collisions(goal)[:3]}")
    qs = [q for q in qs if q not in refused]
    print(f"{len(qs)} queries left (the world's IK does not check self-collision)")
    for arm, label, start, goal in qs:
        planner = planners[arm]
        hit_here: set[str] = set()
        first = len(ours_t)
        for seed in range(seeds):
            t0 = time.perf_counter()
            try:
                traj = planner.plan(start, goal, seed=seed)
            except ManipulationPoseUnreachable as e:
                ours_t.append(time.perf_counter() - t0)
                failed += 1
                print(f"  {label}: ours failed ({e.details.get('reason')})")
                continue
            ours_t.append(time.perf_counter() - t0)
            sampled += traj.planned
            checks.append(traj.checks)
            durations.append(traj.duration)
            path: list[Config] = [(torso, {arm: tuple(map(float, q))}) for q in traj.positions]
            # the reached object may be touched at the pregrasp; the others never
            hit_here |= swept_objects(world, path, free) - _at_goal(world, arm, goal, free)
            world.move_joints(**{arm: start})
        ours_swept += bool(hit_here)
        print(f"  {label}: ours {[round(t * 1e3) for t in ours_t[first:]]} ms")
        # baseline: the controller, with the robot standing at the goal configuration
        world.move_joints(**{arm: goal})
        t0 = time.perf_counter()
        cpath = controller_path(world, "move-joints", [arm], {}, torso, {arm: start})
        base_t.append(time.perf_counter() - t0)
        bh = swept_objects(world, cpath, free) - _at_goal(world, arm, goal, free)
        base_swept += bool(bh)
        world.move_joints(**{arm: start})
        tag = f"ours sweeps {sorted(hit_here)}" if hit_here else ""
        if bh:
            tag += f" controller sweeps {sorted(bh)}"
        if tag:
            print(f"  {label}: {tag}")
    n = len(ours_t)
    print(
        f"OMPL planner  : median {statistics.median(ours_t) * 1e3:7.1f} ms  "
        f"p90 {pct(ours_t, 90) * 1e3:7.1f} ms  max {max(ours_t) * 1e3:7.1f} ms  over {n} plans; "
        f"sampled {sampled}, straight {n - sampled - failed}, failed {failed}; "
        f"median checks {statistics.median(checks):.0f}, "
        f"median duration {statistics.median(durations):.2f} s; "
        f"queries with a swept object {ours_swept}/{len(qs)}"
    )
    print(
        f"controller    : median {statistics.median(base_t) * 1e3:7.1f} ms  "
        f"p90 {pct(base_t, 90) * 1e3:7.1f} ms  max {max(base_t) * 1e3:7.1f} ms  over "
        f"{len(base_t)} paths; queries with a swept object {base_swept}/{len(qs)}"
    )
    # the cost of one check: random configurations, about a third in collision
    planner = planners["right"]
    chain = planner.chain
    rng = np.random.default_rng(0)
    samples = [rng.uniform(chain.lower, chain.upper) for _ in range(500)]
    padded = _Checker(planner.model, chain, ())
    exact = _Checker(planner.verifier, chain, ())
    k = [0]

    def ours_check() -> None:
        k[0] += 1
        padded.valid(samples[k[0] % len(samples)])

    def exact_check() -> None:
        k[0] += 1
        exact.valid(samples[k[0] % len(samples)])

    def world_check() -> None:
        k[0] += 1
        world.move_joints(right=tuple(map(float, samples[k[0] % len(samples)])))
        world.robot_in_collision()

    invalid = sum(not padded.valid(q) for q in samples)
    print(f"one check ({invalid}/{len(samples)} samples in collision):")
    print(f"  planner, padded model   {median_us(ours_check, 3000):8.1f} µs")
    print(f"  planner, exact model    {median_us(exact_check, 3000):8.1f} µs")
    print(f"  world move_joints + robot_in_collision {median_us(world_check, 3000):8.1f} µs")
    world.move_joints(right=qs[0][2])
    t0 = time.perf_counter()
    other = ArmMotionPlanner.for_world(
        world, chain.joints, world.robot.arm("right").tool_frame, ["r_gripper_palm_link"]
    )
    built = time.perf_counter() - t0
    t0 = time.perf_counter()
    other.sync(world)
    synced = time.perf_counter() - t0
    other.close()
    print(f"planner build {built * 1e3:.1f} ms (2 models, self pairs), sync {synced * 1e3:.1f} ms")
    for p in planners.values():
        p.close()
    world.close()


def transport(flag: bool) -> None:
    import cpl
    import plans
    from cpl.testing import MockClock
    from projection import FaultProfile, set_up_scene, with_projected_robot, with_real_robot

    world = World(seed=0)
    world.arm_motion_planning = flag

    async def projected() -> dict[str, plans.ObjectOutcome]:
        async with with_projected_robot(world):
            return await plans.table_setting(("bowl",))

    t0 = time.perf_counter()
    set_up_scene(world, ("bowl",), random=False, settle_steps=0)
    out = cpl.run(projected, clock=MockClock())["bowl"]
    dt = time.perf_counter() - t0
    hits = sum(p.cache_hits for p in world._arm_planners.values())
    print(
        f"  projected  planning={flag!s:5}: {dt:6.2f} s  success {out.success}  "
        f"fallbacks {world.motion_planning_fallbacks}  cache hits {hits}"
    )
    world.close()
    true, belief = make_world_pair(0, objects={})
    true.arm_motion_planning = belief.arm_motion_planning = flag

    async def real() -> dict[str, plans.ObjectOutcome]:
        async with with_real_robot(true, belief, FaultProfile(seed=1)):
            return await plans.table_setting(("bowl",))

    t0 = time.perf_counter()
    set_up_scene(true, ("bowl",), random=False, settle_steps=0)
    out = cpl.run(real, clock=MockClock())["bowl"]
    dt = time.perf_counter() - t0
    print(
        f"  real robot planning={flag!s:5}: {dt:6.2f} s  success {out.success}  "
        f"fallbacks true {true.motion_planning_fallbacks} belief "
        f"{belief.motion_planning_fallbacks}"
    )
    true.close()
    belief.close()


def _at_goal(world: World, arm: str, goal: tuple[float, ...], free: set[str]) -> set[str]:
    from projection._arm_planner import touched_objects

    before = world.arm_joints(arm)
    world.move_joints(**{arm: goal})
    out = touched_objects(world, free)
    world.move_joints(**{arm: before})
    return out


if __name__ == "__main__":
    main()
