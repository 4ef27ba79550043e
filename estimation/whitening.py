"""Weighting of the balance equations: Cholesky whitening of their covariance.

Equations A x = y + noise of covariance C (block diagonal: one block per run) are solved, and
their fit's chi^2 taken, after multiplying them by L^-1, C = L L^T: the whitened equations
have unit white noise. The solver (rsp_inertia.estimation.gls), its model tests
(rsp_inertia.estimation.model_tests) and the planner's prediction
(rsp_inertia.estimation.predict) share these few functions, so that they weigh alike.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

__all__ = ["JITTER", "cholesky_factors", "information", "weighted_chi2", "whiten"]

JITTER = 1e-12
"""Relative ridge on the covariance before its Cholesky factor: the speed errors have no
low-frequency content, so with a noise-free torque log the covariance is singular to
rounding; 1e-12 of its mean variance is far below any noise and keeps it definite."""


def cholesky_factors(covs: list[np.ndarray]) -> list[np.ndarray]:
    """Lower Cholesky factors of the diagonal blocks of the covariance (with the ridge)."""
    return [
        np.linalg.cholesky(cov + JITTER * np.trace(cov) / len(cov) * np.eye(len(cov)))
        for cov in covs
    ]


def whiten(M: np.ndarray, factors: list[np.ndarray]) -> np.ndarray:
    """Rows of M (stacked blocks) multiplied by the inverse Cholesky factor, block by block."""
    out, start = [], 0
    for L in factors:
        n = L.shape[0]
        out.append(scipy.linalg.solve_triangular(L, M[start : start + n], lower=True))
        start += n
    return np.concatenate(out)


def weighted_chi2(A: np.ndarray, y: np.ndarray, factors: list[np.ndarray]) -> tuple[float, int, np.ndarray]:
    """Weighted residual chi^2, rank of A and the estimate."""
    Aw, yw = whiten(A, factors), whiten(y, factors)
    x, _, rank, _ = np.linalg.lstsq(Aw, yw, rcond=None)
    r = yw - Aw @ x
    return float(r @ r), int(rank), x


def information(A: np.ndarray, cov: np.ndarray) -> np.ndarray:
    """A^T C^-1 A: the Fisher information of equations A x = y + noise of covariance C.

    Whitened with the same factor (and the same jitter) as the least squares itself.
    """
    Aw = whiten(A, cholesky_factors([cov]))
    return Aw.T @ Aw
