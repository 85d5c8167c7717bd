"""A check that a picture shows something: not one colour, not a blank plot.

:func:`picture_problems` measures a PNG (or an RGB array) and names what is wrong with
it; :func:`assert_picture_shows_something` fails a test with those names. The measures,
on colours quantised to 5 bits per channel (anti-aliasing shades merge):

- the share of pixels in the most common colour over the whole picture: a blank or
  solid picture is one colour;
- in its *plotted region* (by default the central half in both directions, where a
  figure's axes are; a box of fractions otherwise), what is not the background colour
  (the colour at the picture's corners): a blank plot has nothing there, and a solid
  square under a legend is one colour among what is drawn;
- the number of distinct colours: a flat image has a handful;
- the entropy (bits) of the colour histogram: a picture that is mostly one colour with
  a few specks has little.

The thresholds are keyword arguments; the defaults pass every picture the demo, the
examples and the campaign write and fail a uniform square, a blank plot and a plot
region of one colour (``tests/aiocram/test_pictures.py`` checks both sides).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Any

__all__ = ["PictureStats", "assert_picture_shows_something", "picture_problems", "picture_stats"]


@dataclass(frozen=True)
class PictureStats:
    """What :func:`picture_stats` measured (colours quantised to 5 bits per channel)."""

    width: int
    height: int
    dominant: float  # share of pixels in the most common colour, whole picture
    #: inside the plotted region, the share of pixels not in the background colour (the
    #: colour at the picture's corners: a figure's face colour, a scene's floor)
    region_content: float
    #: the share of the most common colour among those non-background pixels
    region_dominant: float
    colours: int  # distinct colours, whole picture
    region_colours: int  # distinct colours inside the plotted region
    entropy: float  # bits, of the whole picture's colour histogram


#: The plotted region by default: (left, top, right, bottom) as fractions of the size.
CENTRE = (0.25, 0.25, 0.75, 0.75)


def _pixels(picture: Any) -> Any:
    import numpy as np

    if isinstance(picture, str | os.PathLike):
        from PIL import Image

        with Image.open(picture) as img:
            return np.asarray(img.convert("RGB"))
    array = np.asarray(picture)
    if array.ndim != 3 or array.shape[2] not in (3, 4):
        raise ValueError(
            f"a picture is a PNG path or an H x W x 3 (or 4) array, got shape {array.shape}"
        )
    return array[:, :, :3]


def _codes(rgb: Any) -> Any:
    """One integer per pixel: its colour quantised to 5 bits per channel."""
    import numpy as np

    q = (rgb.astype(np.uint32) >> 3).reshape(-1, 3)
    return (q[:, 0] << 10) | (q[:, 1] << 5) | q[:, 2]


def _histogram(codes: Any) -> Any:
    import numpy as np

    _, counts = np.unique(codes, return_counts=True)
    return counts


def picture_stats(picture: Any, region: tuple[float, float, float, float] = CENTRE) -> PictureStats:
    """Measure ``picture`` (a PNG path or an RGB array); ``region``: the plotted region
    as (left, top, right, bottom) fractions of the width and height."""
    left, top, right, bottom = region
    if not (0.0 <= left < right <= 1.0 and 0.0 <= top < bottom <= 1.0):
        raise ValueError(
            f"region must be (left, top, right, bottom) fractions with left < right and "
            f"top < bottom, got {region!r}"
        )
    rgb = _pixels(picture)
    h, w = rgb.shape[:2]
    if h == 0 or w == 0:
        raise ValueError(f"the picture has no pixels ({w} x {h})")
    import numpy as np

    counts = _histogram(_codes(rgb))
    share = counts / counts.sum()
    entropy = max(0.0, float(-(share * np.log2(share)).sum()))
    corners = _codes(rgb[[0, 0, -1, -1], [0, -1, 0, -1]][None, :, :])
    values, votes = np.unique(corners, return_counts=True)
    background = values[votes.argmax()]
    r0, r1 = int(top * h), max(int(bottom * h), int(top * h) + 1)
    c0, c1 = int(left * w), max(int(right * w), int(left * w) + 1)
    inner = _codes(rgb[r0:r1, c0:c1])
    content = inner[inner != background]
    inner_counts = _histogram(content) if content.size else np.array([0])
    return PictureStats(
        width=w,
        height=h,
        dominant=float(counts.max() / counts.sum()),
        region_content=float(content.size / inner.size),
        region_dominant=float(inner_counts.max() / max(content.size, 1)),
        colours=int(counts.size),
        region_colours=int(_histogram(inner).size),
        entropy=entropy,
    )


def picture_problems(
    picture: Any,
    *,
    region: tuple[float, float, float, float] = CENTRE,
    max_dominant: float = 0.95,
    min_region_content: float = 0.01,
    max_region_dominant: float = 0.88,
    min_colours: int = 24,
    min_region_colours: int = 4,
    min_entropy: float = 0.5,
) -> list[str]:
    """What is wrong with ``picture`` (empty: nothing), one sentence each (see the module
    docstring for the measures)."""
    s = picture_stats(picture, region)
    problems = []
    if s.dominant > max_dominant:
        problems.append(
            f"{s.dominant:.0%} of the picture is one colour (at most {max_dominant:.0%})"
        )
    if s.region_content < min_region_content:
        problems.append(
            f"the plotted region {region} is {1 - s.region_content:.1%} background: "
            f"nothing drawn there (at least {min_region_content:.0%} must differ)"
        )
    elif s.region_dominant > max_region_dominant:
        problems.append(
            f"{s.region_dominant:.0%} of what is drawn in the plotted region {region} is "
            f"one colour (at most {max_region_dominant:.0%}): a solid area hides the plot"
        )
    if s.colours < min_colours:
        problems.append(f"only {s.colours} distinct colours (at least {min_colours})")
    if s.region_colours < min_region_colours:
        problems.append(
            f"only {s.region_colours} distinct colours in the plotted region "
            f"(at least {min_region_colours})"
        )
    if s.entropy < min_entropy:
        problems.append(f"colour entropy {s.entropy:.2f} bits (at least {min_entropy})")
    return problems


def assert_picture_shows_something(picture: Any, **thresholds: Any) -> None:
    """Fail (AssertionError naming the picture and every problem) unless
    :func:`picture_problems` finds none."""
    problems = picture_problems(picture, **thresholds)
    if problems:
        what = picture if isinstance(picture, str | os.PathLike) else "the picture"
        raise AssertionError(f"{what} shows nothing useful: " + "; ".join(problems))
