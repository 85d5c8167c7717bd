"""The demo's pictures that need to see the run as it happened: the head camera's view
at the last detection, and the base-pose costmaps as the robot used them.

Both are recorded by instruments while the run goes (after the run the objects have
moved and the robot stands elsewhere) and drawn at the end:

- :class:`CameraRecorder`: when a real (not imagined) ``detecting`` action succeeds, it
  takes a snapshot of the true world (cheap); :meth:`CameraRecorder.write` restores the
  last one for a moment, renders it from the robot's head camera, projects the detected
  objects' bounding boxes into the image and outlines and names them.
- :class:`CostmapRecorder`: when the real robot starts navigating to a costmap location
  (``visible-for`` / ``reachable-for``), it notes the robot's pose and the objects as the
  robot believed them then; at the end :func:`costmap_figure` draws, in metres, the
  kitchen outline, the costmap with a colour bar, the objects where they were, the robot
  where it started, every pose of that location chain the plan tried (and whether the
  navigation from it failed) and the pose it chose.
"""

from __future__ import annotations

import math
import textwrap
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

import cpl

from ._views import imagined

__all__ = ["CameraRecorder", "CostmapRecorder", "costmap_figure"]

_VIEW_SIZE = (640, 480)


def _matrix(values: Any) -> np.ndarray:
    """A PyBullet 16-float matrix (column-major) as a numpy 4x4."""
    return np.asarray(values, dtype=float).reshape(4, 4).T


def _names_in(result: Any) -> list[str]:
    items = result if isinstance(result, list | tuple) else [result]
    names = []
    for item in items:
        name = item.get("name") if hasattr(item, "get") else getattr(item, "name", None)
        if isinstance(name, str):
            names.append(name)
    return names


class CameraRecorder(cpl.Instrument):
    """Keeps the head camera's image at the last real detection (see the module
    docstring). ``detections`` counts the detections seen."""

    def __init__(self, world: Any) -> None:
        self.world = world
        self.detections = 0
        self.state: Any = None  # world snapshot at the last detection
        self.names: list[str] = []  # the objects detected then
        self.when: float | None = None

    def task_status_changed(self, task: cpl.Task, old: cpl.Status, new: cpl.Status) -> None:
        if new is not cpl.Status.SUCCEEDED or imagined(task):
            return
        from executive import action_of

        action = action_of(task)
        if action is None or action.type != "detecting":
            return
        names = [n for n in _names_in(task.result) if n in self.world.objects]
        if not names:
            return
        self.detections += 1
        # a cheap copy of the true world now; the picture is rendered from it at the end
        self.state = self.world.snapshot()
        self.names = names
        self.when = task.end_time

    def _shoot(
        self, names: list[str]
    ) -> tuple[np.ndarray, list[tuple[str, tuple[float, float, float, float]]]]:
        from projection import render

        width, height = _VIEW_SIZE
        pixels, view, proj = render.camera_image(self.world, "robot", width, height)
        m = _matrix(proj) @ _matrix(view)
        boxes = []
        for name in names:
            lo, hi = self.world.object_aabb(name)
            corners = np.array(
                [
                    [x, y, z, 1.0]
                    for x in (lo[0], hi[0])
                    for y in (lo[1], hi[1])
                    for z in (lo[2], hi[2])
                ]
            )
            clip = corners @ m.T
            if np.any(clip[:, 3] <= 1e-6):
                continue  # partly behind the camera
            ndc = clip[:, :3] / clip[:, 3:4]
            xs = (ndc[:, 0] + 1.0) / 2.0 * width
            ys = (1.0 - ndc[:, 1]) / 2.0 * height
            box = (
                float(np.clip(xs.min(), 0, width - 1)),
                float(np.clip(ys.min(), 0, height - 1)),
                float(np.clip(xs.max(), 0, width - 1)),
                float(np.clip(ys.max(), 0, height - 1)),
            )
            if box[2] - box[0] >= 1 and box[3] - box[1] >= 1:
                boxes.append((name, box))
        return pixels, boxes

    def write(self, path: Path) -> Path:
        """The PNG: the last detection's image with each detected object outlined and
        named and a caption; without any detection, the camera's view now, captioned so."""
        from PIL import Image, ImageDraw

        if self.state is None:
            image, boxes = self._shoot([])
            caption = "head camera at the end of the run (the robot detected nothing)"
        else:
            now = self.world.snapshot()
            try:
                self.world.restore(self.state)
                image, boxes = self._shoot(self.names)
            finally:
                self.world.restore(now)
            seen = ", ".join(name for name, _ in boxes) or "an object outside the frame"
            t = f" at t={self.when:.1f} s" if self.when is not None else ""
            caption = f"head camera at the last detection{t}: {seen}"
        img = Image.fromarray(image, "RGB")
        draw = ImageDraw.Draw(img)
        for name, (x0, y0, x1, y1) in boxes:
            for k in range(3):
                draw.rectangle((x0 - k, y0 - k, x1 + k, y1 + k), outline=(255, 40, 40))
            tw = 7 * len(name) + 8
            ty = y0 - 18 if y0 >= 18 else y1 + 4
            draw.rectangle((x0 - 2, ty, x0 - 2 + tw, ty + 16), fill=(255, 40, 40))
            draw.text((x0 + 2, ty + 2), name, fill=(255, 255, 255))
        draw.rectangle((0, img.height - 20, img.width, img.height), fill=(0, 0, 0))
        draw.text((6, img.height - 16), caption, fill=(255, 255, 255))
        img.save(path, format="PNG")
        return path


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


def _xyyaw(pose: Any) -> tuple[float, float, float]:
    return float(pose.position[0]), float(pose.position[1]), float(pose.yaw)


class CostmapRecorder(cpl.Instrument):
    """Notes each real navigation to a costmap location (see the module docstring)."""

    def __init__(self, world: Any) -> None:
        self.world = world
        self.uses: list[_Use] = []
        self._by_chain: dict[int, _Use] = {}
        self._pending: dict[int, tuple[_Use, Any]] = {}
        #: every candidate pose the location pipeline generated, by chain (see
        #: :meth:`recording`); those that did not become solutions were rejected
        self.candidates: dict[int, list[tuple[float, float, float]]] = {}
        self.by_text: dict[str, list[tuple[float, float, float]]] = {}

    def recording(self, rules: Any) -> Any:
        """A child of ``rules`` whose first location validator notes every candidate pose
        (and decides nothing): pass it as the run's rules to draw rejected samples."""
        child = rules.child("demo-costmap-recording")

        def note(d: Any, pose: Any) -> str:
            # by chain, and by the chain's text: plans resolve copies of the designator
            # they navigate by (e.g. a collision-checked one), whose chain is another
            first = d.first() if hasattr(d, "first") else d
            if getattr(pose, "frame", "map") == "map":
                xyyaw = _xyyaw(pose)
                self.candidates.setdefault(id(first), []).append(xyyaw)
                self.by_text.setdefault(repr(first), []).append(xyyaw)
            return "unknown"

        child.register_location_validator(note, -1000)
        return child

    @staticmethod
    def _location(task: cpl.Task) -> Any:
        from executive import action_of

        action = action_of(task)
        if action is None or action.type != "navigating" or imagined(task):
            return None
        loc = action.get("location")
        if loc is None or not hasattr(loc, "first") or loc.get("pose") is not None:
            return None
        return loc

    def task_status_changed(self, task: cpl.Task, old: cpl.Status, new: cpl.Status) -> None:
        if new is cpl.Status.RUNNING and old is cpl.Status.CREATED:
            loc = self._location(task)
            if loc is None:
                return
            first = loc.first()
            use = self._by_chain.get(id(first))
            if use is None:
                use = self._new_use(task, first)
                self._by_chain[id(first)] = use
                self.uses.append(use)
            self._pending[id(task)] = (use, loc)
        elif new.dead and id(task) in self._pending:
            use, loc = self._pending.pop(id(task))
            member = loc.newest_effective() if hasattr(loc, "newest_effective") else None
            if member is not None:
                use.tries.append((_xyyaw(member.reference()), new is cpl.Status.SUCCEEDED))

    def _new_use(self, task: cpl.Task, first: Any) -> _Use:
        purpose, obj = "location", "?"
        for key, short in (("visible-for", "visible"), ("reachable-for", "reachable")):
            if first.get(key) is not None:
                purpose = short
        inner = first.get("location")
        target = inner.get("object") if inner is not None and hasattr(inner, "get") else None
        for candidate in (first.get("object"), target, first.get("for")):
            if candidate is not None and hasattr(candidate, "get"):
                obj = str(candidate.get("name") or candidate.get("type") or "?")
                break
        if obj == "?":
            obj = _object_of_step(task)
        step = next(
            (
                p.split("#")[0]
                for p in reversed(task.path)
                if p.split("#")[0] in ("search-for-object", "fetch", "deliver", "transport")
            ),
            "navigate",
        )
        boxes = {}
        for name in self.world.objects:
            lo, hi = self.world.object_aabb(name)
            boxes[name] = (tuple(lo), tuple(hi))
        return _Use(first, obj, purpose, step, _xyyaw(self.world.robot_pose()), boxes)

    def figures(
        self, engine: Any, out_dir: Path, limit: int = 6, part: tuple[int, int] = (0, 1)
    ) -> list[Path]:
        """Draw up to ``limit`` figures, named ``costmap-K-STEP-OBJECT.png`` (``STEP``:
        search, fetch or deliver): the chains where a navigation failed first, then one
        per object and step. A figure that cannot be drawn is reported on
        stderr and skipped (a picture never fails the demo). ``part=(i, n)``: only the
        figures with ``(K - 1) % n == i`` (for drawing them in n processes at once)."""
        import sys

        # first, the chains where a navigation failed (the robot had to try another
        # pose: the pictures that show why), then one per (object, step), in run order
        chosen: list[_Use] = [u for u in self.uses if any(not ok for _, ok in u.tries)][:limit]
        seen = {(u.object, u.step) for u in chosen}
        for use in self.uses:
            if len(chosen) >= limit:
                break
            if (use.object, use.step) not in seen:
                seen.add((use.object, use.step))
                chosen.append(use)
        chosen.sort(key=self.uses.index)
        paths = []
        for k, use in enumerate(chosen, start=1):
            if (k - 1) % part[1] != part[0]:
                continue
            name = f"costmap-{k}-{_STEPS.get(use.step, use.step)}-{_slug(use.object)}.png"
            try:
                tried = self.candidates.get(id(use.location)) or self.by_text.get(
                    repr(use.location), []
                )
                paths.append(
                    costmap_figure(engine, use, out_dir / name, number=k, candidates=tried)
                )
            except Exception as exc:  # reported, and the demo goes on
                print(f"(costmap {name} not drawn: {type(exc).__name__}: {exc})", file=sys.stderr)
        return paths


def _object_of_step(task: Any) -> str:
    from executive import action_of

    t = task
    while t is not None:
        action = action_of(t)
        if action is not None and action.get("object") is not None:
            obj = action.get("object")
            return str(obj.get("name") or obj.get("type") or "?")
        t = t.parent
    return "?"


def _slug(text: str) -> str:
    return "".join(c if c.isalnum() or c == "-" else "-" for c in text).strip("-") or "object"


_STEPS = {"search-for-object": "search", "transport": "transport"}

_PURPOSE = {
    "visible": "where to stand to see",
    "reachable": "where to stand to reach",
    "location": "where to stand for",
}


def kitchen_boxes(world: Any) -> list[tuple[Sequence[float], Sequence[float]]]:
    """The kitchen furniture's axis-aligned boxes ``(lo, hi)`` in ``world``."""
    from projection import _costmaps as cmod

    return [world.link_aabb(link) for link in cmod.KITCHEN_LINKS]


def draw_furniture(
    ax: Any, boxes: Iterable[tuple[Sequence[float], Sequence[float]]], lw: float = 1.0
) -> None:
    """The furniture's footprints on a floor-plan axes (grey, under everything else)."""
    from matplotlib.patches import Rectangle

    for lo, hi in boxes:
        ax.add_patch(
            Rectangle(
                (lo[0], lo[1]),
                hi[0] - lo[0],
                hi[1] - lo[1],
                facecolor=(0.85, 0.85, 0.85),
                edgecolor="0.35",
                lw=lw,
                zorder=0,
            )
        )


def costmap_figure(
    engine: Any,
    use: _Use,
    path: Path,
    *,
    number: int = 1,
    candidates: list[tuple[float, float, float]] = (),  # type: ignore[assignment]
) -> Path:
    """One costmap figure (see the module docstring) written to ``path``; ``candidates``:
    every pose the location pipeline generated for the chain (those that are not among
    its solutions were rejected by a validator)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D
    from matplotlib.patches import Polygon, Rectangle

    cmap = engine.costmap(use.location)
    spec = cmap.spec
    values = np.asarray(cmap.values(), dtype=float)
    top = float(cmap.max or 1.0)
    world = engine.world
    boxes = kitchen_boxes(world)
    x0 = min(lo[0] for lo, _ in boxes) - 0.3
    x1 = max(hi[0] for _, hi in boxes) + 0.3
    y0 = min(lo[1] for lo, _ in boxes) - 0.3
    y1 = max(hi[1] for _, hi in boxes) + 0.3

    fig, ax = plt.subplots(figsize=(8.0, 7.6), dpi=100)
    extent = (
        spec.origin[0],
        spec.origin[0] + spec.width * spec.resolution,
        spec.origin[1],
        spec.origin[1] + spec.height * spec.resolution,
    )
    shown = np.ma.masked_less_equal(values / top, 0.0)
    image = ax.imshow(
        shown, origin="lower", extent=extent, cmap="viridis", vmin=0.0, vmax=1.0, zorder=1
    )
    bar = fig.colorbar(image, ax=ax, fraction=0.046, pad=0.04)
    bar.set_label("costmap value (1 = best; blank = excluded)")
    draw_furniture(ax, boxes, lw=1.2)
    for name, (lo, hi) in use.objects.items():
        ax.add_patch(
            Rectangle(
                (lo[0], lo[1]),
                hi[0] - lo[0],
                hi[1] - lo[1],
                facecolor="tab:blue",
                edgecolor="navy",
                lw=1.0,
                zorder=3,
            )
        )
        ax.annotate(
            name,
            ((lo[0] + hi[0]) / 2, hi[1]),
            xytext=(0, 3),
            textcoords="offset points",
            ha="center",
            fontsize=8,
            color="navy",
            zorder=6,
        )
    rx, ry, ryaw = use.robot
    half = 0.33  # the PR2 base footprint is about 0.66 m square
    c, s = math.cos(ryaw), math.sin(ryaw)
    corners = [
        (rx + c * dx - s * dy, ry + s * dx + c * dy)
        for dx, dy in ((half, half), (-half, half), (-half, -half), (half, -half))
    ]
    ax.add_patch(
        Polygon(
            corners, closed=True, facecolor="none", edgecolor="black", lw=1.5, ls="--", zorder=4
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
        (rx, ry - half),
        xytext=(0, -12),
        textcoords="offset points",
        ha="center",
        fontsize=8,
        zorder=6,
    )
    inner = use.location.get("location")
    target = inner.get("pose") if inner is not None and hasattr(inner, "get") else None
    if target is not None and getattr(target, "frame", "map") == "map":
        tx, ty = float(target.position[0]), float(target.position[1])
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
    if failed:
        ax.scatter(
            [p[0] for p in failed],
            [p[1] for p in failed],
            marker="x",
            s=60,
            color="red",
            lw=2,
            zorder=6,
        )
    if good:
        gx, gy, gyaw = good[-1]
        ax.scatter([gx], [gy], marker="*", s=260, color="orange", edgecolor="black", zorder=7)
        ax.annotate(
            "",
            (gx + 0.3 * math.cos(gyaw), gy + 0.3 * math.sin(gyaw)),
            (gx, gy),
            arrowprops={"arrowstyle": "->", "color": "darkorange", "lw": 2},
            zorder=7,
        )
    legend = [
        Rectangle(
            (0, 0), 1, 1, facecolor=(0.85, 0.85, 0.85), edgecolor="0.35", label="kitchen furniture"
        ),
        Rectangle((0, 0), 1, 1, facecolor="tab:blue", label="objects (as believed then)"),
        Line2D([], [], color="black", ls="--", label="robot base before navigating"),
        Line2D(
            [],
            [],
            marker="D",
            ls="",
            color="magenta",
            markeredgecolor="black",
            label=f"target: where {use.object} is (to see/reach)",
        ),
        Line2D(
            [],
            [],
            marker="*",
            ls="",
            color="orange",
            markeredgecolor="black",
            markersize=14,
            label="pose chosen (navigation succeeded)",
        ),
        Line2D(
            [],
            [],
            marker="x",
            ls="",
            color="red",
            markersize=9,
            mew=2,
            label="pose tried, navigation failed",
        ),
        Line2D(
            [],
            [],
            marker="o",
            ls="",
            markerfacecolor="white",
            markeredgecolor="0.2",
            label="pose accepted, not driven to",
        ),
        Line2D(
            [],
            [],
            marker="x",
            ls="",
            color="0.45",
            mew=0.8,
            label="sample rejected (collision, reach, view...)",
        ),
    ]
    ax.legend(handles=legend, loc="upper left", fontsize=7.5, framealpha=0.9)
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m, map frame)")
    ax.set_ylabel("y (m, map frame)")
    ax.grid(True, lw=0.3, alpha=0.5)
    title = f"costmap {number}: {_PURPOSE[use.purpose]} {use.object} ({use.step})"
    subtitle = textwrap.fill(use.location.short(), 95)
    ax.set_title(f"{title}\n{subtitle}", fontsize=9)
    fig.tight_layout()
    # the layout is done: without an engine, savefig draws once instead of twice (the same
    # pixels); compress_level 1 encodes the PNG several times faster (pixels unchanged,
    # the file ~20 % larger)
    fig.set_layout_engine("none")
    fig.savefig(path, format="png", pil_kwargs={"compress_level": 1})
    plt.close(fig)
    return path
