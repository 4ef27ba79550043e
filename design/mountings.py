"""Presentation of axis designs: a text report and the conditioning figure (paper Fig. 1).

The geometry itself (directions, V, cond(V), the optimum cone) lives in
:mod:`rsp_inertia.plant.geometry` (docs/method.md §5 "Axis designs"); this module only formats and draws it.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from numpy.typing import ArrayLike
from scipy.optimize import minimize_scalar

from rsp_inertia.plant.config import load_device
from rsp_inertia.plant.geometry import (
    AxisDesign,
    cone_condition,
    cone_plus_z_design,
    device_design,
    icosahedron_design,
    rcond_curve,
)
from rsp_inertia.plots import save_figure

__all__ = [
    "DEFAULT_OPENINGS_DEG",
    "best_cone_opening",
    "design_report",
    "mounting_conditioning",
    "mounting_report",
    "plot_cone_conditioning",
    "run_design",
]

DEFAULT_OPENINGS_DEG = np.linspace(10.0, 175.0, 661)
"""Opening angles 2 beta (deg) of the default Fig. 1 curve: 10 to 175 deg in 0.25 deg steps."""


def _axes_table(design: AxisDesign) -> list[str]:
    """One line per axis: stage, lambda, cone opening, node, direction."""
    header = (
        f"  {'axis':>4} {'stage':>5} {'lambda':>9} {'2beta[deg]':>10} {'node[deg]':>9}"
        f" {'ex':>9} {'ey':>9} {'ez':>9}"
    )
    lines = [header]
    for k, (stage, lam, phi, e) in enumerate(
        zip(design.stages, design.gear_ratios, design.phis, design.directions, strict=True),
        start=1,
    ):
        opening = 2.0 * np.degrees(np.arctan(abs(lam)))
        lines.append(
            f"  {k:>4d} {stage:>5d} {lam:>9.4f} {opening:>10.3f} {np.degrees(phi):>9.3f}"
            f" {e[0]:>9.5f} {e[1]:>9.5f} {e[2]:>9.5f}"
        )
    return lines


def _angles_table(angles: np.ndarray) -> list[str]:
    """The angle matrix between the axes (deg) and its off-diagonal min/max/mean."""
    n = angles.shape[0]
    header = "  " + " " * 4 + "".join(f"{j:>8d}" for j in range(1, n + 1))
    lines = ["  Angles between the axes [deg]:", header]
    for i in range(n):
        lines.append(f"  {i + 1:>4d}" + "".join(f"{a:>8.2f}" for a in angles[i]))
    if n > 1:
        off = angles[np.triu_indices(n, k=1)]
        lines.append(
            f"  {off.size} angles off the diagonal: min {off.min():.4f}  max {off.max():.4f}"
            f"  mean {off.mean():.4f} deg"
        )
    return lines


def design_report(designs: list[AxisDesign]) -> str:
    """Human-readable report of axis designs (docs/method.md §5 "Axis designs").

    Parameters
    ----------
    designs : list of AxisDesign
        Designs to describe, in order.

    Returns
    -------
    str
        For each design: its name, a table of its axes (stage, gear ratio lambda, cone
        opening 2 beta = 2 arctan lambda, node angle, unit direction), the matrix of angles
        between the axes with the min/max/mean of the off-diagonal ones, and cond(V) to four
        decimals. Ends with a newline.

    Examples
    --------
    >>> from rsp_inertia.plant.geometry import icosahedron_design
    >>> "cond(V) = 1.5811" in design_report([icosahedron_design()])
    True
    """
    blocks = []
    for design in designs:
        stages = np.unique(design.stages)
        lines = [f"Axis design: {design.name}  ({design.n_axes} axes, {stages.size} stages)"]
        lines += _axes_table(design)
        lines += _angles_table(design.angles_deg)
        lines.append(f"  cond(V) = {design.condition:.4f}   (2-norm, V is {design.n_axes}x6)")
        blocks.append("\n".join(lines))
    return "\n\n".join(blocks) + "\n"


def plot_cone_conditioning(
    path: str | os.PathLike[str], openings_deg: ArrayLike | None = None
) -> None:
    """Write the paper's Fig. 1 as a PNG: 1/cond(V) of the cone-plus-z design vs 2 beta.

    The optimum opening (:func:`rsp_inertia.design.mountings.best_cone_opening`) is marked and the
    icosahedron's 1/cond(V) = sqrt(2/5) is drawn as a horizontal reference
    (docs/method.md §5 "Axis designs"). The file is written atomically: to a temporary file in
    the same folder, then renamed over ``path``.

    Parameters
    ----------
    path : str or os.PathLike
        Output PNG file; its folder must exist.
    openings_deg : array_like, optional
        Opening angles 2 beta (deg) of the curve, each in [0, 180). Default
        :data:`DEFAULT_OPENINGS_DEG` (10 to 175 deg in 0.25 deg steps).
    """
    path = Path(path)
    openings = DEFAULT_OPENINGS_DEG if openings_deg is None else np.asarray(openings_deg, float)
    rcond = rcond_curve(openings)
    best_deg, best_cond = best_cone_opening()
    ico_rcond = 1.0 / icosahedron_design().condition

    fig = Figure(figsize=(6.4, 4.2), dpi=120)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    ax.plot(openings, rcond, color="C0", label="five axes on a cone + z axis")
    ax.axhline(
        ico_rcond, color="C2", linestyle="--", label=f"icosahedron (two stages): {ico_rcond:.4f}"
    )
    ax.plot(
        [best_deg],
        [1.0 / best_cond],
        "o",
        color="C3",
        label=f"optimum 2\u03b2 = {best_deg:.2f}\u00b0, cond(V) = {best_cond:.4f}",
    )
    ax.axvline(best_deg, color="C3", linewidth=0.8, alpha=0.5)
    ax.set_xlabel("cone opening angle 2\u03b2 [deg]")
    ax.set_ylabel("1 / cond(V)")
    ax.set_title("Conditioning of the design matrix V (paper Fig. 1)")
    ax.set_ylim(bottom=0.0)
    ax.grid(True, alpha=0.3)
    ax.legend(loc="upper left", fontsize="small")
    fig.tight_layout()

    save_figure(fig, path)


def mounting_conditioning(rotations: list[np.ndarray]) -> tuple[float, np.ndarray]:
    """How well a set of mountings determines the centre of mass (docs/method.md §5,
    "Combining mountings").

    Mounting k measures m g (R_k c)_x and m g (R_k c)_y, the first two rows of R_k applied
    to the body-axes centre of mass c (the shaft's component never changes the potential
    energy). Stacked over the mountings they form G (2K x 3); with equal stds of the gravity
    terms, the std of c along body axis i is proportional to sqrt((G^T G)^-1)_ii.

    Parameters
    ----------
    rotations : list of numpy.ndarray, shape (3, 3) each
        Each mounting's R, body axes -> rig axes (device.toml ``[mounting] rotation``).

    Returns
    -------
    condition : float
        cond(G), 2-norm (1 is ideal; infinite when a body direction stays on the shaft in
        every mounting).
    gain : numpy.ndarray, shape (3,)
        sqrt((G^T G)^-1)_ii for body x, y, z: the std of that coordinate over one mounting's
        std of x_c (infinite for a coordinate no mounting sees).
    """
    G = np.vstack([np.asarray(R, dtype=float)[:2, :] for R in rotations])
    values, vectors = np.linalg.eigh(G.T @ G)  # ascending: the squared singular values
    if values[0] <= 1e-12 * values[-1]:
        blind = np.abs(vectors[:, 0]) > 1e-6  # the body directions no mounting sees
        gain = np.sqrt(np.diag(np.linalg.pinv(G.T @ G)))
        return math.inf, np.where(blind, math.inf, gain)
    return float(np.sqrt(values[-1] / values[0])), np.sqrt(np.diag(np.linalg.inv(G.T @ G)))


def mounting_report(names: list[str], rotations: list[np.ndarray]) -> str:
    """The mountings' part of the design report: each one's rotation, which body axes the
    gravity terms see, and the set's conditioning for the centre of mass."""
    condition, gain = mounting_conditioning(rotations)
    lines = [f"Mountings for the centre of mass ({len(names)}):"]
    for name, R in zip(names, rotations):
        R = np.asarray(R, dtype=float)
        shaft = R[2]  # the body direction that lies along the shaft (rig z)
        lines.append(
            f"  {name}: body direction on the shaft (not seen by gravity) "
            f"[{', '.join(f'{c:+.3f}' for c in shaft)}]"
        )
    lines.append(
        "  std of x_c, y_c, z_c over one mounting's std of x_c: "
        + ", ".join("not measured" if not math.isfinite(g) else f"{g:.3f}" for g in gain)
        + (f"; cond(G) = {condition:.4f}" if math.isfinite(condition) else "")
    )
    if not math.isfinite(condition):
        lines.append(
            "  the centre of mass is not determined: add a mounting turned 90 deg about the "
            "rig's x axis (rotation = [[1, 0, 0], [0, 0, -1], [0, 1, 0]] from a body as drawn)"
        )
    return "\n".join(lines) + "\n"


def run_design(exps: list[Path] | Path | None = None, plot: Path | None = None) -> str:
    """``rsp-inertia design``: both paper designs (and each EXP's), their report, Fig. 1, and
    for several EXP (or one with ``[mounting]``) the mountings' conditioning for the centre
    of mass (:func:`mounting_report`).

    Parameters
    ----------
    exps : list of paths, or a path, optional
        Experiment folders whose device.toml designs are reported too (mountings of one body).
    plot : path, optional
        Where to write Fig. 1 (default: the first EXP/design.png, or ./design.png).

    Returns
    -------
    str
        The report, with the optimum opening angle and the plot's path.
    """
    if exps is None:
        exps = []
    elif isinstance(exps, (str, Path)):
        exps = [exps]
    best_deg, best_cond = best_cone_opening()
    designs = [icosahedron_design(), cone_plus_z_design(best_deg)]
    devices = [load_device(Path(exp) / "device.toml") for exp in exps]
    designs += [device_design(device) for device in devices]
    mountings = ""
    if len(devices) > 1 or any(device.mounting is not None for device in devices):
        mountings = "\n" + mounting_report(
            [str(exp) for exp in exps],
            [np.eye(3) if d.mounting is None else d.mounting.rotation for d in devices],
        )
    if plot is None:
        plot = (Path(exps[0]) if exps else Path(".")) / "design.png"
    plot_cone_conditioning(plot)
    return (
        design_report(designs)
        + mountings
        + f"\ncone + z: cond(V) is least at 2beta = {best_deg:.3f} deg, cond(V) = {best_cond:.4f}"
        + " (paper Fig. 1: 140 deg, 1.4899)"
        + f"\nplot of 1/cond(V) against 2beta -> {plot}"
    )


def best_cone_opening() -> tuple[float, float]:
    """Opening angle 2 beta of the cone-plus-z design that minimises cond(V) (docs/method.md §5).

    cond(V) has a cusp at its minimum (two singular values cross there), so a smooth
    optimiser alone is unreliable: a 0.1 deg grid over (0, 180) locates the basin, then a
    bounded scalar search (xatol 1e-6 deg) refines it within one grid step either side.

    Returns
    -------
    tuple of float
        ``(opening_deg, cond)``: about 141.967 deg and 1.48925 (the paper's Fig. 1 reads
        140 deg, 1.4899).
    """
    step = 0.1
    grid = np.arange(step, 180.0, step)
    conds = 1.0 / rcond_curve(grid)
    i = int(np.argmin(conds))
    lo, hi = grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]
    res = minimize_scalar(
        cone_condition, bounds=(lo, hi), method="bounded", options={"xatol": 1e-6}
    )
    if res.fun <= conds[i]:
        return float(res.x), float(res.fun)
    return float(grid[i]), float(conds[i])
