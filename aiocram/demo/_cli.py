"""``aiocram demo``: the command line of the table-setting demo (its parser and the command
that runs it, prints the summary and chooses the exit status)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from ._config import (
    DEFAULT_ROBOT,
    DemoConfig,
    DemoConfigError,
    add_objects_argument,
    speed_arg,
    whole,
)
from ._run import frozen_imports, run_demo
from ._summary import print_report

__all__ = ["EXIT_INTERNAL", "EXIT_OK", "EXIT_USAGE", "EXIT_VIOLATED", "add_parser"]


def add_parser(subparsers: Any) -> None:
    """Add ``demo`` to the CLI's subcommands."""
    from aiocram._help import HelpFormatter
    from aiocram._outputs import out_dir_arg

    p = subparsers.add_parser(
        "demo",
        help="table setting: projection-then-execute on the simulated real robot",
        description=(
            "Set the kitchen island's table on the simulated real robot: before each "
            "transport the robot imagines it --runs times in projection and executes the "
            "cheapest plan. Writes the event log, plans.log and pictures to --out. Exit "
            "status: 0 all invariants hold, 1 one was violated, 2 bad arguments, "
            "3 internal error, 130 interrupted (Ctrl-C)."
        ),
        formatter_class=HelpFormatter,
    )
    add_objects_argument(p, "objects to set, in this order")
    p.add_argument(
        "--robot",
        default=DEFAULT_ROBOT,
        metavar="NAME",
        help="the robot that sets the table: a module of the robots package (pr2, panda; "
        "docs/robots.md says how to add yours)",
    )
    p.add_argument(
        "--seed",
        type=whole(0),
        default=1,
        help="seeds the scene, the sampling and the faults (whole number >= 0)",
    )
    p.add_argument("--runs", type=whole(1), default=3, help="imagined runs per transport (>= 1)")
    p.add_argument(
        "--no-projection",
        action="store_true",
        help="execute without imagining first",
    )
    p.add_argument(
        "--faults",
        default=None,
        metavar="PROFILE",
        help="faults to inject: a rate for every kind ('0.1') or 'navigation=0.05,ik=0.1' "
        "(kinds: navigation, ptu, perception, grasp_slip, drop, ik; also miss_rate, "
        "detection_noise=POS:YAW, seed); default: detection noise only",
    )
    p.add_argument(
        "--speed",
        type=speed_arg,
        default="max",
        help="simulated seconds per wall second: 'max' (as fast as possible), "
        "1 (real time), 5, ...",
    )
    p.add_argument("--gui", action="store_true", help="show the true world in a PyBullet GUI")
    p.add_argument(
        "--out",
        type=out_dir_arg,
        default="out/demo",
        metavar="DIR",
        help="directory for log.jsonl, plans.log and the pictures (replaced when the run "
        "ends; a bad argument leaves it untouched)",
    )
    p.add_argument(
        "--no-live",
        action="store_true",
        help="no live view (for logs and pipes); the summary is printed still",
    )
    p.add_argument(
        "--store",
        default=None,
        metavar="FILE_OR_URL",
        help="record the run in this experience store: an SQLite file or a database URL "
        "(postgresql+psycopg://user@host/db); default: OUT/experience.sqlite",
    )
    p.add_argument(
        "--no-store", action="store_true", help="do not record the run in the experience store"
    )
    p.add_argument(
        "--learned",
        type=Path,
        default=None,
        metavar="FILE",
        help="order designator resolution's choices by priors learned from experience "
        "(aiocram experience learn --out FILE); default: not used",
    )
    p.set_defaults(handler=_command)


EXIT_OK, EXIT_VIOLATED, EXIT_USAGE, EXIT_INTERNAL = 0, 1, 2, 3


def _command(args: argparse.Namespace) -> int:
    import traceback

    from rich.console import Console

    from aiocram._interrupt import EXIT_INTERRUPTED, Interrupts

    console = Console()
    config = DemoConfig(
        objects=tuple(args.objects),
        seed=args.seed,
        runs=args.runs,
        projection=not args.no_projection,
        faults=args.faults,
        speed=args.speed,
        gui=args.gui,
        out=Path(args.out),
        live=not args.no_live,
        store=None if args.no_store else (args.store or Path(args.out) / "experience.sqlite"),
        learned=args.learned,
        robot=args.robot,
    )
    if args.no_store and args.store is not None:
        print("aiocram demo: error: --store and --no-store: give one of them", file=sys.stderr)
        return EXIT_USAGE
    try:
        config.check()
    except DemoConfigError as exc:
        print(f"aiocram demo: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    try:
        with frozen_imports(), Interrupts() as interrupts:
            report = run_demo(config, console=console, interrupts=interrupts)
    except DemoConfigError as exc:  # e.g. --out could not be created after all
        print(f"aiocram demo: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:  # Ctrl-C before the plan started (building the worlds)
        print("aiocram demo: interrupted before the robot started", file=sys.stderr)
        return EXIT_INTERRUPTED
    except Exception:  # a bug, not the user's input: say so, with the trace
        traceback.print_exc()
        print(
            f"aiocram demo: internal error (a bug, not your input); the files written so "
            f"far are in {config.out}",
            file=sys.stderr,
        )
        return EXIT_INTERNAL
    print_report(report, console)
    if report.interrupted:
        return EXIT_INTERRUPTED
    return EXIT_OK if all(report.invariants.values()) else EXIT_VIOLATED
