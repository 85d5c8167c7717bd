"""Pictures of the projection world, written as PNG files with Pillow.

:func:`scene` renders the world with PyBullet's TinyRenderer (CPU, works headless).
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from PIL import Image

if TYPE_CHECKING:
    from projection._world import World

__all__ = ["OVERVIEW_CAMERA", "camera_image", "scene"]

#: The default camera ``(eye, target)`` in ``map``: the kitchen from above-behind the robot's
#: start pose, looking at the counter.
OVERVIEW_CAMERA: tuple[tuple[float, float, float], tuple[float, float, float]] = (
    (-1.6, -1.3, 3.0),
    (0.9, 0.3, 0.6),
)
_ROBOT_CAMERA_LINK = "head_mount_kinect_rgb_optical_frame"
_ROBOT_FOV = 50.0  # CRAM's camera: 50° vertical field of view
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
        pose = world.link_pose(_ROBOT_CAMERA_LINK)
        rot = pose.as_rotation().as_matrix()
        position = np.asarray(pose.position)
        forward, down = rot[:, 2], rot[:, 1]  # optical frame: z forward, y down
        return tuple(position), tuple(position + forward), tuple(-down), _ROBOT_FOV
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
    for what, value in (("width", width), ("height", height)):
        if isinstance(value, bool) or not isinstance(value, int):
            raise TypeError(f"{what} must be an int, got {value!r}")
        if not 1 <= value <= 4096:
            raise ValueError(f"{what} must be in 1..4096, got {value}")
    fov_y = _view(world, camera)[3] if fov is None else float(fov)
    if not 1.0 <= fov_y <= 170.0:
        raise ValueError(f"fov must be in 1..170 degrees, got {fov}")
    pixels, _view_matrix, _proj_matrix = camera_image(world, camera, width, height, fov_y)
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(pixels, "RGB").save(out, format="PNG")
    return out


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
    """Write a PNG of a location designator's costmap over the kitchen's floor plan: link
    footprints (AABBs) in grey, objects in blue, the normalised costmap as a heat map, the
    chain's solutions so far as black dots with a heading tick, and ``samples`` fresh
    samples (a private generator seeded 0: the chain and ``world.rng`` are not touched) as
    green dots. The view covers the kitchen; ``scale`` is pixels per costmap cell.

    The costmap comes from the location rules of the current environment
    (:func:`projection._locations.location_rules`), so a designator resolved there is drawn
    with its cached map; with ``world=`` (and no such rules for it) a fresh map is built.
    Raises TypeError without either, and :class:`executive.DesignatorError` when the
    designator has no costmap. Returns the path written.
    """
    from PIL import ImageDraw

    from executive import current_environment
    from projection import _costmaps as cmod
    from projection._locations import LocationCostmaps, costmaps_of

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
    values = cmap.values()
    top = cmap.max or 1.0
    boxes = [w.link_aabb(link) for link in cmod.KITCHEN_LINKS]
    x0 = min(lo[0] for lo, _ in boxes) - 0.2
    x1 = max(hi[0] for _, hi in boxes) + 0.2
    y0 = min(lo[1] for lo, _ in boxes) - 0.2
    y1 = max(hi[1] for _, hi in boxes) + 0.2
    c0 = max(0, int((x0 - spec.origin[0]) / spec.resolution))
    c1 = min(spec.width, math.ceil((x1 - spec.origin[0]) / spec.resolution))
    r0 = max(0, int((y0 - spec.origin[1]) / spec.resolution))
    r1 = min(spec.height, math.ceil((y1 - spec.origin[1]) / spec.resolution))
    v = values[r0:r1, c0:c1] / top
    # heat: white -> yellow -> red where the map is positive; y up in the picture
    rgb = np.full((*v.shape, 3), 255.0)
    pos = v > 0
    rgb[..., 1] = np.where(pos, 255.0 * (1.0 - 0.8 * v), 255.0)
    rgb[..., 2] = np.where(pos, 120.0 * (1.0 - v), 255.0)
    img = Image.fromarray(np.flipud(rgb).astype(np.uint8), "RGB")
    img = img.resize((img.width * scale, img.height * scale), Image.Resampling.NEAREST)
    draw = ImageDraw.Draw(img)
    px_per_m = scale / spec.resolution
    bx0 = spec.origin[0] + c0 * spec.resolution
    by1 = spec.origin[1] + r1 * spec.resolution

    def to_px(x: float, y: float) -> tuple[float, float]:
        return (x - bx0) * px_per_m, (by1 - y) * px_per_m

    for lo, hi in boxes:
        (ax, ay), (bx, by) = to_px(lo[0], hi[1]), to_px(hi[0], lo[1])
        draw.rectangle((ax, ay, bx, by), outline=(90, 90, 90), width=2)
    for name in w.objects:
        lo, hi = w.object_aabb(name)
        (ax, ay), (bx, by) = to_px(lo[0], hi[1]), to_px(hi[0], lo[1])
        draw.rectangle((ax, ay, bx, by), outline=(30, 60, 200), width=2)

    def dot(pose: Any, colour: tuple[int, int, int]) -> None:
        x, y = pose.position[0], pose.position[1]
        cx, cy = to_px(x, y)
        draw.ellipse((cx - 4, cy - 4, cx + 4, cy + 4), fill=colour)
        yaw = pose.yaw
        if abs(yaw) > 1e-9:
            ex, ey = to_px(x + 0.15 * math.cos(yaw), y + 0.15 * math.sin(yaw))
            draw.line((cx, cy, ex, ey), fill=colour, width=2)

    if samples > 0 and not cmap.empty:
        rng = np.random.default_rng(0)
        for _ in range(samples):
            for pose in cmap.sample(rng):
                dot(pose, (20, 150, 40))
    for member in designator.chain():
        if member.effective:
            dot(member.reference(), (0, 0, 0))
    out = Path(path)
    img.save(out, format="PNG")
    return out


def camera_image(
    world: World, camera: Camera, width: int, height: int, fov: float | None = None
) -> tuple[np.ndarray, tuple[float, ...], tuple[float, ...]]:
    """Render ``world`` from ``camera`` (as :func:`scene`; sizes and fov unchecked): the RGB
    pixels (height x width x 3, a copy) and PyBullet's view and projection matrices, for
    callers that draw onto the picture. The world is not changed."""
    import pybullet as pb

    client = world.client
    eye, target, up, default_fov = _view(world, camera)
    fov_y = default_fov if fov is None else float(fov)
    view = pb.computeViewMatrix(eye, target, up, physicsClientId=client)
    proj = pb.computeProjectionMatrixFOV(fov_y, width / height, _NEAR, _FAR, physicsClientId=client)
    _, _, rgba, _, _ = pb.getCameraImage(
        width,
        height,
        view,
        proj,
        renderer=pb.ER_TINY_RENDERER,
        shadow=0,
        lightDirection=(-1.0, -0.5, 2.0),
        flags=pb.ER_NO_SEGMENTATION_MASK,
        physicsClientId=client,
    )
    pixels = np.asarray(rgba, dtype=np.uint8).reshape(height, width, 4)[:, :, :3].copy()
    return pixels, tuple(view), tuple(proj)
