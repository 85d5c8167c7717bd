"""A fake robot for plan tests: an InMemoryWorld with probes, scriptable process modules
that update it, and deterministic location rules whose solutions are visible sequences."""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

import pytest

import executive
import plans  # noqa: F401 - registers the action rules
from cpl.testing import MockClock, run_guarded
from executive import Pose, RobotDescription, RuleSet, static_rules
from executive.testing import FakeProcessModule, InMemoryWorld
from kitchens.iai import DESCRIPTION as KITCHEN
from robots.pr2 import DESCRIPTION as PR2

HANDLE = "sink_area_left_upper_drawer_handle"
DRAWER = executive.an.object(
    type="drawer", urdf_name="sink_area_left_upper_drawer_main", part_of="kitchen"
)


def base_poses(target: Pose, n: int = 60) -> Iterator[Pose]:
    """Deterministic robot poses 0.5 m, 0.6 m, ... behind ``target`` (along -x)."""
    for k in range(n):
        yield Pose((target.position[0] - 0.5 - 0.1 * k, target.position[1], 0.0))


def location_generator(d: executive.Designator) -> Iterator[Pose] | None:
    """reachable-for / visible-for -> :func:`base_poses` of the target; ``(spots n)`` ->
    n search spots 0.2 m apart along y."""
    if "reachable-for" in d or "visible-for" in d:
        inner = d.get("location")
        return base_poses(inner.reference())
    if "in" in d:
        return iter([Pose((1.3, 0.9, 0.75))])
    if "spots" in d:
        return (Pose((1.0, 0.2 * k, 0.8)) for k in range(d["spots"]))
    return None


@dataclass
class Robot:
    world: InMemoryWorld
    pms: dict[str, FakeProcessModule] = field(default_factory=dict)
    rules: RuleSet = field(default_factory=lambda: static_rules.child("test"))
    preferences: Any = None  # executive.Preferences, None: the rules' order

    def calls(self, name: str, motion_type: str | None = None) -> list[Any]:
        return [m for m in self.pms[name].calls if motion_type is None or m.type == motion_type]

    def run(self, fn: Any, *args: Any) -> Any:
        async def main() -> Any:
            env = executive.Environment(
                "test",
                process_modules=self.pms.values(),
                world=self.world,
                rules=self.rules,
                preferences=self.preferences,
            )
            async with executive.environment(env):
                return await fn(*args)

        return run_guarded(main, clock=MockClock())  # a hang fails, with its task tree


def _base(world: InMemoryWorld) -> str:
    assert world.robot is not None, "plan tests need InMemoryWorld(robot=...)"
    return world.robot.base_frame


def _perceive(world: InMemoryWorld, motion: executive.Designator) -> executive.Designator:
    wanted = motion.reference().arguments["object"]
    for name, obj in world.objects.items():
        if obj.type == wanted.type and obj.attached_to is None:
            return wanted.copy(
                name=name,
                pose=world.object_pose(name),
                transform=world.object_pose(name, _base(world)).to_transform(name),
            )
    raise executive.PerceptionObjectNotFound(object=wanted)


def make_robot(world: InMemoryWorld, **fail_on: dict[int, Any]) -> Robot:
    """Process modules ``navigation``, ``ptu``, ``perception``, ``grippers``, ``arms``,
    ``torso`` (``fail_on={name: {n: failure}}``) acting on ``world``."""

    def drive(m: executive.Designator) -> None:
        world.set_robot_pose(m.reference().arguments["pose"])

    def move_tcp(m: executive.Designator) -> None:
        command, args = m.reference()
        if command != "move-tcp":
            return
        assert world.robot is not None, "plan tests need InMemoryWorld(robot=...)"
        for arm in world.robot.arms:
            if args[arm.name] is not None:
                for link in (arm.tool_frame, arm.hand_link):  # one frame, here
                    world.set_link_pose(link, args[arm.name])

    robot = Robot(world)
    specs = {
        "navigation": ("going", drive),
        "ptu": ("looking", None),
        "perception": ("detecting", lambda m: _perceive(world, m)),
        "grippers": (
            {"gripping", "opening-gripper", "closing-gripper", "moving-gripper-joint"},
            None,
        ),
        "arms": ({"moving-tcp", "moving-arm-joints"}, move_tcp),
        "torso": ("moving-torso", None),
    }
    for name, (accepts, result) in specs.items():
        robot.pms[name] = FakeProcessModule(
            name, accepts=accepts, fail_on=fail_on.get(name), result=result
        )
    robot.rules.register_location_generator(location_generator, 15)
    return robot


def hand_links(robot: RobotDescription = PR2) -> dict[str, Pose]:
    """Each arm's tool frame and hand link, 0.3 m ahead of the base, 1 m high, the left
    arm's 0.2 m to the left, the right arm's 0.2 m to the right (base frame)."""
    return {
        link: Pose((0.3, 0.2 if arm.name == "left" else -0.2, 1.0), frame=robot.base_frame)
        for arm in robot.arms
        for link in (arm.tool_frame, arm.hand_link)
    }


def cup_world_for(robot: RobotDescription) -> InMemoryWorld:
    """The cup world (a cup on the table, a drawer handle, the hands) for ``robot``."""
    return InMemoryWorld(
        objects={"cup-1": Pose((1.3, 0.6, 0.9))},
        types={"cup-1": "cup"},
        links={HANDLE: Pose((1.1, 1.0, 0.78)), **hand_links(robot)},
        robot=robot,
        kitchen=KITCHEN,
    )


@pytest.fixture
def cup_world() -> InMemoryWorld:
    return cup_world_for(PR2)


async def transport_for_real(true: Any, belief: Any, object_type: str, name: str) -> Any:
    """Transport one object on the simulated real robot (no faults, no projection
    reasoning) from where the demo looks for its type to where the demo puts it."""
    from executive import an, perform
    from plans.demo import fetch_location, place_location
    from projection import FaultProfile, with_real_robot

    async with with_real_robot(true, belief, FaultProfile.none()):
        return await perform(
            an.action(
                type="transporting",
                object=an.object(type=object_type, name=name),
                location=fetch_location(object_type),
                target=place_location(object_type, bowl_placed=False),
                projection_reasoning=False,
            )
        )


#: A cereal box on its broad face: its y axis (0.07 m) vertical, on its 0.19 x 0.29 m face,
#: its x axis (0.19 m) along map x.
ON_ITS_BROAD_FACE = (math.sqrt(0.5), 0.0, 0.0, math.sqrt(0.5))


def tilt(pose: Pose) -> float:
    """Angle (rad) between the object's z axis and the vertical."""
    return math.acos(max(-1.0, min(1.0, float(pose.matrix()[2, 2]))))


def stage_lying_box(true: Any, name: str) -> Pose:
    """Lay ``name`` (a cereal box) on its broad face on the sink counter where it stands in
    ``true``, let it settle, and return where it came to rest (lying)."""
    from projection import settle

    x, y, _z = true.object_pose(name).position
    (_, _, _), (_, _, top) = true.link_aabb("sink_area_surface")
    true.set_object_pose(name, Pose((x, y, top + 0.035), ON_ITS_BROAD_FACE))
    settle(true, 240)
    before = true.object_pose(name)
    assert tilt(before) > math.radians(80)
    return before


def transport_counted(
    mrun: Any, true: Any, belief: Any, object_type: str, name: str, counts: dict[str, int]
) -> Any:
    """:func:`transport_for_real` run by ``mrun`` under a retry ledger, whose counts go
    into ``counts`` (also when the transport raises)."""
    from plans import retry_ledger

    async def main() -> Any:
        with retry_ledger() as ledger:
            try:
                return await transport_for_real(true, belief, object_type, name)
            finally:
                counts.update(ledger)

    return mrun(main)
