"""The robot's imagination: a PyBullet world (PR2-like robot, kitchen, household objects),
CRAM's low-level projection functions, projection process modules, and costmap-based
location resolution. Implements the interfaces that :mod:`executive` defines."""
