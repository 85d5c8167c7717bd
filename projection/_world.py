"""The projection world: one PyBullet client with a robot (by default the PR2-like robot;
any :class:`executive.RobotDescription` via ``World(robot=...)``), the kitchen and the
household objects, and CRAM's low-level projection functions (``urdf-proj``) as methods.

Everything robot-specific comes from the world's description (``world.robot``): the body
(its ``urdf()``, validated against it before loading), the arms (any number of joints,
one or two arms: a one-armed robot has only ``left``), tool frames, hand links (where held
objects hang), grippers (opening <-> finger joints by the :class:`GripperDescription`;
the gripper links are those below the hand link), torso, neck and camera (frame and field
of view), the initial state, the IK seeds and the arms' reach. The IK's reach geometry
and the head's pan/tilt geometry are read from the loaded body by forward kinematics.

Design decisions (measured, see ``bench/projection_ops.py``):

- The robot is loaded with ``useFixedBase=True`` and moved by teleport
  (``resetBasePositionAndOrientation``); the kitchen is fixed and never reset. After the
  robot's first reset Bullet tests its links against the static kitchen (the "quirk" of
  the performance notes): that is exactly what a navigation probe needs, so the world does
  one reset at start-up and every probe is ``reset + performCollisionDetection +
  getContactPoints(robot)``.
- A contact counts as a collision when its penetration exceeds
  :data:`COLLISION_TOLERANCE` (resting contacts report about -1 mm).
- Snapshots are manual (poses, velocities, joints, attachments, registry): PyBullet's
  ``saveState`` costs milliseconds and cannot undo spawns or removals.
- ``detect`` casts rays from the camera to a grid of points in the object's AABB
  (``rayTestBatch``); a render (``getCameraImage``) at CRAM's 320x200 costs more than the
  whole 20 ms budget twice over.
- IK is PyBullet's ``calculateInverseKinematics`` on the tool frame with huge damping on
  every non-arm joint (so only the arm's joints move), several seeds, FK verification,
  and CRAM's torso resampling (the 0.05 m grid, current height first, then from the upper
  limit down). Two fast paths that never change an answer: a sound reach pre-check (the
  wrist, the last arm joint's origin, must lie in the annulus the arm can span around
  the circle of its second joint's positions, with the FK tolerance as margin) skips
  heights before any IK call, and a per-world LRU memo keyed by (arm, goal in the torso
  frame, seed joints) replays earlier solutions, each re-verified by FK. Measured:
  ordering the heights by distance from the current one cost more on the demo grasps
  than CRAM's order, so CRAM's order stays.

Every failing method leaves the world as it was unless its docstring says otherwise.
Poses are :class:`executive._pose.Pose` in ``map`` or ``base_footprint``.
"""

from __future__ import annotations

from executive._kitchen import KitchenDescription
from executive._robot import RobotDescription
from projection._world_base import ASSETS, DEFAULT_TORSO, FRAMES, KITCHEN
from projection._world_collisions import COLLISION_TOLERANCE, Contact
from projection._world_containers import Containers
from projection._world_grippers import Grippers
from projection._world_ik import IK_CACHE_SIZE, TORSO_STEP, ArmIK
from projection._world_motion import BodyMotions
from projection._world_perception import PerceivedObject, Perception
from projection._world_snapshots import Snapshot, Snapshots
from projection._world_stability import Stability

__all__ = [
    "ASSETS",
    "COLLISION_TOLERANCE",
    "DEFAULT_TORSO",
    "FRAMES",
    "IK_CACHE_SIZE",
    "KITCHEN",
    "TORSO_STEP",
    "Contact",
    "PerceivedObject",
    "Snapshot",
    "World",
]


class World(Perception, Grippers, ArmIK, Containers, Snapshots, Stability, BodyMotions):
    """A PyBullet projection world (see the module docstring).

    ``World(seed=None, gui=False, *, robot=None, kitchen=None)``; ``robot``: an
    :class:`executive.RobotDescription` (default ``robots.pr2.DESCRIPTION``); one that
    does not fit its URDF raises :class:`executive.RobotDescriptionError` before anything
    is loaded. ``kitchen``: the :class:`executive.KitchenDescription` of the kitchen
    (default ``kitchens.iai.DESCRIPTION``; the kitchen's body is always the projection's
    generated kitchen, ``assets/kitchen.urdf``); one naming a link or joint that URDF
    lacks raises :class:`executive.KitchenDescriptionError` before anything is loaded.
    ``close()`` is idempotent and the world is a context manager; any use after
    ``close()`` raises :class:`RuntimeError`. A new world has the robot at the map
    origin, every arm in the description's ``initial_state`` (parked), the torso at its
    ``torso.default`` (the PR2-like robot's: :data:`DEFAULT_TORSO`), the head forward,
    grippers open and the drawer closed. ``rng`` is a seeded
    :class:`numpy.random.Generator`.

    Each concept is a mixin in its own module: the client, names, frames, registry and
    attachments (``_world_base``), collisions (``_world_collisions``), base/torso/joint
    motions (``_world_motion``), IK (``_world_ik``), grippers (``_world_grippers``), head
    and detection (``_world_perception``), containers (``_world_containers``), snapshots
    (``_world_snapshots``) and placing stability (``_world_stability``).
    """

    def __init__(
        self,
        seed: int | None = None,
        gui: bool = False,
        *,
        robot: RobotDescription | None = None,
        kitchen: KitchenDescription | None = None,
    ) -> None:
        super().__init__(seed, gui, robot=robot, kitchen=kitchen)
        self._init_ik()
