"""Mathematics of axis designs and mountings: the optimum cone and the mountings' conditioning.

The geometry itself (directions, V, cond(V)) lives in :mod:`rsp_inertia.plant.geometry`
(docs/method.md §5 "Axis designs"). Here: the cone opening that minimises cond(V)
(:func:`best_cone_opening`, the paper's Fig. 1) and how well a set of mountings determines the
centre of mass (:func:`mounting_conditioning`). ``rsp-inertia design`` reports them
(:mod:`rsp_inertia.axis_designs`), its text is :class:`rsp_inertia.results.AxisDesignResult`'s
and its figure :func:`rsp_inertia.plots.cone_conditioning_figure`.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import minimize_scalar

from rsp_inertia.plant.geometry import cone_condition, rcond_curve

__all__ = [
    "DEFAULT_OPENINGS_DEG",
    "best_cone_opening",
    "mounting_conditioning",
]

DEFAULT_OPENINGS_DEG = np.linspace(10.0, 175.0, 661)
"""Opening angles 2 beta (deg) of the default Fig. 1 curve: 10 to 175 deg in 0.25 deg steps."""


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
