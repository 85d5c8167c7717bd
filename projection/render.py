"""Pictures of the projection world, written as PNG files with Pillow.

:func:`scene` renders the world with PyBullet's TinyRenderer (CPU, works headless).
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from PIL import Image

if TYPE_CHECKING:
    from projection._world import World

__all__ = [
    "OVERVIEW_CAMERA",
    "camera_image",
    "camera_showing",
    "draw_furniture",
    "draw_objects",
    "kitchen_boxes",
    "scene",
    "visible_pixels",
]

#: The default camera ``(eye, target)`` in ``map``: the kitchen from above-behind the robot's
#: start pose, looking at the counter.
OVERVIEW_CAMERA: tuple[tuple[float, float, float], tuple[float, float, float]] = (
    (-1.6, -1.3, 3.0),
    (0.9, 0.3, 0.6),
)
_ROBOT_FOV = 50.0  # CRAM's camera: 50° vertical field of view (the PR2-like robot's)
_OVERVIEW_FOV = 60.0
_NEAR, _FAR = 0.1, 20.0

Camera = str | tuple[Sequence[float], Sequence[float]] | None


def _vec3(value: Any, what: str) -> tuple[float, float, float]:
    try:
        out = tuple(float(v) for v in value)
    except (TypeError, ValueError):
        raise TypeError(f"{what} must be 3 numbers, got {value!r}") from None
    if len(out) != 3 or not all(math.isfinite(v) for v in out):
        raise ValueError(f"{what} must be 3 finite numbers, got {value!r}")
    return out[0], out[1], out[2]


def _view(
    world: World, camera: Camera
) -> tuple[tuple[float, ...], tuple[float, ...], tuple[float, ...], float]:
    """Eye, target, up and default vertical fov (degrees) of a camera spec."""
    if camera is None or camera == "overview":
        eye, target = OVERVIEW_CAMERA
        return eye, target, (0.0, 0.0, 1.0), _OVERVIEW_FOV
    if camera == "robot":
        # the robot's camera (its description's optical frame and vertical field of view)
        pose = world.link_pose(world.robot.neck.camera.frame)
        rot = pose.as_rotation().as_matrix()
        position = np.asarray(pose.position)
        forward, down = rot[:, 2], rot[:, 1]  # optical frame: z forward, y down
        fov = round(math.degrees(world.robot.neck.camera.vertical_fov), 9)
        return tuple(position), tuple(position + forward), tuple(-down), fov
    if isinstance(camera, str):
        raise ValueError(f"unknown camera {camera!r}; use 'overview', 'robot' or (eye, target)")
    if not isinstance(camera, (tuple, list)) or len(camera) != 2:
        raise TypeError(f"camera must be 'overview', 'robot' or (eye, target), got {camera!r}")
    eye, target = _vec3(camera[0], "camera eye"), _vec3(camera[1], "camera target")
    if math.dist(eye, target) < 1e-6:
        raise ValueError("camera eye and target coincide")
    up = (0.0, 0.0, 1.0)
    horizontal = math.hypot(target[0] - eye[0], target[1] - eye[1])
    if horizontal < 1e-6:  # looking straight down or up: image top towards +x
        up = (1.0, 0.0, 0.0)
    return eye, target, up, _OVERVIEW_FOV


def _check_size(width: Any, height: Any) -> None:
    for what, value in (("width", width), ("height", height)):
        if isinstance(value, bool) or not isinstance(value, int):
            raise TypeError(f"{what} must be an int, got {value!r}")
        if not 1 <= value <= 4096:
            raise ValueError(f"{what} must be in 1..4096, got {value}")


def scene(
    world: World,
    path: str | os.PathLike[str],
    *,
    camera: Camera = None,
    width: int = 640,
    height: int = 480,
    fov: float | None = None,
) -> Path:
    """Render ``world`` to a PNG at ``path`` (parent directories are created) and return
    the path. ``camera``: ``None``/``"overview"`` (:data:`OVERVIEW_CAMERA`), ``"robot"``
    (what the head camera sees, 50° vertical fov) or ``(eye, target)`` in ``map``;
    ``fov``: vertical field of view in degrees (default 60, or 50 for the robot). The
    world is not changed. Bad sizes or cameras raise TypeError/ValueError; a closed world
    RuntimeError."""
    _check_size(width, height)
    fov_y = _view(world, camera)[3] if fov is None else float(fov)
    if not 1.0 <= fov_y <= 170.0:
        raise ValueError(f"fov must be in 1..170 degrees, got {fov}")
    pixels, _view_matrix, _proj_matrix = camera_image(world, camera, width, height, fov_y)
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(pixels, "RGB").save(out, format="PNG")
    return out


def visible_pixels(
    world: World,
    camera: Camera,
    names: Sequence[str],
    *,
    width: int = 160,
    height: int = 120,
    fov: float | None = None,
) -> dict[str, int]:
    """How many pixels of each object in ``names`` the ``camera`` (as :func:`scene`) sees:
    PyBullet's segmentation mask, so an object hidden behind another counts 0. Unknown
    names raise LookupError, bad sizes TypeError/ValueError. The world is not changed."""
    _check_size(width, height)
    bodies = {world.body_of(name): name for name in names}
    seg = _render(world, camera, width, height, fov, segmentation=True)[1]
    ids, counts = np.unique(np.asarray(seg, dtype=np.int64).reshape(-1), return_counts=True)
    seen = dict(zip(ids.tolist(), counts.tolist(), strict=True))
    return {name: int(seen.get(body, 0)) for body, name in bodies.items()}


#: The elevation (degrees above the horizon) and the directions (degrees, map frame) from
#: which :func:`camera_showing` looks at the objects.
SHOWING_ELEVATION = 55.0
SHOWING_AZIMUTHS = tuple(range(0, 360, 30))


def camera_showing(
    world: World,
    names: Sequence[str] | None = None,
    *,
    width: int = 640,
    height: int = 480,
    fov: float | None = None,
) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    """A camera ``(eye, target)`` for :func:`scene` that shows every object in ``names``
    (default: all of the world's objects): it looks down at :data:`SHOWING_ELEVATION`
    degrees at the centre of their bounding box, from far enough that the box fits the
    view, and from the direction (one of :data:`SHOWING_AZIMUTHS`) whose picture shows the
    least visible object best (:func:`visible_pixels` at a quarter of the size; walls,
    furniture, the robot and the objects themselves occlude), ties to the earlier
    direction. Without objects: :data:`OVERVIEW_CAMERA`. The world is not changed."""
    _check_size(width, height)
    chosen = list(world.objects) if names is None else list(names)
    if not chosen:
        return OVERVIEW_CAMERA
    boxes = [world.object_aabb(name) for name in chosen]
    lo = np.min([b[0] for b in boxes], axis=0)
    hi = np.max([b[1] for b in boxes], axis=0)
    centre = (lo + hi) / 2.0
    radius = max(float(np.linalg.norm(hi - lo)) / 2.0, 0.3) + 0.15
    fov_y = _OVERVIEW_FOV if fov is None else float(fov)
    half = math.radians(min(fov_y, fov_y * width / height)) / 2.0
    distance = max(radius / math.tan(half), 1.2)
    elevation = math.radians(SHOWING_ELEVATION)
    best: tuple[int, int] | None = None
    camera = OVERVIEW_CAMERA
    target = (float(centre[0]), float(centre[1]), float(centre[2]))
    for azimuth in SHOWING_AZIMUTHS:
        a = math.radians(azimuth)
        eye = (
            target[0] + distance * math.cos(elevation) * math.cos(a),
            target[1] + distance * math.cos(elevation) * math.sin(a),
            target[2] + distance * math.sin(elevation),
        )
        seen = visible_pixels(
            world,
            (eye, target),
            chosen,
            width=max(width // 4, 1),
            height=max(height // 4, 1),
            fov=fov_y,
        )
        score = (min(seen.values()), sum(seen.values()))
        if best is None or score > best:
            best, camera = score, (eye, target)
    return camera


# ----------------------------------------------------------------------------- costmap
# (owned by the costmap module's author: only this region)
__all__ += ["costmap"]


def costmap(
    designator: Any,
    path: str | os.PathLike[str],
    *,
    world: World | None = None,
    samples: int = 0,
    scale: int = 5,
) -> Path:
    """Write a PNG of a location designator's costmap over the kitchen's floor plan, in
    metres (x and y axes in the ``map`` frame): link footprints (AABBs) in grey, objects
    in blue and named, the normalised costmap as a heat map with a colour bar (blank:
    excluded cells), the chain's solutions so far as black dots with a heading arrow, and
    ``samples`` fresh samples (a private generator seeded 0: the chain and ``world.rng``
    are not touched) as green dots; a legend names each. The view covers the kitchen;
    ``scale`` is about how many pixels one costmap cell takes.

    The costmap comes from the location rules of the current environment
    (:func:`projection._locations.location_rules`), so a designator resolved there is drawn
    with its cached map; with ``world=`` (and no such rules for it) a fresh map is built.
    Raises TypeError without either, and :class:`executive.DesignatorError` when the
    designator has no costmap. An empty costmap is drawn with the reason in the title.
    Returns the path written.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D
    from matplotlib.patches import Rectangle

    from executive import current_environment
    from projection._locations import LocationCostmaps, costmaps_of

    if isinstance(scale, bool) or not isinstance(scale, int) or not 1 <= scale <= 20:
        raise ValueError(f"scale must be an int in 1..20 (pixels per cell), got {scale!r}")
    engine = costmaps_of(current_environment().rules)
    if world is not None and (engine is None or engine.world is not world):
        engine = LocationCostmaps(world)
    if engine is None:
        raise TypeError(
            "costmap() needs world=... or an environment with projection location_rules"
        )
    if not LocationCostmaps.applies(designator):
        from executive import DesignatorError

        raise DesignatorError(f"{designator.short()} has no costmap key", designator)
    w = engine.world
    cmap = engine.costmap(designator.first())
    spec = cmap.spec
    boxes = kitchen_boxes(w)
    x0 = min(lo[0] for lo, _ in boxes) - 0.2
    x1 = max(hi[0] for _, hi in boxes) + 0.2
    y0 = min(lo[1] for lo, _ in boxes) - 0.2
    y1 = max(hi[1] for _, hi in boxes) + 0.2
    dpi = 100
    plot_w = (x1 - x0) / spec.resolution * scale / dpi  # inches
    plot_h = (y1 - y0) / spec.resolution * scale / dpi
    fig, ax = plt.subplots(figsize=(plot_w + 2.6, plot_h + 2.4), dpi=dpi)
    try:
        extent = (
            spec.origin[0],
            spec.origin[0] + spec.width * spec.resolution,
            spec.origin[1],
            spec.origin[1] + spec.height * spec.resolution,
        )
        title = f"costmap of {designator.short()}"
        if cmap.empty:
            title += f"\nempty: {cmap.empty_reason}"
        else:
            values = np.asarray(cmap.values(), dtype=float) / float(cmap.max)
            image = ax.imshow(
                np.ma.masked_less_equal(values, 0.0),
                origin="lower",
                extent=extent,
                cmap="viridis",
                vmin=0.0,
                vmax=1.0,
                interpolation="nearest",
                zorder=1,
            )
            bar = fig.colorbar(image, ax=ax, fraction=0.046, pad=0.04)
            bar.set_label("costmap value / max (blank = excluded)")
        draw_furniture(ax, boxes, filled=False)
        draw_objects(ax, {name: w.object_aabb(name) for name in w.objects})

        def dots(poses: list[Any], colour: str, size: float) -> None:
            xs = [float(p.position[0]) for p in poses]
            ys = [float(p.position[1]) for p in poses]
            ax.scatter(xs, ys, s=size, color=colour, edgecolor="black", lw=0.4, zorder=5)
            for p in poses:
                if abs(p.yaw) > 1e-9:
                    ax.annotate(
                        "",
                        (
                            p.position[0] + 0.15 * math.cos(p.yaw),
                            p.position[1] + 0.15 * math.sin(p.yaw),
                        ),
                        (p.position[0], p.position[1]),
                        arrowprops={"arrowstyle": "->", "color": colour, "lw": 1.0},
                        zorder=5,
                    )

        legend: list[Any] = [
            Rectangle((0, 0), 1, 1, facecolor="none", edgecolor="0.35", label="kitchen furniture"),
            Rectangle((0, 0), 1, 1, facecolor="tab:blue", edgecolor="navy", label="objects"),
        ]
        if samples > 0 and not cmap.empty:
            rng = np.random.default_rng(0)
            fresh = [pose for _ in range(samples) for pose in cmap.sample(rng)]
            dots(fresh, "tab:green", 18)
            legend.append(
                Line2D(
                    [], [], marker="o", ls="", color="tab:green", label=f"{samples} fresh samples"
                )
            )
        solved = [m.reference() for m in designator.chain() if m.effective]
        if solved:
            dots(solved, "black", 30)
            legend.append(
                Line2D([], [], marker="o", ls="", color="black", label="the chain's solutions")
            )
        ax.legend(handles=legend, loc="upper left", fontsize=8, framealpha=0.9)
        ax.set_xlim(x0, x1)
        ax.set_ylim(y0, y1)
        ax.set_aspect("equal")
        ax.set_xlabel("x (m, map frame)")
        ax.set_ylabel("y (m, map frame)")
        ax.grid(True, lw=0.3, alpha=0.5)
        ax.set_title(title, fontsize=9)
        fig.tight_layout()
        out = Path(path)
        fig.savefig(out, format="png")
    finally:
        plt.close(fig)
    return out


def camera_image(
    world: World, camera: Camera, width: int, height: int, fov: float | None = None
) -> tuple[np.ndarray, tuple[float, ...], tuple[float, ...]]:
    """Render ``world`` from ``camera`` (as :func:`scene`; sizes and fov unchecked): the RGB
    pixels (height x width x 3, a copy) and PyBullet's view and projection matrices, for
    callers that draw onto the picture. The world is not changed."""
    rgba, _seg, view, proj = _render(world, camera, width, height, fov, segmentation=False)
    pixels = np.asarray(rgba, dtype=np.uint8).reshape(height, width, 4)[:, :, :3].copy()
    return pixels, tuple(view), tuple(proj)


def _render(
    world: World, camera: Camera, width: int, height: int, fov: float | None, *, segmentation: bool
) -> tuple[Any, Any, Any, Any]:
    """PyBullet's camera image of ``world`` from ``camera`` (the tiny renderer, no shadow):
    ``(rgba, segmentation mask, view matrix, projection matrix)``; the mask only when
    ``segmentation`` (else PyBullet skips it), the lighting only when not (the mask does not
    need it)."""
    import pybullet as pb

    client = world.client
    eye, target, up, default_fov = _view(world, camera)
    fov_y = default_fov if fov is None else float(fov)
    view = pb.computeViewMatrix(eye, target, up, physicsClientId=client)
    proj = pb.computeProjectionMatrixFOV(fov_y, width / height, _NEAR, _FAR, physicsClientId=client)
    extra: dict[str, Any] = (
        {}
        if segmentation
        else {"lightDirection": (-1.0, -0.5, 2.0), "flags": pb.ER_NO_SEGMENTATION_MASK}
    )
    _, _, rgba, _, seg = pb.getCameraImage(
        width,
        height,
        view,
        proj,
        renderer=pb.ER_TINY_RENDERER,
        shadow=0,
        physicsClientId=client,
        **extra,
    )
    return rgba, seg, view, proj


def kitchen_boxes(world: World) -> list[tuple[Sequence[float], Sequence[float]]]:
    """The kitchen furniture's axis-aligned boxes ``(lo, hi)`` in ``world``."""
    from projection import _costmaps as cmod

    return [world.link_aabb(link) for link in cmod.KITCHEN_LINKS]


def draw_furniture(
    ax: Any,
    boxes: Iterable[tuple[Sequence[float], Sequence[float]]],
    lw: float = 1.0,
    *,
    filled: bool = True,
) -> None:
    """The furniture's footprints on a top-down matplotlib axis: grey, under everything
    else (``filled``); or outlined only, over a heat map that must stay visible."""
    from matplotlib.patches import Rectangle

    face: Any = (0.85, 0.85, 0.85) if filled else "none"
    for lo, hi in boxes:
        ax.add_patch(
            Rectangle(
                (lo[0], lo[1]),
                hi[0] - lo[0],
                hi[1] - lo[1],
                facecolor=face,
                edgecolor="0.35",
                lw=lw,
                zorder=0 if filled else 2,
            )
        )


def draw_objects(ax: Any, boxes: Any) -> None:
    """Draw objects on a top-down matplotlib axis: each ``name -> (lo, hi)`` AABB as a blue
    footprint labelled with its name above it (the costmap pictures' convention)."""
    from matplotlib.patches import Rectangle

    for name, (lo, hi) in boxes.items():
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
