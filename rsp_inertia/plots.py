"""Figures (PNG, matplotlib Agg): what people would rather look at than read.

Only drawing here; the numbers come from the library. Every figure is written atomically
(temporary file in the same folder, then renamed).
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

__all__ = ["save_figure", "plot_tracking"]


def save_figure(fig: Figure, path: str | os.PathLike) -> None:
    """Write ``fig`` as PNG to ``path`` atomically, with the usual file permissions."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".png", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as f:
            fig.savefig(f, format="png")
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def plot_tracking(
    path: str | os.PathLike,
    t: np.ndarray,
    reference: np.ndarray,
    output: np.ndarray,
    title: str,
) -> None:
    """The paper's Fig. 4: reference speed (r), output (y) and error (e) of the reverse pass.

    Parameters
    ----------
    t : array
        s, reverse-pass time.
    reference, output : arrays
        rad/s, the mirrored speed and the speed the body had (or its estimate).
    """
    fig = Figure(figsize=(7.0, 5.0), dpi=120)
    FigureCanvasAgg(fig)
    top, bottom = fig.subplots(2, 1, sharex=True, gridspec_kw={"height_ratios": [2, 1]})
    top.plot(t, reference, color="C0", label="reference r (mirror of the braking)")
    top.plot(t, output, color="C1", linestyle="--", label="output y")
    top.set_ylabel("speed [rad/s]")
    top.legend(loc="best", fontsize="small")
    top.grid(True, alpha=0.3)
    top.set_title(title)
    bottom.plot(t, output - reference, color="C3", linewidth=0.6, label="error e = y - r")
    bottom.set_xlabel("reverse time t' [s]")
    bottom.set_ylabel("error [rad/s]")
    bottom.grid(True, alpha=0.3)
    bottom.legend(loc="best", fontsize="small")
    fig.tight_layout()
    save_figure(fig, path)
