"""The seed's walkthrough in projection, every REPL step in order: low-level functions,
process modules, motions, atomic actions, pick and place, and the transport of the bowl
from the sink area to the kitchen island. Prints each designator and, at the end, the task
tree (finished subtrees collapsed).

    python examples/07_seed_walkthrough.py [SEED]
"""

from __future__ import annotations

import math
import sys

import cpl
import plans
import projection
from cpl.display import render_text
from cpl.testing import MockClock
from executive import Pose, a, an, perform, pm_execute
from plans.demo import fetch_location, place_location


def section(title: str) -> None:
    print(f"\n=== {title}")


def show(what: str, value: object) -> None:
    print(f"> {what}\n  {value}")


async def walkthrough(world: projection.World) -> None:
    section("1. low-level functions (the belief world itself)")
    world.drive(Pose((0.5, 0.0, 0.0)))
    show("(drive (0.5 0 0))", world.robot_pose())
    world.move_torso(0.25)
    show("(move-torso 0.25)", f"torso at {world.torso_height:.3f} m")
    world.spawn_object("cup-1", "cup", Pose((1.5, 0.0, 1.3)))
    world.look_at(world.object_pose("cup-1"))
    show("(detect (an object (type cup)))", world.detect(an.object(type="cup"))[0])
    world.remove_object("cup-1")

    async with projection.with_projected_robot(world):
        section("2. process modules")
        going = a.motion(type="going", pose=Pose((0.3, 0.0, 0.0)))
        await pm_execute("navigation", going)
        show(f"(pm-execute navigation {going})", world.robot_pose())

        section("3. motions")
        for motion in (
            a.motion(type="going", pose=Pose.from_xyz_yaw(0.5, 0.2, 0.0, 0.0)),
            a.motion(type="moving-torso", joint_angle=0.3),
            a.motion(type="looking", direction="forward"),
        ):
            await perform(motion)
            show(f"(perform {motion})", "done")

        section("4. atomic actions")
        world.spawn_object("cup-1", "cup", Pose((1.3, 0.6, 0.9)))
        spot = a.location(pose=Pose((1.3, 0.6, 0.9)))
        for action in (
            an.action(
                type="positioning-arm", left_configuration="park", right_configuration="park"
            ),
            an.action(type="navigating", location=Pose((0.75, 0.6, 0.0))),
            an.action(type="looking", target=spot),
        ):
            await perform(action)
            show(f"(perform {action})", "done")
        cup = await perform(an.action(type="detecting", object=an.object(type="cup")))
        show("(perform (an action (type detecting) (object (an object (type cup)))))", cup)

        section("5. pick and place")
        picking = plans.check_picking_up_collisions(
            an.action(type="picking-up", object=cup, arm="left")
        )
        show("check-picking-up-collisions chose", picking.reference().arguments["grasp"])
        await perform(picking)
        await perform(an.action(type="navigating", location=Pose((0.55, 0.6, 0.0))))
        show("the cup follows the hand", world.object_pose("cup-1"))
        placing = plans.check_placing_collisions(
            an.action(type="placing", arm="left", target=a.location(pose=Pose((1.25, 0.4, 0.9))))
        )
        await perform(placing)
        show(f"(perform {placing})", world.object_pose("cup-1"))
        world.remove_object("cup-1")

        section("6. transporting the bowl from the sink area to the kitchen island")
        world.spawn_object("bowl-1", "bowl", Pose.from_xyz_yaw(1.4, 0.8, 0.88, math.pi / 8))
        transport = an.action(
            type="transporting",
            object=an.object(type="bowl"),
            location=fetch_location("bowl"),
            target=place_location("bowl"),
        )
        show("transport", transport)
        await perform(transport)
        show("the bowl is now at", world.object_pose("bowl-1"))


def main() -> None:
    seed = int(sys.argv[1]) if len(sys.argv) > 1 else 3
    world = projection.World(seed=seed)
    try:
        cpl.run(walkthrough, world, name="walkthrough", clock=MockClock())
    finally:
        world.close()
    tree = cpl.task_tree("walkthrough")
    if tree is not None:
        section("the task tree (the first 60 nodes)")
        print(render_text(tree, max_nodes=60, width=110))


if __name__ == "__main__":
    main()
