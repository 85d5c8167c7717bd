"""The demo's summary on the console: the final tree, a table per object that fits the
console, the foresight, retries by kind, the truth and the files written."""

from __future__ import annotations

import asyncio
import re
from typing import Any

from aiocram.foresight import print_foresight

from ._report import DemoReport

__all__ = ["outcome_table", "print_report"]


def _retries_text(retries: dict[str, int]) -> str:
    """``"61: detecting 56, search 3, …"``: the total, then the kinds most granted first
    (the console cuts what does not fit; plans.log and the JSON have every one)."""
    granted = {k: v for k, v in retries.items() if v}
    if not granted:
        return "-"
    kinds = sorted(granted.items(), key=lambda kv: (-kv[1], kv[0]))
    return f"{sum(granted.values())}: " + ", ".join(f"{k} {v}" for k, v in kinds)


#: The table's numeric columns: the full header, the short one for a narrow console
#: (the caption explains both).
_NUMBER_HEADERS = (("dist (m)", "dist"), ("sim (s)", "sim"), ("imag (s)", "imag"))
_TABLE_CHROME = 19  # 7 vertical rules and a space each side of 6 cells


def _breaks(text: str, width: int) -> str:
    """``text`` broken into lines of at most ``width`` where words join: before a capital
    (``ObjectNowhere`` / ``ToBeFound``), after a hyphen or at a space; a part longer than
    ``width`` is left for the table to fold."""
    parts = re.findall(r"[A-Z]?[^A-Z\s-]*-?\s*", text)
    lines = [""]
    for part in (p for p in parts if p):
        if lines[-1] and len(lines[-1]) + len(part.rstrip()) > width:
            lines.append("")
        lines[-1] += part
    return "\n".join(line.rstrip() for line in lines)


def outcome_table(report: DemoReport, width: int = 80) -> Any:
    """The summary per object as a rich table at most ``width`` columns wide (down to
    about 50). A number is never cut: the numeric columns are as wide as their widest
    value, with short headers when the console is narrow; the object and outcome cells
    wrap where words join; the retries cell, whose kinds are listed in full below the
    table, keeps its total and is cut after it with an ellipsis."""
    from rich.markup import escape
    from rich.table import Table

    rows: list[tuple[str, str, str, str, list[str]]] = []  # name, outcome, style, retries
    for name, o in report.outcomes.items():
        truth = None if report.truth is None else report.truth.objects.get(o.name)
        if truth is not None and truth.delivered:
            outcome, style = "delivered", "green"
        elif truth is not None and truth.phantom:
            outcome, style = f"phantom ({truth.where})", "red"
        elif o.failure is None or isinstance(o.failure, asyncio.CancelledError):
            outcome, style = "interrupted", "grey50"  # Ctrl-C evaporated the plan
        else:
            outcome, style = type(o.failure).__name__, "red"
        numbers = [
            f"{report.distances.get(name, 0.0):.2f}",
            f"{report.real_sim_s.get(name, 0.0):.1f}",
            f"{report.imagined_wall_s.get(name, 0.0):.2f}",
        ]
        rows.append((name, outcome, style, _retries_text(o.retries), numbers))
    headers = [full for full, _ in _NUMBER_HEADERS]
    widths = [max([len(h), *(len(r[4][i]) for r in rows)]) for i, h in enumerate(headers)]
    room = width - _TABLE_CHROME - sum(widths)
    if room < 32:  # narrow: the short headers
        headers = [short for _, short in _NUMBER_HEADERS]
        widths = [max([len(h), *(len(r[4][i]) for r in rows)]) for i, h in enumerate(headers)]
        room = width - _TABLE_CHROME - sum(widths)
    # the three text columns (object, outcome, retries) share ``room``, shrunk one
    # character at a time: the retries down to 10, then object and outcome (wrapping)
    # down to 12, then the retries down to their total and an ellipsis, then the rest
    text = [
        max([6, *(len(r[0]) for r in rows)]),
        max([7, *(len(r[1]) for r in rows)]),
        max([7, *(len(r[3]) for r in rows)]),
    ]
    total = max([1, *(len(r[3].split(":")[0]) for r in rows)])
    for floors in ((99, 99, 10), (12, 12, 10), (12, 12, total + 2), (4, 4, total + 2)):
        for i in (2, 1, 0):
            cut = min(sum(text) - room, text[i] - min(floors[i], text[i]))
            text[i] -= max(0, cut)
    table = Table(
        title=f"table setting by {report.robot}, seed {report.config.seed}"
        f" ({'with' if report.config.projection else 'without'} projection reasoning)",
        caption="dist: m driven · sim: simulated s · imag: wall s imagining",
    )
    table.add_column("object", width=text[0], overflow="fold")
    table.add_column("outcome", width=text[1], overflow="fold")
    table.add_column("retries", width=text[2], no_wrap=True, overflow="ellipsis")
    for header, w in zip(headers, widths, strict=True):
        table.add_column(header, justify="right", no_wrap=True, width=w)
    for name, outcome, style, retries, numbers in rows:
        table.add_row(
            _breaks(name, text[0]),
            f"[{style}]{escape(_breaks(outcome, text[1]))}[/]",
            retries,
            *numbers,
        )
    return table


def print_report(report: DemoReport, console: Any) -> None:
    """The whole summary of ``report`` on ``console`` (what ``aiocram demo`` prints)."""
    from aiocram._views import final_tree

    if report.root is not None:
        log = next((str(p) for p in report.files if p.name == "log.jsonl"), None)
        console.print(final_tree(report.root))
        if log is not None:
            console.print(
                f"the whole tree: aiocram show {log}",
                soft_wrap=True,
                markup=False,
                highlight=False,
                style="dim",
            )
    console.print(outcome_table(report, console.width))
    print_foresight(report.foresight, console)
    kinds = [(name, _retries_text(o.retries)) for name, o in report.outcomes.items()]
    kinds = [(name, text.split(": ", 1)[1]) for name, text in kinds if text != "-"]
    if kinds:
        console.print("retries by kind (each one is in plans.log):")
        for name, text in kinds:
            console.print(f"  {name}: {text}", highlight=False)
    n = len(report.config.objects)
    if report.interrupted:
        console.print(
            f"interrupted by Ctrl-C during object {len(report.outcomes)} of {n}: the plan was "
            "evaporated and its cleanup ran"
        )
    console.print(
        f"{report.delivered}/{n} objects delivered (true world; the plan claimed {report.claimed})"
    )
    console.print(f"simulated {report.sim_time_s:.1f} s in {report.wall_time_s:.1f} s wall time")
    if report.knocks is not None and report.knocks.knocks:
        from rich.text import Text

        knocked = report.knocks.knocked
        console.print(
            f"{len(knocked)} object{'s' if len(knocked) > 1 else ''} knocked by the robot "
            "(true world; each knock is in plans.log):"
        )
        for name in knocked:  # one line each: how often, and the first knock's motion
            knocks = [k for k in report.knocks.knocks if k.object == name]
            times = f"{len(knocks)} times, first" if len(knocks) > 1 else "once,"
            console.print(Text(f"  {name}: {times} by {knocks[0].motion.describe()}"))
    if report.truth is not None and report.truth.cleanup_intervened:
        console.print("final cleanup intervened: " + "; ".join(report.truth.cleanup_intervened))
    if report.cleanup_failures:
        where = " (each in plans.log)" if report.files else ""
        console.print(
            f"[red]{report.cleanup_failures} cleanup failure(s)[/]: the cleanup of an "
            f"evaporated task raised{where}"
        )
    bad = {k: report.violations.get(k, "") for k, v in report.invariants.items() if not v}
    if bad:
        from rich.text import Text

        console.print("[red]invariants violated:[/]")
        for name, why in bad.items():  # one per line, the detail as recorded
            console.print(Text(f"  {name}: {why or '(no detail recorded)'}"), soft_wrap=True)
    else:
        console.print("invariants hold: " + ", ".join(report.invariants))
    for path in report.files:  # whole, so that it can be copied
        console.print(f"wrote {path}", soft_wrap=True, markup=False, highlight=False)
