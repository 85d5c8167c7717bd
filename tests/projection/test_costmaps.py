"""The costmap engine: grid, factors, de-duplication, normalisation, sampling,
orientation generators and the key builders' geometry (no designators)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from projection import _costmaps as cm


def test_spec_grid_and_cells() -> None:
    spec = cm.CostmapSpec()
    X, Y = spec.grid()
    assert X.shape == (300, 300)
    assert X[0, 0] == -6.0 and Y[0, 0] == -6.0
    assert X[0, 1] == pytest.approx(-5.96) and Y[1, 0] == pytest.approx(-5.96)
    assert spec.cell(0.0, 0.0) == (150, 150)
    assert spec.cell(7.0, 0.0) is None
    with pytest.raises(ValueError):
        cm.CostmapSpec(width=0)


def test_factors_multiply_dedupe_and_sample_corners() -> None:
    c = cm.Costmap(cm.CostmapSpec(width=50, height=50, resolution=0.1, origin=(0.0, 0.0)))
    assert c.add("box", lambda x, y: ((x > 1) & (x < 2)).astype(float))
    assert not c.add("box", lambda x, y: np.zeros_like(x))  # same name: dropped
    assert c.unique_name("box") == "box-2"
    c.add("half", lambda x, y: (y > 2.5).astype(float))
    vals = c.values()
    assert vals.sum() > 0 and not c.empty
    rng = np.random.default_rng(1)
    for _ in range(200):
        x, y = c.sample_xy(rng)
        assert 1 < x < 2 and y > 2.5
        assert round(x / 0.1, 6) == round(x / 0.1)  # a cell corner
    with pytest.raises(RuntimeError):
        c.add("late", lambda x, y: x)


def test_empty_map_names_the_factor() -> None:
    c = cm.Costmap()
    c.add("left", lambda x, y: (x < 0).astype(float), 5)
    c.add("right", lambda x, y: (x > 1).astype(float), 4)
    assert c.empty
    assert "'right'" in str(c.empty_reason) and "left" in str(c.empty_reason)
    assert list(c.poses(np.random.default_rng(0))) == []
    with pytest.raises(ValueError, match="empty"):
        c.sample_xy(np.random.default_rng(0))


def test_normalisation_follows_the_weights() -> None:
    c = cm.Costmap(cm.CostmapSpec(width=2, height=1, resolution=1.0, origin=(0.0, 0.0)))
    c.add("w", lambda x, y: np.where(x < 0.5, 1.0, 3.0))
    rng = np.random.default_rng(0)
    xs = [c.sample_xy(rng)[0] for _ in range(4000)]
    assert np.mean(np.asarray(xs) == 1.0) == pytest.approx(0.75, abs=0.03)
    assert c.value(1.0, 0.0) == 1.0 and c.value(0.0, 0.0) == pytest.approx(1 / 3)


def test_same_seed_same_samples() -> None:
    def draw(seed: int) -> list[tuple[float, float]]:
        c = cm.Costmap()
        cm.add_reachable_for(c, [(1.4, 0.8, 0.87)])
        rng = np.random.default_rng(seed)
        return [c.sample_xy(rng) for _ in range(20)]

    assert draw(3) == draw(3)
    assert draw(3) != draw(4)


def test_facing_with_two_samples_gives_one_yaw() -> None:
    assert list(cm.facing(1.0, 1.0)(0.0, 0.0)) == pytest.approx([math.pi / 4])
    three = cm.facing(1.0, 0.0, samples=3, step=0.1)(0.0, 0.0)
    assert list(three) == pytest.approx([0.0, 0.1, -0.1])


def test_pose_covariance_minvar() -> None:
    mu, cov = cm.pose_covariance([(1.0, 2.0, 0.9)], 0.5)
    assert mu == (1.0, 2.0)
    assert np.allclose(cov, 0.5 * np.eye(2))


def test_reachable_for_factors_and_orientation() -> None:
    c = cm.Costmap()
    cm.add_reachable_for(c, [(0.0, 0.0, 0.9)])
    rng = np.random.default_rng(0)
    for _ in range(100):
        (pose,) = c.sample(rng)
        x, y, z = pose.position
        assert 0.2 <= math.hypot(x, y) <= 0.7 and z == 0.0
        assert abs(math.remainder(pose.yaw - math.atan2(-y, -x), 2 * math.pi)) < 1e-9


def test_slot_centres_on_the_island() -> None:
    lo, hi = (-1.2, 0.2, 0.82), (-0.55, 2.4, 0.85)
    centres = cm.slot_centres(lo, hi, cm.SLOT_PADDINGS["kitchen_island_surface"], "bowl", 3)
    assert len(centres) == 3
    expected = [(-0.68, 1.215), (-0.68, 0.615), (-1.07, 0.915)]
    for (x, y), (ex, ey) in zip(centres, expected):
        assert x == pytest.approx(ex, abs=1e-9) and y == pytest.approx(ey, abs=1e-9)


def test_closest_edge_prefers_long_edges() -> None:
    lo, hi = (-1.2, 0.2, 0.82), (-0.55, 2.4, 0.85)  # the island, long along y
    assert cm.closest_edge(lo, hi, (-0.76, 1.19)) == "back"
    assert cm.closest_edge(lo, hi, (-1.1, 1.3)) == "front"
    assert cm.closest_edge(lo, hi, (-0.9, 2.38)) == "left"


def test_demo_area_and_free_space() -> None:
    c = cm.Costmap()
    cm.add_free_space(c, [((1.12, -0.65), (1.9, 1.25))])
    cm.add_demo_area(c)
    assert c.value(0.75, 0.7) > 0 and c.value(0.75, 1.2) > 0  # widened sink rectangle
    assert c.value(0.9, 0.5) == 0  # within the 0.3 padding of the counter
    assert c.value(-0.2, 1.5) > 0 and c.value(-0.2, 2.7) == 0
