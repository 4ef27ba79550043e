"""Identification of an experiment: every stage's logs in, tensor and centre of mass out.

Reads only what a rig produces (device.toml and the logs), never virtual.toml. Steps, each in
its own function elsewhere: smoothing and motor work (rsp_inertia.estimation.passes), balances and the node
formula (rsp_inertia.estimation.balance), least squares and the tensor (rsp_inertia.estimation.tensor).

Two estimates of the tensor are reported:

- **least squares** (the headline): every stage's balance angles over all covered turns in
  one weighted least-squares problem (METHOD.md §5), tensor and gravity terms together;
- **node formula**: M at each node from its whole-turn pairs, J_k = (M - M_tare)/(1+lam^2),
  and the tensor from the J_k through V (the paper's six-axis solve, (8)).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from rsp_inertia.estimation.balance import NodeEstimate, node_formula
from rsp_inertia.estimation.calibration import calibrated_stiffness, known_terms
from rsp_inertia.estimation.gls import ModelTest, model_warnings
from rsp_inertia.estimation.pendulum import (
    BestPractice,
    PendulumEstimate,
    best_practice_inertia,
    estimate_pendulum,
    half_cycle_fit,
)
from rsp_inertia.estimation.runs import run_balances
from rsp_inertia.estimation.tensor import (
    KnownTerms,
    axis_values,
    fit_tensor,
    format_run,
    physical_warnings,
    principal,
    tensor_from_axes,
)
from rsp_inertia.plant.errors import InputError
from rsp_inertia.plant.experiment import Experiment
from rsp_inertia.plant.geometry import axis_direction, design_matrix
from rsp_inertia.plant.logs import read_log

__all__ = [
    "MAX_CONDITION",
    "AxisResult",
    "Identification",
    "PendulumResult",
    "axial_moment",
    "axial_std",
    "identify",
    "identify_pendulum",
]

ENTRY_NAMES = ("Jx", "Jy", "Jz", "Jxy", "Jyz", "Jxz")

MAX_CONDITION = 1e3
"""cond(V) above which the axis design is refused: the tensor would be noise."""

WARN_CONDITION = 10.0
"""cond(V) above which the design is accepted with a warning."""


@dataclass(frozen=True)
class AxisResult:
    """The moment of inertia about one node's axis."""

    stage: int
    """Stage number, from 1."""
    phi_deg: float
    """Node, deg."""
    direction: np.ndarray
    """Unit axis in the body frame (METHOD.md §1)."""
    J: float
    """kg m^2, from the least-squares tensor (headline)."""
    J_std: float
    """kg m^2."""
    J_node: float
    """kg m^2, from the node formula with the measured reverse speeds."""
    J_node_std: float
    """kg m^2."""
    J_plain: float
    """kg m^2, the paper's plain formula (6)/(7)."""
    J_plain_std: float
    """kg m^2."""
    pairs: int
    """One-turn pairs behind the node formula."""


@dataclass(frozen=True)
class PendulumResult:
    """The torsion-pendulum baseline: per-axis moments and, with every node run, tensors."""

    runs: list[PendulumEstimate]
    """One per pendulum log found."""
    J_classic: np.ndarray
    """kg m^2 per run, (M - M_tare) / (1 + lam^2) from the classic period formula."""
    J_classic_std: np.ndarray
    """kg m^2."""
    J_damped: np.ndarray
    """kg m^2 per run, from the damped fit."""
    J_damped_std: np.ndarray
    """kg m^2."""
    entries_classic: np.ndarray | None
    """Tensor through V from the classic J_k, when every node has a run."""
    entries_damped: np.ndarray | None
    """Tensor through V from the damped-fit J_k, when every node has a run."""
    best: list[BestPractice | None] = field(default_factory=list)
    """Per run, the best-practice reduction (rsp_inertia.estimation.pendulum), None where it failed."""
    J_best: np.ndarray | None = None
    """kg m^2 per run, J along the axis at the run's equilibrium angle ``phi_best``."""
    J_best_std: np.ndarray | None = None
    """kg m^2, the best-practice budget's std."""
    phi_best: np.ndarray | None = None
    """rad per run, the oscillation's equilibrium (the axis J_best is about)."""
    entries_best: np.ndarray | None = None
    """Tensor through V from J_best, with the axes at the equilibria, when every run has one."""
    entries_best_cov: np.ndarray | None = None
    """(6, 6) its covariance."""
    J_best_budget: list[dict[str, float]] = field(default_factory=list)
    """Per run, J_best's std by source (kg m^2: the best practice's M budget over 1+lam^2)."""
    stiffness: tuple[float, float, str] | None = None
    """(c, std, source) the best practice used, N m/rad: calibration.toml's [pendulum] (the
    calibration folders' pendulum runs) when it has one, else device.toml's."""

    def to_json(self) -> dict:
        """The result.json section ``pendulum``."""
        axes = [
            {
                "stage": r.stage,
                "phi_deg": r.node_deg,
                "period": r.period,
                "period_std": r.period_std,
                "J_classic": float(self.J_classic[i]),
                "J_classic_std": float(self.J_classic_std[i]),
                "J_damped": float(self.J_damped[i]),
                "J_damped_std": float(self.J_damped_std[i]),
                **self._best_json(i),
            }
            for i, r in enumerate(self.runs)
        ]
        def entries(e):
            return None if e is None else dict(zip(ENTRY_NAMES, map(float, e)))
        best_std = (
            None if self.entries_best_cov is None
            else np.sqrt(np.maximum(np.diag(self.entries_best_cov), 0.0))
        )
        stiffness = None
        if self.stiffness is not None:
            c, c_std, source = self.stiffness
            stiffness = {"value": c, "std": c_std, "source": source}
        return {
            "axes": axes,
            "best_stiffness": stiffness,
            "tensor_classic": entries(self.entries_classic),
            "tensor_damped": entries(self.entries_damped),
            "tensor_best": entries(self.entries_best),
            "tensor_best_std": entries(best_std),
        }

    def best_axes(self, device) -> np.ndarray:
        """(runs, 3) unit axes about which J_best is measured (each run's equilibrium), NaN
        rows where the best practice failed."""
        phi = np.full(len(self.runs), np.nan) if self.phi_best is None else self.phi_best
        return np.array(
            [
                axis_direction(p, device.stages[r.stage - 1].gear_ratio)
                if np.isfinite(p) else np.full(3, np.nan)
                for r, p in zip(self.runs, phi)
            ]
        )

    def _best_json(self, i: int) -> dict:
        """The best-practice keys of run i's entry in ``axes`` (None where it failed)."""
        b = self.best[i] if i < len(self.best) else None
        if b is None or self.J_best is None:
            return {"J_best": None, "J_best_std": None, "phi_best_deg": None, "best_budget": None}
        return {
            "J_best": float(self.J_best[i]),
            "J_best_std": float(self.J_best_std[i]),
            "phi_best_deg": math.degrees(float(self.phi_best[i])),
            "best_budget": {k: float(v) for k, v in self.J_best_budget[i].items()},
        }


@dataclass(frozen=True)
class Identification:
    """Everything ``identify`` finds; :meth:`to_json` gives result.json (INTERFACES.md)."""

    entries: np.ndarray
    """[Jx, Jy, Jz, Jxy, Jyz, Jxz], kg m^2, least squares (headline)."""
    entries_cov: np.ndarray
    """(6, 6), kg^2 m^4."""
    node_entries: np.ndarray
    """Same entries from the node formula's J_k through V."""
    node_entries_cov: np.ndarray
    """(6, 6)."""
    axes: list[AxisResult]
    """One per node of every stage."""
    com: np.ndarray | None
    """[x_c, y_c], m, when device.toml gives the mass."""
    com_std: np.ndarray | None
    """m."""
    gravity: np.ndarray
    """[m g x_c, m g y_c], N m."""
    gravity_std: np.ndarray
    """N m."""
    condition_number: float
    """cond(V) of the node axes."""
    chi2_dof: float
    """Least squares: residual chi^2 per degree of freedom."""
    n_equations: int
    """Least squares: balance angles used."""
    speed_noise_scale: list[float]
    """Least squares: per stage, the factor on the derived speed-error covariance fitted to
    the residuals."""
    friction_slope: np.ndarray | None = None
    """(stages, 2) [d1, d2] of the friction torque's slope D'(Omega) = d1 + d2 Omega that the
    least squares fits from the reverse's tracking mismatch (rsp_inertia.estimation.balance); NaN rows
    only for a stage whose passes match exactly (exact data)."""
    friction_slope_std: np.ndarray | None = None
    """(stages, 2)."""
    std_budget: dict[str, dict[str, np.ndarray]] = field(default_factory=dict)
    """Uncertainty budget of the least squares: for each noise source (rsp_inertia.estimation.tensor
    NOISE_SOURCES), the standard deviations it alone gives to ``axes`` J ("axes") and to the
    entries ("tensor"); the variances of the sources add up to the totals."""
    warnings: list[str] = field(default_factory=list)
    """Physical-sense and design warnings."""
    pendulum: PendulumResult | None = None
    """The torsion-pendulum baseline, when its logs are present."""
    runs: list[tuple[int, str]] = field(default_factory=list)
    """(stage, direction) of each run, the order of the per-run lists."""
    friction_asymmetry: np.ndarray | None = None
    """(stages, 3) D_backward - D_forward = e1 + e2 |Omega| + e3 Omega^2 per stage run in
    both directions (N m, N m s, N m s^2); NaN rows for the others."""
    friction_asymmetry_std: np.ndarray | None = None
    """(stages, 3)."""
    model_tests: list[ModelTest] = field(default_factory=list)
    """The balance model's chi^2 tests (rsp_inertia.estimation.gls): runs against each other, early
    against late turns."""
    calibration: dict | None = None
    """What the identification took from calibration.toml (None: device.toml's tares)."""
    gravity_cov: np.ndarray | None = None
    """(2, 2) covariance of ``gravity``, N^2 m^2 (the pendulum's gravity correction uses it)."""

    @property
    def entries_std(self) -> np.ndarray:
        """Standard deviations of ``entries``."""
        return np.sqrt(np.diag(self.entries_cov))

    def to_json(self) -> dict:
        """The result.json document (INTERFACES.md), with extensions."""
        moments, vectors = principal(self.entries)
        node_std = np.sqrt(np.diag(self.node_entries_cov))
        return {
            "tensor": dict(zip(ENTRY_NAMES, map(float, self.entries))),
            "tensor_std": dict(zip(ENTRY_NAMES, map(float, self.entries_std))),
            "principal_moments": [float(m) for m in moments],
            "principal_axes": [[float(c) for c in v] for v in vectors],
            "axes": [
                {
                    "stage": a.stage,
                    "phi_deg": a.phi_deg,
                    "direction": [float(c) for c in a.direction],
                    "J": a.J,
                    "J_std": a.J_std,
                    "J_node": a.J_node,
                    "J_node_std": a.J_node_std,
                    "J_plain": a.J_plain,
                    "J_plain_std": a.J_plain_std,
                    "pairs": a.pairs,
                }
                for a in self.axes
            ],
            "com": None
            if self.com is None
            else {"x": float(self.com[0]), "y": float(self.com[1])},
            "com_std": None
            if self.com_std is None
            else {"x": float(self.com_std[0]), "y": float(self.com_std[1])},
            "condition_number": self.condition_number,
            "headline": "least_squares",
            "node_formula": {
                "tensor": dict(zip(ENTRY_NAMES, map(float, self.node_entries))),
                "tensor_std": dict(zip(ENTRY_NAMES, map(float, node_std))),
            },
            "gravity_torque": {
                "m_g_xc": float(self.gravity[0]),
                "m_g_yc": float(self.gravity[1]),
                "std": [float(s) for s in self.gravity_std],
            },
            "least_squares": {
                "equations": self.n_equations,
                "chi2_dof": self.chi2_dof,
                "speed_noise_scale": [float(v) for v in self.speed_noise_scale],
                "runs": [format_run(key) for key in self.runs],
                "tracking_mismatch": [
                    {
                        "stage": stage,
                        "direction": direction,
                        "run": format_run((stage, direction)),
                        "fitted": _finite_list(slope) is not None,
                        "friction_slope": _finite_list(slope),
                        "friction_slope_std": _finite_list(std),
                    }
                    for (stage, direction), slope, std in zip(
                        self.runs, self.friction_slope, self.friction_slope_std
                    )
                ]
                if self.friction_slope is not None
                else [],
                "friction_asymmetry": [
                    {
                        "stage": k + 1,
                        "coefficients": _finite_list(e),
                        "coefficients_std": _finite_list(std),
                    }
                    for k, (e, std) in enumerate(
                        zip(self.friction_asymmetry, self.friction_asymmetry_std)
                    )
                    if np.all(np.isfinite(e))
                ]
                if self.friction_asymmetry is not None
                else [],
                "model_tests": [test.to_json() for test in self.model_tests],
                "std_budget": {
                    source: {
                        "axes_J_std": [float(v) for v in part["axes"]],
                        "tensor_std": dict(zip(ENTRY_NAMES, map(float, part["tensor"]))),
                    }
                    for source, part in self.std_budget.items()
                },
            },
            "calibration": self.calibration,
            "warnings": list(self.warnings),
            "pendulum": None if self.pendulum is None else self.pendulum.to_json(),
        }


def _finite_list(values) -> list[float] | None:
    """Plain floats for JSON, or None when the values are not estimated (NaN)."""
    values = np.asarray(values, dtype=float)
    return [float(v) for v in values] if np.all(np.isfinite(values)) else None


def axial_moment(M, stage, empty=None) -> np.ndarray | float:
    """J_e = (M - M_tare) / (1 + lam^2) about a stage's axis (METHOD.md §2).

    ``empty``: the empty system's reduced inertia at the node (tare and fixture, from a
    calibration); device.toml's tare by default.
    """
    tare = stage.tare_inertia if empty is None else empty
    return (np.asarray(M) - tare) / (1.0 + stage.gear_ratio**2)


def axial_std(M_std, stage) -> np.ndarray | float:
    """Standard deviation of :func:`axial_moment` (the tare is exact)."""
    return np.asarray(M_std) / (1.0 + stage.gear_ratio**2)


def _combine_directions(found: list[NodeEstimate]) -> NodeEstimate:
    """One node's estimate from its runs: one run as it is; forward and backward averaged.

    The two directions' node formulas carry a friction asymmetry's work with opposite signs
    (rsp_inertia.estimation.balance friction_shape), so their plain mean cancels it to first order; the
    runs' noise is independent.
    """
    if len(found) == 1:
        return found[0]
    first = found[0]

    def mean(attr: str) -> float:
        return float(np.mean([getattr(n, attr) for n in found]))

    def std_of_mean(attr: str) -> float:
        return float(math.sqrt(sum(getattr(n, attr) ** 2 for n in found)) / len(found))

    return NodeEstimate(
        stage=first.stage,
        node_deg=first.node_deg,
        M=mean("M"),
        M_std=std_of_mean("M_std"),
        M_plain=mean("M_plain"),
        M_plain_std=std_of_mean("M_plain_std"),
        pairs=sum(n.pairs for n in found),
    )


def identify(
    exp: Experiment, progress: Callable[[str], None] | None = None
) -> Identification:
    """Identify the tensor (and centre of mass) from every stage's braking and reverse logs.

    Raises
    ------
    InputError
        Missing or malformed logs, logs that do not overlap, too few turns for a node,
        a braking whose speed reverses, an ill-conditioned axis design.
    """
    say = progress or (lambda _text: None)
    device = exp.device
    known, warnings = known_terms(exp)
    balances, nodes = run_balances(exp, warnings, say)
    fit = fit_tensor(balances, known)
    by_node = {}
    for k, (stage, sign, b_est, r_est) in enumerate(nodes):
        for n in node_formula(
            device, stage, b_est, r_est, fit.speed_noise_scale[k], sign, known.work_scale,
            fit.friction_slope[k], fit.friction_slope_cov[k],
        ):
            by_node.setdefault((n.stage, n.node_deg), []).append(n)
    nodes = [_combine_directions(found) for found in by_node.values()]
    labels = [format_run(key) for key in fit.runs]
    warnings += model_warnings(fit.tests, fit.speed_noise_scale, labels)

    directions = np.array(
        [
            axis_direction(math.radians(n.node_deg), device.stages[n.stage - 1].gear_ratio)
            for n in nodes
        ]
    )
    cond = float(np.linalg.cond(design_matrix(directions)))
    if not cond < MAX_CONDITION:
        raise InputError(
            f"{exp.root / 'device.toml'}: stage: the node axes are ill-conditioned "
            f"(cond(V) = {cond:.3g} > {MAX_CONDITION:g}); choose gear ratios and nodes that "
            "spread the axes (see rsp-inertia design)"
        )
    if cond > WARN_CONDITION:
        warnings.append(f"the axis design is poorly conditioned: cond(V) = {cond:.3g}")

    J_ls, J_ls_std = axis_values(fit.entries, fit.entries_cov, directions)
    std_budget = {
        source: {
            "axes": axis_values(fit.entries, part[:6, :6], directions)[1],
            "tensor": np.sqrt(np.diag(part[:6, :6])),
        }
        for source, part in fit.cov_parts.items()
    }
    J_node, J_node_std, J_plain, J_plain_std = [], [], [], []
    for n in nodes:
        st = device.stages[n.stage - 1]
        phi = math.radians(n.node_deg)
        empty = known.empty_inertia(n.stage, phi)
        # The known terms' uncertainty (calibration, or device.toml's stated stds) adds to
        # the node formula's own, as it does to the least squares'.
        known_var = known.node_variance(n.stage, phi, n.M) if known.calibrated else 0.0
        J_node.append(axial_moment(n.M, st, empty))
        J_node_std.append(axial_std(math.sqrt(n.M_std**2 + known_var), st))
        J_plain.append(axial_moment(n.M_plain, st, empty))
        plain_var = known.node_variance(n.stage, phi, n.M_plain) if known.calibrated else 0.0
        J_plain_std.append(axial_std(math.sqrt(n.M_plain_std**2 + plain_var), st))
    node_entries, node_cov, _ = tensor_from_axes(
        np.array(J_node), np.array(J_node_std), directions
    )
    axes = [
        AxisResult(
            stage=n.stage,
            phi_deg=n.node_deg,
            direction=d,
            J=float(J_ls[i]),
            J_std=float(J_ls_std[i]),
            J_node=float(J_node[i]),
            J_node_std=float(J_node_std[i]),
            J_plain=float(J_plain[i]),
            J_plain_std=float(J_plain_std[i]),
            pairs=n.pairs,
        )
        for i, (n, d) in enumerate(zip(nodes, directions))
    ]
    gravity_std = np.sqrt(np.diag(fit.gravity_cov))
    com = com_std = None
    if device.body is not None:
        weight = device.body.mass * device.gravity
        com = fit.gravity / weight
        com_std = gravity_std / weight
    warnings += physical_warnings(fit.entries, fit.entries_cov)
    pendulum = identify_pendulum(
        exp, say, known, fit.gravity, fit.gravity_cov, warnings
    )
    return Identification(
        entries=fit.entries,
        entries_cov=fit.entries_cov,
        node_entries=node_entries,
        node_entries_cov=node_cov,
        axes=axes,
        com=com,
        com_std=com_std,
        gravity=fit.gravity,
        gravity_std=gravity_std,
        gravity_cov=fit.gravity_cov,
        condition_number=cond,
        chi2_dof=fit.chi2_dof,
        n_equations=fit.n_equations,
        speed_noise_scale=fit.speed_noise_scale,
        friction_slope=fit.friction_slope,
        friction_slope_std=fit.friction_slope_std,
        std_budget=std_budget,
        warnings=warnings,
        pendulum=pendulum,
        runs=fit.runs,
        friction_asymmetry=fit.friction_asymmetry,
        friction_asymmetry_std=fit.friction_asymmetry_std,
        model_tests=fit.tests,
        calibration=known.summary(),
    )


def identify_pendulum(
    exp: Experiment,
    progress: Callable[[str], None] | None = None,
    known: KnownTerms | None = None,
    gravity: np.ndarray | None = None,
    gravity_cov: np.ndarray | None = None,
    warnings: list[str] | None = None,
) -> PendulumResult | None:
    """The torsion-pendulum baseline from every ``stageN/pendulum_kK.csv`` present.

    None when there is no such log. The stiffness is device.toml's ``[pendulum]`` one; the
    empty system's inertia at the node is the calibration's when ``known`` has one (the same
    tare and fixture as the RSP result), else device.toml's tare. ``gravity`` (the body's
    [Gs, Gc], N m, with ``gravity_cov``: the RSP least squares') feeds the best-practice
    reduction's gravity stiffness, with the fixture's from ``known``; without it that
    reduction is skipped. A run the best-practice reduction cannot take (too few half
    cycles) gets None there and a line in ``warnings``.
    """
    device = exp.device
    found = [
        (stage, k)
        for stage in exp.stages()
        for k in range(1, len(device.stages[stage - 1].nodes) + 1)
        if exp.pendulum_path(stage, k).is_file()
    ]
    if not found:
        return None
    if device.pendulum is None:
        raise InputError(
            f"{exp.root / 'device.toml'}: pendulum: pendulum logs are present but the "
            "[pendulum] table (its stiffness) is missing"
        )
    runs, directions, logs = [], [], []
    for stage, k in found:
        st = device.stages[stage - 1]
        path = exp.pendulum_path(stage, k)
        log = read_log(path, device.encoder, "pendulum")
        logs.append(log)
        runs.append(
            estimate_pendulum(log, device.pendulum.stiffness, stage, st.nodes_deg[k - 1], str(path))
        )
        directions.append(axis_direction(st.nodes[k - 1], st.gear_ratio))
    stages = [device.stages[r.stage - 1] for r in runs]
    empty = [
        None if known is None else known.empty_inertia(r.stage, math.radians(r.node_deg))
        for r in runs
    ]
    J_classic = np.array(
        [axial_moment(r.M_classic, st, e) for r, st, e in zip(runs, stages, empty)]
    )
    J_classic_std = np.array([axial_std(r.M_classic_std, st) for r, st in zip(runs, stages)])
    J_damped = np.array([axial_moment(r.M_damped, st, e) for r, st, e in zip(runs, stages, empty)])
    J_damped_std = np.array([axial_std(r.M_damped_std, st) for r, st in zip(runs, stages)])
    entries_classic = entries_damped = None
    complete = len(found) == sum(len(st.nodes) for st in device.stages)
    if complete:
        entries_classic = tensor_from_axes(J_classic, np.ones(len(runs)), np.array(directions))[0]
        entries_damped = tensor_from_axes(J_damped, np.ones(len(runs)), np.array(directions))[0]
    best_parts = {}
    if gravity is not None:
        best_parts = _best_practice(
            exp, found, runs, logs, known, gravity, gravity_cov, warnings, complete
        )
    if progress is not None:
        progress(f"pendulum: {len(runs)} run(s) reduced")
    return PendulumResult(
        runs=runs,
        J_classic=J_classic,
        J_classic_std=J_classic_std,
        J_damped=J_damped,
        J_damped_std=J_damped_std,
        entries_classic=entries_classic,
        entries_damped=entries_damped,
        **best_parts,
    )


def _best_practice(
    exp, found, runs, logs, known, gravity, gravity_cov, warnings, complete
) -> dict:
    """The best-practice reduction of every pendulum run (rsp_inertia.estimation.pendulum) and, when
    every node has one, its tensor through V with the axes at the runs' equilibria."""
    device = exp.device
    G = np.asarray(gravity, dtype=float)
    G_cov = np.zeros((2, 2)) if gravity_cov is None else np.asarray(gravity_cov, dtype=float)
    if known is not None:
        G = G + known.gravity
        G_cov = G_cov + known.cov[-2:, -2:]
    calibrated = calibrated_stiffness(exp)
    if calibrated is not None:
        c, c_std, source = *calibrated, "calibration.toml"
    else:
        c, c_std, source = device.pendulum.stiffness, device.pendulum.stiffness_std, "device.toml"
        if c_std is None:
            c_std = 0.0
            if warnings is not None:
                warnings.append(
                    f"{exp.root / 'device.toml'}: pendulum: no stiffness_std and no calibrated "
                    "stiffness (calibration.toml [pendulum]): the best-practice pendulum takes "
                    "the stiffness as exact, and its error is not in the stds (calibrate with "
                    "pendulum runs in the empty and reference folders)"
                )
    best, budgets, J, J_std, phi = [], [], [], [], []
    for (stage, k), run, log in zip(found, runs, logs):
        st = device.stages[stage - 1]
        path = exp.pendulum_path(stage, k)
        try:
            fit = half_cycle_fit(log, run.period, device.encoder.quantum, str(path))
        except InputError as exc:
            if warnings is not None:
                warnings.append(f"pendulum best practice: {exc}")
            best.append(None)
            budgets.append({})
            J.append(math.nan)
            J_std.append(math.nan)
            phi.append(math.nan)
            continue
        b = best_practice_inertia(fit, c, c_std, fit.centre, G, G_cov)
        empty = None if known is None else known.empty_inertia(stage, fit.centre)
        # The empty system subtracted from M: its uncertainty (calibration, or device.toml's
        # tare_inertia_std) is the budget's "empty system".
        empty_std = 0.0
        if known is not None and known.calibrated:
            empty_std = math.sqrt(max(known.empty_variance(stage, fit.centre), 0.0))
        best.append(b)
        budget = {name: float(axial_std(v, st)) for name, v in b.budget.items()}
        budget["empty system"] = float(axial_std(empty_std, st))
        budgets.append(budget)
        J.append(float(axial_moment(b.M, st, empty)))
        J_std.append(float(axial_std(math.sqrt(b.M_std**2 + empty_std**2), st)))
        phi.append(fit.centre)
    J, J_std, phi = np.array(J), np.array(J_std), np.array(phi)
    entries = cov = None
    if complete and np.all(np.isfinite(J)):
        dirs = np.array(
            [
                axis_direction(p, device.stages[stage - 1].gear_ratio)
                for (stage, _), p in zip(found, phi)
            ]
        )
        entries, cov, _ = tensor_from_axes(J, J_std, dirs)
    return {
        "best": best,
        "J_best": J,
        "J_best_std": J_std,
        "phi_best": phi,
        "entries_best": entries,
        "entries_best_cov": cov,
        "J_best_budget": budgets,
        "stiffness": (float(c), float(c_std), source),
    }

