"""The demo's floor plan: where the robot really drove, and where it imagined standing.

Projection reasoning imagines each transport a few times before the real robot acts
(:mod:`plans.reasoning`); each imagined run stands somewhere to pick the object up and
somewhere to put it down. This picture puts those imagined base poses (per transport,
every imagined run, the chosen one marked) on the kitchen's floor plan next to the route
the real robot's *true* base took:

- :class:`RouteRecorder` (an instrument) reads the true world's robot base pose when the
  run starts and whenever a real (not imagined) ``navigating`` task ends, so the route
  is the true base's sequence of stops, joined by straight lines (the real paths between
  them may bend around furniture);
- :func:`floor_plan_figure` draws, in metres, the kitchen furniture, that route, and per
  transport (one colour each) every imagined run's pick base (circle) and place base
  (square), the chosen run's ringed in black, and the true base at pick and place
  (crosses; recorded by the truth observer, see :data:`aiocram.fidelity.TRUE_BASES`).

Every plotted point set carries a ``gid`` (``route``, ``imagined-K-RUN-pick``,
``imagined-K-RUN-place``, ``chosen-K-pick`` ..., ``true-K-pick`` ...; ``K`` the transport's
1-based number) so that a test can read the figure's content back, not its pixels.
"""

from __future__ import annotations

import sys
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import cpl

from ._costmap_figure import draw_furniture, kitchen_boxes
from ._views import imagined

__all__ = ["RouteRecorder", "floor_plan_figure"]

_MARKERS = {"pick": "o", "place": "s"}


def _xyyaw(pose: Any) -> tuple[float, float, float]:
    return float(pose.position[0]), float(pose.position[1]), float(pose.yaw)


class RouteRecorder(cpl.Instrument):
    """Records the true robot base at the start and after every real navigation."""

    def __init__(self, true_world: Any) -> None:
        self.true_world = true_world
        self.route: list[tuple[float, float, float]] = []  # x, y, yaw (true world)

    def run_started(self, root: cpl.Task) -> None:
        del root
        self._note()

    def _note(self) -> None:
        try:
            here = _xyyaw(self.true_world.robot_pose())
        except Exception:  # a closed world: nothing to read (the picture is optional)
            return
        if not self.route or here != self.route[-1]:
            self.route.append(here)

    def task_status_changed(self, task: cpl.Task, old: cpl.Status, new: cpl.Status) -> None:
        del old
        if not new.dead or imagined(task):
            return
        from executive import action_of

        action = action_of(task)
        if action is not None and action.type == "navigating":
            self._note()

    def write(self, world: Any, rows: Sequence[dict[str, Any]], path: Path) -> Path | None:
        """Draw :func:`floor_plan_figure` to ``path``; a figure that cannot be drawn is
        reported on stderr and skipped (a picture never fails the demo)."""
        try:
            return floor_plan_figure(world, self.route, rows, path)
        except Exception as exc:  # reported, and the demo goes on
            print(f"(floor plan not drawn: {type(exc).__name__}: {exc})", file=sys.stderr)
            return None


def draw_floor_plan(
    ax: Any,
    furniture: Iterable[tuple[Sequence[float], Sequence[float]]],
    route: Sequence[tuple[float, float, float]],
    rows: Sequence[dict[str, Any]],
) -> None:
    """Draw the floor plan on the matplotlib axes ``ax`` (see the module docstring);
    ``rows`` are :func:`aiocram.foresight.foresight_records` rows."""
    from matplotlib.lines import Line2D

    boxes = list(furniture)
    draw_furniture(ax, boxes, lw=1.0)
    if route:
        ax.plot(
            [p[0] for p in route],
            [p[1] for p in route],
            color="black",
            lw=1.3,
            marker=".",
            zorder=3,
            gid="route",
        )
        ax.scatter([route[0][0]], [route[0][1]], marker=">", s=80, color="black", zorder=4)
    colours = [f"C{k % 10}" for k in range(len(rows))]
    handles: list[Any] = [
        Line2D([], [], color="black", marker=".", label="real route (true base at each stop)"),
        Line2D([], [], marker="o", ls="", color="0.5", label="imagined pick base"),
        Line2D([], [], marker="s", ls="", color="0.5", label="imagined place base"),
        Line2D(
            [],
            [],
            marker="o",
            ls="",
            markerfacecolor="none",
            markeredgecolor="black",
            mew=2,
            markersize=11,
            label="chosen imagined run",
        ),
        Line2D([], [], marker="x", ls="", color="0.2", mew=2, label="true base at pick/place"),
    ]
    for k, (row, colour) in enumerate(zip(rows, colours), start=1):
        handles.append(Line2D([], [], color=colour, lw=4, label=f"{k}: {row['object']}"))
        for run in row.get("imagined", ()):
            for kind, marker in _MARKERS.items():
                point = (run.get("bases") or {}).get(kind)
                if point is None:
                    continue
                ax.scatter(
                    [point[0]],
                    [point[1]],
                    marker=marker,
                    s=40,
                    color=colour,
                    alpha=0.8,
                    zorder=5,
                    gid=f"imagined-{k}-{run['run']}-{kind}",
                )
                if run["run"] == row.get("chosen"):
                    ax.scatter(
                        [point[0]],
                        [point[1]],
                        marker=marker,
                        s=140,
                        facecolor="none",
                        edgecolor="black",
                        lw=2,
                        zorder=6,
                        gid=f"chosen-{k}-{kind}",
                    )
        for kind in _MARKERS:
            point = (row.get("true_bases") or {}).get(kind)
            if point is not None:
                ax.scatter(
                    [point[0]],
                    [point[1]],
                    marker="x",
                    s=70,
                    color=colour,
                    lw=2,
                    zorder=7,
                    gid=f"true-{k}-{kind}",
                )
    xs = [v for lo, hi in boxes for v in (lo[0], hi[0])] + [p[0] for p in route]
    ys = [v for lo, hi in boxes for v in (lo[1], hi[1])] + [p[1] for p in route]
    if xs and ys:
        ax.set_xlim(min(xs) - 0.4, max(xs) + 0.4)
        ax.set_ylim(min(ys) - 0.4, max(ys) + 0.4)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m, map frame)")
    ax.set_ylabel("y (m, map frame)")
    ax.grid(True, lw=0.3, alpha=0.5)
    ax.legend(handles=handles, loc="upper left", fontsize=7, framealpha=0.9)
    ax.set_title(
        "floor plan: the real route and the base poses each transport imagined", fontsize=9
    )


def floor_plan_figure(
    world: Any,
    route: Sequence[tuple[float, float, float]],
    rows: Sequence[dict[str, Any]],
    path: Path,
) -> Path:
    """Write the floor plan (:func:`draw_floor_plan`, the furniture read from ``world``)
    as a PNG to ``path``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8.0, 7.6), dpi=100)
    try:
        draw_floor_plan(ax, kitchen_boxes(world), route, rows)
        fig.tight_layout()
        fig.savefig(path, format="png")
    finally:
        plt.close(fig)
    return path
