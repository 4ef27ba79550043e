"""Figures as PNG files (written atomically) and as PNG bytes, without importing matplotlib.

A matplotlib figure brings its own ``savefig``: writing one needs nothing of matplotlib's, so
the results (:mod:`rsp_inertia.results`) write the figures they are handed and only the
commands that draw import matplotlib (:mod:`rsp_inertia.plots`, half a second).
"""

from __future__ import annotations

import io
import os
from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING

from rsp_inertia.infra.files import write_atomic

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["figure_png", "save_figure", "save_figures"]


def save_figure(fig: Figure, path: str | os.PathLike) -> None:
    """Write ``fig`` as PNG to ``path`` atomically (rsp_inertia.infra.files.write_atomic: a
    reader sees the old file or the new one), with the usual file permissions.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure.
    path : str or os.PathLike
        The PNG file; its folder must exist.
    """
    write_atomic(path, figure_png(fig))


def save_figures(figures: Iterable[tuple[str, Figure]], folder: str | os.PathLike) -> list[Path]:
    """Write (file name, figure) pairs into ``folder`` (created if needed), each atomically.

    Parameters
    ----------
    figures : iterable of (str, matplotlib.figure.Figure)
        The figures with their file names, as a result's ``draw()`` gives them.
    folder : str or os.PathLike
        Where to write them.

    Returns
    -------
    list of pathlib.Path
        The files written, in the order given.
    """
    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, figure in figures:
        paths.append(out / name)
        save_figure(figure, paths[-1])
    return paths


def figure_png(fig: Figure) -> bytes:
    """``fig`` as PNG bytes (the report inlines them; nothing is written)."""
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png")
    return buffer.getvalue()
