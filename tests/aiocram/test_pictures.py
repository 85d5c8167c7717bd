"""Every picture teaches something (issue 27): the picture check itself, and every picture
the default demo (seed 1), examples/06 and the campaign write passes it; the costmap
figures show the costmap a pose rests on, the imagined alternatives and the winner."""

from __future__ import annotations

import importlib.util
import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import matplotlib
import numpy as np
import pytest
from PIL import Image

from aiocram import _costmap_figure, _figures
from aiocram.cli import main
from aiocram.demo import _outputs as demo_outputs
from aiocram.testing import assert_picture_shows_something, picture_problems, picture_stats

matplotlib.use("Agg")
import matplotlib.pyplot as plt

ROOT = Path(__file__).resolve().parents[2]


# ------------------------------------------------------------------ the check itself
def _figure(tmp_path: Path, name: str, draw: Any) -> Path:
    fig, ax = plt.subplots(figsize=(6, 4), dpi=100)
    try:
        draw(fig, ax)
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        path = tmp_path / name
        fig.savefig(path)
    finally:
        plt.close(fig)
    return path


def test_a_uniform_square_fails(tmp_path: Path) -> None:
    path = tmp_path / "square.png"
    Image.new("RGB", (200, 150), (250, 230, 30)).save(path)
    problems = picture_problems(path)
    assert any("one colour" in p for p in problems), problems
    with pytest.raises(AssertionError, match=r"square\.png shows nothing useful"):
        assert_picture_shows_something(path)


def test_a_blank_plot_fails(tmp_path: Path) -> None:
    path = _figure(tmp_path, "blank.png", lambda fig, ax: None)
    problems = picture_problems(path)
    assert any("nothing drawn there" in p for p in problems), problems


def test_a_solid_costmap_under_a_colour_bar_fails(tmp_path: Path) -> None:
    """The old demo picture: a costmap of ones fills the plot, a few markers on top."""

    def solid(fig: Any, ax: Any) -> None:
        image = ax.imshow(np.ones((40, 40)), extent=(-2, 2, -2, 2), vmin=0, vmax=1)
        fig.colorbar(image, ax=ax)
        ax.scatter([0.5], [0.2], marker="*", s=200, color="orange")

    problems = picture_problems(_figure(tmp_path, "solid.png", solid))
    assert any("solid area hides the plot" in p for p in problems), problems


def test_a_plot_with_a_real_costmap_passes(tmp_path: Path) -> None:
    def heat(fig: Any, ax: Any) -> None:
        y, x = np.mgrid[-2:2:80j, -2:2:80j]
        values = np.exp(-(x**2 + y**2))
        image = ax.imshow(np.ma.masked_less(values, 0.3), extent=(-2, 2, -2, 2))
        fig.colorbar(image, ax=ax)
        ax.plot([-1.5, 1.5], [-1, 1], color="black")

    path = _figure(tmp_path, "heat.png", heat)
    assert picture_problems(path) == []
    stats = picture_stats(path)
    assert stats.region_content > 0.2 and stats.colours > 50


def test_bad_input_names_what_to_fix(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="region must be"):
        picture_stats(np.zeros((10, 10, 3), dtype=np.uint8), region=(0.5, 0.0, 0.2, 1.0))
    with pytest.raises(ValueError, match="H x W x 3"):
        picture_stats(np.zeros((10, 10), dtype=np.uint8))


# ------------------------------------------------------------------ the demo's pictures
@pytest.fixture(scope="module")
def demo_run(
    tmp_path_factory: pytest.TempPathFactory,
) -> Iterator[tuple[Path, list[dict[str, Any]]]]:
    """The default demo (seed 1) in this process, every costmap figure drawn here (no
    fork) and read back: what each figure's axes hold, by ``gid``."""
    drawn: list[dict[str, Any]] = []
    original = _costmap_figure.draw_costmap

    def reading(fig: Any, ax: Any, engine: Any, use: Any, **kwargs: Any) -> None:
        original(fig, ax, engine, use, **kwargs)
        source = kwargs.get("source")
        if source is None and _costmap_figure._has_costmap(use.location):
            source = use.location
        drawn.append(
            {
                "use": use,
                "among": use.location.get("among") is not None,
                "empty": source is not None and engine.costmap(source).empty,
                "gids": {a.get_gid(): a for a in ax.get_children() if a.get_gid()},
            }
        )

    out = tmp_path_factory.mktemp("demo") / "out"
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(_costmap_figure, "draw_costmap", reading)
        mp.setattr(demo_outputs, "_fork", lambda work, adopt=None: None)
        code = main(["demo", "--seed", "1", "--no-live", "--out", str(out)])
    assert code in (0, 1)  # 1 = an invariant violated: reported, not a crash
    yield out, drawn


def test_every_demo_picture_shows_something(demo_run: tuple[Path, list[dict[str, Any]]]) -> None:
    out, _ = demo_run
    pictures = sorted(out.glob("*.png"))
    names = {p.name for p in pictures}
    assert {"final_scene.png", "robot_view.png", "floor_plan.png"} <= names
    assert any(n.startswith("costmap-") for n in names)
    for path in pictures:
        assert_picture_shows_something(path)


def test_costmap_figures_show_the_costmap_the_pose_rests_on(
    demo_run: tuple[Path, list[dict[str, Any]]],
) -> None:
    """Not the factor-less map of an ``(among ...)`` location (all ones: a solid square)
    but the costmap its poses were drawn from; an empty costmap shows the cells the other
    factors kept."""
    _, drawn = demo_run
    assert drawn
    for figure in drawn:
        gids = figure["gids"]
        if figure["empty"]:
            assert "costmap-before-empty" in gids, figure["use"].location.short()
            continue
        assert "costmap" in gids, figure["use"].location.short()
        values = np.ma.compressed(gids["costmap"].get_array())
        assert values.size > 10
        assert values.min() < 0.9 * values.max(), "a uniform costmap shows nothing"
        assert np.count_nonzero(values) < np.asarray(gids["costmap"].get_array()).size


def test_poses_chosen_by_imagining_show_the_alternatives_and_the_winner(
    demo_run: tuple[Path, list[dict[str, Any]]],
) -> None:
    _, drawn = demo_run
    chosen_by_imagining = [f for f in drawn if f["among"]]
    assert chosen_by_imagining, "seed 1 fetches and searches from imagined choices"
    for figure in chosen_by_imagining:
        gids = figure["gids"]
        reached = [g for g in gids if g.startswith("alternative-") and g.endswith("-reached")]
        assert len(reached) >= 2, (figure["use"].location.short(), sorted(gids))
        assert "alternative-chosen" in gids
        assert any(g.endswith("-region") for g in gids)


# ------------------------------------------------------------------ examples/06, campaign
def test_example_06_pictures_show_something(tmp_path: Path, capsys: Any) -> None:
    spec = importlib.util.spec_from_file_location(
        "example_06", ROOT / "examples" / "06_seed_walkthrough_low_level.py"
    )
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    assert module.main(["06", str(tmp_path / "06_scene.png")]) == 0
    capsys.readouterr()
    pictures = sorted(tmp_path.glob("*.png"))
    assert [p.name for p in pictures] == ["06_scene.png", "06_scene_costmap.png"]
    for path in pictures:
        assert_picture_shows_something(path)


def test_campaign_plots_say_how_many_seeds(tmp_path: Path, monkeypatch: Any) -> None:
    from matplotlib.figure import Figure

    from aiocram import campaign

    titles: list[str] = []
    save = Figure.savefig

    def saving(self: Figure, *args: Any, **kwargs: Any) -> Any:
        titles.extend(ax.get_title() for ax in self.axes if ax.get_title())
        return save(self, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", saving)
    summary = json.loads((ROOT / "docs" / "campaign" / "summary.json").read_text())
    runs = {row["runs"] for row in summary["rows"]}
    paths = campaign._plot(summary, tmp_path)
    assert [p.name for p in paths] == ["success_rate.png", "distance.png"]
    assert len(titles) == 2
    assert all(f"{min(runs)} seeds per point" in t for t in titles), titles
    for path in paths:
        assert_picture_shows_something(path)


def test_the_final_scene_shows_and_names_every_object(tmp_path: Path) -> None:
    """A cup the overview camera hides behind the cereal box: the demo's final scene
    (camera_showing + write_scene) has both in view, each with a name tag."""
    from executive import Pose
    from projection import World, render

    with World(seed=0) as w:
        w.spawn_object("breakfast-cereal-1", "breakfast-cereal", Pose((-0.8, 0.9, 0.95)))
        w.spawn_object("cup-1", "cup", Pose((-0.74, 1.06, 0.9)))
        assert render.visible_pixels(w, None, ["cup-1"], width=640, height=480) == {"cup-1": 0}
        camera = render.camera_showing(w)
        _, boxes = _figures._shoot(w, camera, list(w.objects))
        assert sorted(name for name, _ in boxes) == ["breakfast-cereal-1", "cup-1"]
        path = _figures.write_scene(w, tmp_path / "scene.png", camera, "two objects")
    assert_picture_shows_something(path)
    pixels = np.asarray(Image.open(path).convert("RGB"))
    white_tags = np.all(pixels == 255, axis=2)
    assert white_tags.sum() > 2 * 200  # two white name tags (the scene has no pure white)


def test_a_partial_campaign_labels_each_point_with_its_runs(
    tmp_path: Path, monkeypatch: Any
) -> None:
    from matplotlib.figure import Figure

    from aiocram import campaign

    texts: list[str] = []
    save = Figure.savefig

    def saving(self: Figure, *args: Any, **kwargs: Any) -> Any:
        for ax in self.axes:
            texts.append(ax.get_title())
            texts.extend(t.get_text() for t in ax.texts)
        return save(self, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", saving)
    rows = [
        {
            "projection": proj,
            "fault_rate": rate,
            "runs": runs,
            "objects": 5 * runs,
            "delivered": 4 * runs,
            "success_rate": 0.8,
            "mean_distance_m": 15.0 + rate,
        }
        for proj, rate, runs in ((True, 0.0, 3), (True, 0.1, 2), (False, 0.0, 3), (False, 0.1, 2))
    ]
    paths = campaign._plot({"rows": rows}, tmp_path)
    assert any("2-3 seeds per point" in t for t in texts), texts
    assert texts.count("n=2") == 4 and texts.count("n=3") == 4  # 2 plots x 2 modes
    for path in paths:
        assert_picture_shows_something(path)


def test_an_empty_costmap_shows_the_cells_before_the_factor_that_emptied_it() -> None:
    from projection import _costmaps as cm

    costmap = cm.Costmap()
    cm.add_range(costmap, (0.5, 0.5), 0.4, invert=False)
    costmap.add("blocked", lambda x, y: np.zeros_like(x), 1.0)
    assert costmap.empty and "'blocked'" in str(costmap.empty_reason)
    before = _costmap_figure._before_empty(costmap)
    assert before is not None
    layer, factor = before
    assert factor == "blocked"
    xs, ys = costmap.spec.grid()
    inside = np.hypot(xs - 0.5, ys - 0.5) <= 0.4
    assert np.array_equal(layer > 0, inside)  # the disc the range factor kept

    kept = cm.Costmap()
    cm.add_range(kept, (0.5, 0.5), 0.4, invert=False)
    assert _costmap_figure._before_empty(kept) is None  # nothing empties it
