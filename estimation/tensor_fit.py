"""The tensor from the runs' balances: one least squares over every run's balance angles.

Least squares over many turns (docs/method.md §5). With w(phi) = (lam sin phi, lam cos phi, 1),
(1 + lam^2) J_e(phi) = w^T J w = v(phi) . [Jx Jy Jz Jxy Jyz Jxz], v the design-matrix row of
the unnormalised w (docs/method.md §2: the harmonic form of M per stage written in the tensor's
entries, so that all stages share one set of unknowns; rsp_inertia.plant.model.tensor_basis
gives these rows from the model's M, rsp_inertia.plant.model.gravity_basis the gravity
columns from its Pi). Each balance angle of a run (one
stage, one direction of rotation) gives

    1/2 S v(phi) . J + 2 Gs sin phi + 2 Gc cos phi - C_run - d . R - dir e_s . Q
        = h_d W_d(phi) + h_b W_b(phi) - 2 Pi_spring - 1/2 S M_empty(phi) - 2 Pi_fixture(phi)

(rsp_inertia.estimation.balance), linear in the six entries, the gravity terms Gs = m g x_c,
Gc = m g y_c shared by all runs, one constant per run, per run the two slopes d of the
friction torque that the closed loop's tracking mismatch leaves in the balance (regressors R),
and, for a stage run in both directions, its friction asymmetry e_s (regressors Q, sign
dir = +1 forward, -1 backward: the first-order effect of a friction that differs between the
directions of rotation cancels between the runs; the columns every run has:
rsp_inertia.estimation.columns). The right-hand side holds what the rig's calibration knows
(rsp_inertia.estimation.known_terms.KnownTerms): the drive's gains h_d, h_b on the logged
motor work's driving and back-driven parts W_d, W_b (docs/method.md §3, encoder and drive),
the empty system's reduced inertia M_empty (tare and fixture), the fixture's gravity and the
encoder's error (taken off the readings before the balances); without a calibration,
device.toml's tare as exact. The calibrated terms also join the unknowns with their
calibration as prior, and the model tests' probes look for a drive's loss and an encoder's
error left in the runs (rsp_inertia.estimation.model_tests.probe_detail). Weights, the
speed-noise scale, the model tests and the uncertainty budget: rsp_inertia.estimation.gls.
The tensor's axes and the axes' tensor: rsp_inertia.estimation.axes.

A run whose braking held two levels (device.toml ``braking_torque_2``) has one more unknown,
its pass gain d (:func:`pass_gain_unknown`): the body received 1 + d times the reverse
pass's logged torque against the braking's scale (a motor that warms between the passes),
the column -h W_r(phi) of the reverse's work. One braking torque leaves d separable from
the tensor only through the friction's speed dependence; two levels give the contrast
(docs/method.md, "A torque scale that differs between the passes").
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from rsp_inertia.estimation.balance import StageBalance
from rsp_inertia.estimation.columns import (
    WARMING_UNKNOWN,
    asymmetry_unknowns,
    both_directions,
    cause_probes,
    gravity_row_slopes,
    gravity_rows,
    probe_bounds,
    run_columns,
    run_key,
    run_label,
    run_priors,
    slope_unknowns,
)
from rsp_inertia.estimation.gls import (
    DRIFT_SOURCE,
    GAP_SOURCE,
    NOISE_SOURCES,
    BalanceFit,
    Block,
    Equations,
    assemble_blocks,
    block_model_tests,
    predict_blocks,
    solve_blocks,
    speed_noise_scales,
)
from rsp_inertia.estimation.known_terms import KnownTerms
from rsp_inertia.estimation.layout import SHARED_LAYOUT
from rsp_inertia.estimation.model_tests import ModelTest, described
from rsp_inertia.plant.geometry import ENTRY_KEYS, GRAVITY_NAMES
from rsp_inertia.plant.model import inertia_basis, tensor_basis, tensor_basis_slope

__all__ = [
    "PASS_GAIN_SOURCE",
    "WARMING_UNKNOWN",
    "TensorFit",
    "angle_slopes",
    "balance_rhs",
    "drift_column",
    "fit_tensor",
    "pass_gain_unknown",
    "predict_tensor",
    "tensor_block",
]

ENTRIES = SHARED_LAYOUT.slice("entries")
"""The tensor's entries among the shared unknowns [entries, gravity] (TensorFit.cov)."""
GRAVITY = SHARED_LAYOUT.slice("gravity")
"""The gravity terms among the shared unknowns."""


@dataclass(frozen=True)
class TensorFit:
    """Result of the least squares over every stage's balance angles."""

    entries: np.ndarray
    """[Jx, Jy, Jz, Jxy, Jyz, Jxz], kg m^2 (products as tensor entries)."""
    gravity: np.ndarray
    """[Gs, Gc] = m g [x_c, y_c], N m."""
    cov: np.ndarray
    """(8, 8) joint covariance of [entries, gravity] (kg^2 m^4, kg m^2 N m, N^2 m^2): the
    least squares solves them together, so their errors correlate (a combination of
    mountings needs the whole matrix, rsp_inertia.estimation.combine)."""
    chi2_dof: float
    """Residual chi^2 per degree of freedom of the weighted fit (1 when the noise model fits)."""
    speed_noise_scale: list[float]
    """Per run, the factor on the derived speed-error covariance that makes the run's own
    fit reach chi^2/dof = 1 (rsp_inertia.estimation.gls)."""
    n_equations: int
    """Balance angles used, all runs."""
    friction_slope: np.ndarray
    """(runs, 2) [d1, d2] of D'(Omega) = d1 + d2 Omega per run (N m s, N m s^2), from the
    tracking mismatch; NaN for a run with exactly no mismatch (exact data)."""
    friction_slope_std: np.ndarray
    """(runs, 2)."""
    friction_slope_cov: np.ndarray
    """(runs, 2, 2) covariance of each run's [d1, d2] (NaN where not fitted)."""
    mismatch_terms: list[bool]
    """Per run: whether the tracking-mismatch friction terms were fitted (NaN slopes if not:
    only when the mismatch is exactly zero)."""
    cov_parts: dict[str, np.ndarray]
    """Covariance of [entries, gravity] split by noise source (rsp_inertia.estimation.gls NOISE_SOURCES
    and CALIBRATION_SOURCE); the parts sum to the whole: the uncertainty budget."""
    friction_asymmetry: np.ndarray | None = None
    """(stages, 3) e = [e1, e2, e3] of D_backward - D_forward = e1 + e2 |Omega| + e3 Omega^2
    (N m, N m s, N m s^2) for stages run in both directions; NaN rows for the others."""
    friction_asymmetry_std: np.ndarray | None = None
    """(stages, 3)."""
    tests: list[ModelTest] | None = None
    """The balance model's tests (rsp_inertia.estimation.gls): runs against each other, early against
    late turns."""
    runs: list[tuple[int, str]] | None = None
    """(stage, direction) of each run, in the order of the balances."""
    known_after: KnownTerms | None = None
    """The calibrated terms after the runs refined them (rsp_inertia.estimation.gls: the
    calibration as prior, the runs' information added); None without calibrated terms."""
    prior_warnings: list[str] = field(default_factory=list)
    """A line per run whose friction slopes' prior its balances rejected
    (rsp_inertia.estimation.gls, priors)."""
    pass_gain: np.ndarray | None = None
    """(runs,) d per run: the reverse pass's torque scale over the braking's, minus one
    (a warming motor), fitted for a run whose braking held two levels
    (:func:`pass_gain_unknown`); NaN for the others; None: no run fitted it."""
    pass_gain_std: np.ndarray | None = None
    """(runs,) std of ``pass_gain``."""
    warming: tuple[float, float] | None = None
    """(c, std), 1/(N^2 m^2): the warming motor's coefficient (:data:`WARMING_UNKNOWN`), fitted
    where device.toml models the warming (``[motor] winding_time_constant``); None: not."""
    warming_drift: np.ndarray | None = None
    """(runs, 2) per run, the torque's scale over the reverse pass less over the braking that
    ``warming`` implies (c StageBalance.warming_gap) and its std; None: not fitted."""

    @property
    def entries_cov(self) -> np.ndarray:
        """(6, 6) covariance of ``entries``, kg^2 m^4: the upper-left block of ``cov``."""
        return self.cov[ENTRIES, ENTRIES]

    @property
    def gravity_cov(self) -> np.ndarray:
        """(2, 2) covariance of ``gravity``, N^2 m^2: the lower-right block of ``cov``."""
        return self.cov[GRAVITY, GRAVITY]


def balance_rhs(bal: StageBalance, known: KnownTerms) -> np.ndarray:
    """The known side of one run's equations: h_d W_d + h_b W_b - 2 Pi_spring - 1/2 S M_empty
    - 2 Pi_f.

    W_d, W_b the driving and back-driven parts of the logged motor work of both passes,
    M_empty(phi) the empty system's reduced inertia and Pi_f the fixture's gravity potential
    (docs/method.md §5, with the rig's terms of :class:`KnownTerms`).
    """
    M_empty = inertia_basis(bal.phi) @ known.inertia[bal.stage - 1]
    spring = 0.0 if bal.spring is None else bal.spring
    received = bal.work if known.gains == (1.0, 1.0) else bal.received_work(known.gains) - spring
    return received - 0.5 * bal.speed_sq * M_empty - gravity_rows(bal.phi) @ known.gravity


def angle_slopes(bal: StageBalance) -> dict[str, np.ndarray]:
    """d column / d phi of the tensor's entries and the body's gravity terms in one run's
    equations (the body's terms an encoder zero's change turns, rsp_inertia.estimation.gls)."""
    slopes = tensor_basis_slope(bal.phi, bal.gear_ratio)
    out = {name: 0.5 * bal.speed_sq * slopes[:, i] for i, name in enumerate(ENTRY_KEYS)}
    out.update(zip(GRAVITY_NAMES, gravity_row_slopes(bal.phi).T))
    return out


def pass_gain_unknown(run: str) -> str:
    """The name of a run's pass gain among the unknowns, ``pass_gain[run]``: d of a reverse
    pass whose torque the body receives 1 + d times the braking's scale (module docstring).

    Parameters
    ----------
    run : str
        The run's key, as :func:`tensor_block` names its own unknowns.

    Returns
    -------
    str
        The unknown's name.
    """
    return f"pass_gain[{run}]"


def tensor_block(
    bal: StageBalance,
    run: str,
    known: KnownTerms,
    asymmetry: bool,
    hottest: float | None = None,
    drift_std: float | None = None,
) -> Block:
    """One run's equations in the tensor's unknowns (module docstring).

    Parameters
    ----------
    bal : StageBalance
        The run's balance.
    run : str
        Names the run's own unknowns (its constant and friction slopes).
    known : KnownTerms
        The rig's known terms: the right-hand side and, when calibrated, their Jacobians.
    asymmetry : bool
        The run's stage is run in both directions, so its friction asymmetry is an unknown.
    hottest : float, optional
        The largest heat gap of the fit's runs (StageBalance.heat_gap), for the warming probe
        (rsp_inertia.estimation.columns.cause_probes); default: this run's.
    drift_std : float, optional
        The relative std of a torque scale that may drift between the run's passes
        (device.toml ``[motor] torque_constant_drift_std``): the reverse pass's received work
        times it is the run's considered column (rsp_inertia.estimation.gls DRIFT_SOURCE).

    Returns
    -------
    Block
        The run's equations for rsp_inertia.estimation.gls.assemble_blocks.
    """
    v = tensor_basis(bal.phi, bal.gear_ratio)
    probes = cause_probes(bal, hottest)
    half_s = 0.5 * bal.speed_sq
    cols = {name: half_s * v[:, i] for i, name in enumerate(ENTRY_KEYS)}
    cols.update(zip(GRAVITY_NAMES, gravity_rows(bal.phi).T))
    cols.update(run_columns(bal, run, asymmetry))
    pass_gain = bal.pass_gain and bal.reverse_work is not None
    if pass_gain:  # the body received (1 + d) x the reverse's work: on the unknowns' side
        cols[pass_gain_unknown(run)] = -drift_column(bal, known, 1.0)[DRIFT_SOURCE]
    if bal.warming_parts is not None:  # the body received u (1 + c m(t)): c on the unknowns' side
        cols[WARMING_UNKNOWN] = -(bal.warming_parts @ np.asarray(known.gains))
    return Block(
        balance=bal,
        label=run_label(bal),
        columns=cols,
        rhs=balance_rhs(bal, known),
        inertia_columns={name: v[:, i] for i, name in enumerate(ENTRY_KEYS)},
        inertia_known=inertia_basis(bal.phi) @ known.inertia[bal.stage - 1],
        work_scales=bal.work_scales(known.gains),
        known_jacobian=known.jacobian(bal) if known.calibrated else None,
        known_jacobian_inertia=known.jacobian_inertia(bal) if known.calibrated else None,
        known_jacobian_angle=known.jacobian_angle(bal) if known.calibrated else None,
        angle_slopes=angle_slopes(bal),
        probes=probes[0],
        probes_per_inertia=probes[1],
        probe_bounds=probe_bounds(known.gains),
        groups={name: run_label(bal) for name in ENTRY_KEYS},
        joint_only=frozenset(
            name for name in cols if name.startswith(("e", "pass_gain", WARMING_UNKNOWN))
        ),
        priors=run_priors(bal, cols, run),
        considered={} if pass_gain else drift_column(bal, known, drift_std),
    )


def drift_column(
    bal: StageBalance, known: KnownTerms, drift_std: float | None
) -> dict[str, np.ndarray]:
    """{DRIFT_SOURCE: column}: what one std of a torque scale drifting between the run's passes
    adds to its balance, the reverse pass's received work times ``drift_std``
    (docs/method.md §5, "A torque scale that differs between the passes"); empty without a
    std or without the reverse's work.

    Parameters
    ----------
    bal : StageBalance
        The run's balance (its ``reverse_work``, ``reverse_work_back``).
    known : KnownTerms
        The drive's gains (h_d, h_b) on the reverse's driving and back-driven work.
    drift_std : float or None
        The relative std of the reverse's torque scale against the braking's.

    Returns
    -------
    dict of str to numpy.ndarray
        The budget line's name and the column, or empty.
    """
    if not drift_std or bal.reverse_work is None:
        return {}
    back = np.zeros(len(bal.phi)) if bal.reverse_work_back is None else bal.reverse_work_back
    h_d, h_b = known.gains
    return {DRIFT_SOURCE: drift_std * (h_d * (bal.reverse_work - back) + h_b * back)}


def fit_tensor(
    balances: list[StageBalance],
    known: KnownTerms | None = None,
    tests: bool = True,
    drift_std: float | None = None,
) -> TensorFit:
    """Generalised least squares for the tensor and the gravity terms (module docstring).

    Unknowns: the six entries and the gravity terms (shared by every run), one constant and
    the tracking mismatch's two friction slopes per run, and the friction asymmetry
    e = [e1, e2, e3] per stage run in both directions. Weighted, solved and checked by
    rsp_inertia.estimation.gls (speed_noise_scales, solve_blocks, block_model_tests).

    Parameters
    ----------
    balances : list of StageBalance
        Every run's balance.
    known : KnownTerms, optional
        The rig's known terms; device.toml's tares as exact by default.
    tests : bool, optional
        False: no model tests (a rehearsal of a plan, rsp_inertia.design.rehearsal).
    drift_std : float, optional
        The relative std of a torque scale that may drift between each run's passes
        (device.toml ``[motor] torque_constant_drift_std``): propagated as the budget line
        rsp_inertia.estimation.gls DRIFT_SOURCE (:func:`drift_column`).

    Returns
    -------
    TensorFit
        The entries and gravity terms with their covariance and budget, the runs' speed-noise
        scales and friction terms, and the model tests.
    """
    known = _known_or_tares(balances, known)
    equations = _equations(balances, known, drift_std)
    scales = speed_noise_scales(equations)
    fit = solve_blocks(equations, scales)
    tensor = _tensor_fit(
        balances, known, fit, block_model_tests(equations, fit) if tests else []
    )
    if tensor.pass_gain is None and tensor.warming is None:
        return tensor
    fixed = solve_blocks(_pinned(equations), scales)
    ratio = max(fit.chi2_dof, 1.0) / max(fixed.chi2_dof, 1.0)
    return _with_pass_gain_share(tensor, _tensor_fit(balances, known, fixed, []), ratio)


PASS_GAIN_SOURCE = "torque scale between the passes, fitted"
"""Budget line of the runs' pass gains (:func:`pass_gain_unknown`) and the warming motor's
coefficient (:data:`WARMING_UNKNOWN`): what fitting them adds to
the tensor's covariance (a run that fits its pass gain has no considered drift,
rsp_inertia.estimation.gls DRIFT_SOURCE: the fit measures it)."""


def _pinned(equations: Equations) -> Equations:
    """``equations`` with the pass gains and the warming known to be zero: their columns
    taken out, the weights (the first pass's M, the noise) kept, so that the budget's other
    lines are those of the same fit without them (a fit assembled without the columns would
    weigh by a first pass that the drift has biased)."""
    keep = [
        j for j, name in enumerate(equations.names)
        if not (name.startswith("pass_gain") or name == WARMING_UNKNOWN)
    ]
    A = equations.A[:, keep]
    return dataclasses.replace(
        equations,
        names=[equations.names[j] for j in keep],
        A=A,
        A_all=np.hstack([A, equations.N]),
    )


def _with_pass_gain_share(free: TensorFit, fixed: TensorFit, ratio: float) -> TensorFit:
    """``free``'s budget with one more line, :data:`PASS_GAIN_SOURCE`: what fitting the pass
    gains and the warming adds to the noise sources' share. The noise sources' lines are
    ``fixed``'s (the same equations with them known to be zero, taken at ``free``'s inflation:
    ``ratio`` = the fits' chi^2/dof above 1, free over fixed), the calibration's and the
    considered terms' ``free``'s own (fitting c changes how a torque scale's error reaches
    the tensor), and the new line the rest of ``free``'s covariance, so that the lines still
    add up to it."""
    inflated = set(NOISE_SOURCES) | {GAP_SOURCE}
    parts = {
        name: fixed.cov_parts[name] * ratio if name in inflated else part
        for name, part in free.cov_parts.items()
    }
    parts[PASS_GAIN_SOURCE] = free.cov - sum(parts.values())
    return dataclasses.replace(free, cov_parts=parts)


def predict_tensor(balances: list[StageBalance], known: KnownTerms | None = None) -> TensorFit:
    """The least squares of :func:`fit_tensor` on noise-free balances of a planned run: the
    covariance the noise model alone implies (rsp_inertia.estimation.gls.predict_blocks,
    rsp_inertia.estimation.predict), no model tests.

    Parameters
    ----------
    balances : list of StageBalance
        Every planned run's balance.
    known : KnownTerms, optional
        The rig's known terms; device.toml's tares as exact by default.

    Returns
    -------
    TensorFit
        The entries and gravity terms with their predicted covariance and budget.
    """
    known = _known_or_tares(balances, known)
    equations = _equations(balances, known)
    tensor = _tensor_fit(balances, known, predict_blocks(equations), [])
    if tensor.pass_gain is None and tensor.warming is None:
        return tensor
    fixed = predict_blocks(_pinned(equations))
    return _with_pass_gain_share(tensor, _tensor_fit(balances, known, fixed, []), 1.0)


def _known_or_tares(balances: list[StageBalance], known: KnownTerms | None) -> KnownTerms:
    """``known``, or device.toml's tares (the balances') as exact."""
    if known is None:
        tares = {bal.stage: bal.tare_inertia for bal in balances}
        known = KnownTerms.from_tares([tares.get(s, 0.0) for s in range(1, max(tares) + 1)])
    return known


def _equations(
    balances: list[StageBalance], known: KnownTerms, drift_std: float | None = None
) -> Equations:
    """Every run's block (:func:`tensor_block`), assembled for the least squares."""
    both = both_directions(balances)
    hottest = max(bal.heat_gap for bal in balances)
    blocks = [
        tensor_block(bal, str(k), known, bal.stage in both, hottest, drift_std)
        for k, bal in enumerate(balances)
    ]
    return assemble_blocks(
        blocks,
        known.cov if known.calibrated else None,
        known.budget_groups(),
        consider=known.common_scale(),
        known_shares=known.budget_shares(),
    )


def _tensor_fit(
    balances: list[StageBalance], known: KnownTerms, fit: BalanceFit, tests: list[ModelTest]
) -> TensorFit:
    """The TensorFit of the least squares' solution ``fit`` and its model tests ``tests``."""
    both = both_directions(balances)
    one_direction = len(both) < len({bal.stage for bal in balances})
    compensated = any(bal.compensated for bal in balances)
    model_tests = described(tests, known, one_direction, compensated)
    shared = [fit.index(name) for name in SHARED_LAYOUT.names()]
    n_runs, stages = len(balances), sorted({bal.stage for bal in balances})
    n_slopes, n_terms = len(slope_unknowns("")), len(asymmetry_unknowns(""))
    slope = np.full((n_runs, n_slopes), np.nan)
    slope_std = np.full((n_runs, n_slopes), np.nan)
    slope_cov = np.full((n_runs, n_slopes, n_slopes), np.nan)
    for k in range(n_runs):
        names = slope_unknowns(str(k))
        for j, name in enumerate(names):
            slope[k, j], slope_std[k, j] = fit.value(name)
        if all(name in fit.names for name in names):
            i = [fit.index(name) for name in names]
            slope_cov[k] = fit.cov[np.ix_(i, i)]
    asym = np.full((max(stages), n_terms), np.nan)
    asym_std = np.full((max(stages), n_terms), np.nan)
    for s in both:
        for j, name in enumerate(asymmetry_unknowns(str(s))):
            asym[s - 1, j], asym_std[s - 1, j] = fit.value(name)
    gains = [fit.value(pass_gain_unknown(str(k))) for k in range(n_runs)]
    fitted = any(bal.pass_gain for bal in balances)
    warming = fit.value(WARMING_UNKNOWN) if WARMING_UNKNOWN in fit.names else None
    sub = np.ix_(shared, shared)
    # The sum of the sources' parts is symmetric up to rounding (4e-10 of the smallest
    # products); result.json and a combination of mountings take it exactly symmetric.
    cov = (fit.cov[sub] + fit.cov[sub].T) / 2
    return TensorFit(
        entries=fit.x[shared][ENTRIES],
        gravity=fit.x[shared][GRAVITY],
        cov=cov,
        chi2_dof=fit.chi2_dof,
        speed_noise_scale=fit.scales,
        n_equations=fit.n_equations,
        friction_slope=slope,
        friction_slope_std=slope_std,
        friction_slope_cov=slope_cov,
        mismatch_terms=[bool(np.any(bal.mismatch != 0.0)) for bal in balances],
        cov_parts={name: part[sub] for name, part in fit.cov_parts.items()},
        friction_asymmetry=asym,
        friction_asymmetry_std=asym_std,
        tests=model_tests,
        runs=[run_key(bal) for bal in balances],
        known_after=(
            None
            if fit.known_shift is None
            else known.with_theta(known.theta + fit.known_shift, fit.known_shift_cov)
        ),
        prior_warnings=list(fit.prior_warnings),
        pass_gain=np.array([g[0] for g in gains]) if fitted else None,
        pass_gain_std=np.array([g[1] for g in gains]) if fitted else None,
        warming=warming,
        warming_drift=None if warming is None else np.array(
            [[warming[0] * bal.warming_gap, warming[1] * abs(bal.warming_gap)] for bal in balances]
        ),
    )
