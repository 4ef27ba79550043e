"""The inertia tensor from the stages' balances: least squares, axis solve, physical checks.

Least squares over many turns (METHOD.md §5). With w(phi) = (lam sin phi, lam cos phi, 1),
(1 + lam^2) J_e(phi) = w^T J w = v(phi) . [Jx Jy Jz Jxy Jyz Jxz], v the design-matrix row of
the unnormalised w (METHOD.md §2: the harmonic form of M per stage written in the tensor's
entries, so that all stages share one set of unknowns). Each balance angle of stage s gives

    1/2 S v(phi) . J + 2 Gs sin phi + 2 Gc cos phi - C_s = W(phi) - 1/2 S M_tare

(estimation.balance), linear in the six entries, the gravity terms Gs = m g x_c,
Gc = m g y_c shared by all stages, one constant per stage, and per stage the two slopes
d1, d2 of the friction torque that the closed loop's tracking mismatch leaves in the balance
(the right-hand side gains - d1 R1 - d2 R2, estimation.balance). Weighted (generalised) least
squares: the covariance of the equations is the motor work's (from the torque logs' noise,
estimation.energy) plus the speed noise's, 1/4 M_i M_j cov(S_i, S_j) (M from a first
unweighted pass; cov(S) from the smoothers' derived error autocovariance, correlated over a
few 1/w_c, estimation.smoothing). The speed noise's size is calibrated on the residuals
(:func:`fit_tensor`), so that the standard deviations follow what the data show.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from scipy.optimize import brentq

from estimation.balance import StageBalance
from plant.geometry import axis_direction, design_matrix, tensor_from_entries

__all__ = [
    "NOISE_SOURCES",
    "TensorFit",
    "axis_values",
    "fit_tensor",
    "physical_warnings",
    "principal",
    "tensor_from_axes",
]


@dataclass(frozen=True)
class TensorFit:
    """Result of the least squares over every stage's balance angles."""

    entries: np.ndarray
    """[Jx, Jy, Jz, Jxy, Jyz, Jxz], kg m^2 (products as tensor entries)."""
    entries_cov: np.ndarray
    """(6, 6) covariance, kg^2 m^4."""
    gravity: np.ndarray
    """[Gs, Gc] = m g [x_c, y_c], N m."""
    gravity_cov: np.ndarray
    """(2, 2) covariance, N^2 m^2."""
    chi2_dof: float
    """Residual chi^2 per degree of freedom of the weighted fit (1 when the noise model fits)."""
    speed_noise_scale: list[float]
    """Per stage, the factor on the derived speed-error covariance that makes the stage's own
    fit reach chi^2/dof = 1."""
    n_equations: int
    """Balance angles used, all stages."""
    friction_slope: np.ndarray
    """(stages, 2) [d1, d2] of D'(Omega) = d1 + d2 Omega per stage (N m s, N m s^2), from the
    tracking mismatch; NaN for a stage with exactly no mismatch (exact data)."""
    friction_slope_std: np.ndarray
    """(stages, 2)."""
    mismatch_terms: list[bool]
    """Per stage: whether the tracking-mismatch friction terms were fitted (NaN slopes if not:
    only when the mismatch is exactly zero)."""
    cov_parts: dict[str, np.ndarray]
    """Covariance of [entries, gravity] split by noise source (:data:`NOISE_SOURCES`); the
    parts sum to the whole: the uncertainty budget."""


def _design_rows(bal: StageBalance) -> np.ndarray:
    """Rows v(phi) of the unnormalised axes w = (lam sin phi, lam cos phi, 1) at the balance
    angles: v . J = w^T J w = (1 + lam^2) J_e (METHOD.md §1-2)."""
    lam = bal.gear_ratio
    return design_matrix(axis_direction(bal.phi, lam) * np.sqrt(1.0 + lam * lam))


def _rows(bal: StageBalance) -> np.ndarray:
    """The 8 shared columns of a stage's equations (six entries, Gs, Gc)."""
    v = _design_rows(bal)
    return np.column_stack([0.5 * bal.speed_sq[:, None] * v, 2 * np.sin(bal.phi), 2 * np.cos(bal.phi)])


NOISE_SOURCES = ("braking torque log", "reverse torque log", "encoder (speed)")
"""The independent noise sources of the balance equations, for the uncertainty budget."""

_JITTER = 1e-12
"""Relative ridge on the covariance before its Cholesky factor: the speed errors have no
low-frequency content, so with a noise-free torque log the covariance is singular to
rounding; 1e-12 of its mean variance is far below any noise and keeps it definite."""


def _factors(covs: list[np.ndarray]) -> list[np.ndarray]:
    """Lower Cholesky factors of the diagonal blocks of the covariance (with the ridge)."""
    return [
        np.linalg.cholesky(cov + _JITTER * np.trace(cov) / len(cov) * np.eye(len(cov)))
        for cov in covs
    ]


def _whitened(A: np.ndarray, y: np.ndarray, factors: list[np.ndarray]):
    """A and y multiplied by the inverse Cholesky factor of the block-diagonal covariance."""
    Aw, yw, start = [], [], 0
    for L in factors:
        n = L.shape[0]
        Aw.append(scipy.linalg.solve_triangular(L, A[start : start + n], lower=True))
        yw.append(scipy.linalg.solve_triangular(L, y[start : start + n], lower=True))
        start += n
    return np.vstack(Aw), np.concatenate(yw)


def _budget(Aw, factors, parts, cov_x) -> np.ndarray:
    """cov_x Aw^T (L^-1 C_part L^-T) Aw cov_x: the share of one noise source in cov_x.

    The estimate is x = cov_x Aw^T L^-1 y, so a source of covariance C_part in y reaches x as
    above; with C = sum of the parts, the shares sum to cov_x = (Aw^T Aw)^-1 (before the
    chi^2 inflation, applied by the caller to both).
    """
    inner, start = np.zeros((Aw.shape[1], Aw.shape[1])), 0
    for L, part in zip(factors, parts):
        n = L.shape[0]
        B = Aw[start : start + n]
        W = scipy.linalg.solve_triangular(L, part, lower=True)
        W = scipy.linalg.solve_triangular(L, W.T, lower=True)
        inner += B.T @ W @ B
        start += n
    return cov_x @ inner @ cov_x


def _solve(A, y, balances, speed_var, scales):
    """Weighted fit with the speed part of stage k's covariance scaled by ``scales[k]``.

    Returns the estimate, the whitened design, chi^2/dof and the covariance factors.
    """
    dof = max(len(y) - A.shape[1], 1)
    factors = _factors([bal.work_cov + s * v for bal, v, s in zip(balances, speed_var, scales)])
    Aw, yw = _whitened(A, y, factors)
    x, *_ = np.linalg.lstsq(Aw, yw, rcond=None)
    r = yw - Aw @ x
    return x, Aw, float(r @ r / dof), factors


def _calibrated_scale(A, y, bal, speed_var) -> float:
    """The speed noise's scale s that makes one stage's own fit reach chi^2/dof = 1.

    A root in log s on [1e-4, 1e4] (Brent); the bound where chi^2/dof stays on one side.
    """
    lo, hi = 1e-4, 1e4

    def chi2_dof(scale: float) -> float:
        return _solve(A, y, [bal], [speed_var], [scale])[2]

    if chi2_dof(hi) >= 1.0:
        return hi
    if chi2_dof(lo) <= 1.0:
        return lo
    return math.exp(
        brentq(lambda ls: math.log(chi2_dof(math.exp(ls))), math.log(lo), math.log(hi), xtol=1e-3)
    )


def fit_tensor(balances: list[StageBalance]) -> TensorFit:
    """Generalised least squares for the tensor and the gravity terms (module docstring).

    The covariance of the equations has two parts: the motor work's, known from the torque
    logs' own noise, and the speed noise's, derived for quantization noise alone (a real
    encoder adds its own line errors, a closed loop its regulator's jitter). The speed part of
    each stage is therefore scaled by the factor s_k that makes that stage's own fit reach a
    residual chi^2 per degree of freedom of 1 (a root found in log s_k; s_k ~ 1 on the
    virtual device's ideal reverse). If even s -> 0 leaves chi^2/dof above 1 (something the noise model does
    not contain), the whole covariance of the estimate is scaled by the remaining chi^2/dof.
    """
    n_stages = len(balances)
    blocks, rhs = [], []
    for s, bal in enumerate(balances):
        const = np.zeros((len(bal.phi), n_stages))
        const[:, s] = -1.0
        slopes = np.zeros((len(bal.phi), 2 * n_stages))
        slopes[:, 2 * s : 2 * s + 2] = -bal.mismatch
        blocks.append(np.hstack([_rows(bal), const, slopes]))
        rhs.append(bal.work - 0.5 * bal.speed_sq * bal.tare_inertia)
    A = np.vstack(blocks)
    y = np.concatenate(rhs)
    # First pass, unweighted: the reduced inertia at each angle for the speed-noise weights.
    x0, *_ = np.linalg.lstsq(A, y, rcond=None)
    speed_var = []
    for bal in balances:
        M = _design_rows(bal) @ x0[:6] + bal.tare_inertia
        speed_var.append(0.25 * np.outer(M, M) * bal.speed_sq_cov)
    n_fixed = 8 + n_stages

    def slope_columns(stage: int) -> list[int]:
        return [n_fixed + 2 * stage, n_fixed + 2 * stage + 1]

    # Always fitted: the speed noise's calibrated scale also absorbs whatever else the
    # closed-loop reverse adds, which would hide the asymmetry from a significance test
    # (measured: a closed-loop case with a 4.7-sigma error that a chi^2 test at 1% kept out).
    # On an ideal reverse the slopes only fit noise; their cost is in the stds. Only a stage
    # whose mismatch is exactly zero (exact data) leaves its slopes out.
    keep = list(range(n_fixed))
    mismatch_terms = []
    for s, bal in enumerate(balances):
        needed = bool(np.any(bal.mismatch != 0.0))
        mismatch_terms.append(needed)
        if needed:
            keep += slope_columns(s)
    A = A[:, keep]
    # The speed noise's scale, stage by stage on each stage's own equations and unknowns: a
    # closed-loop reverse adds speed error of its own (regulator jitter, measured ~30 x the
    # quantization model's chi^2 on stage 2 and ~1.3 x on stage 1), which one shared scale
    # would spread over every stage.
    rows = np.cumsum([0] + [len(bal.phi) for bal in balances])
    scales = []
    for s, bal in enumerate(balances):
        mine = slice(rows[s], rows[s + 1])
        used = np.nonzero(np.any(A[mine] != 0.0, axis=0))[0]
        scales.append(_calibrated_scale(A[mine][:, used], y[mine], bal, speed_var[s]))
    x, Aw, chi2_dof, factors = _solve(A, y, balances, speed_var, scales)
    cov_x = np.linalg.pinv(Aw.T @ Aw)
    sources = {
        NOISE_SOURCES[0]: [bal.braking_work_cov for bal in balances],
        NOISE_SOURCES[1]: [bal.reverse_work_cov for bal in balances],
        NOISE_SOURCES[2]: [s * v for s, v in zip(scales, speed_var)],
    }
    inflation = max(chi2_dof, 1.0)
    cov_parts = {
        name: _budget(Aw, factors, parts, cov_x)[:8, :8] * inflation
        for name, parts in sources.items()
    }
    cov_x = cov_x * inflation
    slope = np.full(2 * n_stages, np.nan)
    slope_std = np.full(2 * n_stages, np.nan)
    kept = np.array(keep[n_fixed:], dtype=int) - n_fixed
    slope[kept] = x[n_fixed:]
    slope_std[kept] = np.sqrt(np.diag(cov_x)[n_fixed:])
    return TensorFit(
        entries=x[:6],
        entries_cov=cov_x[:6, :6],
        gravity=x[6:8],
        gravity_cov=cov_x[6:8, 6:8],
        chi2_dof=chi2_dof,
        speed_noise_scale=scales,
        n_equations=len(y),
        friction_slope=slope.reshape(n_stages, 2),
        friction_slope_std=slope_std.reshape(n_stages, 2),
        mismatch_terms=mismatch_terms,
        cov_parts=cov_parts,
    )


def axis_values(entries: np.ndarray, cov: np.ndarray, directions: np.ndarray):
    """J_k = e_k^T J e_k for unit directions, with standard deviations (METHOD.md §5 (8))."""
    V = design_matrix(directions)
    values = V @ entries
    stds = np.sqrt(np.einsum("ij,jk,ik->i", V, cov, V))
    return values, stds


def tensor_from_axes(values: np.ndarray, stds: np.ndarray, directions: np.ndarray):
    """Tensor entries from axis moments through V: solve (6 axes) or weighted least squares.

    Returns the entries, their covariance and cond(V).
    """
    V = design_matrix(directions)
    W = 1 / np.asarray(stds)
    x, *_ = np.linalg.lstsq(V * W[:, None], values * W, rcond=None)
    cov = np.linalg.pinv((V * W[:, None]).T @ (V * W[:, None]))
    return x, cov, float(np.linalg.cond(V))


def principal(entries: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Principal moments (ascending) and axes (rows, unit vectors) of the tensor."""
    moments, vectors = np.linalg.eigh(tensor_from_entries(entries))
    return moments, vectors.T


def physical_warnings(entries: np.ndarray, cov: np.ndarray, samples: int = 2000) -> list[str]:
    """Warnings when the tensor is not a physical one within its uncertainty.

    A rigid body's tensor is positive definite and its principal moments obey the triangle
    inequality I1 + I2 >= I3 (NOTES.md). A violation is reported when it holds beyond two
    standard deviations of the margin, estimated by sampling the entries' covariance
    (seeded, deterministic).
    """
    rng = np.random.default_rng(0)
    draws = rng.multivariate_normal(entries, cov, size=samples, check_valid="ignore")

    def margins(e):
        m = np.linalg.eigvalsh(tensor_from_entries(e))
        return m[0], m[0] + m[1] - m[2]
    smallest, triangle = margins(entries)
    spread = np.array([margins(d) for d in draws])
    std_small, std_tri = spread.std(axis=0)
    warnings = []
    if smallest < -2 * std_small:
        warnings.append(
            f"the tensor is not positive definite: smallest principal moment "
            f"{smallest:.6g} +- {std_small:.2g} kg m^2"
        )
    if triangle < -2 * std_tri:
        warnings.append(
            f"the principal moments break the triangle inequality I1 + I2 >= I3 by "
            f"{-triangle:.6g} +- {std_tri:.2g} kg m^2"
        )
    return warnings

