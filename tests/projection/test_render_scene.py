"""render.scene: PNG pictures of the projection world (TinyRenderer, headless)."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from executive import Pose
from projection import World, render


@pytest.fixture()
def world() -> Iterator[World]:
    with World(seed=0) as w:
        w.drive(Pose.from_xyz_yaw(0.5, 0.0, 0.0, 0.0))
        w.spawn_object("cup-1", "cup", Pose((1.5, 0.0, 1.3)))
        yield w


def pixels(path: Path) -> np.ndarray:
    with Image.open(path) as img:
        assert img.format == "PNG"
        return np.asarray(img.convert("RGB"))


def test_overview_is_a_png_of_the_requested_size(world: World, tmp_path: Path) -> None:
    before = world.snapshot()
    out = render.scene(world, tmp_path / "sub" / "scene.png")
    assert out == tmp_path / "sub" / "scene.png"
    img = pixels(out)
    assert img.shape == (480, 640, 3)
    assert len(np.unique(img.reshape(-1, 3), axis=0)) > 20  # not a single colour
    assert world.snapshot() == before


def test_robot_camera_sees_the_red_cup(world: World, tmp_path: Path) -> None:
    img = pixels(
        render.scene(world, tmp_path / "robot.png", camera="robot", width=160, height=100)
    ).astype(int)
    assert img.shape == (100, 160, 3)
    red = (img[:, :, 0] > 150) & (img[:, :, 1] < 80) & (img[:, :, 2] < 80)
    assert red.sum() > 20
    cols = np.nonzero(red.any(axis=0))[0]
    assert 60 < cols.mean() < 100  # straight ahead: the middle of the image


def test_explicit_camera_and_errors(world: World, tmp_path: Path) -> None:
    top = render.scene(
        world,
        str(tmp_path / "top.png"),
        camera=((0.5, 0.0, 5.0), (0.5, 0.0, 0.0)),
        width=64,
        height=48,
        fov=40,
    )
    assert pixels(top).shape == (48, 64, 3)
    with pytest.raises(ValueError, match="unknown camera"):
        render.scene(world, tmp_path / "x.png", camera="ceiling")
    with pytest.raises(TypeError, match="camera"):
        render.scene(world, tmp_path / "x.png", camera=42)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="coincide"):
        render.scene(world, tmp_path / "x.png", camera=((1, 1, 1), (1, 1, 1)))
    with pytest.raises(ValueError, match="width"):
        render.scene(world, tmp_path / "x.png", width=0)
    with pytest.raises(TypeError, match="height"):
        render.scene(world, tmp_path / "x.png", height=4.5)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="fov"):
        render.scene(world, tmp_path / "x.png", fov=0)
    assert not (tmp_path / "x.png").exists()
    world.close()
    with pytest.raises(RuntimeError, match="closed"):
        render.scene(world, tmp_path / "x.png")


def test_camera_showing_finds_an_object_the_overview_hides(tmp_path: Path) -> None:
    """A cup right behind the cereal box, as seen from the fixed overview camera: the
    overview shows none of it, the chosen camera shows both, and the world is unchanged."""
    with World(seed=0) as w:
        w.spawn_object("breakfast-cereal-1", "breakfast-cereal", Pose((-0.8, 0.9, 0.95)))
        w.spawn_object("cup-1", "cup", Pose((-0.74, 1.06, 0.9)))
        names = ["breakfast-cereal-1", "cup-1"]
        hidden = render.visible_pixels(w, None, names, width=640, height=480)
        assert hidden["cup-1"] == 0 and hidden["breakfast-cereal-1"] > 100  # the premise
        before = w.snapshot()
        camera = render.camera_showing(w)
        assert w.snapshot() == before
        seen = render.visible_pixels(w, camera, names, width=640, height=480)
        assert min(seen.values()) > 100, seen
        render.scene(w, tmp_path / "both.png", camera=camera)
        assert (tmp_path / "both.png").stat().st_size > 0
        with pytest.raises(LookupError):
            render.visible_pixels(w, camera, ["no-such-object"])


def test_camera_showing_without_objects_is_the_overview(world: World) -> None:
    assert render.camera_showing(world, []) == render.OVERVIEW_CAMERA


def test_visible_pixels_rejects_bad_sizes(world: World) -> None:
    with pytest.raises(ValueError, match=r"width must be in 1\.\.4096"):
        render.visible_pixels(world, None, ["cup-1"], width=0)
    with pytest.raises(TypeError, match="height must be an int"):
        render.camera_showing(world, height=2.5)  # type: ignore[arg-type]
