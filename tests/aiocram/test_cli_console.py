"""The command line's console manners (issue 27, item 5): ``python -m aiocram`` works,
log records and warnings reach stderr with their level and logger name, ``--out ""`` is
refused."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
ENV = {**os.environ, "PYTHONPATH": str(ROOT)}


def test_python_m_aiocram_runs_the_command():
    proc = subprocess.run(
        [sys.executable, "-m", "aiocram", "--version"],
        capture_output=True,
        text=True,
        env=ENV,
        timeout=120,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.startswith("aiocram ")


_WARNS = textwrap.dedent(
    """
    import logging, sys, warnings
    from aiocram import cli

    def warn(args):
        logging.getLogger("plans.fetch_deliver").warning("the cup slipped")
        logging.getLogger("plans.fetch_deliver").info("not shown: below WARNING")
        warnings.warn("careful", UserWarning)
        return 0

    def add(subparsers):
        subparsers.add_parser("warn").set_defaults(handler=warn)

    cli._SUBCOMMANDS = (*cli._SUBCOMMANDS, add)
    sys.exit(cli.main(["warn"]))
    """
)


def test_log_records_and_warnings_name_their_level_and_logger():
    proc = subprocess.run(
        [sys.executable, "-c", _WARNS],
        capture_output=True,
        text=True,
        env=ENV,
        timeout=120,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr
    lines = proc.stderr.splitlines()
    assert "WARNING plans.fetch_deliver: the cup slipped" in lines
    assert any(line.startswith("WARNING py.warnings: ") and "careful" in line for line in lines)
    assert "not shown" not in proc.stderr
