"""Weighting of the balance equations: their covariance by structure, and its whitening.

Equations A x = y + noise of covariance C (block diagonal: one block per run) are solved, and
their fit's chi^2 taken, after multiplying them by a whitening W, W^T W = C^-1: the whitened
equations have unit white noise. The solver (rsp_inertia.estimation.gls), its model tests
(rsp_inertia.estimation.model_tests) and the planner's prediction
(rsp_inertia.estimation.predict) share these functions, so that they weigh alike.

Structure (docs/method.md §5, the balances' noise). A run's n equations, in the order of its
balance angles, carry noise of three kinds (:class:`Noise`):

- random walks, cov = min(v_i, v_j) for v monotone along the rows (either way): a torque
  log's sample-by-sample work summed from its pass's start (the braking's from the first
  angle, the reverse's from the last), the gaps' interpolation, the smoothed angle's error
  under a changing torque (rsp_inertia.estimation.passes);
- rank-one terms c c^T: a constant braking torque's mean, one error shared by every angle;
- a banded part: the smoothed speeds' errors, correlated over the smoother's span only
  (rsp_inertia.estimation.smoothing, zero beyond w_c |tau| = KERNEL_SPAN).

Dense, C costs n^2 memory and n^3 time. Every run's equations share its free constant C_run
(rsp_inertia.estimation.columns run_columns), so nothing but that constant changes when the
equations are replaced by their differences y_i - y_{i+1}, i < n - 1, and the last one, which
alone holds C_run, is left out with it (profiling a free unknown that only one equation
holds out of a Gaussian likelihood leaves the marginal of the others: the estimates of every
other unknown, their covariance and the chi^2 are those of the whole system). In the
differences each random walk is independent increments (diagonal), the band stays a band
one wider, and a rank-one term stays rank one: D C D^T = K + sum c_k c_k^T, K banded. Its
banded Cholesky factor K = L L^T (LAPACK pbtrf) and the rank-one terms V = L^-1 [c_k] give
W = (I + V V^T)^(-1/2) L^-1, the symmetric square root by V's thin SVD: W^T W = (D C D^T)^-1.
Whitening a run of n rows and p columns costs O(n (b^2 + b p)), b the band's width.

Ridge. The speed errors have no low-frequency content, so with a noise-free torque log C is
singular to rounding: JITTER x its mean variance is added to its diagonal (D (e I) D^T =
e tridiag(-1, 2, -1) in the differences), far below any noise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.linalg import lapack

__all__ = [
    "JITTER",
    "Identity",
    "Noise",
    "Whitener",
    "add_bands",
    "band_dense",
    "band_matmul",
    "band_of",
    "information",
    "lstsq_rows",
    "scaled_band",
    "weighted_chi2",
    "whiten",
    "whitened_rows",
    "whitener",
    "whiteners",
]

JITTER = 1e-12
"""Relative ridge on the covariance before its factor (module docstring)."""


def band_of(matrix: np.ndarray, width: int | None = None) -> np.ndarray:
    """(width, n) lower band of a symmetric matrix, band[d, i] = matrix[i + d, i] (zero-padded
    at the end); ``width`` by default the widest non-zero diagonal + 1."""
    n = matrix.shape[0]
    if width is None:
        width = 1
        for d in range(n - 1, 0, -1):
            if np.any(np.diagonal(matrix, -d) != 0.0):
                width = d + 1
                break
    band = np.zeros((width, n))
    for d in range(min(width, n)):
        band[d, : n - d] = np.diagonal(matrix, -d)
    return band


def band_dense(band: np.ndarray) -> np.ndarray:
    """The symmetric matrix of a lower band (:func:`band_of`'s inverse)."""
    n = band.shape[1]
    out = np.zeros((n, n))
    for d in range(min(band.shape[0], n)):
        idx = np.arange(n - d)
        out[idx + d, idx] = band[d, : n - d]
        out[idx, idx + d] = band[d, : n - d]
    return out


def scaled_band(band: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Lower band of diag(u) B diag(u) for B of lower band ``band``."""
    n = band.shape[1]
    out = band.copy()
    for d in range(min(band.shape[0], n)):
        out[d, : n - d] *= u[d:] * u[: n - d]
    return out


def add_bands(*bands: np.ndarray) -> np.ndarray:
    """Lower band of the sum of symmetric matrices given by their lower bands (same n)."""
    width = max(band.shape[0] for band in bands)
    out = np.zeros((width, bands[0].shape[1]))
    for band in bands:
        out[: band.shape[0]] += band
    return out


def band_matmul(band: np.ndarray, X: np.ndarray) -> np.ndarray:
    """B X for the symmetric matrix B of lower band ``band`` and X (n,) or (n, k)."""
    n = band.shape[1]
    Y = band[0].reshape((n,) + (1,) * (X.ndim - 1)) * X
    for d in range(1, min(band.shape[0], n)):
        b = band[d, : n - d].reshape((n - d,) + (1,) * (X.ndim - 1))
        Y[d:] += b * X[:-d]
        Y[:-d] += b * X[d:]
    return Y


def _difference_band(band: np.ndarray) -> np.ndarray:
    """Lower band of D B D^T (n - 1 rows) for B of lower band ``band`` (n), with
    (D x)_i = x_i - x_{i+1}: one diagonal wider.

    (D B D^T)[i+d, i] = B[i+d, i] + B[i+d+1, i+1] - B[i+d+1, i] - B[i+d, i+1].
    """
    w, n = band.shape
    padded = np.zeros((w + 2, n + 1))
    padded[:w, :n] = band
    out = np.zeros((w + 1, n - 1))
    for d in range(w + 1):
        upper = padded[1, : n - 1] if d == 0 else padded[d - 1, 1:n]
        out[d] = padded[d, : n - 1] + padded[d, 1:n] - padded[d + 1, : n - 1] - upper
    return out


@dataclass(frozen=True)
class Noise:
    """The covariance of one run's n equations by its structure (module docstring):
    sum of random walks min(v_i, v_j), rank-one terms c c^T and a symmetric band."""

    n: int
    """Equations."""
    walks: tuple[np.ndarray, ...] = ()
    """Each (n,): the walk's variance at each equation, monotone along them (either way)."""
    rank_one: tuple[np.ndarray, ...] = ()
    """Each (n,): c of a term c c^T."""
    band: np.ndarray | None = None
    """(w, n) lower band, band[d, i] = C[i + d, i]; None: no banded part."""

    def __post_init__(self) -> None:
        for v in self.walks:
            steps = np.diff(v)
            if not (np.all(steps >= 0.0) or np.all(steps <= 0.0)):
                raise ValueError("a random walk's variance must be monotone along the equations")

    def __add__(self, other: Noise) -> Noise:
        bands = [b for b in (self.band, other.band) if b is not None]
        band = add_bands(*bands) if len(bands) == 2 else (bands[0] if bands else None)
        return Noise(self.n, self.walks + other.walks, self.rank_one + other.rank_one, band)

    def times(self, factor: float) -> Noise:
        """This covariance times ``factor`` >= 0."""
        root = math.sqrt(factor)
        return Noise(
            self.n,
            tuple(factor * v for v in self.walks),
            tuple(root * c for c in self.rank_one),
            None if self.band is None else factor * self.band,
        )

    def trace(self) -> float:
        """Sum of the variances."""
        total = sum(float(np.sum(v)) for v in self.walks)
        total += sum(float(c @ c) for c in self.rank_one)
        return total + (0.0 if self.band is None else float(np.sum(self.band[0])))

    def dense(self) -> np.ndarray:
        """(n, n) the matrix itself (a reference for tests and small cases)."""
        C = np.zeros((self.n, self.n)) if self.band is None else band_dense(self.band)
        for v in self.walks:
            C += np.minimum.outer(v, v)
        for c in self.rank_one:
            C += np.outer(c, c)
        return C

    def differenced(self) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """D C D^T (module docstring) as (diagonal (n-1,), rank-one rows (k, n-1), lower band or
        None)."""
        diagonal = np.zeros(self.n - 1)
        for v in self.walks:
            diagonal += np.abs(np.diff(v))
        rows = np.array([c[:-1] - c[1:] for c in self.rank_one]).reshape(-1, self.n - 1)
        band = None if self.band is None else _difference_band(self.band)
        return diagonal, rows, band

    def quadratic(self, H: np.ndarray) -> np.ndarray:
        """H^T (D C D^T) H for H (n - 1, p): this noise seen through the rows H weigh."""
        diagonal, rows, band = self.differenced()
        out = (H * diagonal[:, None]).T @ H
        if rows.size:
            RH = rows @ H
            out += RH.T @ RH
        if band is not None:
            out += H.T @ band_matmul(band, H)
        return out


class Identity:
    """The whitening of pseudo-equations that are already white (a prior's): rows unchanged."""

    def __init__(self, n: int):
        self.n_in = self.n_out = n

    def whiten(self, M: np.ndarray) -> np.ndarray:
        """M itself."""
        return M

    def transpose_whiten(self, M: np.ndarray) -> np.ndarray:
        """M itself (W^T = I)."""
        return M


@dataclass
class Whitener:
    """W of one run's equations (module docstring): n_in rows in, n_out = n_in - 1 out."""

    n_in: int
    """Equations in."""
    factor: np.ndarray
    """(w, n_in - 1) lower band of L, K = L L^T."""
    basis: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    """(n_in - 1, k) orthonormal left singular vectors of V = L^-1 [c_k]."""
    shrink: np.ndarray = field(default_factory=lambda: np.zeros(0))
    """(k,) (1 + s^2)^(-1/2) - 1 for V's singular values s."""

    @property
    def n_out(self) -> int:
        """Whitened rows."""
        return self.n_in - 1

    def _solve(self, X: np.ndarray, trans: str) -> np.ndarray:
        flat = X.ndim == 1
        B = np.asfortranarray(X.reshape(X.shape[0], -1), dtype=float)
        if B.shape[1] == 0:
            return X
        out, info = lapack.dtbtrs(self.factor, B, uplo="L", trans=trans)
        if info != 0:
            raise np.linalg.LinAlgError(f"banded triangular solve failed (info {info})")
        return out[:, 0] if flat else out

    def _root(self, X: np.ndarray) -> np.ndarray:
        """(I + V V^T)^(-1/2) X."""
        if self.shrink.size == 0:
            return X
        U = self.basis
        if X.ndim == 1:
            return X + U @ (self.shrink * (U.T @ X))
        return X + U @ (self.shrink[:, None] * (U.T @ X))

    def whiten(self, M: np.ndarray) -> np.ndarray:
        """W D M: the whitened differences of the rows of M (n_in, ...)."""
        M = np.asarray(M, dtype=float)
        return self._root(self._solve(M[:-1] - M[1:], "N"))

    def transpose_whiten(self, M: np.ndarray) -> np.ndarray:
        """W^T M for M (n_out, ...): L^-T (I + V V^T)^(-1/2) M."""
        return self._solve(self._root(np.asarray(M, dtype=float)), "T")


def whitener(noise: Noise) -> Whitener:
    """W of a run's noise (module docstring), with the ridge JITTER x the mean variance.

    Raises
    ------
    numpy.linalg.LinAlgError
        The differenced covariance is not positive definite.
    """
    diagonal, rows, band = noise.differenced()
    m = noise.n - 1
    width = 2 if band is None else max(band.shape[0], 2)
    K = np.zeros((width, m))
    if band is not None:
        K[: band.shape[0]] += band
    K[0] += diagonal
    ridge = JITTER * noise.trace() / noise.n
    K[0] += 2.0 * ridge  # D (ridge I) D^T = ridge tridiag(-1, 2, -1)
    K[1, : m - 1] -= ridge
    factor, info = lapack.dpbtrf(K, lower=1)
    if info != 0:
        raise np.linalg.LinAlgError(f"the run's covariance is not positive definite ({info})")
    out = Whitener(noise.n, factor)
    if rows.size:
        V = out._solve(rows.T, "N")
        U, s, _ = np.linalg.svd(V.reshape(m, -1), full_matrices=False)
        out.basis, out.shrink = U, 1.0 / np.sqrt(1.0 + s * s) - 1.0
    return out


def whiteners(noises: list[Noise]) -> list[Whitener]:
    """One :func:`whitener` per run."""
    return [whitener(noise) for noise in noises]


def whiten(M: np.ndarray, factors: list) -> np.ndarray:
    """Rows of M (stacked blocks, each factor's ``n_in`` rows) whitened block by block."""
    out, start = [], 0
    for factor in factors:
        out.append(factor.whiten(M[start : start + factor.n_in]))
        start += factor.n_in
    return np.concatenate(out)


def whitened_rows(factors: list) -> int:
    """Rows of the whitened equations of all blocks."""
    return sum(factor.n_out for factor in factors)


def lstsq_rows(pieces, width: int) -> tuple[float, int, np.ndarray]:
    """Least squares over whitened rows given piece by piece, with bounded memory.

    ``pieces`` yields (columns (k,) int, Aw (m, k), yw (m,)): whitened rows whose other
    columns (of ``width``) are zero. The pieces are folded into the triangular factor of
    [Aw | yw] (QR, as LAPACK's least squares does), so only one piece and a (width + 1)^2
    factor are held at once. Returns (chi^2, rank, estimate), the rank decided as
    numpy.linalg.lstsq decides it (singular values below eps x max(rows, width) x the largest
    left out).
    """
    R = np.zeros((0, width + 1))
    rows = 0
    for columns, Aw, yw in pieces:
        block = np.zeros((Aw.shape[0], width + 1))
        block[:, columns] = Aw
        block[:, width] = yw
        R = np.linalg.qr(np.vstack([R, block]), mode="r")
        rows += Aw.shape[0]
    A, b = R[:, :width], R[:, width]
    x, _, rank, _ = np.linalg.lstsq(A, b, rcond=np.finfo(float).eps * max(rows, width))
    r = b - A @ x  # |Aw x - yw| = |R [x; -1]|: Q is orthogonal
    return float(r @ r), int(rank), x


def weighted_chi2(
    A: np.ndarray, y: np.ndarray, factors: list
) -> tuple[float, int, np.ndarray]:
    """Weighted residual chi^2, rank of the whitened A and the estimate.

    Parameters
    ----------
    A : np.ndarray, shape (n, p)
        The stacked blocks' equations.
    y : np.ndarray, shape (n,)
        Their right-hand side.
    factors : list
        Each block's whitener (:func:`whitener`), in the order of the blocks.

    Returns
    -------
    chi2 : float
        The whitened residuals' sum of squares.
    rank : int
        The rank of the whitened A.
    x : np.ndarray, shape (p,)
        The weighted least-squares estimate.
    """
    Aw, yw = whiten(A, factors), whiten(y, factors)
    x, _, rank, _ = np.linalg.lstsq(Aw, yw, rcond=None)
    r = yw - Aw @ x
    return float(r @ r), int(rank), x


def information(A: np.ndarray, noise: Noise) -> np.ndarray:
    """A^T C^-1 A over the run's differenced equations: the Fisher information of its
    equations on every unknown but its constant (module docstring), whitened as the least
    squares whitens them."""
    Aw = whitener(noise).whiten(A)
    return Aw.T @ Aw
