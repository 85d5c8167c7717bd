"""The demo's costmap figure: one base-pose costmap as the real robot used it, in metres.

:func:`costmap_figure` (:func:`draw_costmap` on a fresh figure) draws, zoomed on what
matters, the kitchen outline, the costmap the poses rest on with a colour bar (for an
``(among ...)`` location: the costmap its poses were drawn from, not its own factor-less
map, which is one value everywhere; for an empty costmap: the cells the factors before
the emptying one kept, and why it is empty), the objects where the robot believed them,
the robot where it started, every pose of the location chain the plan tried (and whether
the navigation from it failed), the pose it chose and, when the choice was imagined
first, every imagined alternative: the poses it was given, where its imagined robot
stood, what imagining it predicted, and which one the real robot followed. What to draw
is recorded during the run by :class:`aiocram._figures.CostmapRecorder`.
"""

from __future__ import annotations

import math
import textwrap
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from projection.render import draw_furniture, draw_objects, kitchen_boxes

__all__ = ["costmap_figure", "draw_costmap", "draw_furniture", "kitchen_boxes"]


@dataclass
class _Use:
    """One location chain the real robot navigated to, as it was when it first did."""

    location: Any  # the chain's first designator
    object: str  # what the location is for ("spoon-1", "bowl", ...)
    purpose: str  # "visible" (to see the object) or "reachable" (to reach it)
    step: str  # the plan step that navigated ("search-for-object", "fetch", "deliver")
    robot: tuple[float, float, float]  # x, y, yaw where the robot stood
    objects: dict[str, tuple[tuple[float, ...], tuple[float, ...]]]  # belief AABBs then
    tries: list[tuple[tuple[float, float, float], bool]] = field(default_factory=list)
    task: Any = None  # the first real navigating task to this chain (for the task tree)
    #: half the base's length and width (m, base frame): the robot's base link
    #: (:func:`base_half_extents`); None: unknown, the base is not outlined
    footprint: tuple[float, float] | None = None


@dataclass
class _Alternative:
    """One imagined alternative of the decision a real navigation ran inside: a
    ``projection-run-K`` of a transport or an ``imagine-viewpoint-K`` of a search."""

    name: str  # the imagined run's name ("projection-run-2", "viewpoint-1")
    verdict: str  # what imagining it predicted ("clean, cost 4.92", "saw 3 points")
    region: list[tuple[float, float, float]]  # the poses it was given, (among ...)
    reached: tuple[float, float, float] | None  # where its imagined base stood, if it got there
    failed: list[tuple[float, float, float]]  # poses its imagined navigation failed at
    chosen: bool  # the real robot went on with this one


def base_half_extents(world: Any) -> tuple[float, float]:
    """Half the length and width (m) of the base of ``world``'s robot, in its own frame:
    the axis-aligned box of its description's ``base_link`` as the world has it now,
    turned back by the robot's yaw (exact for a box-shaped base at any yaw but 45 deg
    multiples, where the box's extents cannot be told apart: a square is assumed)."""
    lo, hi = world.link_aabb(world.robot.base_link)
    ex, ey = (hi[0] - lo[0]) / 2.0, (hi[1] - lo[1]) / 2.0
    yaw = float(world.robot_pose().yaw)
    c, s = abs(math.cos(yaw)), abs(math.sin(yaw))
    det = c * c - s * s  # ex = a c + b s, ey = a s + b c
    if abs(det) < 1e-3:
        side = (ex + ey) / (2.0 * (c + s))
        return side, side
    return (ex * c - ey * s) / det, (ey * c - ex * s) / det


def _xyyaw(pose: Any) -> tuple[float, float, float]:
    return float(pose.position[0]), float(pose.position[1]), float(pose.yaw)


def _has_costmap(designator: Any) -> bool:
    from projection._locations import LocationCostmaps

    return bool(hasattr(designator, "kind") and LocationCostmaps.applies(designator))


_PURPOSE = {
    "visible": "where to stand to see",
    "reachable": "where to stand to reach",
    "location": "where to stand for",
}


#: the imagined alternatives' colours: clear of the objects' blue, the failures' red and
#: the chosen pose's orange
_ALTERNATIVE_COLOURS = ("tab:purple", "tab:cyan", "tab:olive", "tab:brown", "tab:pink")


def _focus(
    points: Sequence[tuple[float, float]],
    bounds: tuple[float, float, float, float],
    margin: float = 0.5,
    span: float = 2.2,
) -> tuple[float, float, float, float]:
    """The view (x0, x1, y0, y1): around ``points`` with ``margin``, at least ``span``
    metres each way, inside ``bounds`` (the whole kitchen without points)."""
    if not points:
        return bounds
    bx0, bx1, by0, by1 = bounds
    out = []
    for lo_b, hi_b, values in (
        (bx0, bx1, [p[0] for p in points]),
        (by0, by1, [p[1] for p in points]),
    ):
        lo, hi = min(values) - margin, max(values) + margin
        if hi - lo < span:
            mid = (lo + hi) / 2
            lo, hi = mid - span / 2, mid + span / 2
        if hi - lo >= hi_b - lo_b:
            lo, hi = lo_b, hi_b
        elif lo < lo_b:
            lo, hi = lo_b, lo_b + (hi - lo)
        elif hi > hi_b:
            lo, hi = hi_b - (hi - lo), hi_b
        out += [lo, hi]
    return out[0], out[1], out[2], out[3]


def _cells(layer: Any, extent: tuple[float, float, float, float]) -> list[tuple[float, float]]:
    """The corners of the box around a layer's positive cells (none if it has none)."""
    rows, cols = np.nonzero(np.asarray(layer) > 0.0)
    if rows.size == 0:
        return []
    h, w = np.asarray(layer).shape
    sx, sy = (extent[1] - extent[0]) / w, (extent[3] - extent[2]) / h
    return [
        (extent[0] + cols.min() * sx, extent[2] + rows.min() * sy),
        (extent[0] + (cols.max() + 1) * sx, extent[2] + (rows.max() + 1) * sy),
    ]


def _before_empty(cmap: Any) -> tuple[Any, str] | None:
    """For an empty costmap: the product of its factors up to the one that left no cell
    (in the order :class:`projection._costmaps.Costmap` multiplies them), and that factor's
    name; ``None`` if every factor keeps a cell now (the world changed since)."""
    spec = cmap.spec
    xs, ys = spec.grid()
    xs, ys = xs.ravel(), ys.ravel()
    product = np.ones(xs.size)
    live = np.arange(xs.size)  # a factor is evaluated only where the product is positive
    for f in sorted(cmap.factors, key=lambda f: (f.expensive, -f.score)):
        values = np.clip(np.asarray(f.fn(xs[live], ys[live]), dtype=float), 0.0, None)
        after = product[live] * values
        if not (after > 0.0).any():
            return product.reshape(spec.height, spec.width), f.name
        product[live] = after
        live = live[after > 0.0]
    return None


def _purpose_of(designator: Any, fallback: str) -> str:
    for key, short in (("visible-for", "visible"), ("reachable-for", "reachable")):
        if designator is not None and designator.get(key) is not None:
            return short
    return fallback


def costmap_figure(
    engine: Any,
    use: _Use,
    path: Path,
    *,
    number: int = 1,
    candidates: Sequence[tuple[float, float, float]] = (),
    alternatives: Sequence[_Alternative] = (),
    source: Any = None,
) -> Path:
    """One costmap figure (see the module docstring) written to ``path``: see
    :func:`draw_costmap` for the arguments."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8.0, 8.4), dpi=100)
    try:
        draw_costmap(
            fig,
            ax,
            engine,
            use,
            number=number,
            candidates=candidates,
            alternatives=alternatives,
            source=source,
        )
        fig.tight_layout()
        # the layout is done: without an engine, savefig draws once instead of twice (the
        # same pixels); compress_level 1 encodes the PNG several times faster (pixels
        # unchanged, the file ~20 % larger)
        fig.set_layout_engine("none")
        fig.savefig(path, format="png", pil_kwargs={"compress_level": 1})
    finally:
        plt.close(fig)
    return path


def draw_costmap(
    fig: Any,
    ax: Any,
    engine: Any,
    use: _Use,
    *,
    number: int = 1,
    candidates: Sequence[tuple[float, float, float]] = (),
    alternatives: Sequence[_Alternative] = (),
    source: Any = None,
) -> None:
    """Draw one costmap figure on ``ax``: the costmap of ``source`` (the designator the
    location's poses come from, :meth:`CostmapRecorder.costmap_designator`; ``None``: the
    location itself if it has a costmap) with a colour bar, or, when it is empty, the
    cells the factors before the emptying one kept, in grey; the kitchen, the objects as
    believed then, the robot before navigating, the poses tried and chosen;
    ``candidates``: every pose the location pipeline generated for the chain (those not
    among its solutions were rejected by a validator); ``alternatives``: the imagined
    alternatives of the decision the navigation ran inside (their regions, where their
    imagined robot stood, which one won).

    Every plotted layer carries a ``gid`` so that a test can read the figure back:
    ``costmap`` (the heat map), ``costmap-before-empty``, ``alternative-K-region``,
    ``alternative-K-reached``, ``alternative-chosen``, ``chosen``, ``failed``."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch, Polygon, Rectangle

    if source is None and _has_costmap(use.location):
        source = use.location
    world = engine.world
    boxes = kitchen_boxes(world)
    x0 = min(lo[0] for lo, _ in boxes) - 0.3
    x1 = max(hi[0] for _, hi in boxes) + 0.3
    y0 = min(lo[1] for lo, _ in boxes) - 0.3
    y1 = max(hi[1] for _, hi in boxes) + 0.3
    legend: list[Any] = [
        Rectangle(
            (0, 0), 1, 1, facecolor=(0.85, 0.85, 0.85), edgecolor="0.35", label="kitchen furniture"
        ),
        Rectangle((0, 0), 1, 1, facecolor="tab:blue", label="objects (as believed then)"),
        Line2D([], [], color="black", ls="--", label="robot base before navigating"),
    ]
    note = ""
    focus: list[tuple[float, float]] = [use.robot[:2]]
    focus += [p[:2] for p, _ in use.tries]
    for alt in alternatives:
        focus += [p[:2] for p in (*alt.region, *alt.failed)]
        focus += [alt.reached[:2]] if alt.reached is not None else []
    if source is not None:
        builds = engine.builds
        cmap = engine.costmap(source)
        if engine.builds > builds:  # not cached: built now, in the world after the run
            note = "costmap rebuilt after the run from the same designator"
            if source.get("visible-for") is not None:  # ray tests: objects block the view
                note += " (the objects that block the view may have moved since)"
        spec = cmap.spec
        extent = (
            spec.origin[0],
            spec.origin[0] + spec.width * spec.resolution,
            spec.origin[1],
            spec.origin[1] + spec.height * spec.resolution,
        )
        before = _before_empty(cmap) if cmap.empty else None
        if before is not None:
            layer, factor = before
            focus += _cells(layer, extent)
            ax.imshow(
                np.ma.masked_less_equal(layer, 0.0),
                origin="lower",
                extent=extent,
                cmap="Greys",
                vmin=-0.2 * float(layer.max()),
                vmax=float(layer.max()),
                alpha=0.6,
                zorder=1,
                gid="costmap-before-empty",
            )
            legend.append(
                Patch(
                    facecolor="0.55",
                    label=f"cells the other factors keep: '{factor}' removes every one",
                )
            )
            note = "; ".join(filter(None, (note, f"the costmap is empty: {cmap.empty_reason}")))
        elif cmap.empty:
            note = "; ".join(filter(None, (note, f"the costmap is empty: {cmap.empty_reason}")))
        else:
            values = np.asarray(cmap.values(), dtype=float) / float(cmap.max)
            focus += _cells(values, extent)
            image = ax.imshow(
                np.ma.masked_less_equal(values, 0.0),
                origin="lower",
                extent=extent,
                cmap="viridis",
                vmin=0.0,
                vmax=1.0,
                zorder=1,
                gid="costmap",
            )
            bar = fig.colorbar(image, ax=ax, fraction=0.046, pad=0.04)
            bar.set_label("costmap value (1 = best; blank = excluded)")
            if source is not use.location and not note:
                note = "the heat map: the costmap the chosen poses were drawn from"
    else:
        note = "no costmap: the plan gave the poses to try"
    draw_furniture(ax, boxes, lw=1.2)
    draw_objects(ax, use.objects)
    rx, ry, ryaw = use.robot
    c, s = math.cos(ryaw), math.sin(ryaw)
    if use.footprint is not None:  # the robot's base, from its description's base link
        hx, hy = use.footprint
        corners = [
            (rx + c * dx - s * dy, ry + s * dx + c * dy)
            for dx, dy in ((hx, hy), (-hx, hy), (-hx, -hy), (hx, -hy))
        ]
        ax.add_patch(
            Polygon(
                corners,
                closed=True,
                facecolor="none",
                edgecolor="black",
                lw=1.5,
                ls="--",
                zorder=4,
            )
        )
    ax.annotate(
        "",
        (rx + 0.45 * c, ry + 0.45 * s),
        (rx, ry),
        arrowprops={"arrowstyle": "->", "color": "black", "lw": 1.5},
        zorder=5,
    )
    ax.annotate(
        "robot (before)",
        (rx, ry - (0.0 if use.footprint is None else max(use.footprint))),
        xytext=(0, -12),
        textcoords="offset points",
        ha="center",
        fontsize=8,
        zorder=6,
    )
    where = source if source is not None else use.location
    inner = where.get("location")
    target = inner.get("pose") if inner is not None and hasattr(inner, "get") else None
    if target is not None and getattr(target, "frame", "map") == "map":
        tx, ty = float(target.position[0]), float(target.position[1])
        focus.append((tx, ty))
        ax.scatter([tx], [ty], marker="D", s=70, color="magenta", edgecolor="black", zorder=8)
        ax.annotate(
            f"target: {use.object}",
            (tx, ty),
            xytext=(6, -12),
            textcoords="offset points",
            fontsize=8,
            color="purple",
            zorder=8,
        )
        legend.append(
            Line2D(
                [],
                [],
                marker="D",
                ls="",
                color="magenta",
                markeredgecolor="black",
                label=f"target: the point to see or reach ({use.object})",
            )
        )
    if alternatives:
        legend.append(
            Line2D(
                [],
                [],
                marker="^",
                ls="",
                color="0.6",
                markeredgecolor="black",
                label="where an imagined run's robot stood:",
            )
        )
    for k, alt in enumerate(alternatives, start=1):
        colour = _ALTERNATIVE_COLOURS[(k - 1) % len(_ALTERNATIVE_COLOURS)]
        if alt.region:
            ax.scatter(
                [p[0] for p in alt.region],
                [p[1] for p in alt.region],
                marker="o",
                s=22,
                facecolor="none",
                edgecolor=colour,
                lw=1.2,
                zorder=5,
                gid=f"alternative-{k}-region",
            )
        if alt.failed:
            ax.scatter(
                [p[0] for p in alt.failed],
                [p[1] for p in alt.failed],
                marker="x",
                s=30,
                color=colour,
                lw=1.2,
                zorder=5,
            )
        if alt.reached is not None:
            px, py, pyaw = alt.reached
            ax.scatter(
                [px],
                [py],
                marker="^",
                s=70,
                color=colour,
                edgecolor="black",
                lw=0.6,
                zorder=6,
                gid=f"alternative-{k}-reached",
            )
            ax.annotate(
                "",
                (px + 0.22 * math.cos(pyaw), py + 0.22 * math.sin(pyaw)),
                (px, py),
                arrowprops={"arrowstyle": "->", "color": colour, "lw": 1.2},
                zorder=6,
            )
            if alt.chosen:
                ax.scatter(
                    [px],
                    [py],
                    marker="o",
                    s=260,
                    facecolor="none",
                    edgecolor="black",
                    lw=1.8,
                    zorder=6,
                    gid="alternative-chosen",
                )
        mark = " (chosen)" if alt.chosen else ""
        legend.append(
            Line2D(
                [],
                [],
                marker="^",
                ls="",
                color=colour,
                markeredgecolor="black",
                label=f"{alt.name}{mark}: {alt.verdict}",
            )
        )
    if any(alt.region for alt in alternatives):
        legend.append(
            Line2D(
                [],
                [],
                marker="o",
                ls="",
                markerfacecolor="none",
                markeredgecolor="0.3",
                label="an imagined run's poses to try (its region)",
            )
        )
    if alternatives:
        legend += [
            Line2D(
                [],
                [],
                marker="o",
                ls="",
                markerfacecolor="none",
                markeredgecolor="black",
                mew=1.8,
                markersize=13,
                label="the imagined run the real robot followed",
            ),
        ]
    failed = [p for p, ok in use.tries if not ok]
    good = [p for p, ok in use.tries if ok]
    tried = {(round(p[0], 3), round(p[1], 3)) for p, _ in use.tries}
    accepted = [_xyyaw(m.reference()) for m in use.location.chain() if m.effective]
    sampled = [p for p in accepted if (round(p[0], 3), round(p[1], 3)) not in tried]
    solutions = {(round(p[0], 4), round(p[1], 4)) for p in accepted}
    rejected = [p for p in candidates if (round(p[0], 4), round(p[1], 4)) not in solutions]
    if rejected:
        ax.scatter(
            [p[0] for p in rejected],
            [p[1] for p in rejected],
            marker="x",
            s=14,
            color="0.45",
            lw=0.8,
            zorder=4,
        )
        legend.append(
            Line2D(
                [],
                [],
                marker="x",
                ls="",
                color="0.45",
                mew=0.8,
                label="sample rejected (collision, reach, view...)",
            )
        )
    if sampled:
        ax.scatter(
            [p[0] for p in sampled],
            [p[1] for p in sampled],
            marker="o",
            s=18,
            facecolor="white",
            edgecolor="0.2",
            zorder=5,
        )
        legend.append(
            Line2D(
                [],
                [],
                marker="o",
                ls="",
                markerfacecolor="white",
                markeredgecolor="0.2",
                label="pose accepted, not driven to",
            )
        )
    if failed:
        ax.scatter(
            [p[0] for p in failed],
            [p[1] for p in failed],
            marker="x",
            s=60,
            color="red",
            lw=2,
            zorder=6,
            gid="failed",
        )
        legend.append(
            Line2D(
                [],
                [],
                marker="x",
                ls="",
                color="red",
                markersize=9,
                mew=2,
                label="pose tried, navigation failed",
            )
        )
    if good:
        gx, gy, gyaw = good[-1]
        ax.scatter(
            [gx],
            [gy],
            marker="*",
            s=260,
            color="orange",
            edgecolor="black",
            zorder=7,
            gid="chosen",
        )
        ax.annotate(
            "",
            (gx + 0.3 * math.cos(gyaw), gy + 0.3 * math.sin(gyaw)),
            (gx, gy),
            arrowprops={"arrowstyle": "->", "color": "darkorange", "lw": 2},
            zorder=7,
        )
        legend.append(
            Line2D(
                [],
                [],
                marker="*",
                ls="",
                color="orange",
                markeredgecolor="black",
                markersize=14,
                label="pose the real robot stood at",
            )
        )
    vx0, vx1, vy0, vy1 = _focus(focus, (x0, x1, y0, y1))
    ax.set_xlim(vx0, vx1)
    ax.set_ylim(vy0, vy1)
    # under the plot, where it hides nothing
    ax.legend(
        handles=legend,
        loc="upper center",
        bbox_to_anchor=(0.5, -0.09),
        ncol=2,
        fontsize=7,
        framealpha=0.9,
    )
    ax.set_aspect("equal")
    ax.set_xlabel("x (m, map frame)")
    ax.set_ylabel("y (m, map frame)")
    ax.grid(True, lw=0.3, alpha=0.5)
    purpose = _purpose_of(source, use.purpose)
    how = ", chosen by imagining" if alternatives else ""
    title = f"costmap {number}: {_PURPOSE[purpose]} {use.object} ({use.step}{how})"
    subtitle = textwrap.shorten(use.location.short(), 100)
    lines = [title, subtitle] + ([textwrap.shorten(note, 110)] if note else [])
    ax.set_title("\n".join(lines), fontsize=9)
