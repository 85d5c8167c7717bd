"""Placing-pose stability in a :class:`projection.World`: simulate an object at a pose
in a side client holding only the kitchen."""

from __future__ import annotations

import numpy as np
import pybullet as pb

from executive._pose import Pose
from projection._objects import object_type
from projection._world_base import ASSETS, WorldBase, _static_plane

__all__ = ["Stability"]


class Stability(WorldBase):
    """``placing_pose_stable`` (a mixin of :class:`projection.World`)."""

    def placing_pose_stable(
        self, object_type_name: str, pose: Pose, steps: int = 600, threshold: float = 0.2
    ) -> bool:
        """Simulate an object of the type at ``pose`` in a side client holding only the
        kitchen (with this world's kitchen joint positions) for up to ``steps`` steps;
        stable unless it moved more than ``threshold`` metres. Stops early once the object
        is at rest. The main world is untouched. Unknown type -> LookupError."""
        self._check()
        otype = object_type(object_type_name)
        pos, orn = self._to_map(pose)
        side = self._side_client()
        for name, index in self._kitchen_joints.items():
            pb.resetJointState(
                self._side_kitchen, index, self.joint_position(name), physicsClientId=side
            )
        body = pb.loadURDF(
            str(ASSETS / "objects" / otype.urdf_name), pos, orn, physicsClientId=side
        )
        try:
            start = np.asarray(pos)
            still = 0
            for k in range(steps):
                pb.stepSimulation(physicsClientId=side)
                if k % 10 == 9:
                    now = pb.getBasePositionAndOrientation(body, physicsClientId=side)[0]
                    p_now = np.asarray(now)
                    if np.linalg.norm(p_now - start) > threshold:
                        return False
                    lin, ang = pb.getBaseVelocity(body, physicsClientId=side)
                    still = (
                        still + 1
                        if (np.linalg.norm(lin) < 1e-3 and np.linalg.norm(ang) < 1e-2)
                        else 0
                    )
                    if still >= 3 and k >= 60:
                        return True
            p_end = np.asarray(pb.getBasePositionAndOrientation(body, physicsClientId=side)[0])
            return bool(np.linalg.norm(p_end - start) <= threshold)
        finally:
            pb.removeBody(body, physicsClientId=side)

    def _side_client(self) -> int:
        if self._side < 0:
            self._side = pb.connect(pb.DIRECT)
            pb.setGravity(0, 0, -9.81, physicsClientId=self._side)
            self._side_kitchen = pb.loadURDF(
                str(ASSETS / "kitchen.urdf"), useFixedBase=True, physicsClientId=self._side
            )
            _static_plane(self._side)
        return self._side
