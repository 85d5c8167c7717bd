"""What projection reasoning imagined, chose and how well it predicted (issue 14).

Read from a finished task tree: for every real ``transporting`` task (not one inside an
imagined run), its real-run subtree (marked :attr:`cpl.Subtree.REAL`) carries the
assessments of the imagined runs (``"imagined"``) and the winner (``"chosen"``, ``"why"``);
once the real run ended, :func:`aiocram.fidelity.fidelity_of` measures its
:class:`aiocram.fidelity.Fidelity`. :func:`foresight_records`
turns those into JSON rows (the demo's report and the campaign's runs carry them),
:func:`print_foresight` prints them per transport, :func:`fidelity_summary` aggregates a
campaign group's rows (the prediction agreed with the real outcome; how far the real base
goals and route were from the imagined ones, and how far the *true* robot's base stood at
pick and place from where the imagined robot stood: ``"true_bases"``, recorded by the demo's
truth observer from the true world).
"""

from __future__ import annotations

import statistics
from collections.abc import Iterable, Iterator
from typing import Any

import cpl

__all__ = ["fidelity_summary", "foresight_records", "print_foresight"]


def _xyyaw(pose: Any) -> list[float] | None:
    """A pose as ``[x, y, yaw]`` (rounded to the millimetre / milliradian)."""
    if pose is None:
        return None
    return [
        round(float(pose.position[0]), 3),
        round(float(pose.position[1]), 3),
        round(float(pose.yaw), 3),
    ]


def _real_tasks(task: cpl.Task) -> Iterator[cpl.Task]:
    """Every task of the tree outside imagined subtrees."""
    stack = [task]
    while stack:
        t = stack.pop()
        if t.subtree is cpl.Subtree.IMAGINED:
            continue
        yield t
        stack.extend(reversed(t.children))


def foresight_records(root: cpl.Task) -> list[dict[str, Any]]:
    """One JSON row per real transport that imagined: object type, the imagined runs
    (name, prediction, cost, what each explored), the chosen run and why, the fidelity."""
    from executive import action_of

    from .fidelity import TRUE_BASES, fidelity_of

    rows: list[dict[str, Any]] = []
    for task in _real_tasks(root):
        action = action_of(task)
        if action is None or action.type != "transporting":
            continue
        for real in (c for c in task.children if c.subtree is cpl.Subtree.REAL):
            notes = real.annotations or {}
            imagined = notes.get("imagined", ())
            fidelity = fidelity_of(real)
            obj = action.get("object")
            rows.append(
                {
                    "object": str(obj.get("type")) if obj is not None else task.path_entry,
                    "imagined": [
                        {
                            "run": a.name,
                            "predicted": a.verdict(),
                            "clean": a.clean,
                            "cost": a.cost,
                            "explored": dict(a.explored),
                            "bases": {k: _xyyaw(p) for k, p in a.bases.items()},
                        }
                        for a in imagined
                    ],
                    "chosen": notes.get("chosen"),
                    "why": notes.get("why"),
                    "imagining_wall_s": notes.get("imagined_wall_s"),
                    "fidelity": None if fidelity is None else fidelity.to_json(),
                    "true_bases": {k: _xyyaw(p) for k, p in (notes.get(TRUE_BASES) or {}).items()},
                }
            )
    return rows


def print_foresight(rows: Iterable[dict[str, Any]], console: Any) -> None:
    """Per transport: the imagined runs (prediction, cost, what they explored) and which
    one won and why."""
    for row in rows:
        wall = row.get("imagining_wall_s")
        head = f"[bold]{row['object']}[/]: imagined {len(row['imagined'])} runs"
        if wall is not None:
            head += f" in {wall:.2f} s"
        console.print(head)
        for run in row["imagined"]:
            mark = "→" if run["run"] == row["chosen"] else " "
            explored = ", ".join(f"{k} {v}" for k, v in run["explored"].items())
            console.print(f"  {mark} {run['run']}: {run['predicted']}")
            if explored:
                console.print(f"      [dim]{explored}[/]")
        if row["chosen"] is None:
            console.print("    no run usable: the plans chose for themselves")
        else:
            console.print(f"    chose {row['chosen']}: {row['why']}")
        fid = row.get("fidelity")
        if fid is not None:
            console.print(f"    real: {fid['real']} (predicted {fid['predicted']})")
            off = [
                f"{what} {fid[key]:.2f} m"
                for what, key in (("pick", "true_pick_base_m"), ("place", "true_place_base_m"))
                if fid.get(key) is not None
            ]
            if off:
                console.print("    true base vs imagined: " + ", ".join(off))


def fidelity_summary(runs: Iterable[dict[str, Any]]) -> dict[str, Any]:
    """Aggregate the fidelity rows of campaign runs: transports with a record, the share
    whose real outcome the chosen imagined run predicted, mean base-goal and route
    differences (m)."""
    records = [
        row["fidelity"]
        for r in runs
        for row in r.get("foresight", ())
        if row.get("fidelity") is not None
    ]
    picks = [f["pick_base_m"] for f in records if f.get("pick_base_m") is not None]
    places = [f["place_base_m"] for f in records if f.get("place_base_m") is not None]
    routes = [f["route_m"] for f in records if f.get("route_m") is not None]
    true_picks = [f["true_pick_base_m"] for f in records if f.get("true_pick_base_m") is not None]
    true_places = [
        f["true_place_base_m"] for f in records if f.get("true_place_base_m") is not None
    ]
    agreeing = [f for f in records if f["agrees"]]

    def agreeing_mean(key: str) -> float | None:
        values = [f[key] for f in agreeing if f.get(key) is not None]
        return statistics.fmean(values) if values else None

    return {
        "transports": len(records),
        "agreed": sum(1 for f in records if f["agrees"]),
        "fidelity": (sum(1 for f in records if f["agrees"]) / len(records)) if records else None,
        "mean_pick_base_m": statistics.fmean(picks) if picks else None,
        "mean_place_base_m": statistics.fmean(places) if places else None,
        "mean_route_m": statistics.fmean(routes) if routes else None,
        # the true robot's base vs the imagined robot's, at pick / place (n: measured)
        "true_pick_n": len(true_picks),
        "mean_true_pick_base_m": statistics.fmean(true_picks) if true_picks else None,
        "max_true_pick_base_m": max(true_picks) if true_picks else None,
        "true_place_n": len(true_places),
        "mean_true_place_base_m": statistics.fmean(true_places) if true_places else None,
        "max_true_place_base_m": max(true_places) if true_places else None,
        # the same where the real outcome was the predicted one (a real failure ends
        # elsewhere, e.g. the object dropped at the sink)
        "agreeing_true_pick_base_m": agreeing_mean("true_pick_base_m"),
        "agreeing_true_place_base_m": agreeing_mean("true_place_base_m"),
    }


def fidelity_lines(rows: Iterable[dict[str, Any]]) -> list[str]:
    """One line per campaign row that has fidelity records."""
    out = []
    for r in rows:
        f = r.get("fidelity") or {}
        if not f.get("transports"):
            continue

        def m(key: str, f: dict[str, Any] = f) -> str:
            v = f.get(key)
            return "-" if v is None else f"{v:.2f}"

        out.append(
            f"projection fidelity at faults {r['fault_rate']:.2f}: "
            f"{f['agreed']}/{f['transports']} = {100 * f['fidelity']:.1f} % predicted; "
            f"real vs imagined: pick base {m('mean_pick_base_m')} m, "
            f"place base {m('mean_place_base_m')} m, route {m('mean_route_m')}; "
            f"true base vs imagined: pick {m('mean_true_pick_base_m')} m "
            f"(max {m('max_true_pick_base_m')}, n {f.get('true_pick_n', 0)}), "
            f"place {m('mean_true_place_base_m')} m "
            f"(max {m('max_true_place_base_m')}, n {f.get('true_place_n', 0)}); "
            f"where predicted: pick {m('agreeing_true_pick_base_m')} m, "
            f"place {m('agreeing_true_place_base_m')} m"
        )
    return out
