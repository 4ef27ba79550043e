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

__all__ = ["plot_tracking", "save_figure"]


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


def plot_motion(
    path: str | os.PathLike,
    braking: tuple[np.ndarray, np.ndarray],
    reverse: tuple[np.ndarray, np.ndarray],
    undamped: tuple[np.ndarray, np.ndarray],
    damped: tuple[np.ndarray, np.ndarray],
    title: str,
) -> None:
    """The paper's Fig. 3: the symmetric semi-program motion (1), free undamped (2), damped (3).

    Each argument is (t, Omega): the braking from the release, the reverse (its time shifted
    to follow the braking, its speed as a magnitude so that the symmetry shows), and the two
    free motions from the same release with the motor off.
    """
    fig = Figure(figsize=(7.0, 4.2), dpi=120)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    tb, wb = braking
    tr, wr = reverse
    ax.plot(tb, wb, color="C0", label="(1) braking, then reverse (semi-program motion)")
    ax.plot(tb[-1] + tr, np.abs(wr), color="C0", linestyle="--")
    ax.plot(*undamped, color="C2", linewidth=0.8, label="(2) free undamped motion")
    ax.plot(*damped, color="C3", linewidth=0.8, label="(3) free damped motion")
    ax.axvline(tb[-1], color="grey", linewidth=0.6, alpha=0.6)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("|speed| [rad/s]")
    ax.set_ylim(bottom=0.0)
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize="small")
    ax.set_title(title)
    fig.tight_layout()
    save_figure(fig, path)


def plot_errors(
    path: str | os.PathLike, labels: list[str], errors: dict[str, np.ndarray], title: str
) -> None:
    """Bar chart of |relative error| per axis for each method (log scale)."""
    fig = Figure(figsize=(7.5, 4.2), dpi=120)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    width = 0.8 / max(len(errors), 1)
    x = np.arange(len(labels))
    for i, (method, values) in enumerate(errors.items()):
        ax.bar(x + (i - (len(errors) - 1) / 2) * width, np.abs(values), width, label=method)
    ax.set_yscale("log")
    ax.set_xticks(x, labels, fontsize="small")
    ax.set_ylabel("|relative error| of J_k")
    ax.grid(True, axis="y", alpha=0.3)
    ax.legend(loc="best", fontsize="small")
    ax.set_title(title)
    fig.tight_layout()
    save_figure(fig, path)
