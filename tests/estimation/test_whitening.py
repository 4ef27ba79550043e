"""The structured whitening against the dense generalised least squares it replaces.

A run's covariance is held by structure (random walks, rank-one terms, a band) and whitened in
the differences of its equations, its free constant profiled out with the last one
(rsp_inertia.estimation.whitening). Two independent computations must agree: the dense GLS
with the whole covariance matrix, x = (A^T C^-1 A)^-1 A^T C^-1 y, and the structured one, on
every unknown but the constants, their covariance, each noise source's share and the chi^2.
The dense path is kept here only, as the reference.
"""

import dataclasses

import numpy as np
import pytest

from rsp_inertia.estimation.gls import NOISE_SOURCES, assemble_blocks, solve_blocks
from rsp_inertia.estimation.known_terms import KnownTerms
from rsp_inertia.estimation.tensor_fit import tensor_block
from rsp_inertia.estimation.whitening import (
    JITTER,
    Noise,
    band_dense,
    band_of,
    lstsq_rows,
    scaled_band,
    whitener,
)

# Rounding: the dense covariance's Cholesky factor loses ~cond(C) eps, the differenced one far
# less; 1e-9 is the bound and far above what either loses on these sizes.
AGREE = 1e-9


def _dense_gls(A, y, C):
    """Estimate, covariance and chi^2 of A x = y + noise of covariance C (with the ridge)."""
    n = len(y)
    C = C + JITTER * np.trace(C) / n * np.eye(n)
    Ci = np.linalg.inv(C)
    F = A.T @ Ci @ A
    cov = np.linalg.inv(F)
    x = cov @ A.T @ Ci @ y
    r = y - A @ x
    return x, cov, float(r @ Ci @ r), Ci @ A @ cov


def _relative(a, b):
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


def test_structured_whitening_equals_dense_gls():
    """Walks in both directions, a rank-one term and a band: the differenced whitening gives
    the dense GLS's estimate, covariance, chi^2 and per-part shares for every unknown but the
    run's constant."""
    rng = np.random.default_rng(3)
    n, p = 240, 4
    rising = np.cumsum(rng.uniform(0.0, 1.0, n))  # a braking's walk, from the first angle
    falling = np.cumsum(rng.uniform(0.0, 2.0, n))[::-1]  # a reverse's, from the last
    c = 0.3 * np.linspace(0.0, 1.0, n)  # a constant torque's mean: (phi - phi_0)
    t = np.cumsum(rng.uniform(0.5, 1.5, n))
    lag = np.abs(t[:, None] - t[None, :])
    band = band_of(np.where(lag < 5.0, np.exp(-lag**2 / 3.0), 0.0) + 1e-6 * np.eye(n))
    band = scaled_band(band, rng.uniform(1.0, 2.0, n))
    parts = [Noise(n, walks=(rising,)), Noise(n, walks=(falling,)),
             Noise(n, rank_one=(c,)), Noise(n, band=band)]
    noise = sum(parts, Noise(n))
    C = noise.dense()
    assert np.allclose(band_dense(band), band_dense(band).T)
    A = np.column_stack([rng.normal(size=(n, p)), -np.ones(n)])  # last: the run's constant
    y = A @ rng.normal(size=p + 1) + rng.multivariate_normal(np.zeros(n), C)
    x, cov, chi2, G = _dense_gls(A, y, C)

    W = whitener(noise)
    assert np.all(W.whiten(A[:, p]) == 0.0)  # the constant is gone with the differences
    Aw, yw = W.whiten(A[:, :p]), W.whiten(y)
    cov_w = np.linalg.inv(Aw.T @ Aw)
    x_w = cov_w @ Aw.T @ yw
    r = yw - Aw @ x_w
    assert _relative(x_w, x[:p]) < AGREE
    assert _relative(cov_w, cov[:p, :p]) < AGREE
    assert abs(float(r @ r) - chi2) < AGREE * chi2
    H = W.transpose_whiten(Aw @ cov_w)
    for part in parts:
        dense_share = (G.T @ part.dense() @ G)[:p, :p]
        assert _relative(part.quadratic(H), dense_share) < AGREE


def test_rows_folded_by_qr_equal_one_least_squares():
    """lstsq_rows over pieces with columns of their own gives numpy's lstsq of the stacked
    rows: chi^2, rank (a column the data do not determine left out) and estimate."""
    rng = np.random.default_rng(5)
    width = 7
    pieces, stacked, rhs = [], [], []
    for k in range(4):
        columns = np.array([0, 1, 2 + k])  # shared, then one of its own
        Aw, yw = rng.normal(size=(50, 3)), rng.normal(size=50)
        pieces.append((columns, Aw, yw))
        full = np.zeros((50, width))
        full[:, columns] = Aw
        stacked.append(full)
        rhs.append(yw)
    A, y = np.vstack(stacked), np.concatenate(rhs)  # column 6 never used: rank 6
    x, _, rank, _ = np.linalg.lstsq(A, y, rcond=None)
    chi2, rank_rows, x_rows = lstsq_rows(iter(pieces), width)
    assert rank_rows == rank == 6
    assert abs(chi2 - float(np.sum((y - A @ x) ** 2))) < 1e-10 * chi2
    assert np.allclose(x_rows, x, rtol=1e-10, atol=1e-12)




def test_solve_blocks_equals_the_dense_reference(default_balances):
    """The least squares of the default experiment's runs (given speed-noise scales) against
    the dense GLS over the same equations, constants included: estimates, covariance, the
    budget's shares and chi^2/dof."""
    known = KnownTerms.from_tares([bal.tare_inertia for bal in default_balances])
    blocks = []
    for k, bal in enumerate(default_balances):
        block = tensor_block(bal, str(k), known, False)
        # An ideal reverse leaves the friction slopes undetermined (only speed noise in its
        # mismatch): a comparison of two computations needs a well-posed problem.
        columns = {n: c for n, c in block.columns.items() if not n.startswith("d")}
        blocks.append(dataclasses.replace(block, columns=columns))
    scales = [1.3, 0.7]
    fit = solve_blocks(assemble_blocks(blocks), scales)

    # Dense reference: every named column and the constants, the first unweighted pass's M.
    names = list(dict.fromkeys(n for b in blocks for n in b.columns))
    A = np.vstack([np.column_stack([b.columns.get(n, np.zeros(len(b.rhs))) for n in names])
                   for b in blocks])
    y = np.concatenate([b.rhs for b in blocks])
    x0, *_ = np.linalg.lstsq(A, y, rcond=None)
    sizes = [len(b.rhs) for b in blocks]
    C = np.zeros((len(y), len(y)))
    parts = {name: np.zeros_like(C) for name in NOISE_SOURCES}
    start = 0
    for block, scale, n in zip(blocks, scales, sizes):
        M = block.inertia_known + sum(
            x0[names.index(k)] * col for k, col in block.inertia_columns.items()
        )
        bal = block.balance
        mine = slice(start, start + n)
        parts[NOISE_SOURCES[0]][mine, mine] = bal.braking_work_noise.dense()
        parts[NOISE_SOURCES[1]][mine, mine] = bal.reverse_work_noise.dense()
        parts[NOISE_SOURCES[2]][mine, mine] = (
            scale * 0.25 * np.outer(M, M) * band_dense(bal.speed_sq_band)
        )
        parts[NOISE_SOURCES[3]][mine, mine] = bal.encoder_work_noise().dense()
        C[mine, mine] = sum(part[mine, mine] for part in parts.values())
        # the ridge per run, as the structured whitening adds it
        C[mine, mine] += JITTER * np.trace(C[mine, mine]) / n * np.eye(n)
        start += n
    Ci = np.linalg.inv(C)
    F = A.T @ Ci @ A
    cov = np.linalg.pinv(F)
    x = cov @ A.T @ Ci @ y
    r = y - A @ x
    G = Ci @ A @ cov
    index = [names.index(n) for n in fit.names]
    assert all(n.startswith("C[") for n in names if n not in fit.names)
    sub = np.ix_(index, index)
    assert _relative(fit.x, x[index]) < AGREE
    assert _relative(fit.cov, cov[sub]) < AGREE
    dof = len(y) - len(names)
    assert abs(fit.chi2_dof - float(r @ Ci @ r) / dof) < AGREE * fit.chi2_dof
    for name in NOISE_SOURCES:
        assert _relative(fit.cov_parts[name], (G.T @ parts[name] @ G)[sub]) < AGREE


def test_a_walk_must_be_monotone():
    """min(v_i, v_j) is a random walk's covariance only for v monotone along the rows."""
    with pytest.raises(ValueError, match="monotone"):
        Noise(3, walks=(np.array([1.0, 3.0, 2.0]),))


def test_noise_sums_and_scales_like_its_matrix():
    """Noise's +, times and trace are those of the matrices it stands for."""
    rng = np.random.default_rng(0)
    n = 20
    a = Noise(n, walks=(np.cumsum(rng.uniform(size=n)),), band=band_of(np.eye(n) * 2.0))
    b = Noise(n, rank_one=(rng.normal(size=n),),
              band=band_of(np.diag(np.ones(n - 1), 1) + np.diag(np.ones(n - 1), -1) + np.eye(n)))
    assert np.allclose((a + b).dense(), a.dense() + b.dense())
    assert np.allclose(a.times(2.5).dense(), 2.5 * a.dense())
    assert np.isclose((a + b).trace(), np.trace(a.dense() + b.dense()))
    # dataclasses stay frozen: a Noise is a value
    with pytest.raises(dataclasses.FrozenInstanceError):
        a.n = 3
