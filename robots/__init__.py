"""robots: one module per robot, each holding the robot's :class:`executive.RobotDescription`
(as ``DESCRIPTION``) beside its URDF or the generator of its URDF.

- :mod:`robots.pr2`: the PR2-like robot of the projection (primitive shapes).
- :mod:`robots.panda`: a Franka Panda arm (pybullet_data's URDF and meshes) on a holonomic
  base with a torso lift and a pan-tilt camera mast.

This package sits between ``executive`` (whose contract it fills in) and ``projection`` /
``plans`` / ``aiocram`` (which read descriptions); it imports neither of the latter.
See docs/robots.md for describing a robot of your own.
"""

from __future__ import annotations

import importlib
import pkgutil

from executive import RobotDescription

__all__ = ["UnknownRobot", "by_name", "names"]


class UnknownRobot(LookupError):
    """No module of this package describes a robot of that name. ``name``: what was asked
    for; ``known``: the names there are (:func:`names`). The message lists them."""

    def __init__(self, name: str, known: tuple[str, ...]) -> None:
        super().__init__(
            f"no robot named {name!r}: the robots package describes {', '.join(known)} "
            "(one module robots.NAME with a DESCRIPTION each; docs/robots.md says how to "
            "add yours)"
        )
        self.name = name
        self.known = known


def names() -> tuple[str, ...]:
    """The robots this package describes, sorted: every public module ``robots.NAME``
    whose ``DESCRIPTION`` is a :class:`executive.RobotDescription` (a module holding only
    parts, like :mod:`robots.mobile_base`, is no robot). No registry: a new module is a
    new robot."""
    found = []
    for info in pkgutil.iter_modules(__path__):
        if info.name.startswith("_") or info.ispkg:
            continue
        module = importlib.import_module(f"{__name__}.{info.name}")
        if isinstance(getattr(module, "DESCRIPTION", None), RobotDescription):
            found.append(info.name)
    return tuple(sorted(found))


def by_name(name: str) -> RobotDescription:
    """The description of the robot ``name`` (``"pr2"``, ``"panda"``): the ``DESCRIPTION``
    of module ``robots.<name>``. A name that is not one of :func:`names` (not a module
    here, or a module without a description) raises :class:`UnknownRobot` listing them;
    nothing is loaded into a world."""
    if not isinstance(name, str) or not name.isidentifier() or name.startswith("_"):
        raise UnknownRobot(str(name), names())
    try:
        module = importlib.import_module(f"{__name__}.{name}")
    except ModuleNotFoundError as exc:
        if exc.name != f"{__name__}.{name}":
            raise  # the robot's module exists but imports something missing: a real error
        raise UnknownRobot(name, names()) from None
    description = getattr(module, "DESCRIPTION", None)
    if not isinstance(description, RobotDescription):
        raise UnknownRobot(name, names())
    return description
