"""``aiocram experience ...``: the questions, answered from the store on rich tables.

- ``failures [--by kind|object|step|robot] [--imagined]``: failures where they arose;
- ``retries``: retries spent per recovery, and how many of those objects arrived;
- ``parameters --object cup [--surface S] [--action picking-up|placing]``: which arm
  and grasp succeeded, and where the base stood relative to the object;
- ``compare A B``: two campaigns or two commits (ids or unique prefixes) side by side;
- ``plot [--png FILE]``: failures by kind per fault rate, as a picture;
- ``learn --out priors.json``: learned priors (:mod:`._priors`) for ``--learned``.

Exit status: 0 answered, 2 bad arguments or a store that cannot be read (the message
says what to fix).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

__all__ = ["add_parser"]

DEFAULT_STORE = "out/campaign/experience.sqlite"


def add_parser(subparsers: Any) -> None:
    from aiocram._help import HelpFormatter

    from ._store import FAILURE_GROUPS

    common = argparse.ArgumentParser(add_help=False)
    common.add_argument(
        "--store",
        default=DEFAULT_STORE,
        metavar="FILE_OR_URL",
        help="the store: an SQLite file or a database URL "
        "(postgresql+psycopg://user@host/db); default: the campaign's",
    )
    p = subparsers.add_parser(
        "experience",
        help="ask the experience store (failures, retries, parameters, compare, plot)",
        description="Questions answered from the experience store that every demo and "
        "campaign writes (OUT/experience.sqlite, or --store URL). Exit status: 0 answered, "
        "2 bad arguments or a store that cannot be read.",
        formatter_class=HelpFormatter,
    )
    sub = p.add_subparsers(dest="question", metavar="QUESTION", required=True)
    f = sub.add_parser(
        "failures",
        parents=[common],
        help="failures where they arose, by kind, object, step or robot",
        formatter_class=HelpFormatter,
    )
    f.add_argument("--by", choices=FAILURE_GROUPS, default="kind", help="group by")
    f.add_argument(
        "--imagined", action="store_true", help="the imagined runs' failures (default: real)"
    )
    f.set_defaults(handler=_failures)
    r = sub.add_parser(
        "retries",
        parents=[common],
        help="retries spent per recovery",
        formatter_class=HelpFormatter,
    )
    r.set_defaults(handler=_retries)
    q = sub.add_parser(
        "parameters",
        parents=[common],
        help="which arm and grasp succeeded for an object (on a surface)",
        formatter_class=HelpFormatter,
    )
    q.add_argument("--object", required=True, metavar="TYPE", help="object type, e.g. cup")
    q.add_argument("--surface", metavar="NAME", help="e.g. sink_area_surface (default: any)")
    q.add_argument(
        "--action", choices=("picking-up", "placing"), default="picking-up", help="which action"
    )
    q.add_argument(
        "--imagined", action="store_true", help="the imagined runs' choices (default: real)"
    )
    q.set_defaults(handler=_parameters)
    c = sub.add_parser(
        "compare",
        parents=[common],
        help="two campaigns or two commits: delivered rate, failures, retries",
        formatter_class=HelpFormatter,
    )
    c.add_argument("before", metavar="A", help="campaign id or commit (or a unique prefix)")
    c.add_argument("after", metavar="B", help="campaign id or commit (or a unique prefix)")
    c.set_defaults(handler=_compare)
    g = sub.add_parser(
        "plot",
        parents=[common],
        help="failures by kind per fault rate, as a PNG",
        formatter_class=HelpFormatter,
    )
    g.add_argument(
        "--png",
        type=Path,
        default=None,
        metavar="FILE",
        help="where to write it (default: failures_by_kind.png next to an SQLite store)",
    )
    g.add_argument("--imagined", action="store_true", help="the imagined runs' failures")
    g.set_defaults(handler=_plot)
    lp = sub.add_parser(
        "learn",
        parents=[common],
        help="learn priors (arm/grasp success, base pose density) into a JSON file",
        formatter_class=HelpFormatter,
    )
    lp.add_argument(
        "--out", type=Path, required=True, metavar="FILE", help="the priors file to write"
    )
    lp.add_argument("--robot", metavar="NAME", help="whose runs (default: the store's one robot)")
    lp.set_defaults(handler=_learn)
    p.set_defaults(handler=lambda args: p.print_help() or 2)


def _open(args: argparse.Namespace) -> Any:
    from ._errors import StoreError
    from ._store import Store

    try:
        return Store(args.store)
    except StoreError as exc:
        print(f"aiocram experience: error: {exc}", file=sys.stderr)
        return None


def _console() -> Any:
    from rich.console import Console

    return Console()


def _table(title: str, columns: list[tuple[str, str]], caption: str | None = None) -> Any:
    from rich import box
    from rich.table import Table

    table = Table(title=title, caption=caption, box=box.SIMPLE_HEAD)
    for name, justify in columns:
        table.add_column(name, justify=justify)  # type: ignore[arg-type]
    return table


def _guarded(args: argparse.Namespace, answer: Any) -> int:
    from ._errors import StoreError

    store = _open(args)
    if store is None:
        return 2
    try:
        with store:
            return int(answer(store))
    except StoreError as exc:
        print(f"aiocram experience: error: {exc}", file=sys.stderr)
        return 2


def _failures(args: argparse.Namespace) -> int:
    def answer(store: Any) -> int:
        rows = store.failures_by(args.by, imagined=args.imagined)
        total = sum(n for _, n in rows)
        which = "imagined" if args.imagined else "real"
        table = _table(
            f"failures by {args.by} ({which} runs, {store.run_count()} runs in the store)",
            [(args.by, "left"), ("failures", "right"), ("share", "right")],
            caption="counted where each failure arose, not at every task it passed through",
        )
        for key, n in rows:
            table.add_row(key, str(n), f"{100 * n / total:.1f} %")
        _console().print(table)
        return 0

    return _guarded(args, answer)


def _retries(args: argparse.Namespace) -> int:
    def answer(store: Any) -> int:
        table = _table(
            "retries spent per recovery",
            [
                ("recovery", "left"),
                ("retries", "right"),
                ("objects", "right"),
                ("per object", "right"),
                ("then delivered", "right"),
            ],
            caption="objects: that spent any; then delivered: of those, measured on the true world",
        )
        for kind, spent, objects, delivered in store.retries():
            table.add_row(
                kind,
                str(spent),
                str(objects),
                f"{spent / objects:.2f}",
                f"{delivered} ({100 * delivered / objects:.0f} %)",
            )
        _console().print(table)
        return 0

    return _guarded(args, answer)


def _parameters(args: argparse.Namespace) -> int:
    def answer(store: Any) -> int:
        stats = store.parameters(
            args.object, surface=args.surface, action=args.action, imagined=args.imagined
        )
        if not stats:
            surfaces = store.surfaces(args.object)
            where = f" on {args.surface}" if args.surface else ""
            print(
                f"aiocram experience: no {args.action} of {args.object}{where} in the store"
                + (f" (surfaces with it: {', '.join(surfaces)})" if surfaces else ""),
                file=sys.stderr,
            )
            return 2
        where = f" on {args.surface}" if args.surface else ""
        table = _table(
            f"{args.action} {args.object}{where}: which parameters succeeded",
            [
                ("arm", "left"),
                ("grasp", "left"),
                ("tried", "right"),
                ("succeeded", "right"),
                ("rate", "right"),
                ("object in base frame (m)", "right"),
            ],
            caption="object in base frame: the mean x (ahead), y (left) of the object "
            "(placing: of the placing pose) seen from the base, over the successes",
        )
        for p in stats:
            rel = (
                "-"
                if p.mean_rel_x is None or p.mean_rel_y is None
                else f"{p.mean_rel_x:+.2f}, {p.mean_rel_y:+.2f}"
            )
            table.add_row(
                str(p.arm),
                str(p.grasp),
                str(p.tried),
                str(p.succeeded),
                f"{100 * p.rate:.0f} %",
                rel,
            )
        _console().print(table)
        return 0

    return _guarded(args, answer)


def _compare(args: argparse.Namespace) -> int:
    def answer(store: Any) -> int:
        cmp = store.compare(args.before, args.after)
        a, b = cmp.before, cmp.after
        table = _table(
            "compare (real runs, true world)",
            [("", "left"), ("A", "right"), ("B", "right"), ("B - A", "right")],
            caption=f"A: {a.label} · B: {b.label}; failures counted where they arose",
        )
        table.columns[0].overflow = "fold"
        table.add_row("runs", str(a.runs), str(b.runs), f"{b.runs - a.runs:+d}")
        table.add_row(
            "delivered",
            f"{100 * a.delivered_rate:.1f} % ({a.delivered}/{a.objects})",
            f"{100 * b.delivered_rate:.1f} % ({b.delivered}/{b.objects})",
            f"{100 * (b.delivered_rate - a.delivered_rate):+.1f} pts",
        )
        table.add_row(
            "failures / run",
            f"{a.failures_per_run:.2f}",
            f"{b.failures_per_run:.2f}",
            f"{b.failures_per_run - a.failures_per_run:+.2f}",
        )
        table.add_row(
            "retries / object",
            f"{a.retries_per_object:.2f}",
            f"{b.retries_per_object:.2f}",
            f"{b.retries_per_object - a.retries_per_object:+.2f}",
        )
        kinds = set(a.by_kind) | set(b.by_kind)
        for kind in sorted(kinds, key=lambda k: (-a.by_kind.get(k, 0) - b.by_kind.get(k, 0), k)):
            x, y = a.by_kind.get(kind, 0), b.by_kind.get(kind, 0)
            table.add_row(f"  {kind}", str(x), str(y), f"{y - x:+d}")
        _console().print(table)
        return 0

    return _guarded(args, answer)


def _learn(args: argparse.Namespace) -> int:
    from ._priors import learn_priors

    def answer(store: Any) -> int:
        priors = learn_priors(store, args.robot)
        table = _table(
            f"learned priors for {priors.robot} ({priors.runs} runs)",
            [
                ("action", "left"),
                ("object", "left"),
                ("surface", "left"),
                ("n", "right"),
                ("success", "right"),
                ("best (rate)", "left"),
                ("base samples", "right"),
            ],
            caption="real runs only; rate (succeeded + 1) / (tried + 2); base samples: "
            "successful base poses in the object frame, read as a kernel density",
        )
        for p in priors.priors:
            best = p.choices[0]
            table.add_row(
                p.action,
                p.object,
                p.surface or "-",
                str(p.tried),
                f"{100 * p.succeeded / p.tried:.0f} %" if p.tried else "-",
                f"{best.arm}/{best.grasp} ({best.smoothed:.2f})",
                str(len(p.samples)),
            )
        _console().print(table)
        print(f"wrote {priors.save(args.out)}")
        return 0

    return _guarded(args, answer)


def _plot(args: argparse.Namespace) -> int:
    from ._plot import plot_failures

    def answer(store: Any) -> int:
        png = args.png
        if png is None:
            database = store.url.database if store.url.get_backend_name() == "sqlite" else None
            png = (Path(database).parent if database else Path(".")) / "failures_by_kind.png"
        path = plot_failures(store, png, imagined=args.imagined)
        print(f"wrote {path}")
        return 0

    return _guarded(args, answer)
