"""The seed's pick-and-place walkthrough in projection, one REPL step at a time: spawn a
cup, navigate, look, detect, pick it up with the left arm and a grasp of the cup's table,
drive away with the cup following, place it; then print the task tree.

    python examples/07_seed_walkthrough.py
"""

from __future__ import annotations

import cpl
import plans
import projection
from cpl.display import render_text
from cpl.testing import MockClock
from executive import Pose, a, an, perform


async def walkthrough(world: projection.World) -> None:
    async with projection.with_projected_robot(world):
        world.spawn_object("cup-1", "cup", Pose((1.3, 0.6, 0.9)))
        spot = a.location(pose=Pose((1.3, 0.6, 0.9)))
        steps = [
            an.action(type="navigating", location=Pose((0.75, 0.6, 0.0))),
            an.action(type="looking", target=spot),
        ]
        for step in steps:
            print("perform", step)
            await perform(step)
        cup = await perform(an.action(type="detecting", object=an.object(type="cup")))
        print("perceived", cup)
        picking = plans.check_picking_up_collisions(
            an.action(type="picking-up", object=cup, arm="left")
        )
        print("picking up with", picking.reference().arguments["grasp"])
        await perform(picking)
        await perform(an.action(type="navigating", location=Pose((0.55, 0.6, 0.0))))
        print("cup follows the hand:", world.object_pose("cup-1"))
        placing = plans.check_placing_collisions(
            an.action(type="placing", arm="left", target=a.location(pose=Pose((1.25, 0.4, 0.9))))
        )
        print("perform", placing)
        await perform(placing)
        print("cup placed at", world.object_pose("cup-1"))


def main() -> None:
    world = projection.World(seed=3)
    cpl.run(walkthrough, world, name="walkthrough", clock=MockClock())
    tree = cpl.task_tree("walkthrough")
    if tree is not None:
        print(render_text(tree))


if __name__ == "__main__":
    main()
