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
