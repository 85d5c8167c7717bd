"""The seed's first REPL steps on the projected PR2: low-level functions, a process module,
then ``perform``.

Run: ``python examples/06_seed_walkthrough_low_level.py [out/06_scene.png]``

1. ``drive`` the base to x = 0.5 and ``move-torso`` to 0.3 (CRAM's ``pr2-proj::drive`` and
   ``pr2-proj::move-torso`` inside ``with-simulated-robot``);
2. spawn ``cup-1`` at (1.5, 0, 1.3), as the seed does: our counter (x 1.12..1.90, top at
   z 0.85) is below it, so the cup floats above the counter until physics runs;
3. ``detect`` it with the low-level function, then with the perception process module
   (``perform`` a ``detecting`` motion), which returns the perceived object designator;
4. ``pm-execute`` a ``going`` motion on the navigation module, then ``perform`` one, whose
   target is a location designator ``(pose P)``;
5. write a PNG of the scene (and, when ``projection.render.costmap`` exists, one of a
   ``reachable-for`` costmap next to it).
"""

from __future__ import annotations

import sys
from pathlib import Path

import cpl
from executive import Pose, a, an, perform, pm_execute
from projection import World, render, with_projected_robot


def step(text: str) -> None:
    print(f"\n> {text}")


async def walkthrough(world: World, out: Path) -> None:
    step('(pr2-proj::drive (make-pose-stamped "map" 0 (make-3d-vector 0.5 0 0) identity))')
    world.drive(Pose((0.5, 0.0, 0.0)))
    print(world.robot_pose())

    step("(pr2-proj::move-torso 0.3)")
    world.move_torso(0.3)
    print(f"torso_lift_joint = {world.torso_height:.3f}")

    step("(btr-utils:spawn-object :cup-1 :cup :pose '((1.5 0 1.3) (0 0 0 1)))")
    world.spawn_object("cup-1", "cup", Pose((1.5, 0.0, 1.3)))
    print(world.object_pose("cup-1"))

    step("(pr2-proj::detect (desig:an object (type cup)))")
    (found,) = world.detect(an.object(type="cup"))
    print(f"name {found.name}, type {found.type}")
    print(f"  pose      {found.pose}")
    print(f"  map pose  {found.map_pose}")
    print(f"  transform {found.transform}")

    async with with_projected_robot(world):
        step("(exe:perform (desig:a motion (type detecting) (object (an object (type cup)))))")
        cup = an.object(type="cup")
        perceived = await perform(a.motion(type="detecting", object=cup))
        print(perceived)
        print(f"equated to the input: {cup.current() is perceived}")

        step("(cpm:pm-execute 'navigation (desig:a motion (type going) (pose ((0 0.5 0))))")
        going = a.motion(type="going", pose=Pose((0.0, 0.5, 0.0)))
        print(going)
        print(going.reference())
        await pm_execute("navigation", going)
        print(world.robot_pose())

        step("(exe:perform (desig:a motion (type going) (target (desig:a location (pose P)))))")
        target = a.location(pose=Pose.from_xyz_yaw(0.5, 0.0, 0.0, 0.0))
        going = a.motion(type="going", target=target)
        print(going)
        await perform(going)
        print(world.robot_pose())

        step(f"render.scene(world, {str(out)!r})")
        print(render.scene(world, out))
        costmap = getattr(render, "costmap", None)
        if costmap is not None:
            costmap_out = out.with_name(f"{out.stem}_costmap.png")
            visible = a.location(visible_for="pr2", object=perceived)
            print(visible)
            print(visible.reference())
            step(f"render.costmap({visible.short()}, {str(costmap_out)!r}, samples=20)")
            print(costmap(visible, costmap_out, samples=20))


def main(argv: list[str]) -> int:
    out = Path(argv[1]) if len(argv) > 1 else Path("out/06_scene.png")
    with World(seed=0) as world:
        cpl.run(walkthrough, world, out, name="seed-walkthrough")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
