"""docs/gimbal.png is the figure rsp_inertia.gimbal_figure draws now (docs/method.md §1 shows it).

The figure is drawn again into memory and both PNGs are decoded to pixels; the committed file
must be current, so that the conventions the page states and the figure it shows cannot drift
apart.
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
from matplotlib.image import imread

from rsp_inertia.gimbal_figure import DEFAULT_PATH, gimbal_png

COMMITTED = Path(__file__).resolve().parent.parent / "docs" / "gimbal.png"
REFRESH = "python -m rsp_inertia.gimbal_figure"

# Pixels, not bytes: zlib's compression level or a PNG chunk may differ between builds and
# change the file but not the picture. A few pixels may differ by a grey level or two where
# another matplotlib or FreeType build rounds an antialiased edge differently; a changed drawing
# moves pixels by far more (one label moved by 1.5 pixels changed 214 pixels, by up to 0.75 of
# the range). So: at most 0.1% of the pixels may differ, none by more than a quarter of the
# range (a new FreeType that moves every glyph fails, and the file is then redrawn).
MOST_PIXELS = 1e-3
LARGEST = 0.25


def _pixels(png: bytes) -> np.ndarray:
    return imread(io.BytesIO(png), format="png")


def test_the_default_output_is_the_committed_file():
    assert DEFAULT_PATH == COMMITTED


def test_the_committed_figure_is_current():
    assert COMMITTED.is_file(), f"docs/gimbal.png is missing: run {REFRESH}"
    committed = _pixels(COMMITTED.read_bytes())
    drawn = _pixels(gimbal_png())
    assert committed.shape == drawn.shape, (
        f"docs/gimbal.png is {committed.shape[1]}x{committed.shape[0]} pixels, the figure "
        f"{drawn.shape[1]}x{drawn.shape[0]}: it is out of date, run {REFRESH}"
    )
    difference = np.abs(committed.astype(float) - drawn.astype(float)).max(axis=-1)
    changed = float(np.mean(difference > 0))
    assert changed <= MOST_PIXELS and difference.max() <= LARGEST, (
        f"docs/gimbal.png differs from the figure rsp_inertia.gimbal_figure draws "
        f"({changed:.2%} of the pixels, by up to {difference.max():.2f}): it is out of date, "
        f"run {REFRESH} and commit docs/gimbal.png"
    )


def test_the_figure_is_drawn_the_same_every_time():
    """The same code gives the same bytes (no time stamp, no software version in the file)."""
    assert gimbal_png() == gimbal_png()
