"""The demo's configuration: what to run (:class:`DemoConfig`), checked before anything
moves or is written (:class:`DemoConfigError` names the flag), and the command-line
pieces the ``demo`` and ``campaign`` parsers share (the objects, whole numbers, speed).

The demo's objects are :attr:`executive.KitchenDescription.demo_objects` of
``kitchens.iai.DESCRIPTION`` (see :mod:`aiocram.demo`
for where a newcomer adds one); every list and check here derives from it.
"""

from __future__ import annotations

import argparse
import math
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from kitchens import iai

__all__ = [
    "DEFAULT_OBJECTS",
    "DEFAULT_ROBOT",
    "DemoConfig",
    "DemoConfigError",
    "add_objects_argument",
    "check_objects",
    "fault_profile",
    "robot_description",
    "robot_names",
    "speed_arg",
    "whole",
]

#: The demo's objects, in the order they are set: the kitchen's ``demo_objects``.
DEFAULT_OBJECTS: tuple[str, ...] = iai.DESCRIPTION.demo_objects


#: The robot the demo runs unless ``--robot`` says otherwise: ``robots.pr2``.
DEFAULT_ROBOT = "pr2"


class DemoConfigError(ValueError):
    """A :class:`DemoConfig` field (a command-line flag) is wrong; the message names the
    flag and says what to give instead. Raised before anything is written or moved."""


def check_objects(objects: Sequence[str]) -> tuple[str, ...]:
    """``objects`` as a tuple, each a demo object given once, at least one; else
    :class:`DemoConfigError` naming ``--objects`` and the objects the demo knows (the
    demo's and the campaign's check)."""
    objects = tuple(objects)
    if not objects:
        raise DemoConfigError(f"--objects needs at least one of {' '.join(DEFAULT_OBJECTS)}")
    unknown = [o for o in objects if o not in DEFAULT_OBJECTS]
    if unknown:
        raise DemoConfigError(
            f"--objects: unknown {' '.join(unknown)}; the demo knows {' '.join(DEFAULT_OBJECTS)}"
        )
    repeated = sorted({o for o in objects if objects.count(o) > 1})
    if repeated:
        raise DemoConfigError(f"--objects: {' '.join(repeated)} given more than once")
    return objects


@dataclass
class DemoConfig:
    """What to run. ``faults``: a :class:`projection.FaultProfile`, its command-line text
    (``"0.1"``, ``"navigation=0.05,ik=0.1"``) or ``None`` (noise only). ``speed``: ``None``
    = as fast as possible, ``1.0`` = real time, or a factor."""

    objects: tuple[str, ...] = DEFAULT_OBJECTS
    seed: int = 1
    runs: int = 3
    projection: bool = True
    faults: Any = None
    speed: float | None = None
    gui: bool = False
    out: Path | None = None
    live: bool = True
    #: The experience store the run is recorded in (an SQLite path or a database URL;
    #: ``None``: not recorded). The command's default is ``OUT/experience.sqlite``.
    store: str | Path | None = None
    #: Learned priors (``aiocram experience learn --out FILE``) that reorder designator
    #: resolution's choices; ``None`` (the default): the rules' own order, nothing learned.
    learned: str | Path | None = None
    #: The robot: a name of the ``robots`` package (``"pr2"``, ``"panda"``: the module
    #: ``robots.NAME``) or an :class:`executive.RobotDescription` of your own.
    robot: Any = DEFAULT_ROBOT

    def check(self) -> None:
        """Raise :class:`DemoConfigError` (naming the flag) for the first bad field. Touches
        nothing: :func:`run_demo` calls it before it writes a file or builds a world."""
        from aiocram._outputs import OutputError, check_out_dir

        check_objects(self.objects)
        robot_description(self)  # raises DemoConfigError naming --robot
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            raise DemoConfigError(f"--seed must be a whole number >= 0, got {self.seed!r}")
        if isinstance(self.runs, bool) or not isinstance(self.runs, int) or self.runs < 1:
            raise DemoConfigError(f"--runs must be a whole number >= 1, got {self.runs!r}")
        if self.speed is not None and not (
            isinstance(self.speed, int | float) and self.speed > 0 and not math.isnan(self.speed)
        ):
            raise DemoConfigError(
                f"--speed must be 'max' or a number > 0 (1 = real time), got {self.speed!r}"
            )
        fault_profile(self)  # raises DemoConfigError for a bad profile
        if self.gui and not os.environ.get("DISPLAY"):
            raise DemoConfigError("--gui needs a display (DISPLAY is not set); drop --gui")
        if self.out is not None:
            try:
                check_out_dir(Path(self.out))
            except OutputError as exc:
                raise DemoConfigError(str(exc)) from None
        if self.store is not None:
            from aiocram.experience import StoreError, store_url

            try:
                store_url(self.store)
            except StoreError as exc:
                raise DemoConfigError(str(exc)) from None
        learned_priors(self)  # raises DemoConfigError for a bad file


def learned_priors(config: DemoConfig) -> Any:
    """The :class:`aiocram.experience.LearnedPriors` of ``--learned`` (None without it),
    checked for this robot; DemoConfigError naming ``--learned`` if unusable."""
    if config.learned is None:
        return None
    from aiocram.experience import LearnedPriors, PriorsError, robot_name

    try:
        priors = LearnedPriors.load(config.learned)
        priors.check_robot(robot_name(robot_description(config)))
    except PriorsError as exc:
        raise DemoConfigError(f"--learned: {exc}") from None
    return priors


def robot_description(config: DemoConfig) -> Any:
    """The :class:`executive.RobotDescription` of ``config.robot`` (looked up by name in
    the ``robots`` package: :func:`robots.by_name`); an unknown name or a value that is
    neither a name nor a description raises :class:`DemoConfigError` naming ``--robot``
    and the robots there are. Loads nothing into a world."""
    import robots
    from executive import RobotDescription

    robot = config.robot
    if isinstance(robot, RobotDescription):
        return robot
    if not isinstance(robot, str):
        raise DemoConfigError(
            f"--robot takes a robot's name ({', '.join(robots.names())}) or an "
            f"executive.RobotDescription, got {robot!r}"
        )
    try:
        return robots.by_name(robot)
    except robots.UnknownRobot as exc:
        raise DemoConfigError(
            f"--robot {robot}: unknown robot; known: {', '.join(exc.known)} "
            "(docs/robots.md says how to describe yours)"
        ) from None


def robot_names(text: str) -> tuple[str, ...]:
    """The robots of a comma-separated ``--robots`` text (the campaign's), each checked
    (:func:`robot_description`), in the order given, each once; else
    :class:`DemoConfigError` naming ``--robots``."""
    given = tuple(part.strip() for part in text.split(","))
    if not all(given):
        raise DemoConfigError(f"--robots {text!r}: give names separated by commas, e.g. pr2,panda")
    repeated = sorted({r for r in given if given.count(r) > 1})
    if repeated:
        raise DemoConfigError(f"--robots: {' '.join(repeated)} given more than once")
    for name in given:
        try:
            robot_description(DemoConfig(robot=name))
        except DemoConfigError as exc:
            raise DemoConfigError(str(exc).replace("--robot ", "--robots: ", 1)) from None
    return given


def fault_profile(config: DemoConfig) -> Any:
    """The fault profile of ``config`` (DemoConfigError naming ``--faults`` if bad)."""
    from dataclasses import replace

    from projection import FaultProfile

    if config.faults is None:
        return FaultProfile(seed=config.seed)
    if isinstance(config.faults, FaultProfile):
        return config.faults
    if not isinstance(config.faults, str):
        raise DemoConfigError(
            f"--faults takes a FaultProfile or its text ('0.1', 'ik=0.2'), got {config.faults!r}"
        )
    try:
        bare = float(config.faults)
    except ValueError:
        bare = None
    if bare is not None and not 0.0 <= bare <= 1.0:
        raise DemoConfigError(
            f"--faults {config.faults}: a fault rate is a probability from 0 to 1 (e.g. "
            "--faults 0.1, or per kind: --faults navigation=0.05,ik=0.1)"
        )
    try:
        profile = FaultProfile.parse(config.faults)
    except (TypeError, ValueError) as exc:
        text = str(exc).replace("FaultProfile.", "")
        raise DemoConfigError(
            f"--faults {config.faults!r}: {text} (rates are probabilities from 0 to 1, "
            "e.g. --faults 0.1 or --faults navigation=0.05,ik=0.1)"
        ) from None
    if "seed=" not in config.faults:
        profile = replace(profile, seed=config.seed)
    return profile


def speed_arg(text: str) -> float | None:
    """The argparse type of ``--speed``: ``max`` (None) or a factor > 0."""
    if text.strip().lower() in ("max", "inf"):
        return None
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (value > 0 and math.isfinite(value)):
        raise argparse.ArgumentTypeError(
            f"must be 'max' or a number > 0 (1 = real time), got {text!r}"
        )
    return value


def whole(minimum: int) -> Callable[[str], int]:
    """The argparse type of a whole number >= ``minimum``."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            value = minimum - 1
        if value < minimum:
            raise argparse.ArgumentTypeError(f"must be a whole number >= {minimum}, got {text!r}")
        return value

    return parse


def add_objects_argument(parser: Any, help_prefix: str, *, choices: bool = True) -> None:
    """``--objects`` (the demo's and the campaign's): any of :data:`DEFAULT_OBJECTS`.
    Without ``choices`` argparse takes any name and :func:`check_objects` says what is
    wrong (the campaign checks every flag before it writes)."""
    parser.add_argument(
        "--objects",
        nargs="+",
        default=list(DEFAULT_OBJECTS),
        choices=DEFAULT_OBJECTS if choices else None,
        metavar="OBJECT",
        help=f"{help_prefix}; any of: {' '.join(DEFAULT_OBJECTS)}",
    )
