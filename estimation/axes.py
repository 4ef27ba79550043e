"""The tensor from the axes' moments and back: the paper's six-axis solve (docs/method.md §5 (8)).

J_k = V_k . J for the axes' unit directions e_k, V the design matrix
(rsp_inertia.plant.geometry.design_matrix): :func:`axis_values` gives the axes' moments of a
tensor with their stds, :func:`tensor_from_axes` the tensor of the axes' moments (the node
formula's and the pendulum's, rsp_inertia.estimation.identify).
"""

from __future__ import annotations

import numpy as np

from rsp_inertia.plant.geometry import design_matrix

__all__ = ["axis_values", "tensor_from_axes"]


def axis_values(entries: np.ndarray, cov: np.ndarray, directions: np.ndarray):
    """J_k = e_k^T J e_k for unit directions, with standard deviations (docs/method.md §5 (8)).

    Parameters
    ----------
    entries : numpy.ndarray, shape (6,)
        kg m^2, the tensor's entries [Jx, Jy, Jz, Jxy, Jyz, Jxz].
    cov : numpy.ndarray, shape (6, 6)
        Their covariance.
    directions : numpy.ndarray, shape (k, 3)
        The axes' unit directions e_k.

    Returns
    -------
    values, stds : numpy.ndarray
        kg m^2, J_k and its std per axis.
    """
    V = design_matrix(directions)
    values = V @ entries
    # v^T C v of a covariance is >= 0; a source that leaves an axis untouched (a tare std of
    # 0 on its stage) gives 0, which rounding can turn into -1e-30 (a NaN std otherwise).
    stds = np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", V, cov, V), 0.0))
    return values, stds


def tensor_from_axes(values: np.ndarray, stds: np.ndarray, directions: np.ndarray):
    """Tensor entries from axis moments through V: solve (6 axes) or weighted least squares.

    Parameters
    ----------
    values : numpy.ndarray
        kg m^2, the axis moments J_k.
    stds : numpy.ndarray
        kg m^2, their standard deviations (the weights).
    directions : numpy.ndarray, shape (k, 3)
        The axes' unit directions.

    Returns
    -------
    entries : numpy.ndarray, shape (6,)
        kg m^2, [Jx, Jy, Jz, Jxy, Jyz, Jxz].
    cov : numpy.ndarray, shape (6, 6)
        Their covariance (the design's cond(V): rsp_inertia.plant.geometry.device_design).
    """
    V = design_matrix(directions)
    W = 1 / np.asarray(stds)
    x, *_ = np.linalg.lstsq(V * W[:, None], values * W, rcond=None)
    cov = np.linalg.pinv((V * W[:, None]).T @ (V * W[:, None]))
    return x, cov
