"""``aiocram experience plot``: failures by kind per fault rate, as a picture."""

from __future__ import annotations

from pathlib import Path

from ._store import Store

__all__ = ["plot_failures"]

_TOP = 7  # kinds drawn; the rest are summed as "other"


def plot_failures(store: Store, path: Path, *, imagined: bool = False) -> Path:
    """A grouped bar chart: per fault rate, failures per run of each kind (the most
    frequent kinds, the rest as "other"), each bar labelled with its count, the runs
    per rate under the axis. Written to ``path`` (PNG)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    data = store.failures_by_fault_rate(imagined=imagined)
    runs = store.runs_per_fault_rate()
    rates = sorted(set(runs) | set(data))
    totals: dict[str, int] = {}
    for kinds in data.values():
        for kind, n in kinds.items():
            totals[kind] = totals.get(kind, 0) + n
    ranked = sorted(totals, key=lambda k: (-totals[k], k))
    shown_kinds = ranked[:_TOP] + (["other"] if len(ranked) > _TOP else [])
    fig, ax = plt.subplots(figsize=(9, 5), dpi=100)
    width = 0.8 / max(1, len(shown_kinds))
    for i, kind in enumerate(shown_kinds):
        counts = []
        for rate in rates:
            kinds = data.get(rate, {})
            if kind == "other":
                counts.append(sum(n for k, n in kinds.items() if k not in ranked[:_TOP]))
            else:
                counts.append(kinds.get(kind, 0))
        xs = [j + (i - (len(shown_kinds) - 1) / 2) * width for j in range(len(rates))]
        per_run = [c / runs[r] if runs.get(r) else 0.0 for c, r in zip(counts, rates, strict=True)]
        bars = ax.bar(xs, per_run, width, label=f"{kind} ({totals.get(kind, sum(counts))})")
        for bar, c in zip(bars, counts, strict=True):
            if c:
                ax.annotate(
                    str(c),
                    (bar.get_x() + bar.get_width() / 2, bar.get_height()),
                    xytext=(0, 2),
                    textcoords="offset points",
                    ha="center",
                    fontsize=7,
                )
    ax.set_xticks(range(len(rates)))
    ax.set_xticklabels([f"{r:g}\n({runs.get(r, 0)} runs)" for r in rates])
    ax.set_xlabel("low-level fault rate (runs at that rate)")
    ax.set_ylabel("failures per run (bar label: count)")
    which = "imagined runs" if imagined else "real runs"
    total = sum(totals.values())
    ax.set_title(f"failures by kind per fault rate ({which}; {total} failures where they arose)")
    if shown_kinds:
        ax.legend(title="kind (total)", fontsize=8, loc="upper left")
    else:
        ax.text(0.5, 0.5, "no failures recorded", transform=ax.transAxes, ha="center")
    ax.grid(True, axis="y", alpha=0.3)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)
    return path
