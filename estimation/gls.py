"""Generalised least squares over the runs' balance equations, with its own model checks.

Every run (one stage in one direction) contributes one equation per balance angle
(rsp_inertia.estimation.balance, METHOD.md §5). Which unknowns those equations share depends on the
question: the body's tensor (rsp_inertia.estimation.tensor) or the empty fixture's harmonics and the
torque gain (rsp_inertia.estimation.calibration). Both build :class:`Block` s, named columns and a
right-hand side, and this module solves them the same way:

- **weights**: the covariance of a run's equations is the motor work's (the torque logs'
  own noise, rsp_inertia.estimation.passes) plus the speed noise's, 1/4 M_i M_j cov(S_i, S_j), M from a
  first unweighted pass and cov(S) from the smoothers' derived error autocovariance;
- **speed-noise scale**: the derived speed part of each run is scaled by the factor that makes
  that run's own fit reach chi^2/dof = 1 (a real encoder adds line errors, a closed loop its
  regulator's jitter). A run's own fit can absorb a systematic misfit into that scale (its
  own M harmonics and constant take up much of it), so the scale alone proves nothing: the
  runs are checked against each other;
- **consistency tests**: unknowns declared per group (the tensor, per run) are fitted once
  shared and once free per group (each run its own tensor; each run's early and late
  turns their own; each turn its own), with the same weights. The chi^2 drop is chi^2-distributed with as many
  degrees of freedom as the freed unknowns add to the rank when the model is right. A
  systematic error rarely biases every run, and fast and slow turns, alike: friction that
  differs between the directions of rotation (its work grows with speed), a wrong spring or
  gear ratio, a torque gain that differs between runs. A smooth regressor per run (a drift
  in the angle, the shape of friction work) is no test here: the kinetic energy along the
  braking is itself such a smooth function, so it would stand in for the noisy measured
  speeds and reject every run. Nor is a per-node term (M let off its harmonic form within
  15 deg of each node): it found a local 4e-5 change of M at one node (chi^2 = 90 for 6)
  and kept quiet on the ideal reverse, but a closed-loop reverse leaves structure locked to
  the angle there (chi^2 = 23-36 for 6 on 6 of 24 clean sweep cases whose errors were
  1-1.4 std), so it would raise false alarms;
- **known terms**: the right-hand side may depend on calibrated parameters theta (their
  covariance known); their share of the estimate's covariance is K B cov(theta) B^T K^T,
  K the GLS gain and B = d rhs / d theta;
- **budget**: the covariance of the estimate split by independent noise source.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg
from scipy.optimize import brentq
from scipy.stats import chi2

from rsp_inertia.estimation.balance import StageBalance

__all__ = [
    "CALIBRATION_SOURCE",
    "JITTER",
    "NOISE_SOURCES",
    "SCALE_CAP",
    "TEST_ALPHA",
    "BalanceFit",
    "Block",
    "ModelTest",
    "information",
    "model_warnings",
    "solve_blocks",
]

NOISE_SOURCES = ("braking torque log", "reverse torque log", "encoder (speed)")
"""The independent noise sources of the balance equations, for the uncertainty budget."""

CALIBRATION_SOURCE = "calibration"
"""Budget line of the calibrated terms (tare, fixture, torque gain)."""

SCALE_CAP = 1e4
"""Largest speed-noise scale; a run that needs it has residuals no encoder explains."""

TEST_ALPHA = 0.01
"""Family-wise false-alarm probability of the model tests of one fit (Bonferroni over the
tests): a clean rig's identification warns in about 1 run in 100."""

JITTER = 1e-12
"""Relative ridge on the covariance before its Cholesky factor: the speed errors have no
low-frequency content, so with a noise-free torque log the covariance is singular to
rounding; 1e-12 of its mean variance is far below any noise and keeps it definite."""


@dataclass(frozen=True)
class Block:
    """One run's equations: sum_name x[name] columns[name] = rhs (module docstring)."""

    balance: StageBalance
    """The run's balance angles, speeds and noise."""
    label: str
    """E.g. "stage 1 forward", for messages."""
    columns: dict[str, np.ndarray]
    """Unknown name -> its column, shape (n,)."""
    rhs: np.ndarray
    """(n,) the known side of the equations, J."""
    inertia_columns: dict[str, np.ndarray]
    """Unknown name -> its share of M(phi) per unit (n,): M = sum x[name] col + inertia_known."""
    inertia_known: np.ndarray
    """(n,) the known part of M(phi), kg m^2."""
    work_scale: float = 1.0
    """Factor on the logged motor work in the equations (1 / torque gain): scales the work's
    noise covariance."""
    known_jacobian: np.ndarray | None = None
    """(n, p) d rhs / d theta for calibrated parameters theta, or None."""
    groups: dict[str, str] = field(default_factory=dict)
    """Unknown name -> group label (e.g. the run) for the consistency tests."""
    fixed_in_tests: frozenset[str] = frozenset()
    """Unknowns the consistency tests hold at the joint estimate: a scale on the whole
    equation (the torque gain's h, with a right-hand side that is zero without the
    reference's known terms) would let a freed fit collapse to the trivial solution."""
    joint_only: frozenset[str] = frozenset()
    """Unknowns left out of the run's own fit that sets its speed-noise scale: terms that only
    the runs together determine (a friction asymmetry's work shape, alone in one run, would
    stand in for the kinetic energy and absorb the speed noise)."""


@dataclass(frozen=True)
class ModelTest:
    """A chi^2 test of the balance model (module docstring)."""

    kind: str
    """"consistency" (between runs), "early/late" (between each run's halves) or "per turn"."""
    label: str
    """What was tested, e.g. "stage 1 forward"."""
    statistic: float
    """The chi^2 drop."""
    dof: int
    """Degrees of freedom added."""
    p_value: float
    """P(chi^2_dof >= statistic) under the model."""
    significant: bool
    """p_value below the family-wise level (Bonferroni over the fit's tests)."""

    def to_json(self) -> dict:
        """The result.json entry."""
        return {
            "kind": self.kind,
            "label": self.label,
            "chi2": self.statistic,
            "dof": self.dof,
            "p_value": self.p_value,
            "significant": self.significant,
        }


@dataclass(frozen=True)
class BalanceFit:
    """The solution of :func:`solve_blocks`."""

    names: list[str]
    """The unknowns, in the order of ``x``."""
    x: np.ndarray
    """Estimates."""
    cov: np.ndarray
    """Covariance of ``x``, calibrated terms included."""
    cov_parts: dict[str, np.ndarray]
    """``cov`` split by noise source (:data:`NOISE_SOURCES`, :data:`CALIBRATION_SOURCE`)."""
    chi2_dof: float
    """Residual chi^2 per degree of freedom of the joint fit."""
    scales: list[float]
    """Per block, the speed-noise scale."""
    n_equations: int
    """Equations, all blocks."""
    tests: list[ModelTest]
    """The consistency tests, when blocks declare groups."""
    labels: list[str] = field(default_factory=list)
    """Per block, its label."""

    def index(self, name: str) -> int:
        """Position of unknown ``name``."""
        return self.names.index(name)

    def value(self, name: str) -> tuple[float, float]:
        """(estimate, std) of ``name``; (nan, nan) if it was not fitted."""
        if name not in self.names:
            return math.nan, math.nan
        i = self.names.index(name)
        return float(self.x[i]), float(math.sqrt(self.cov[i, i]))


def _factors(covs: list[np.ndarray]) -> list[np.ndarray]:
    """Lower Cholesky factors of the diagonal blocks of the covariance (with the ridge)."""
    return [
        np.linalg.cholesky(cov + JITTER * np.trace(cov) / len(cov) * np.eye(len(cov)))
        for cov in covs
    ]


def _whiten(M: np.ndarray, factors: list[np.ndarray]) -> np.ndarray:
    """Rows of M (stacked blocks) multiplied by the inverse Cholesky factor, block by block."""
    out, start = [], 0
    for L in factors:
        n = L.shape[0]
        out.append(scipy.linalg.solve_triangular(L, M[start : start + n], lower=True))
        start += n
    return np.concatenate(out)


def _chi2(A: np.ndarray, y: np.ndarray, factors: list[np.ndarray]) -> tuple[float, int, np.ndarray]:
    """Weighted residual chi^2, rank of A and the estimate."""
    Aw, yw = _whiten(A, factors), _whiten(y, factors)
    x, _, rank, _ = np.linalg.lstsq(Aw, yw, rcond=None)
    r = yw - Aw @ x
    return float(r @ r), int(rank), x


def information(A: np.ndarray, cov: np.ndarray) -> np.ndarray:
    """A^T C^-1 A: the Fisher information of equations A x = y + noise of covariance C.

    Whitened with the same factor (and the same jitter) as the least squares itself.
    """
    Aw = _whiten(A, _factors([cov]))
    return Aw.T @ Aw


def _used(A: np.ndarray) -> np.ndarray:
    """Columns with any non-zero entry."""
    return np.nonzero(np.any(A != 0.0, axis=0))[0]


def _calibrated_scale(A, y, work_cov, speed_var) -> float:
    """The speed noise's scale s that makes one run's own fit reach chi^2/dof = 1.

    A root in log s on [1/SCALE_CAP, SCALE_CAP] (Brent); the bound where chi^2/dof stays on
    one side.
    """
    lo, hi = 1.0 / SCALE_CAP, SCALE_CAP

    def chi2_dof(scale: float) -> float:
        value, rank, _ = _chi2(A, y, _factors([work_cov + scale * speed_var]))
        return value / max(len(y) - rank, 1)

    if chi2_dof(hi) >= 1.0:
        return hi
    if chi2_dof(lo) <= 1.0:
        return lo
    return math.exp(
        brentq(lambda ls: math.log(chi2_dof(math.exp(ls))), math.log(lo), math.log(hi), xtol=1e-3)
    )


def _weighted_solution(Aw: np.ndarray, yw: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares solution of whitened equations and its covariance (Aw^T Aw)^-1.

    Columns are scaled to unit norm first (their units differ by orders of magnitude) and the
    covariance is taken from the SVD, so that it stays positive semi-definite; directions the
    data do not determine (singular values below rounding) are left out (pseudo-inverse).
    """
    norms = np.linalg.norm(Aw, axis=0)
    norms[norms == 0.0] = 1.0
    U, sv, Vt = np.linalg.svd(Aw / norms, full_matrices=False)
    keep = sv > sv[0] * max(Aw.shape) * np.finfo(float).eps
    inv = np.where(keep, 1.0 / np.where(keep, sv, 1.0), 0.0)
    x = (Vt.T * inv) @ (U.T @ yw) / norms
    cov = (Vt.T * inv**2) @ Vt / np.outer(norms, norms)
    return x, cov


def _budget(Aw, factors, parts, cov_x) -> np.ndarray:
    """cov_x Aw^T (L^-1 C_part L^-T) Aw cov_x: the share of one noise source in cov_x.

    The estimate is x = cov_x Aw^T L^-1 y, so a source of covariance C_part in y reaches x as
    above; with C = sum of the parts, the shares sum to cov_x = (Aw^T Aw)^-1.
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


def _matrix(blocks: list[Block], names: list[str]) -> np.ndarray:
    """Stack the blocks' named columns into a matrix with the columns ``names``."""
    rows = []
    for block in blocks:
        n = len(block.rhs)
        rows.append(np.column_stack([block.columns.get(name, np.zeros(n)) for name in names]))
    return np.vstack(rows)


def solve_blocks(
    blocks: list[Block],
    known_cov: np.ndarray | None = None,
    predict: bool = False,
    tests: bool = True,
) -> BalanceFit:
    """Generalised least squares over the blocks, with the model tests (module docstring).

    Raises nothing on a misfit: whatever the noise model leaves in the joint fit's chi^2/dof
    above 1 inflates the covariance, and the tests say whether the runs agree.

    Parameters
    ----------
    blocks : list of Block
        One per run.
    known_cov : array, shape (p, p), optional
        Covariance of the calibrated parameters theta that the blocks' ``known_jacobian``
        refers to.
    predict : bool
        The blocks hold noise-free balances of a planned run (rsp_inertia.estimation.predict): the
        covariance is the noise model's as it stands (every speed-noise scale 1, no
        inflation by the residuals, which are zero) and no model test is made.
    tests : bool
        Make the model tests (False: the estimate and its covariance only, as a rehearsal of
        a plan needs).
    """
    names = list(dict.fromkeys(name for block in blocks for name in block.columns))
    A = _matrix(blocks, names)
    y = np.concatenate([block.rhs for block in blocks])
    rows = np.cumsum([0] + [len(block.rhs) for block in blocks])
    # First pass, unweighted: the reduced inertia at each angle for the speed-noise weights.
    x0, *_ = np.linalg.lstsq(A, y, rcond=None)
    speed_var, work_parts = [], []
    for block in blocks:
        cols = block.inertia_columns
        M = block.inertia_known + sum(x0[names.index(k)] * c for k, c in cols.items())
        speed_var.append(0.25 * np.outer(M, M) * block.balance.speed_sq_cov)
        h2 = block.work_scale**2
        work_parts.append(
            (h2 * block.balance.braking_work_cov, h2 * block.balance.reverse_work_cov)
        )
    work_cov = [b + r for b, r in work_parts]

    def run_scales(y_own: np.ndarray) -> list[float]:
        """Each run's own fit (its own unknowns, joint-only ones left out) sets its scale."""
        scales = []
        for k, block in enumerate(blocks):
            mine = slice(rows[k], rows[k + 1])
            own = [j for j in _used(A[mine]) if names[j] not in block.joint_only]
            scales.append(
                _calibrated_scale(A[mine][:, own], y_own[mine], work_cov[k], speed_var[k])
            )
        return scales

    def joint_fit(scales: list[float]):
        factors = _factors([w + s * v for w, v, s in zip(work_cov, speed_var, scales)])
        Aw, yw = _whiten(A, factors), _whiten(y, factors)
        return factors, Aw, yw, *_weighted_solution(Aw, yw)

    scales = [1.0] * len(blocks) if predict else run_scales(y)
    factors, Aw, yw, x, cov_x = joint_fit(scales)
    joint = [j for j, name in enumerate(names) if any(name in b.joint_only for b in blocks)]
    if joint and not predict:
        # The joint-only terms, now known, are taken off each run's own fit, whose speed-noise
        # scale they would otherwise inflate; then the joint fit again with those scales.
        scales = run_scales(y - A[:, joint] @ x[joint])
        factors, Aw, yw, x, cov_x = joint_fit(scales)
    r = yw - Aw @ x
    dof = max(len(y) - A.shape[1], 1)
    chi2_dof = float(r @ r / dof)
    sources = {
        NOISE_SOURCES[0]: [b for b, _ in work_parts],
        NOISE_SOURCES[1]: [r_ for _, r_ in work_parts],
        NOISE_SOURCES[2]: [s * v for s, v in zip(scales, speed_var)],
    }
    # Whatever the noise model leaves unexplained in the joint fit inflates the covariance.
    inflation = 1.0 if predict else max(chi2_dof, 1.0)
    cov_parts = {
        name: _budget(Aw, factors, parts, cov_x) * inflation for name, parts in sources.items()
    }
    cov = cov_x * inflation
    nuisance = None
    if known_cov is not None and any(b.known_jacobian is not None for b in blocks):
        p = known_cov.shape[0]
        B = np.vstack(
            [
                b.known_jacobian if b.known_jacobian is not None else np.zeros((len(b.rhs), p))
                for b in blocks
            ]
        )
        gain = cov_x @ Aw.T @ _whiten(B, factors)  # dx / dtheta
        cov_parts[CALIBRATION_SOURCE] = gain @ known_cov @ gain.T
        cov = cov + cov_parts[CALIBRATION_SOURCE]
        # For the tests, the calibrated terms are unknowns with their calibration as prior:
        # their errors are common to all runs and would otherwise pass for a disagreement.
        lam, U = np.linalg.eigh(known_cov)
        live = lam > lam.max() * 1e-12 if lam.max() > 0 else np.zeros(len(lam), bool)
        if live.any():
            nuisance = (B @ (U[:, live] * np.sqrt(lam[live])), int(live.sum()))

    found_tests = []
    splits = (
        () if predict or not tests
        else ((None, "consistency"), ("halves", "early/late"), ("turns", "per turn"))
    )
    for split, kind in splits:
        fixed = [j for j, n in enumerate(names) if any(n in b.fixed_in_tests for b in blocks)]
        kept = [j for j in range(len(names)) if j not in fixed]
        found = _consistency(
            blocks,
            [names[j] for j in kept],
            A[:, kept],
            y - A[:, fixed] @ x[fixed],
            factors,
            split,
            nuisance,
        )
        if found is not None:
            found_tests.append(((kind, found[0]), found[1], found[2]))
    level = TEST_ALPHA / max(len(found_tests), 1)
    model_tests = []
    for (kind, label), stat, dof_ in found_tests:
        p_value = float(chi2.sf(max(stat, 0.0), dof_))
        model_tests.append(
            ModelTest(kind, label, float(stat), int(dof_), p_value, p_value < level)
        )
    return BalanceFit(
        names=names,
        x=x,
        cov=cov,
        cov_parts=cov_parts,
        chi2_dof=chi2_dof,
        scales=scales,
        n_equations=len(y),
        tests=model_tests,
        labels=[block.label for block in blocks],
    )


def _consistency(
    blocks, names, A, y, factors, split, nuisance=None
) -> tuple[str, float, int] | None:
    """The chi^2 drop when the grouped unknowns are freed per group, or None if no groups.

    ``split``: None, or each block's balance angles are also cut into parts, each a group of
    its own: "halves" (early turns, late turns) or "turns" (every whole turn travelled; a
    last part shorter than a turn joins the one before). ``nuisance``: (B, p), columns of p
    standardised calibration errors (prior N(0, 1) each) that both fits take as unknowns.
    """
    grouped = {name for block in blocks for name in block.groups}
    labels = list(dict.fromkeys(g for block in blocks for g in block.groups.values()))
    if not grouped or (len(labels) < 2 and split is None):
        return None
    free_names, parts = [n for n in names if n not in grouped], []
    for block in blocks:
        for rows, half in _parts(block, split):
            cols = {k: v[rows] for k, v in block.columns.items() if k not in grouped}
            for name in sorted(grouped & block.columns.keys()):
                key = f"{name}@{block.groups[name]}{half}"
                cols[key] = block.columns[name][rows]
                if key not in free_names:
                    free_names.append(key)
            parts.append((cols, rows.stop - rows.start))
    A_free = np.vstack(
        [np.column_stack([cols.get(k, np.zeros(n)) for k in free_names]) for cols, n in parts]
    )
    if nuisance is not None:
        B, p = nuisance
        A, A_free = np.hstack([A, B]), np.hstack([A_free, B])
        prior = [np.hstack([np.zeros((p, M.shape[1] - p)), np.eye(p)]) for M in (A, A_free)]
        A, A_free = np.vstack([A, prior[0]]), np.vstack([A_free, prior[1]])
        y = np.concatenate([y, np.zeros(p)])
        factors = list(factors) + [np.eye(p)]
    joint, rank_joint, _ = _chi2(A, y, factors)
    free, rank_free, _ = _chi2(A_free, y, factors)
    dof = rank_free - rank_joint
    if dof <= 0:
        return None
    what = {
        None: "the runs " + ", ".join(labels),
        "halves": "the early and late turns of each run",
        "turns": "the turns of each run",
    }[split]
    return what, joint - free, dof


def _parts(block: Block, split: str | None) -> list[tuple[slice, str]]:
    """Row ranges of a block for :func:`_consistency`, with their group suffixes."""
    n = len(block.rhs)
    if split is None:
        return [(slice(0, n), "")]
    if split == "halves":
        return [(slice(0, n // 2), " early"), (slice(n // 2, n), " late")]
    turn = np.floor(block.balance.friction_shape[:, 0] / (2 * math.pi)).astype(int)
    turns = max(int(turn[-1]), 1)  # a last partial turn joins the one before
    turn = np.minimum(turn, turns - 1)
    starts = np.searchsorted(turn, np.arange(turns))
    ends = np.append(starts[1:], n)
    return [(slice(a, b), f" turn {k + 1}") for k, (a, b) in enumerate(zip(starts, ends))]


def model_warnings(tests: list[ModelTest], scales: list[float], labels: list[str]) -> list[str]:
    """Warnings from the balance model's tests and the runs' speed-noise scales."""
    warnings = []
    for label, scale in zip(labels, scales):
        if scale >= SCALE_CAP:
            warnings.append(
                f"{label}: the balance residuals exceed the encoder's speed-noise model even "
                f"{scale:.0f}-fold: the balances do not close; the stds are not reliable"
            )
    for test in tests:
        if not test.significant:
            continue
        warnings.append(
            f"the balances do not close: {test.label} disagree beyond their noise (chi2 = "
            f"{test.statistic:.3g} for {test.dof} terms, p = {test.p_value:.2g}); likely "
            "causes: friction that differs between the directions of rotation (run the "
            'stages both ways: directions = ["forward", "backward"]), a reverse that does not '
            "track the mirror, a wrong spring stiffness or gear ratio in device.toml, a torque "
            "gain that differs between the passes or runs; the result may be off by more "
            "than its std"
        )
    return warnings
