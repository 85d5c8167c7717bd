"""The seed's REPL walkthrough in projection, step by step with the seed's own numbers
(``shared/reference/seed_cram_tutorial.txt``): low-level functions, a process module,
motions, atomic actions, picking up a cup with the left arm and grasp ``top``, carrying it
to (-0.5, 0, 0) and putting it down, then CRAM's demo with the bowl alone
(``demo-random nil '(:bowl)``). Prints each step and, at the end, the task tree (finished
subtrees collapsed).

    python examples/07_seed_walkthrough.py [SEED] [ROBOT]

``ROBOT``: a robot of the ``robots`` package (``pr2``, the default, or ``panda``); the
steps read its tool frame and base frame from its description, and use the left arm,
which every robot has (a one-armed robot's arm is ``left``).

Which of the seed's numbers depend on the PR2 (the seed's tutorial was written for it):

- the torso height 0.3 m (within the PR2's 0..0.33 m lift);
- the hand pose (0.7, 0.5, 0.8) in the base frame for lifting and reaching, and the cup
  spawned at (0.5, 0.3, 1.0): chosen inside the PR2's left arm's reach at that torso
  height; another arm may not reach them (the Panda does not reach the hand pose, 0.86 m
  out to the side: the step then says so and the walkthrough goes on);
- looking at that hand pose to see the cup: the PR2's head camera sees the cup from there;
  a camera elsewhere may not (the Panda's mast camera, 0.22 m to the side, looks at the
  cup past its parked hand, which hides most of it: the step says so, and the robot turns
  its base towards the cup on the spot, detects it and turns back);
- what the pick prints: the link the cup hangs from (``l_wrist_roll_link``; the Panda's:
  ``panda_hand``) and the cup's height while held (1.067 m; the Panda's: 1.069 m), the
  hand's geometry and its ``top`` grasp, and so the height the cup is put down at (the
  PR2's: 0.988 m; the Panda's: 0.990 m).

Robot-independent: the base poses driven to ((0.5, 0, 0), (0.75, 0, 0), the origin,
(-0.5, 0, 0)), the cup detected 1 m ahead of the base, the cup following the hand from
(0.5, 0.3) to (0, 0.3) as the base drives back, its release, and the bowl's transport from
CRAM's spawning pose.
"""

from __future__ import annotations

import sys

import cpl
import projection
import robots
from cpl.display import render_text
from executive import (
    ManipulationPoseUnreachable,
    PerceptionObjectNotFound,
    Pose,
    a,
    an,
    perform,
    pm_execute,
)
from plans.demo import table_setting


def section(title: str) -> None:
    print(f"\n=== {title}")


def show(what: str, value: object) -> None:
    print(f"> {what}\n  {value}")


async def walkthrough(world: projection.World) -> None:
    section("1. low-level functions (the belief world itself)")
    world.drive(Pose((0.5, 0.0, 0.0)))
    show("(urdf-proj::drive (0.5 0 0))", world.robot_pose())
    world.move_torso(0.3)
    show("(urdf-proj::move-torso 0.3)", f"torso at {world.torso_height:.3f} m")
    world.spawn_object("cup-1", "cup", Pose((1.5, 0.0, 1.3)))
    show("(urdf-proj::detect (an object (type cup)))", world.detect(an.object(type="cup"))[0])

    async with projection.with_projected_robot(world):
        section("2. process modules")
        going = a.motion(type="going", pose=Pose((0.75, 0.0, 0.0)))
        await pm_execute("navigation", going)
        show(f"(pm-execute navigation {going})", world.robot_pose())

        section("3. motions")
        await perform(going)
        show(f"(perform {going})", world.robot_pose())

        section("4. atomic actions")
        origin = an.action(type="going", target=a.location(pose=Pose((0.0, 0.0, 0.0))))
        await perform(origin)
        show(f"(perform {origin})", world.robot_pose())
        base, tool = world.robot.base_frame, world.robot.arm("left").tool_frame
        hand = Pose((0.7, 0.5, 0.8), frame=base)
        for verb in ("lifting", "reaching"):
            action = an.action(type=verb, left_poses=(hand,))
            try:
                await perform(action)
            except ManipulationPoseUnreachable as exc:  # the seed's pose is the PR2's
                show(f"(perform {action})", f"beyond this robot's left arm: {exc}")
                continue
            show(f"(perform {action})", world.link_pose(tool, base))

        section("5. picking up a cup, carrying it, putting it down")
        world.remove_object("cup-1")
        world.spawn_object("cup-1", "cup", Pose((0.5, 0.3, 1.0)))
        spawned = world.object_pose("cup-1")
        show("(spawn-object 'cup-1 :cup :pose ((0.5 0.3 1.0) (0 0 0 1)))", spawned)
        await perform(an.action(type="looking", target=a.location(pose=hand)))
        detecting = an.action(type="detecting", object=an.object(type="cup"))
        try:
            cup = await perform(detecting)
        except PerceptionObjectNotFound as exc:  # the seed's view is the PR2's head's
            show("(perform (an action (type detecting) ...))", f"not seen from there: {exc}")
            # turn the base towards the cup (on the spot), look at it, and turn back
            turned = Pose.from_xyz_yaw(0.0, 0.0, 0.0, 0.8)
            await perform(an.action(type="going", target=a.location(pose=turned)))
            await perform(an.action(type="looking", target=a.location(pose=spawned)))
            seen = (await perform(detecting)).get("pose")  # in map
            await perform(origin)
            # the detected pose, in the base frame the robot has turned back to
            in_base = world.robot_pose().to_transform(base).inverse() * seen
            cup = an.object(
                type="cup",
                name="cup-1",
                pose=seen,
                transform=in_base.to_transform("cup-1"),
            )
            show("turning towards the cup instead (0.8 rad on the spot) and back", "")
        show("(perform (an action (type detecting) (object (an object (type cup)))))", cup)
        await perform(an.action(type="picking-up", object=cup, arm="left", grasp="top"))
        show(
            "(perform (an action (type picking-up) (object ?obj) (arm left) (grasp top)))",
            f"held by {world.attachments['cup-1']} at {world.object_pose('cup-1')}",
        )
        away = an.action(type="going", target=a.location(pose=Pose((-0.5, 0.0, 0.0))))
        await perform(away)
        show(f"(perform {away})", f"the cup followed the hand: {world.object_pose('cup-1')}")
        await perform(an.action(type="placing", arm="left"))
        held = dict(world.attachments) or "nothing"
        show(
            "(perform (an action (type placing) (arm left)))",
            f"held: {held}; the cup at {world.object_pose('cup-1')}",
        )
        world.remove_object("cup-1")

        section("6. (demo-random nil '(:bowl)): the bowl from the sink area to the island")
        projection.set_up_scene(world, ["bowl"], random=False, settle_steps=0)
        outcomes = await table_setting(["bowl"])
        show("outcome", outcomes["bowl"])
        show("the bowl is now at", world.object_pose("bowl-1"))


def main() -> None:
    seed = int(sys.argv[1]) if len(sys.argv) > 1 else 3
    try:
        robot = robots.by_name(sys.argv[2] if len(sys.argv) > 2 else "pr2")
    except robots.UnknownRobot as exc:
        sys.exit(f"07_seed_walkthrough.py: {exc}")
    world = projection.World(seed=seed, robot=robot)
    try:
        cpl.run(walkthrough, world, name="walkthrough", clock=cpl.ScaledClock(None))
    finally:
        world.close()
    tree = cpl.task_tree("walkthrough")
    if tree is not None:
        section("the task tree (the first 60 nodes)")
        print(render_text(tree, max_nodes=60, width=110))


if __name__ == "__main__":
    main()
