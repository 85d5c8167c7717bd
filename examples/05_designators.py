"""Designators, resolution and perform against fake process modules.

Run: ``python examples/05_designators.py``

1. builds designators (repeats, nesting, keyword spelling) and resolves some;
2. plugs a toy "reachable-for" location generator and a validator into an environment;
3. performs a ``fetching`` action whose plan navigates to a robot location, relocating with
   ``retry_with_designator_solutions`` when the (fake) navigation module fails, then
   detects and picks up the cup;
4. prints the task tree, with the designators on its nodes.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from typing import Any

import rich

import cpl
from executive import (
    NavigationPoseUnreachable,
    ObjectUnfetchable,
    Pose,
    RuleSet,
    SolutionCursor,
    a,
    an,
    environment,
    perform,
    retry_with_designator_solutions,
)
from executive.events import ObjectAttached, emit
from executive.testing import FakeProcessModule, InMemoryWorld

CUP_POSE = Pose((1.5, 0.4, 0.9))


# ----------------------------------------------------------------- location knowledge
def reachable_for(d: Any, env: Any) -> Iterator[Pose]:
    """Toy costmap: base poses on a ring of 0.6 m around the target, facing it."""
    if d.get("reachable-for") is None:
        return
    target = d["location"].current().reference()
    tx, ty, _ = target.position
    for k in range(12):
        angle = k * math.pi / 6
        x, y = tx + 0.6 * math.cos(angle), ty + 0.6 * math.sin(angle)
        yield Pose.from_xyz_yaw(x, y, 0.0, yaw=angle + math.pi)


def not_inside_the_counter(d: Any, pose: Pose) -> str:
    """Pretend the counter occupies x > 1.6: reject base poses there."""
    return "reject" if pose.position[0] > 1.6 else "unknown"


# -------------------------------------------------------------------------- plans
@cpl.plan(name="fetch")
async def fetch(object: Any, arm: str) -> Any:
    robot_location = SolutionCursor(
        a.location(reachable_for="pr2", location=a.location(of_item_object=object))
    )
    relocations = cpl.RetryCounter(3)

    async def body() -> Any:
        await perform(a.motion(type="going", target=robot_location.current))
        await perform(a.motion(type="looking", target=a.location(of_item_object=object)))
        perceived = await perform(a.motion(type="detecting", object=object))
        return await perform(an.action(type="picking-up", object=perceived, arm=arm))

    return await cpl.with_failure_handling(
        body,
        [
            (
                NavigationPoseUnreachable,
                lambda f: retry_with_designator_solutions(
                    robot_location, relocations, rethrow=ObjectUnfetchable(object=object)
                ),
            )
        ],
    )


@cpl.plan(name="pick-up")
async def pick_up(object: Any, arm: str, grasp: str) -> Any:
    await perform(a.motion(type="opening-gripper", gripper=arm))
    await perform(a.motion(type="moving-tcp", **{f"{arm}_pose": object.get("pose")}))
    await perform(a.motion(type="gripping", gripper=arm, effort=30))
    emit(ObjectAttached(object, arm, f"{arm[0]}_wrist_roll_link"))
    return object


def fetching_rule(d: Any) -> Iterator[Any]:
    yield fetch, {"object": d["object"], "arm": d.get("arm", "right")}


def picking_up_rule(d: Any) -> Iterator[Any]:
    arms = [d["arm"]] if "arm" in d else ["right", "left"]
    for arm in arms:  # arm-major, grasp-minor, as CRAM
        for grasp in ("top", "front"):
            yield pick_up, {"object": d["object"], "arm": arm, "grasp": grasp}


# ------------------------------------------------------------------ process modules
def detect(motion: Any) -> Any:
    obj = motion.reference().arguments["object"]
    return obj.copy(pose=CUP_POSE)  # "perception" adds the pose


def main() -> None:
    cup = an.object(type="cup", name="cup-1")
    shelf = an.object(type="counter", urdf_name="sink_area_surface")
    where = a.location(("side", "left"), ("side", "front"), on=shelf, range_invert=0.5)
    print("Designators:")
    print(" ", where)
    print(
        "  first side:",
        where.get("side"),
        "| all sides:",
        where.get_all("side"),
        "| range-invert:",
        where["range_invert"],
    )
    print("  going ->", a.motion(type="going", pose=Pose((1, 2, 0))).reference())

    rules = RuleSet()
    rules.register("action", "fetching", fetching_rule)
    rules.register("action", "picking-up", picking_up_rule)
    rules.register_location_generator(reachable_for, 20)
    rules.register_location_validator(not_inside_the_counter, 5)

    world = InMemoryWorld({"cup-1": CUP_POSE}, types={"cup-1": "cup"})
    modules = [
        FakeProcessModule(
            "navigation", accepts="going", fail_on={1: NavigationPoseUnreachable}, delay=2.0
        ),
        FakeProcessModule("ptu", accepts="looking", delay=0.2),
        FakeProcessModule("perception", accepts="detecting", result=detect, delay=0.5),
        FakeProcessModule("grippers", accepts={"opening-gripper", "gripping"}, delay=0.3),
        FakeProcessModule("arms", accepts="moving-tcp", delay=1.0),
    ]

    async def demo() -> Any:
        async with environment(
            name="fake-robot", rules=rules, world=world, process_modules=modules
        ):
            robot_loc = a.location(reachable_for="pr2", location=a.location(of_item_object=cup))
            print(
                "  reachable-for solutions:",
                [tuple(round(v, 2) for v in p.position[:2]) for p in robot_loc.solutions().take(4)],
            )
            return await perform(an.action(type="fetching", object=cup))

    held = cpl.run(demo, name="designators-demo")
    print("\nResult:", held)
    print("Attached in the world:", world.attached())
    tree = cpl.task_tree("designators-demo")
    assert tree is not None
    print("\nTask tree:")
    try:
        from cpl.display import render_text

        print(render_text(tree, width=160))
    except ImportError:
        rich.print(tree)
    print("Process-module goals and their motions:")
    for node in tree.walk():
        if "motion" in node.annotations:
            print(f"  {node.name:<11} {node.status.value:<10} {node.annotations['motion']}")


if __name__ == "__main__":
    main()
