"""A true world and a belief staged from a traced run: the robot where it stood, the objects
where each world had them (tests that rebuild a campaign run's situation)."""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping, Sequence
from contextlib import contextmanager

from executive import Pose
from projection import World, make_world_pair


@contextmanager
def staged_pair(
    base: Pose,
    torso: float,
    arms: Mapping[str, Sequence[float]],
    objects: Mapping[str, tuple[str, Pose | None, Pose | None]],
    open_grippers: Iterable[str],
) -> Iterator[tuple[World, World]]:
    """(true, belief): both with the robot at ``base``, the torso at ``torso``, the arms at
    ``arms`` and the grippers of ``open_grippers`` open; ``objects``: name -> (type, its
    pose in the true world, in the belief), None where that world lacks it. Both are
    closed on leaving the context."""
    true, belief = make_world_pair(0, objects={})
    try:
        for world, k in ((true, 0), (belief, 1)):
            world.drive(base)
            world.move_torso(torso)
            world.move_joints(**{arm: tuple(q) for arm, q in arms.items()})
            for arm in open_grippers:
                world.gripper(0.1, arm)
            for name, (otype, *poses) in objects.items():
                pose = poses[k]
                if pose is not None:
                    world.spawn_object(name, otype, pose, allow_overlap=True)
        yield true, belief
    finally:
        true.close()
        belief.close()
