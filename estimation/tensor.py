"""The inertia tensor from the runs' balances: least squares, axis solve, physical checks.

Least squares over many turns (docs/method.md §5). With w(phi) = (lam sin phi, lam cos phi, 1),
(1 + lam^2) J_e(phi) = w^T J w = v(phi) . [Jx Jy Jz Jxy Jyz Jxz], v the design-matrix row of
the unnormalised w (docs/method.md §2: the harmonic form of M per stage written in the tensor's
entries, so that all stages share one set of unknowns; rsp_inertia.plant.model.tensor_basis
gives these rows from the model's M, rsp_inertia.plant.model.gravity_basis the gravity
columns from its Pi). Each balance angle of a run (one
stage, one direction of rotation) gives

    1/2 S v(phi) . J + 2 Gs sin phi + 2 Gc cos phi - C_run - d . R - dir e_s . Q
        = h W(phi) - 2 Pi_spring - 1/2 S M_empty(phi) - 2 Pi_fixture(phi)

(rsp_inertia.estimation.balance), linear in the six entries, the gravity terms Gs = m g x_c,
Gc = m g y_c shared by all runs, one constant per run, per run the two slopes d of the
friction torque that the closed loop's tracking mismatch leaves in the balance (regressors R),
and, for a stage run in both directions, its friction asymmetry e_s (regressors Q, sign
dir = +1 forward, -1 backward: the first-order effect of a friction that differs between the
directions of rotation cancels between the runs). The right-hand side holds what the rig's
calibration knows (:class:`KnownTerms`): the torque gain's h = 1 / gain on the logged motor
work W, the empty system's reduced inertia M_empty (tare and fixture) and the fixture's
gravity; without a calibration, device.toml's tare as exact. Weights, the speed-noise scale,
the model tests and the uncertainty budget: rsp_inertia.estimation.gls.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rsp_inertia.estimation.balance import StageBalance
from rsp_inertia.estimation.gls import NOISE_SOURCES, Block, solve_blocks
from rsp_inertia.estimation.model_tests import ModelTest
from rsp_inertia.plant.geometry import design_matrix, physical_margins, tensor_from_entries
from rsp_inertia.plant.model import gravity_basis, inertia_basis, tensor_basis

__all__ = [
    "ENTRY_KEYS",
    "NOISE_SOURCES",
    "KnownTerms",
    "TensorFit",
    "axis_values",
    "balance_rhs",
    "both_directions",
    "fit_tensor",
    "format_run",
    "gravity_rows",
    "physical_warnings",
    "principal",
    "run_columns",
    "run_key",
    "run_label",
    "tensor_block",
    "tensor_from_axes",
]


ENTRY_KEYS = ("Jx", "Jy", "Jz", "Jxy", "Jyz", "Jxz")
"""Names of the tensor entries, in the order of every 6-vector."""


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


@dataclass(frozen=True)
class KnownTerms:
    """What the balances take as known about the rig (docs/method.md §2-3).

    From ``calibration.toml`` (rsp_inertia.estimation.calibration), or device.toml's tares alone: the
    empty system's reduced inertia per stage (tare and fixture), the fixture's gravity terms,
    and the factor h = 1 / torque gain that turns the logged motor work into the physical
    one; with the covariance of theta = [h, harmonics of stage 1..n, Gs_f, Gc_f].
    """

    work_scale: float
    """h = 1 / torque gain."""
    inertia: np.ndarray
    """(stages, 5) harmonics [M0, Mc2, Ms2, Ms1, Mc1] of the empty system, kg m^2."""
    gravity: np.ndarray
    """(2,) the fixture's [m g x_c, m g y_c], N m."""
    cov: np.ndarray
    """Covariance of theta (class docstring); zero when nothing was calibrated."""
    calibrated: bool = False
    """Whether theta carries an uncertainty to propagate: a calibration, or the stds that
    device.toml states for its tares and torque constant (else they are taken as exact)."""

    @classmethod
    def from_tares(cls, tares) -> KnownTerms:
        """device.toml's tares as exact: M_empty = M_tare, no fixture terms, gain 1."""
        tares = np.asarray(tares, dtype=float)
        inertia = np.zeros((len(tares), 5))
        inertia[:, 0] = tares
        size = 1 + inertia.size + 2
        return cls(1.0, inertia, np.zeros(2), np.zeros((size, size)))

    def empty_inertia(self, stage: int, phi) -> np.ndarray | float:
        """M_empty(phi) of stage ``stage`` (from 1), kg m^2."""
        value = inertia_basis(np.atleast_1d(phi)) @ self.inertia[stage - 1]
        return float(value[0]) if np.ndim(phi) == 0 else value

    def node_variance(self, stage: int, phi: float, M: float) -> float:
        """Variance the known terms give a node's J (1 + lam^2)^2, kg^2 m^4: J = (M -
        M_empty(phi)) / (1 + lam^2) with M = h x (logged motor work's share), so to first
        order dM = M dh / h (a spring's potential, exact, is left out of that share) and
        dM_empty = basis(phi) d(harmonics of the stage)."""
        g = np.zeros(self.cov.shape[0])
        g[0] = M / self.work_scale
        s = stage - 1
        g[1 + 5 * s : 6 + 5 * s] = -inertia_basis(np.atleast_1d(phi))[0]
        return float(g @ self.cov @ g)

    def empty_variance(self, stage: int, phi: float) -> float:
        """Variance of M_empty(phi) of stage ``stage``, kg^2 m^4."""
        g = np.zeros(self.cov.shape[0])
        s = stage - 1
        g[1 + 5 * s : 6 + 5 * s] = inertia_basis(np.atleast_1d(phi))[0]
        return float(g @ self.cov @ g)

    def summary(self) -> dict | None:
        """result.json's ``calibration``: what was applied (None when nothing was)."""
        if not self.calibrated:
            return None
        std = np.sqrt(np.diag(self.cov))
        n = len(self.inertia)
        return {
            "torque_gain": 1.0 / self.work_scale,
            "torque_gain_std": float(std[0] / self.work_scale**2),
            "empty_inertia": [[float(v) for v in row] for row in self.inertia],
            "empty_inertia_std": [
                [float(v) for v in std[1 + 5 * s : 6 + 5 * s]] for s in range(n)
            ],
            "fixture_gravity": [float(v) for v in self.gravity],
            "fixture_gravity_std": [float(v) for v in std[-2:]],
        }

    def jacobian(self, bal: StageBalance) -> np.ndarray:
        """(n, p) d rhs / d theta of one run's equations (:func:`balance_rhs`)."""
        n_stages = len(self.inertia)
        B = np.zeros((len(bal.phi), 1 + 5 * n_stages + 2))
        B[:, 0] = bal.motor_work
        s = bal.stage - 1
        B[:, 1 + 5 * s : 6 + 5 * s] = -0.5 * bal.speed_sq[:, None] * inertia_basis(bal.phi)
        B[:, -2:] = -gravity_rows(bal.phi)
        return B


def gravity_rows(phi: np.ndarray) -> np.ndarray:
    """(n, 2) 2 dPi/d[Gs, Gc]: the gravity potential's share of the balance, twice for the
    two passes (docs/method.md §3, rsp_inertia.plant.model.gravity_basis)."""
    return 2 * gravity_basis(phi)


def balance_rhs(bal: StageBalance, known: KnownTerms) -> np.ndarray:
    """The known side of one run's equations: h W - 2 Pi_spring - 1/2 S M_empty - 2 Pi_f.

    W the logged motor work of both passes, M_empty(phi) the empty system's reduced inertia
    and Pi_f the fixture's gravity potential (docs/method.md §5, with the rig's terms of
    :class:`KnownTerms`).
    """
    M_empty = inertia_basis(bal.phi) @ known.inertia[bal.stage - 1]
    rhs = bal.work - 0.5 * bal.speed_sq * M_empty - gravity_rows(bal.phi) @ known.gravity
    if known.work_scale != 1.0:
        rhs = rhs + (known.work_scale - 1.0) * bal.motor_work
    return rhs


def run_key(bal: StageBalance) -> tuple[int, str]:
    """(stage, "forward" or "backward") of a run."""
    return bal.stage, "forward" if bal.direction > 0 else "backward"


def format_run(key: tuple[int, str]) -> str:
    """"stage N forward" or "stage N backward" from (stage, direction)."""
    stage, direction = key
    return f"stage {stage} {direction}"


def run_label(bal: StageBalance) -> str:
    """"stage N forward" or "stage N backward"."""
    return format_run(run_key(bal))


def run_columns(
    bal: StageBalance, key: str, both_directions: bool, group: str | None = None
) -> dict[str, np.ndarray]:
    """The columns every run has whatever the question: its constant, the tracking mismatch's
    friction slopes (rsp_inertia.estimation.balance; left out when the mismatch is exactly zero, exact
    data), and the friction asymmetry of a stage run in both directions (shared by the runs of
    ``group``, by default the stage).
    """
    group = str(bal.stage) if group is None else group
    n = len(bal.phi)
    cols = {f"C[{key}]": -np.ones(n)}
    if np.any(bal.mismatch != 0.0):
        cols[f"d1[{key}]"] = -bal.mismatch[:, 0]
        cols[f"d2[{key}]"] = -bal.mismatch[:, 1]
    if both_directions:
        for k in range(3):
            cols[f"e{k + 1}[{group}]"] = -bal.direction * bal.friction_shape[:, k]
    return cols


def both_directions(balances: list[StageBalance]) -> set[int]:
    """Stages with runs in both directions."""
    seen: dict[int, set[int]] = {}
    for bal in balances:
        seen.setdefault(bal.stage, set()).add(bal.direction)
    return {stage for stage, dirs in seen.items() if len(dirs) == 2}


def tensor_block(bal: StageBalance, run: str, known: KnownTerms, asymmetry: bool) -> Block:
    """One run's equations in the tensor's unknowns (module docstring).

    ``run`` names the run's own unknowns (its constant and friction slopes); ``asymmetry``:
    the run's stage is run in both directions, so its friction asymmetry is an unknown.
    """
    v = tensor_basis(bal.phi, bal.gear_ratio)
    half_s = 0.5 * bal.speed_sq
    cols = {name: half_s * v[:, i] for i, name in enumerate(ENTRY_KEYS)}
    cols["Gs"], cols["Gc"] = gravity_rows(bal.phi).T
    cols.update(run_columns(bal, run, asymmetry))
    return Block(
        balance=bal,
        label=run_label(bal),
        columns=cols,
        rhs=balance_rhs(bal, known),
        inertia_columns={name: v[:, i] for i, name in enumerate(ENTRY_KEYS)},
        inertia_known=inertia_basis(bal.phi) @ known.inertia[bal.stage - 1],
        work_scale=known.work_scale,
        known_jacobian=known.jacobian(bal) if known.calibrated else None,
        groups={name: run_label(bal) for name in ENTRY_KEYS},
        joint_only=frozenset(name for name in cols if name.startswith("e")),
    )


def fit_tensor(
    balances: list[StageBalance],
    known: KnownTerms | None = None,
    predict: bool = False,
    tests: bool = True,
) -> TensorFit:
    """Generalised least squares for the tensor and the gravity terms (module docstring).

    Unknowns: the six entries and the gravity terms (shared by every run), one constant and
    the tracking mismatch's two friction slopes per run, and the friction asymmetry
    e = [e1, e2, e3] per stage run in both directions. Solved, weighted and checked by
    :func:`rsp_inertia.estimation.gls.solve_blocks`. ``predict``: noise-free balances of a planned run,
    whose covariance is then the noise model's alone (rsp_inertia.estimation.predict); ``tests`` False:
    no model tests (a rehearsal of a plan, rsp_inertia.ocp.rehearsal).
    """
    if known is None:
        tares = {bal.stage: bal.tare_inertia for bal in balances}
        known = KnownTerms.from_tares([tares.get(s, 0.0) for s in range(1, max(tares) + 1)])
    both = both_directions(balances)
    blocks = [tensor_block(bal, str(k), known, bal.stage in both) for k, bal in enumerate(balances)]
    fit = solve_blocks(
        blocks, known.cov if known.calibrated else None, predict=predict, tests=tests
    )
    shared = [fit.index(name) for name in (*ENTRY_KEYS, "Gs", "Gc")]
    n_runs, stages = len(balances), sorted({bal.stage for bal in balances})
    slope = np.full((n_runs, 2), np.nan)
    slope_std = np.full((n_runs, 2), np.nan)
    slope_cov = np.full((n_runs, 2, 2), np.nan)
    for k in range(n_runs):
        for j in range(2):
            slope[k, j], slope_std[k, j] = fit.value(f"d{j + 1}[{k}]")
        names = [f"d1[{k}]", f"d2[{k}]"]
        if all(name in fit.names for name in names):
            i = [fit.index(name) for name in names]
            slope_cov[k] = fit.cov[np.ix_(i, i)]
    asym = np.full((max(stages), 3), np.nan)
    asym_std = np.full((max(stages), 3), np.nan)
    for s in both:
        for j in range(3):
            asym[s - 1, j], asym_std[s - 1, j] = fit.value(f"e{j + 1}[{s}]")
    sub = np.ix_(shared, shared)
    return TensorFit(
        entries=fit.x[shared[:6]],
        entries_cov=fit.cov[sub][:6, :6],
        gravity=fit.x[shared[6:]],
        gravity_cov=fit.cov[sub][6:, 6:],
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
        tests=fit.tests,
        runs=[run_key(bal) for bal in balances],
    )


def axis_values(entries: np.ndarray, cov: np.ndarray, directions: np.ndarray):
    """J_k = e_k^T J e_k for unit directions, with standard deviations (docs/method.md §5 (8))."""
    V = design_matrix(directions)
    values = V @ entries
    # v^T C v of a covariance is >= 0; a source that leaves an axis untouched (a tare std of
    # 0 on its stage) gives 0, which rounding can turn into -1e-30 (a NaN std otherwise).
    stds = np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", V, cov, V), 0.0))
    return values, stds


def tensor_from_axes(values: np.ndarray, stds: np.ndarray, directions: np.ndarray):
    """Tensor entries from axis moments through V: solve (6 axes) or weighted least squares.

    Returns the entries and their covariance (the design's cond(V):
    rsp_inertia.plant.geometry.device_design).
    """
    V = design_matrix(directions)
    W = 1 / np.asarray(stds)
    x, *_ = np.linalg.lstsq(V * W[:, None], values * W, rcond=None)
    cov = np.linalg.pinv((V * W[:, None]).T @ (V * W[:, None]))
    return x, cov


def principal(entries: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Principal moments (ascending) and axes (rows, unit vectors) of the tensor."""
    moments, vectors = np.linalg.eigh(tensor_from_entries(entries))
    return moments, vectors.T


def physical_warnings(entries: np.ndarray, cov: np.ndarray, samples: int = 2000) -> list[str]:
    """Warnings when the tensor is not a physical one within its uncertainty.

    A rigid body's tensor is positive definite and its principal moments obey the triangle
    inequality I1 + I2 >= I3 (rsp_inertia.plant.geometry.physical_margins). A violation is
    reported when it holds beyond two standard deviations of the margin, estimated by
    sampling the entries' covariance (seeded, deterministic).
    """
    rng = np.random.default_rng(0)
    draws = rng.multivariate_normal(entries, cov, size=samples, check_valid="ignore")
    smallest, triangle = physical_margins(entries)
    std_small, std_tri = np.column_stack(physical_margins(draws)).std(axis=0)
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

