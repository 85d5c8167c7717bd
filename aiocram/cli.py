"""The ``aiocram`` command line.

Subcommands:

- ``aiocram show LOG [--ascii] [--max-nodes N] [--run I] [--collapse]``: draw the task
  tree of a run recorded by :class:`cpl._eventlog.EventLog`.

Adding a subcommand (``demo``, ``bench``, ``campaign``, ...): write a function
``_add_<name>(subparsers)`` that adds its parser and sets ``handler=`` (a function taking
the parsed namespace and returning the exit code), and list it in :data:`_SUBCOMMANDS`.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import logging
import sys
from collections.abc import Callable, Iterator, Sequence
from importlib import metadata
from typing import Any

from aiocram._help import HelpFormatter

__all__ = ["build_parser", "main"]

_Subparsers = Any  # argparse's _SubParsersAction is private


def _version() -> str:
    try:
        return metadata.version("aiocram")
    except metadata.PackageNotFoundError:
        return "unknown"


# --------------------------------------------------------------------------- show


def _positive(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a whole number >= 1, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {value}")
    return value


#: The longest problem description ``aiocram show`` prints (a damaged log may hold a
#: megabyte on one line; the message stays one readable line).
_MAX_PROBLEM = 300


def _cannot_read(log: str, problem: str) -> int:
    """Print the one-line "cannot read" error of ``aiocram show`` (``problem`` names the
    line as ``LOG:7:``, as editors and grep do); return exit status 2."""
    problem = " ".join(problem.split())
    if len(problem) > _MAX_PROBLEM:
        problem = problem[: _MAX_PROBLEM - 3] + "..."
    print(f"aiocram show: error: cannot read {log}: {problem}", file=sys.stderr)
    return 2


#: What a damaged log can still make the reader or the renderer raise, however careful the
#: reader's checks: reported as "cannot read", never as a traceback.
_DAMAGE = (
    KeyError,
    TypeError,
    AttributeError,
    IndexError,
    RecursionError,
    MemoryError,
    OverflowError,
)


def _add_show(subparsers: _Subparsers) -> None:
    p = subparsers.add_parser(
        "show",
        help="draw the task tree of a recorded run",
        description="Draw the final task tree of a run recorded as a JSON-lines event log "
        "(e.g. aiocram show --collapse out/demo/log.jsonl).",
        formatter_class=HelpFormatter,
    )
    p.add_argument("log", metavar="LOG", help="event log file written by cpl's EventLog")
    p.add_argument("--ascii", action="store_true", help="ASCII glyphs and tree guides only")
    p.add_argument(
        "--max-nodes",
        type=_positive,
        default=None,
        metavar="N",
        help="draw at most N tasks (default: all)",
    )
    p.add_argument(
        "--run",
        type=int,
        default=-1,
        metavar="I",
        help="which run of the file to show (0 = first, -1 = last)",
    )
    p.add_argument(
        "--collapse",
        action="store_true",
        help="the compact tree the demo prints: one line per top-level step, its "
        "failures folded by name with a count and the last failure (--max-nodes: not used)",
    )
    p.set_defaults(handler=_run_show)


class _AsciiBuffer(io.StringIO):
    """A text buffer that says it holds ASCII, so rich draws tree guides in ASCII."""

    encoding = "ascii"


def _ascii_text(renderable: Any, width: int) -> str:
    from rich.console import Console

    buffer = _AsciiBuffer()
    Console(file=buffer, width=width, color_system=None, highlight=False).print(renderable)
    return buffer.getvalue().translate(_TO_ASCII)


#: one character for one, so that the lines keep their width
_TO_ASCII = str.maketrans({"—": "-", "×": "x", "…": "~", "→": ">", "✔": "+", "✘": "x"})


def _run_show(args: argparse.Namespace) -> int:
    from rich.console import Console

    from cpl._eventlog import tree_from_log, truncated_tail
    from cpl.display import render, render_text

    try:
        tree = tree_from_log(args.log, run=args.run)
        cut = truncated_tail(args.log)
    except FileNotFoundError:
        print(f"aiocram show: error: no such file: {args.log}", file=sys.stderr)
        return 2
    except IsADirectoryError:
        return _cannot_read(args.log, "it is a folder; give the event log file in it")
    except PermissionError:
        return _cannot_read(args.log, "permission denied")
    except (OSError, ValueError) as exc:
        return _cannot_read(args.log, str(exc))
    except _DAMAGE as exc:
        return _cannot_read(args.log, f"a malformed event ({type(exc).__name__}: {exc})")
    console = Console(highlight=False)
    try:  # rendered whole before anything is written: no half tree before an error
        if args.collapse:  # the compact tree the demo prints at its end
            from aiocram._views import final_tree

            if args.ascii:
                text = _ascii_text(final_tree(tree, ascii=True), console.width)
            else:
                with console.capture() as captured:
                    console.print(final_tree(tree))
                text = captured.get()
        elif args.ascii:
            text = render_text(
                tree,
                ascii=True,
                width=console.width,
                max_nodes=args.max_nodes,
                collapse_finished=args.collapse,
            )
        else:
            with console.capture() as captured:
                console.print(
                    render(tree, max_nodes=args.max_nodes, collapse_finished=args.collapse)
                )
            text = captured.get()
    except (ValueError, *_DAMAGE) as exc:
        return _cannot_read(args.log, f"a malformed event ({type(exc).__name__}: {exc})")
    sys.stdout.write(text)
    if cut is not None:
        print(
            f"aiocram show: note: {args.log} ends in a line cut mid-write (line {cut}, left "
            "out): the run crashed or was killed; the tree is as its last complete event "
            "left it",
            file=sys.stderr,
        )
    return 0


# --------------------------------------------------------------------------- main


def _add_demo(subparsers: _Subparsers) -> None:
    from aiocram.demo import add_parser

    add_parser(subparsers)


def _add_bench(subparsers: _Subparsers) -> None:
    from aiocram.bench import add_parser

    add_parser(subparsers)


def _add_campaign(subparsers: _Subparsers) -> None:
    from aiocram.campaign import add_parser

    add_parser(subparsers)


def _add_experience(subparsers: _Subparsers) -> None:
    from aiocram.experience._cli import add_parser

    add_parser(subparsers)


def _add_reference(subparsers: _Subparsers) -> None:
    from aiocram.reference import add_parser

    add_parser(subparsers)


def _add_robot(subparsers: _Subparsers) -> None:
    from aiocram.robot_check import add_parser

    add_parser(subparsers)


_SUBCOMMANDS: tuple[Callable[[_Subparsers], None], ...] = (
    _add_demo,
    _add_show,
    _add_bench,
    _add_campaign,
    _add_experience,
    _add_reference,
    _add_robot,
)
"""Registrars of the subcommands, in help order."""


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every registered subcommand."""
    parser = argparse.ArgumentParser(
        prog="aiocram", description="aiocram: CRAM's plan language and executive on asyncio."
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {_version()}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for add in _SUBCOMMANDS:
        add(subparsers)
    return parser


def _import_pybullet_quietly() -> None:
    """Import pybullet without its ``pybullet build time`` banner on stderr (see
    :mod:`projection._quiet`); a missing pybullet is left for the command to report."""
    try:
        from projection._quiet import import_pybullet_quietly

        import_pybullet_quietly()
    except ImportError:
        pass


#: How a log record or a Python warning reaches the console during a command: its level
#: and the logger's name, like plans.log (``WARNING plans.fetch_deliver: ...``).
LOG_FORMAT = "%(levelname)s %(name)s: %(message)s"


@contextlib.contextmanager
def _console_logging() -> Iterator[None]:
    """Log records (WARNING and up) and Python warnings go to stderr as
    :data:`LOG_FORMAT` while a command runs, instead of the bare message of logging's
    last-resort handler. Left as it is when the root logger has handlers already (an
    application or pytest configured logging); undone at the end."""
    root = logging.getLogger()
    if root.handlers:
        yield
        return
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(logging.Formatter(LOG_FORMAT))
    root.addHandler(handler)
    logging.captureWarnings(True)
    try:
        yield
    finally:
        logging.captureWarnings(False)
        root.removeHandler(handler)


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``aiocram`` command; returns the exit code (2 for bad
    arguments, as argparse reports them, without raising ``SystemExit``)."""
    try:
        args = build_parser().parse_args(argv)
    except SystemExit as exc:  # --help, --version, or a usage error already printed
        return exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 2)
    _import_pybullet_quietly()
    handler: Callable[[argparse.Namespace], int] = args.handler
    with _console_logging():
        return handler(args)


if __name__ == "__main__":
    sys.exit(main())
