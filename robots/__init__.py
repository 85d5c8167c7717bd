"""robots: one module per robot, each holding the robot's :class:`executive.RobotDescription`
(as ``DESCRIPTION``) beside its URDF or the generator of its URDF.

- :mod:`robots.pr2`: the PR2-like robot of the projection (primitive shapes).
- :mod:`robots.panda`: a Franka Panda arm (pybullet_data's URDF and meshes) on a holonomic
  base with a torso lift and a pan-tilt camera mast.

This package sits between ``executive`` (whose contract it fills in) and ``projection`` /
``plans`` / ``aiocram`` (which read descriptions); it imports neither of the latter.
See docs/robots.md for describing a robot of your own.
"""
