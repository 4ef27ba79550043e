"""Generalised least squares over the runs' balance equations.

Every run (one stage in one direction) contributes one equation per balance angle
(rsp_inertia.estimation.balance, docs/method.md §5). Which unknowns those equations share
depends on the question: the body's tensor (rsp_inertia.estimation.tensor_fit) or the empty
fixture's harmonics, the drive's gains and the encoder's error
(rsp_inertia.estimation.calibration). Both build :class:`Block` s, named columns and a
right-hand side, and this module solves them the same way:

- **weights**: the covariance of a run's equations is the motor work's (the torque logs'
  own noise, rsp_inertia.estimation.passes) plus the speed noise's, 1/4 M_i M_j cov(S_i, S_j),
  M from a first unweighted pass and cov(S) from the smoothers' derived error
  autocovariance; the equations are whitened by its Cholesky factor
  (rsp_inertia.estimation.whitening);
- **speed-noise scale**: the derived speed part of each run is scaled by the factor that makes
  that run's own fit reach chi^2/dof = 1 (a real encoder adds line errors, a closed loop its
  regulator's jitter). A run's own fit can absorb a systematic misfit into that scale, so
  the runs are also checked against each other (rsp_inertia.estimation.model_tests);
- **known terms**: the right-hand side may depend on calibrated parameters theta (their
  calibration's estimate and covariance known, B = d rhs / d theta). They join the unknowns
  with their calibration as a prior: theta = theta_cal + S z, S a square root of cov(theta)
  and z ~ N(0, I) a priori (one pseudo-equation z = 0 each), so that the runs refine theta
  where they carry information on it (the drive's gains through the friction's share of the
  work, the encoder's error through its harmonics) and the estimate's covariance holds the
  calibration's uncertainty; where the runs know nothing of theta this is the linear
  propagation K B cov(theta) B^T K^T, K the GLS gain;
- **the torque's common scale is propagated, never estimated**: the balance equations are
  homogeneous in the body's terms and the torque's scale (every term of 1/2 M S + Pi = W
  scales with it, the known tares absorbed by the tensor's constant terms), so the runs
  carry no information on a common change of the drive's gains. A fit with fixed weights
  would still take one from them: the residuals' noise scales with the estimate while the
  weights do not, so it shrinks the scale toward zero (stating a torque gain's std of 1%
  without a calibration, it took the gains, and with them the tensor, 23% low). That
  direction of theta (``consider``, the gains' own values in their slots) is left out of
  the fitted columns and only propagated: its prior's unit variance reaches the estimate
  through the fit's response to its column (:func:`_consider_shift`), in its group's
  budget line, while the runs refine the rest of theta;
- **budget**: the covariance of the estimate split by independent noise source: each torque
  log, the encoder's speed noise, and the calibration by groups of theta (S is the Cholesky
  factor in the groups' order, so each group's line is what it adds to the ones before);
- **priors**: a block may carry a prior on some of its own unknowns (a run's friction slopes
  from its passes' dynamics, rsp_inertia.estimation.balance.friction_slope_prior): mean m and
  covariance C = L L^T give the pseudo-equations L^-1 x = L^-1 m, unit weight, in the joint fit
  (not in a run's own fit that sets its speed-noise scale, nor in the model tests, which keep
  those unknowns free). Each prior is tested against the balances: its pseudo-equations'
  residuals r, of covariance I - P cov_x P^T (P their rows), give chi^2 = r^T (I - P cov_x
  P^T)^-1 r on as many degrees of freedom as it has rows; the worst prior rejected at
  PRIOR_ALPHA is dropped, the fit made again without it and the rest tested again, and the
  fit says so (BalanceFit.prior_warnings).
  The priors' share of the covariance is the budget line PRIOR_SOURCE;
- **considered terms**: a block may carry columns of terms the runs are not asked to
  estimate (``Block.considered``: one standard deviation each, independent between blocks;
  a run's torque scale that may drift between its passes by device.toml's
  ``torque_constant_drift_std``): the fit's response to each, the whitened column solved
  against the joint fit's whitened design (pseudo-equations unchanged), is an error the fit
  cannot see, and its outer product joins the covariance as the column's budget line
  (:data:`DRIFT_SOURCE`): a consider parameter, as the torque's common scale is;
- **probes**: a block may declare the columns a suspected cause would add (a drive's loss,
  an encoder's error); the model tests say whether the runs call for them
  (rsp_inertia.estimation.model_tests).

Each step is a function: :func:`assemble_blocks` stacks the blocks' equations with their noise
model and the known terms (:class:`Equations`, shared by every fit of the same blocks),
:func:`speed_noise_scales` finds the runs' scales, :func:`solve_blocks` makes the joint fit
with given scales (its priors tested, its budget), :func:`block_model_tests` tests it;
:func:`predict_blocks` gives the covariance of a planned run's noise-free blocks.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg
from scipy.optimize import brentq
from scipy.stats import chi2 as chi2_distribution

from rsp_inertia.estimation.balance import StageBalance
from rsp_inertia.estimation.model_tests import (
    SCALE_CAP,
    SCALE_PROBES,
    ModelTest,
    run_model_tests,
)
from rsp_inertia.estimation.whitening import (
    Noise,
    scaled_band,
    weighted_chi2,
    whiten,
    whitened_rows,
    whiteners,
)
from rsp_inertia.infra.progress import report

__all__ = [
    "CALIBRATION_SOURCE",
    "DRIFT_SOURCE",
    "GAP_SOURCE",
    "NOISE_SOURCES",
    "PRIOR_ALPHA",
    "PRIOR_SOURCE",
    "BalanceFit",
    "Block",
    "Equations",
    "Prior",
    "assemble_blocks",
    "block_model_tests",
    "predict_blocks",
    "solve_blocks",
    "speed_noise_scales",
]

NOISE_SOURCES = ("braking torque log", "reverse torque log", "encoder (speed)", "encoder (work)")
"""The independent noise sources of the balance equations, for the uncertainty budget."""

CALIBRATION_SOURCE = "calibration"
"""Budget line of the calibrated terms (tare, fixture, torque gain)."""

GAP_SOURCE = "dropped samples (speed)"
"""Budget line of what the logs' gaps of dropped samples add to the smoothed speeds' noise
where the smoother bridges them (rsp_inertia.estimation.balance.StageBalance
.speed_sq_gap_band); present when a run has such a gap."""

PRIOR_SOURCE = "friction slopes"
"""Budget line of the blocks' priors (the runs' friction slopes from their passes' dynamics)."""

DRIFT_SOURCE = "torque scale between the passes"
"""Budget line of a torque scale that may drift between each run's braking and reverse pass
(device.toml ``[motor] torque_constant_drift_std``; Block.considered)."""

PRIOR_ALPHA = 1e-3
"""A block's prior whose chi^2 against the balances has a p-value below this is dropped
(module docstring, priors)."""


@dataclass(frozen=True)
class Prior:
    """A prior on some of a block's unknowns (module docstring, priors)."""

    names: tuple[str, ...]
    """The unknowns it bears on."""
    mean: np.ndarray
    """(k,) their prior means."""
    cov: np.ndarray
    """(k, k) their prior covariance, positive definite."""
    rejection: str = ""
    """The warning when the balances reject it, with ``{stat}``, ``{dof}`` and ``{p}`` to
    fill; '' for a run's friction slopes' (:func:`_rejected_priors`)."""


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
    work_scales: tuple[float, float] = (1.0, 1.0)
    """Factors on the braking's and the reverse's logged motor work in the equations (the
    drive's gain of each pass's power flow): they scale each torque log's noise covariance."""
    known_jacobian: np.ndarray | None = None
    """(n, p) d rhs / d theta for calibrated parameters theta, or None."""
    known_jacobian_inertia: np.ndarray | None = None
    """(n, p) the part of d rhs / d theta that is M(phi) times this (the encoder's error
    scales the kinetic energy M S / 2), M from the first unweighted pass; or None."""
    known_jacobian_angle: np.ndarray | None = None
    """(n, p) the part of d rhs / d theta that is the angle slope of the unknowns' side times
    this (an encoder zero's change turns the body's terms, rsp_inertia.estimation.known_terms
    .KnownTerms.jacobian_angle): the slope sum_name x[name] angle_slopes[name], x from the
    first unweighted pass; or None."""
    angle_slopes: dict[str, np.ndarray] = field(default_factory=dict)
    """Unknown name -> d column / d phi (n,), for the unknowns whose columns are functions of
    the angle (the tensor's entries, the gravity terms)."""
    inertia_scaled_columns: dict[str, np.ndarray] = field(default_factory=dict)
    """Unknown name -> its column per unit of M(phi): the column is M(phi) times this, M from
    a first pass without these unknowns (an encoder coefficient's, whose effect on the balance
    is proportional to the kinetic energy)."""
    probes: dict[str, dict[str, np.ndarray]] = field(default_factory=dict)
    """Cause -> {name: column} of the terms a suspected cause would add to the equations
    (rsp_inertia.estimation.model_tests probe tests)."""
    probes_per_inertia: dict[str, dict[str, np.ndarray]] = field(default_factory=dict)
    """The same for columns per unit of M(phi) (the first pass's M times these)."""
    probe_bounds: dict[str, float] = field(default_factory=dict)
    """Cause -> the largest value the physics allows its probe's one coefficient (a drive's
    loss: a round-trip efficiency of at most 1, rsp_inertia.estimation.columns
    .probe_bounds); the model tests take the probe's chi^2 drop at that bound beyond it."""
    groups: dict[str, str] = field(default_factory=dict)
    """Unknown name -> group label (e.g. the run) for the consistency tests."""
    fixed_in_tests: frozenset[str] = frozenset()
    """Unknowns the consistency tests hold at the joint estimate: a scale on the whole
    equation (the drive's gains h_d, h_b, with a right-hand side that is zero without the
    reference's known terms) would let a freed fit collapse to the trivial solution."""
    joint_only: frozenset[str] = frozenset()
    """Unknowns left out of the run's own fit that sets its speed-noise scale: terms that only
    the runs together determine (a friction asymmetry's work shape, alone in one run, would
    stand in for the kinetic energy and absorb the speed noise)."""
    priors: tuple[Prior, ...] = ()
    """Priors on the block's own unknowns (module docstring, priors)."""
    considered: dict[str, np.ndarray] = field(default_factory=dict)
    """Budget line -> (n,) the column of one standard deviation of a term the runs are not
    asked to estimate, independent between blocks (a torque scale that may drift between the
    run's passes, DRIFT_SOURCE): propagated, never fitted (module docstring, considered
    terms)."""


@dataclass(frozen=True)
class BalanceFit:
    """The solution of :func:`solve_blocks` (or :func:`predict_blocks`)."""

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
    tests: list[ModelTest] = field(default_factory=list)
    """The model tests (:func:`block_model_tests`), when they were made."""
    labels: list[str] = field(default_factory=list)
    """Per block, its label."""
    known_shift: np.ndarray | None = None
    """theta - theta_cal: how far the runs move the calibrated terms from their calibration
    (module docstring, known terms); None without known terms."""
    known_shift_cov: np.ndarray | None = None
    """Covariance of theta after the runs (the calibration's and theirs together)."""
    prior_warnings: list[str] = field(default_factory=list)
    """One line per prior the balances rejected (module docstring, priors)."""
    z: np.ndarray = field(default_factory=lambda: np.zeros(0))
    """The calibrated terms' standardised shift (module docstring, known terms:
    theta = theta_cal + S z); empty without known terms."""
    z_cov: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    """Covariance of ``z`` from the joint fit (I a priori): below I where the runs carry
    information on theta; I along the ``consider`` direction, which only its prior sets."""
    factors: list = field(default_factory=list, repr=False)
    """The equations' whiteners at ``scales`` (rsp_inertia.estimation.whitening), for the
    model tests (:func:`block_model_tests`)."""

    def index(self, name: str) -> int:
        """Position of unknown ``name``."""
        return self.names.index(name)

    def value(self, name: str) -> tuple[float, float]:
        """(estimate, std) of ``name``; (nan, nan) if it was not fitted."""
        if name not in self.names:
            return math.nan, math.nan
        i = self.names.index(name)
        return float(self.x[i]), float(math.sqrt(self.cov[i, i]))


def _used(A: np.ndarray) -> np.ndarray:
    """Columns with any non-zero entry."""
    return np.nonzero(np.any(A != 0.0, axis=0))[0]


def _calibrated_scale(A, y, work_cov: Noise, speed_var: Noise) -> float:
    """The speed noise's scale s that makes one run's own fit reach chi^2/dof = 1.

    A root in log s on [1/SCALE_CAP, SCALE_CAP] (Brent); the bound where chi^2/dof stays on
    one side.
    """
    lo, hi = 1.0 / SCALE_CAP, SCALE_CAP

    def chi2_dof(scale: float) -> float:
        factors = whiteners([work_cov + speed_var.times(scale)])
        value, rank, _ = weighted_chi2(A, y, factors)
        return value / max(whitened_rows(factors) - rank, 1)

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


def _budget(Aw, factors, parts: list[Noise], cov_x) -> np.ndarray:
    """cov_x H^T (D C_part D^T) H cov_x, H = W^T Aw: the share of one noise source in cov_x.

    The estimate is x = cov_x Aw^T W D y (rsp_inertia.estimation.whitening: W whitens the
    run's differenced equations D y), so a source of covariance C_part in y reaches x as
    above; with C = sum of the parts, the shares sum to cov_x = (Aw^T Aw)^-1.
    """
    inner, start = np.zeros((Aw.shape[1], Aw.shape[1])), 0
    for factor, part in zip(factors, parts):
        m = factor.n_out
        inner += part.quadratic(factor.transpose_whiten(Aw[start : start + m]))
        start += m
    return cov_x @ inner @ cov_x


def _matrix(
    blocks: list[Block], names: list[str], inertia: list[np.ndarray] | None = None
) -> np.ndarray:
    """Stack the blocks' named columns into a matrix with the columns ``names``; a block's
    inertia-scaled columns times its ``inertia`` M(phi) (zeros without it)."""
    rows = []
    for k, block in enumerate(blocks):
        n = len(block.rhs)
        cols = dict(block.columns)
        for name, col in block.inertia_scaled_columns.items():
            cols[name] = col * inertia[k] if inertia is not None else np.zeros(n)
        rows.append(np.column_stack([cols.get(name, np.zeros(n)) for name in names]))
    return np.vstack(rows)


def _inertia(blocks: list[Block], names: list[str], x: np.ndarray) -> list[np.ndarray]:
    """Each block's M(phi) = inertia_known + sum x[name] inertia_columns[name]."""
    return [
        block.inertia_known
        + sum(x[names.index(k)] * c for k, c in block.inertia_columns.items() if k in names)
        for block in blocks
    ]


def _known_jacobian(
    block: Block, M: np.ndarray, p: int, names: list[str], x: np.ndarray
) -> np.ndarray:
    """(n, p) d rhs / d theta of a block, its M-proportional part with the block's M(phi) and
    its angle-slope part with the slope of the unknowns' side at ``x`` (named ``names``)."""
    B = np.zeros((len(block.rhs), p)) if block.known_jacobian is None else block.known_jacobian
    if block.known_jacobian_inertia is not None:
        B = B + M[:, None] * block.known_jacobian_inertia
    if block.known_jacobian_angle is not None:
        slope = sum(
            (x[names.index(k)] * c for k, c in block.angle_slopes.items() if k in names),
            np.zeros(len(block.rhs)),
        )
        B = B + slope[:, None] * block.known_jacobian_angle
    return B


def _prior_root(
    cov: np.ndarray,
    groups: dict[str, list[int]],
    shares: dict[str, np.ndarray] | None = None,
) -> tuple[np.ndarray, list[str]]:
    """(S, group of each column): cov = S S^T, the parameters of zero variance left out
    (their columns dropped).

    ``shares`` (name -> a (p, p) part of ``cov``) are budget lines that are parts of the
    whole covariance rather than groups of parameters (a reference certificate, which moves
    every calibrated term at once): their columns come first, each part's eigen-root. The
    rest, ``cov`` less the shares, is split by ``groups``: its Cholesky factor in the
    groups' order, so that each group's columns carry what that group adds to the groups
    before it, and the shares of an estimate's variance add up to the whole (module
    docstring, budget). The factor is taken in the correlation scale of ``cov``, with a
    relative ridge of 1e-12 (parameters of very different units, some fully correlated).
    """
    p = cov.shape[0]
    columns, names = [np.zeros((p, 0))], []
    rest = cov
    for name, part in (shares or {}).items():
        values, vectors = np.linalg.eigh(0.5 * (part + part.T))
        kept = values > 1e-12 * max(float(values.max()), 0.0)
        if values.max() > 0.0 and kept.any():
            columns.append(vectors[:, kept] * np.sqrt(values[kept]))
            names += [name] * int(kept.sum())
        rest = rest - part
    order = [(name, i) for name, indices in groups.items() for i in indices if cov[i, i] > 0]
    if order:
        idx = [i for _, i in order]
        d = np.sqrt(np.diag(cov)[idx])
        corr = rest[np.ix_(idx, idx)] / np.outer(d, d)
        L = np.linalg.cholesky(0.5 * (corr + corr.T) + 1e-12 * np.eye(len(idx)))
        S = np.zeros((p, len(idx)))
        S[idx] = d[:, None] * L
        columns.append(S)
        names += [name for name, _ in order]
    return np.hstack(columns), names


@dataclass(frozen=True)
class Equations:
    """The blocks' equations stacked, with their noise model and the calibrated terms as
    unknowns: what every fit of the same blocks shares (:func:`assemble_blocks`).

    Each run's constant is profiled out with its last equation (the whitening takes the
    equations' differences, rsp_inertia.estimation.whitening), so its column is left out of
    ``A``: a column constant within every block carries nothing there.
    """

    blocks: list[Block]
    """One per run."""
    names: list[str]
    """The unknowns, in the order of ``A``'s columns."""
    y: np.ndarray
    """The stacked right-hand sides."""
    rows: np.ndarray
    """Each block's first row in ``y``, and the total at the end."""
    A: np.ndarray
    """The stacked design matrix over ``names``."""
    N: np.ndarray
    """(len(y), q) the calibrated terms' columns -B S (module docstring, known terms), with
    the ``consider`` direction taken out (``N (I - a a^T)``)."""
    A_all: np.ndarray
    """[A, N]: the joint fit's design matrix."""
    S: np.ndarray | None
    """(p, q) the square root of theta's covariance (None without known terms)."""
    prior_groups: list[str]
    """The budget line of each column of ``S``."""
    inertia: list[np.ndarray]
    """Per block, M(phi) from a first unweighted pass (the speed noise's weights)."""
    work_parts: list[tuple[Noise, Noise, Noise]]
    """Per block, the braking log's, the reverse log's and the encoder's work noise."""
    work_cov: list[Noise]
    """Per block, the work's noise: the sum of ``work_parts``."""
    speed_var: list[Noise]
    """Per block, the speed noise at scale 1: the sum of ``speed_parts``."""
    priors: list[tuple[int, Prior]]
    """(block, prior) of the blocks' priors whose unknowns are all fitted."""
    speed_parts: list[tuple[Noise, Noise]] = field(default_factory=list)
    """Per block, the speed noise's stationary part and its gaps' (GAP_SOURCE; empty without
    gaps), at scale 1."""
    consider: np.ndarray | None = None
    """(q,) the unit direction a of z that moves theta along the torque's common scale
    (module docstring), propagated, not fitted; None: no such direction (the gains exact)."""
    consider_column: np.ndarray | None = None
    """(len(y),) its column ``N a`` (the calibrated terms' columns before it was taken out)."""

    @property
    def q(self) -> int:
        """The calibrated terms' standardised unknowns z."""
        return self.N.shape[1]

    @property
    def n_x(self) -> int:
        """The unknowns of ``names``."""
        return self.A.shape[1]

    @property
    def joint(self) -> list[int]:
        """Columns of ``A`` of the unknowns some block fits only jointly (Block.joint_only)."""
        return [
            j for j, name in enumerate(self.names) if any(name in b.joint_only for b in self.blocks)
        ]


@dataclass(frozen=True)
class _Solution:
    """One weighted joint fit (:func:`_joint_fit`)."""

    factors: list
    """The equations' whiteners."""
    Aw: np.ndarray
    """The whitened equations, then the pseudo-equations of the calibrated terms' prior and
    of the blocks' priors."""
    yw: np.ndarray
    """Their right-hand side."""
    x: np.ndarray
    """The unknowns of ``names``, then z."""
    cov_x: np.ndarray
    """Covariance of ``x`` ((Aw^T Aw)^-1)."""


def assemble_blocks(
    blocks: list[Block],
    known_cov: np.ndarray | None = None,
    known_groups: dict[str, list[int]] | None = None,
    consider: np.ndarray | None = None,
    known_shares: dict[str, np.ndarray] | None = None,
) -> Equations:
    """The blocks' equations for the fits (module docstring): stacked, with the noise model's
    parts from a first unweighted pass and the calibrated terms as unknowns.

    Parameters
    ----------
    blocks : list of Block
        One per run.
    known_cov : array, shape (p, p), optional
        Covariance of the calibrated parameters theta that the blocks' ``known_jacobian``
        refers to (module docstring: they join the unknowns with this prior).
    known_groups : dict of str to list of int, optional
        Budget lines of theta: name -> its indices, in the order the budget adds them
        (default: one line, CALIBRATION_SOURCE, for all of theta).
    consider : array, shape (p,), optional
        A direction of theta the runs carry no information on (module docstring: the
        torque's common scale), propagated, not estimated; None, or one the prior gives no
        variance: every direction of theta is refined.
    known_shares : dict of str to array, optional
        Budget lines that are parts of ``known_cov`` rather than groups of its parameters
        (name -> (p, p) part; the reference certificate's share of a calibration's
        covariance): each its own line, before the groups, which split the rest.

    Returns
    -------
    Equations
        The equations every fit of these blocks shares.
    """
    names = list(dict.fromkeys(name for block in blocks for name in block.columns))
    y = np.concatenate([block.rhs for block in blocks])
    rows = np.cumsum([0] + [len(block.rhs) for block in blocks])
    inertia = None
    scaled = list(dict.fromkeys(n for block in blocks for n in block.inertia_scaled_columns))
    if scaled:  # their columns are M(phi) times theirs: M from a first pass without them
        x_pre, *_ = np.linalg.lstsq(_matrix(blocks, names), y, rcond=None)
        inertia = _inertia(blocks, names, x_pre)
        names += [n for n in scaled if n not in names]
    A = _matrix(blocks, names, inertia)
    # First pass, unweighted: the reduced inertia at each angle for the speed-noise weights.
    x0, *_ = np.linalg.lstsq(A, y, rcond=None)
    inertia = _inertia(blocks, names, x0)
    speed_var, speed_parts, work_parts = [], [], []
    for block, M in zip(blocks, inertia):
        n = len(block.rhs)
        gap_band = block.balance.speed_sq_gap_band
        parts = (
            Noise(n, band=scaled_band(block.balance.speed_sq_band, 0.5 * M)),
            Noise(n) if gap_band is None else Noise(n, band=scaled_band(gap_band, 0.5 * M)),
        )
        speed_parts.append(parts)
        speed_var.append(parts[0] + parts[1])
        hb2, hr2 = (scale**2 for scale in block.work_scales)
        work_parts.append(
            (
                block.balance.braking_work_noise.times(hb2),
                block.balance.reverse_work_noise.times(hr2),
                block.balance.encoder_work_noise(block.work_scales),
            )
        )
    work_cov = [sum(parts, Noise(len(block.rhs))) for parts, block in zip(work_parts, blocks)]

    # Calibrated terms: unknowns z with the prior z = 0 +- 1 (module docstring, known terms).
    N = np.zeros((len(y), 0))
    prior_groups: list[str] = []
    p = 0 if known_cov is None else known_cov.shape[0]
    if p and any(
        b.known_jacobian is not None or b.known_jacobian_inertia is not None for b in blocks
    ):
        B = np.vstack([_known_jacobian(b, M, p, names, x0) for b, M in zip(blocks, inertia)])
        groups = known_groups or {CALIBRATION_SOURCE: list(range(p))}
        S, prior_groups = _prior_root(known_cov, groups, known_shares)
        N = -B @ S  # rhs(theta_cal + S z) = rhs + B S z: on the unknowns' side, -B S z
        direction, column = _consider_direction(S, consider, N)
        if direction is not None:
            N = N - np.outer(column, direction)
    else:
        S = None
        direction = column = None
    # Each run's constant is profiled out with its last equation (class Equations).
    constant = [
        j
        for j in range(A.shape[1])
        if np.any(A[:, j] != 0.0)
        and all(np.ptp(A[rows[k] : rows[k + 1], j]) == 0.0 for k in range(len(blocks)))
    ]
    if constant:
        names = [name for j, name in enumerate(names) if j not in constant]
        A = np.delete(A, constant, axis=1)
    priors = [(k, prior) for k, block in enumerate(blocks) for prior in block.priors]
    priors = [(k, prior) for k, prior in priors if all(n in names for n in prior.names)]
    return Equations(
        blocks=blocks,
        names=names,
        y=y,
        rows=rows,
        A=A,
        N=N,
        consider=direction,
        consider_column=column,
        A_all=np.hstack([A, N]),
        S=S,
        prior_groups=prior_groups,
        inertia=inertia,
        work_parts=work_parts,
        work_cov=work_cov,
        speed_var=speed_var,
        speed_parts=speed_parts,
        priors=priors,
    )


def _consider_direction(
    S: np.ndarray, consider: np.ndarray | None, N: np.ndarray
) -> tuple[np.ndarray | None, np.ndarray | None]:
    """The unit direction a of z with S a along ``consider`` (module docstring) and its
    column N a; (None, None) without one or when S cannot reach it (its terms exact)."""
    if consider is None or S.shape[1] == 0 or not np.any(consider):
        return None, None
    a, *_ = np.linalg.lstsq(S, consider, rcond=None)
    if np.linalg.norm(S @ a - consider) > 1e-9 * np.linalg.norm(consider):
        return None, None
    a /= np.linalg.norm(a)
    return a, N @ a


def _own_scales(
    eq: Equations, y_own: np.ndarray, extra: np.ndarray | None = None
) -> list[float]:
    """Each run's own fit (its own unknowns, joint-only ones left out, and the used columns
    of ``extra``) sets its scale."""
    scales = []
    for k, block in enumerate(eq.blocks):
        report("least squares: each run's speed-noise scale", k, len(eq.blocks))
        mine = slice(eq.rows[k], eq.rows[k + 1])
        own = [j for j in _used(eq.A[mine]) if eq.names[j] not in block.joint_only]
        A_own = eq.A[mine][:, own]
        if extra is not None:
            A_own = np.hstack([A_own, extra[mine][:, _used(extra[mine])]])
        scales.append(_calibrated_scale(A_own, y_own[mine], eq.work_cov[k], eq.speed_var[k]))
    return scales


def _whiteners(eq: Equations, scales: list[float]) -> list:
    """The equations' whiteners with the speed noise scaled per run by ``scales``."""
    return whiteners([w + v.times(s) for w, v, s in zip(eq.work_cov, eq.speed_var, scales)])


def _joint_fit(eq: Equations, scales: list[float], priors: list[tuple[int, Prior]]) -> _Solution:
    """The weighted joint fit of every block with the speed-noise scales ``scales``, the
    calibrated terms' prior and the blocks' ``priors``."""
    factors = _whiteners(eq, scales)
    Aw, yw = whiten(eq.A_all, factors), whiten(eq.y, factors)
    q, n_x = eq.q, eq.n_x
    if q:  # the prior's pseudo-equations z = 0, unit weight
        Aw = np.vstack([Aw, np.hstack([np.zeros((q, n_x)), np.eye(q)])])
        yw = np.concatenate([yw, np.zeros(q)])
    if priors:  # the blocks' priors' pseudo-equations (module docstring, priors)
        P, m = _prior_rows([prior for _, prior in priors], eq.names, n_x + q)
        Aw, yw = np.vstack([Aw, P]), np.concatenate([yw, m])
    return _Solution(factors, Aw, yw, *_weighted_solution(Aw, yw))


def _off_joint(eq: Equations, x: np.ndarray, z: np.ndarray) -> np.ndarray:
    """The right-hand side with the joint-only terms and the calibrated ones at the joint
    estimate (``x`` of the unknowns, ``z`` of the calibrated terms) taken off: what each
    run's own fit is left with."""
    joint = eq.joint
    return eq.y - eq.A[:, joint] @ x[joint] - eq.N @ z


def speed_noise_scales(eq: Equations) -> list[float]:
    """Each run's speed-noise scale: the factor on its derived speed-error covariance that
    makes its own fit reach chi^2/dof = 1 (module docstring).

    The joint-only terms and the calibrated ones, which a run's own fit cannot take, are
    taken off its equations at a joint fit's estimate (else they would inflate its scale).

    Parameters
    ----------
    eq : Equations
        The blocks' equations (:func:`assemble_blocks`).

    Returns
    -------
    list of float
        Per block, the scale, within [1/SCALE_CAP, SCALE_CAP].
    """
    scales = _own_scales(eq, eq.y)
    if eq.joint or eq.q:
        x = _joint_fit(eq, scales, eq.priors).x
        scales = _own_scales(eq, _off_joint(eq, x[: eq.n_x], x[eq.n_x :]))
    return scales


def solve_blocks(eq: Equations, scales: list[float]) -> BalanceFit:
    """Generalised least squares over the blocks (module docstring), without the model tests
    (:func:`block_model_tests`).

    Raises nothing on a misfit: whatever the noise model leaves in the joint fit's chi^2/dof
    above 1 inflates the covariance, and the model tests say whether the runs agree. A
    block's prior that the balances reject is dropped (module docstring, priors).

    Parameters
    ----------
    eq : Equations
        The blocks' equations (:func:`assemble_blocks`).
    scales : list of float
        The runs' speed-noise scales (:func:`speed_noise_scales`; or an earlier fit's of the
        same runs: a calibration's repeated fit on the corrected logs, whose scales were
        already taken with the correction's terms off the runs' own fits).

    Returns
    -------
    BalanceFit
        The unknowns' estimate and covariance with its budget, and the rejected priors.
    """
    priors = eq.priors
    solution = _joint_fit(eq, scales, priors)
    n_data = whitened_rows(solution.factors)  # a run's last equation went with its constant
    prior_warnings = []
    while priors:
        # The worst rejected prior is dropped and the others tested again without it (a prior
        # far off pulls the fit, and with it the residuals of the others).
        rejected = _rejected_priors(
            priors, solution.Aw, solution.yw, solution.x, solution.cov_x, n_data + eq.q,
            eq.blocks,
        )
        if not rejected:
            break
        worst, line = min(rejected, key=lambda found: found[2])[:2]
        prior_warnings.append(line)
        priors = [(k, prior) for k, prior in priors if prior is not worst]
        solution = _joint_fit(eq, scales, priors)
    return _balance_fit(eq, scales, solution, bool(priors), prior_warnings, predicted=False)


def predict_blocks(eq: Equations) -> BalanceFit:
    """The covariance the noise model alone implies for noise-free balances of a planned run
    (rsp_inertia.estimation.predict): every speed-noise scale 1, no inflation by the
    residuals (which are zero), every prior kept.

    Parameters
    ----------
    eq : Equations
        The planned blocks' equations (:func:`assemble_blocks`).

    Returns
    -------
    BalanceFit
        The unknowns' estimate and their predicted covariance with its budget.
    """
    scales = [1.0] * len(eq.blocks)
    solution = _joint_fit(eq, scales, eq.priors)
    return _balance_fit(eq, scales, solution, bool(eq.priors), [], predicted=True)


def _balance_fit(
    eq: Equations,
    scales: list[float],
    solution: _Solution,
    with_priors: bool,
    prior_warnings: list[str],
    predicted: bool,
) -> BalanceFit:
    """The fit's chi^2/dof, covariance and budget (module docstring) from a joint fit: the
    runs' share inflated by chi^2/dof above 1 unless ``predicted``; ``with_priors``: the
    blocks' priors' pseudo-equations follow the calibration's."""
    factors, Aw, yw, x, cov_x = (
        solution.factors, solution.Aw, solution.yw, solution.x, solution.cov_x
    )
    q, n_x = eq.q, eq.n_x
    n_data = whitened_rows(factors)  # a run's last equation went with its constant
    r = (yw - Aw @ x)[: n_data + q]  # the balances and the calibration's prior
    dof = max(n_data - n_x, 1)
    chi2_dof = float(r @ r / dof)
    work_parts = eq.work_parts
    sources = {
        NOISE_SOURCES[0]: [parts[0] for parts in work_parts],
        NOISE_SOURCES[1]: [parts[1] for parts in work_parts],
        NOISE_SOURCES[2]: [v.times(s) for s, v in zip(scales, eq.speed_var)],
        NOISE_SOURCES[3]: [parts[2] for parts in work_parts],
    }
    if any(gap.band is not None for _, gap in eq.speed_parts):
        sources[NOISE_SOURCES[2]] = [v.times(s) for s, (v, _) in zip(scales, eq.speed_parts)]
        sources[GAP_SOURCE] = [g.times(s) for s, (_, g) in zip(scales, eq.speed_parts)]
    # Whatever the noise model leaves unexplained in the joint fit inflates the covariance
    # (of the runs' noise: the calibration's prior is what it is).
    inflation = 1.0 if predicted else max(chi2_dof, 1.0)
    Aw_data = Aw[:n_data]
    cov_parts = {
        name: _budget(Aw_data, factors, parts, cov_x)[:n_x, :n_x] * inflation
        for name, parts in sources.items()
    }
    for name in dict.fromkeys(eq.prior_groups):  # each group's pseudo-equations
        rows_g = n_data + np.array([j for j, g in enumerate(eq.prior_groups) if g == name])
        P = Aw[rows_g]
        cov_parts[name] = (cov_x @ P.T @ P @ cov_x)[:n_x, :n_x]
    z_cov = z_fit_cov = cov_x[n_x:, n_x:]
    if eq.consider is not None:  # the common scale, propagated (module docstring)
        shift = _consider_shift(eq, solution)
        group = eq.prior_groups[int(np.argmax(np.abs(eq.consider)))]
        cov_parts[group] = cov_parts[group] + np.outer(shift[:n_x], shift[:n_x])
        z_shift = shift[n_x:] - eq.consider
        z_cov = z_cov - np.outer(eq.consider, eq.consider) + np.outer(z_shift, z_shift)
    if with_priors:  # the blocks' priors' pseudo-equations, after the calibration's
        P = Aw[n_data + q :]
        cov_parts[PRIOR_SOURCE] = (cov_x @ P.T @ P @ cov_x)[:n_x, :n_x]
    for source, shifts in _considered_shifts(eq, solution).items():
        cov_parts[source] = shifts[:n_x] @ shifts[:n_x].T
    cov = sum(cov_parts.values())
    known_shift = known_shift_cov = None
    if eq.S is not None:
        known_shift = eq.S @ x[n_x:]
        known_shift_cov = eq.S @ z_cov @ eq.S.T
    return BalanceFit(
        names=eq.names,
        x=x[:n_x],
        cov=cov,
        cov_parts=cov_parts,
        chi2_dof=chi2_dof,
        scales=scales,
        n_equations=len(eq.y),
        labels=[block.label for block in eq.blocks],
        known_shift=known_shift,
        known_shift_cov=known_shift_cov,
        prior_warnings=prior_warnings,
        z=x[n_x:],
        z_cov=z_fit_cov,
        factors=factors,
    )


def _responses(solution: _Solution, columns: np.ndarray) -> np.ndarray:
    """(n_x + q, k) the joint fit's response to ``columns`` (len(y), k) added to the balances'
    right-hand side: whitened as the balances are, the pseudo-equations unchanged (a
    consider parameter's share of the covariance is its outer product)."""
    factors, Aw = solution.factors, solution.Aw
    C = np.zeros((Aw.shape[0], columns.shape[1]))
    C[: whitened_rows(factors)] = whiten(columns, factors)
    scale = np.linalg.norm(Aw, axis=0)
    scale[scale == 0.0] = 1.0
    steps, *_ = np.linalg.lstsq(Aw / scale, C, rcond=None)
    return steps / scale[:, None]


def _considered_shifts(eq: Equations, solution: _Solution) -> dict[str, np.ndarray]:
    """Budget line -> (n_x + q, k) what one std of each block's considered term moves the
    joint fit's estimate by (module docstring, considered terms): :func:`_responses` to its
    column, one per block that has it."""
    sources = dict.fromkeys(src for block in eq.blocks for src in block.considered)
    out = {}
    for source in sources:
        columns = []
        for k, block in enumerate(eq.blocks):
            if source in block.considered:
                column = np.zeros(len(eq.y))
                column[eq.rows[k] : eq.rows[k + 1]] = block.considered[source]
                columns.append(column)
        out[source] = _responses(solution, np.column_stack(columns))
    return out


def _consider_shift(eq: Equations, solution: _Solution) -> np.ndarray:
    """What a unit step of z along ``eq.consider`` moves the joint fit's estimate by (x, then
    z): :func:`_responses` to the column it adds to the balances. With the step itself it is
    the error a unit of that prior leaves, whose outer product is its share of the
    covariance."""
    return _responses(solution, eq.consider_column[:, None])[:, 0]


def block_model_tests(eq: Equations, fit: BalanceFit) -> list[ModelTest]:
    """The model tests of a fit of the blocks (rsp_inertia.estimation.model_tests): the runs
    against each other, early against late turns, per turn, and the blocks' probes.

    Parameters
    ----------
    eq : Equations
        The blocks' equations (:func:`assemble_blocks`).
    fit : BalanceFit
        Their fit (:func:`solve_blocks`).

    Returns
    -------
    list of ModelTest
        One per test made.
    """
    report("least squares: model tests", 0.0)
    nuisance = (eq.N, eq.q) if eq.q else None
    probes = _probe_matrices(eq.blocks, eq.inertia)
    bounds = {c: b for block in eq.blocks for c, b in block.probe_bounds.items()}
    model_tests = run_model_tests(
        eq.blocks, eq.names, eq.A, eq.y, fit.x, fit.factors, nuisance, probes,
        probe_bounds=bounds,
    )
    if any(t.significant for t in model_tests if t.kind in probes or t.kind == SCALE_PROBES):
        # A named cause's misfit inflates every run's speed-noise scale, which then hides
        # another cause: the probe tests again with the scales of runs whose own fits
        # have every probe's columns.
        y_own = _off_joint(eq, fit.x, fit.z)
        probe_scales = _own_scales(eq, y_own, np.hstack(list(probes.values())))
        model_tests = run_model_tests(
            eq.blocks, eq.names, eq.A, eq.y, fit.x, fit.factors, nuisance, probes,
            _whiteners(eq, probe_scales), bounds,
        )
    return model_tests


def _prior_rows(priors: list[Prior], names: list[str], width: int):
    """The priors' whitened pseudo-equations L^-1 x = L^-1 m (C = L L^T) over the unknowns
    ``names`` (then zeros up to ``width`` columns): rows (k, width) and right-hand side (k,)."""
    rows, rhs = [], []
    for prior in priors:
        L = np.linalg.cholesky(prior.cov)
        E = np.zeros((len(prior.names), width))
        E[np.arange(len(prior.names)), [names.index(n) for n in prior.names]] = 1.0
        rows.append(scipy.linalg.solve_triangular(L, E, lower=True))
        rhs.append(scipy.linalg.solve_triangular(L, prior.mean, lower=True))
    return np.vstack(rows), np.concatenate(rhs)


def _rejected_priors(priors, Aw, yw, x, cov_x, start: int, blocks: list[Block]):
    """(prior, warning, p-value) of each prior whose pseudo-equations (rows from ``start`` of
    the whitened system, in the order of ``priors``) the balances reject at PRIOR_ALPHA
    (module docstring, priors)."""
    rejected, row = [], start
    for k, prior in priors:
        P = Aw[row : row + len(prior.names)]
        r = yw[row : row + len(prior.names)] - P @ x
        row += len(prior.names)
        spread = np.eye(len(r)) - P @ cov_x @ P.T
        stat = float(r @ np.linalg.lstsq(spread, r, rcond=None)[0])
        p_value = float(chi2_distribution.sf(max(stat, 0.0), len(r)))
        if p_value < PRIOR_ALPHA and prior.rejection:
            line = prior.rejection.format(stat=f"{stat:.3g}", dof=len(r), p=f"{p_value:.2g}")
            rejected.append((prior, line, p_value))
        elif p_value < PRIOR_ALPHA:
            slopes = ", ".join(f"{v:.3g}" for v in prior.mean)
            line = (
                f"{blocks[k].label}: the friction slopes its passes' dynamics give ({slopes}) "
                f"disagree with its balances (chi2 = {stat:.3g} for {len(r)}, "
                f"p = {p_value:.2g}); its tracking mismatch's friction is taken from the "
                "balances alone, at a cost in the stds (friction that differs between the "
                "directions of rotation, or a drive loss, does this)"
            )
            rejected.append((prior, line, p_value))
    return rejected


def _probe_matrices(blocks: list[Block], inertia: list[np.ndarray]) -> dict[str, np.ndarray]:
    """Cause -> the stacked columns its probe adds (Block.probes, and probes_per_inertia
    times each block's M), zeros in the blocks that do not declare it."""
    causes = list(
        dict.fromkeys(c for b in blocks for c in (*b.probes, *b.probes_per_inertia))
    )
    out = {}
    for cause in causes:
        names = list(
            dict.fromkeys(
                n
                for b in blocks
                for n in (*b.probes.get(cause, {}), *b.probes_per_inertia.get(cause, {}))
            )
        )
        rows = []
        for block, M in zip(blocks, inertia):
            cols = dict(block.probes.get(cause, {}))
            for name, col in block.probes_per_inertia.get(cause, {}).items():
                cols[name] = M * col
            n = len(block.rhs)
            rows.append(np.column_stack([cols.get(name, np.zeros(n)) for name in names]))
        out[cause] = np.vstack(rows)
    return out


