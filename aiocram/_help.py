"""The help formatter of every ``aiocram`` subcommand: each option's default is shown,
as the user would type it, unless the help text already says it or there is none to show
(flags, options without a default)."""

from __future__ import annotations

import argparse

__all__ = ["HelpFormatter"]


class HelpFormatter(argparse.HelpFormatter):
    """``--seed SEED  seeds the scene (default: 1)``; lists shown space-separated."""

    def _get_help_string(self, action: argparse.Action) -> str | None:
        text = action.help or ""
        default = action.default
        if (
            "%(default)" in text
            or "default:" in text
            or default is None
            or default is False
            or default is argparse.SUPPRESS
            or isinstance(action, argparse._HelpAction | argparse._VersionAction)
            or not action.option_strings
        ):
            return text
        shown = " ".join(map(str, default)) if isinstance(default, list | tuple) else default
        # argparse %-formats the help text: the appended default must not format
        return text + f" (default: {shown})".replace("%", "%%")
