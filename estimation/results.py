"""What ``identify`` finds: the result records and their result.json text (docs/files.md).

The estimators that fill them: rsp_inertia.estimation.identify.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from rsp_inertia.estimation.best_practice import BestPractice
from rsp_inertia.estimation.calibration_summary import CalibrationSummary
from rsp_inertia.estimation.columns import format_run
from rsp_inertia.estimation.coverage import (
    DEFAULT_COVERAGE_FACTOR,
    ExpandedUncertainty,
    expanded_uncertainty,
)
from rsp_inertia.estimation.decision import Decision
from rsp_inertia.estimation.model_tests import ModelTest
from rsp_inertia.estimation.pendulum import PendulumEstimate
from rsp_inertia.estimation.records import Record
from rsp_inertia.infra.frozen import freeze_arrays, read_only
from rsp_inertia.plant.geometry import (
    ENTRY_KEYS,
    axis_direction,
    principal,
    principal_uncertainty,
)

__all__ = ["AxisResult", "Identification", "PendulumResult"]


@dataclass(frozen=True)
class AxisResult:
    """The moment of inertia about one node's axis."""

    stage: int
    """Stage number, from 1."""
    phi_deg: float
    """Node, deg."""
    direction: np.ndarray
    """Unit axis in the body frame (docs/method.md §1)."""
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

    def __post_init__(self) -> None:
        freeze_arrays(self)  # its arrays read-only, as the record is frozen


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

    def __post_init__(self) -> None:
        freeze_arrays(self)  # its arrays read-only, as the record is frozen

    def to_dict(self) -> dict:
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
            return None if e is None else dict(zip(ENTRY_KEYS, map(float, e)))
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
    """Everything ``identify`` finds; :meth:`to_json` gives result.json's text, :meth:`to_dict`
    its document (docs/files.md)."""

    entries: np.ndarray
    """[Jx, Jy, Jz, Jxy, Jyz, Jxz], kg m^2, least squares (headline)."""
    covariance: np.ndarray
    """(8, 8) joint covariance of [entries, gravity], order Jx, Jy, Jz, Jxy, Jyz, Jxz,
    m_g_xc, m_g_yc (kg^2 m^4, kg m^2 N m, N^2 m^2): the least squares fits them together
    (rsp_inertia.estimation.tensor_fit.TensorFit.cov); result.json's ``covariance``, which a
    combination of mountings needs (rsp_inertia.estimation.combine)."""
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
    pass_gain: np.ndarray | None = None
    """(runs,) the pass gain d of each run whose braking held two levels: the reverse pass's
    torque scale over the braking's, minus one (rsp_inertia.estimation.tensor_fit
    .pass_gain_unknown); NaN for a run that did not fit it; None: no run did."""
    pass_gain_std: np.ndarray | None = None
    """(runs,) std of ``pass_gain``."""
    warming: tuple[float, float] | None = None
    """(c, std), 1/(N^2 m^2): the warming motor's coefficient, fitted where device.toml models
    the warming (``[motor] winding_time_constant``; rsp_inertia.estimation.tensor_fit
    .WARMING_UNKNOWN); None: not fitted."""
    warming_drift: np.ndarray | None = None
    """(runs, 2) per run, the torque's scale over the reverse pass less over the braking that
    ``warming`` implies, and its std; None: not fitted."""
    std_budget: dict[str, dict[str, np.ndarray]] = field(default_factory=dict)
    """Uncertainty budget of the least squares: for each noise source (rsp_inertia.estimation.tensor_fit
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
    calibration: CalibrationSummary | None = None
    """What the identification took from calibration.toml, each term with its std, and the
    drive's gains and the encoder's error as the runs refined them (None: device.toml's
    tares)."""
    provenance: dict | None = None
    """When and by what the result was made, and the sha256 of every input file read
    (rsp_inertia.provenance.make_provenance; set by the ``identify`` command)."""
    record: Record | None = None
    """Who measured which part on which rig, the environment, the calibration's date and due
    date, the reference's certificate (rsp_inertia.estimation.records; set by identify)."""
    decision: Decision | None = None
    """The decision against EXP/spec.toml (rsp_inertia.estimation.decision); None without
    one."""
    coverage_factor: float = DEFAULT_COVERAGE_FACTOR
    """k of the expanded uncertainties U = k u (``identify --coverage-factor``)."""
    tempco: tuple[float, float | None, str] | None = None
    """(alpha 1/K, its std or None, the file that gave it: "calibration.toml" or
    "device.toml") the logs' torques were compensated with for the magnets' temperature
    (rsp_inertia.estimation.reading.tempco_in_use); None: not compensated."""

    @cached_property
    def expanded_uncertainty(self) -> ExpandedUncertainty:
        """The GUM statement: U = k u of the entries and the centre of mass, the principal
        moments' and axes' Monte Carlo intervals (rsp_inertia.estimation.coverage; computed
        once, when first read)."""
        return expanded_uncertainty(
            self.entries, self.entries_cov, self.coverage_factor, com_std=self.com_std
        )

    def __post_init__(self) -> None:
        freeze_arrays(self)  # its arrays read-only, as the record is frozen

    @property
    def entries_cov(self) -> np.ndarray:
        """(6, 6) covariance of ``entries``, kg^2 m^4: the upper-left block of ``covariance``."""
        return self.covariance[:6, :6]

    @property
    def gravity_cov(self) -> np.ndarray:
        """(2, 2) covariance of ``gravity``, N^2 m^2: the lower-right block of ``covariance``
        (the pendulum's gravity correction uses it)."""
        return self.covariance[6:, 6:]

    @property
    def entries_std(self) -> np.ndarray:
        """Standard deviations of ``entries`` (read-only)."""
        return read_only(np.sqrt(np.diag(self.entries_cov)))

    def _pass_gains(self) -> list[list[float] | None]:
        """Per run, [d, std] of its pass gain, or None where it was not fitted."""
        if self.pass_gain is None:
            return [None] * len(self.runs)
        return [_pass_gain(v, s) for v, s in zip(self.pass_gain, self.pass_gain_std)]

    def to_json(self) -> str:
        """The text of result.json: :meth:`to_dict` indented, with a final newline."""
        return json.dumps(self.to_dict(), indent=2) + "\n"

    def to_dict(self) -> dict:
        """The result.json document (docs/files.md), with extensions."""
        moments, vectors = principal(self.entries)
        moments_std, tilt_std = principal_uncertainty(self.entries, self.entries_cov)
        node_std = np.sqrt(np.diag(self.node_entries_cov))
        return {
            "tensor": dict(zip(ENTRY_KEYS, map(float, self.entries))),
            "tensor_std": dict(zip(ENTRY_KEYS, map(float, self.entries_std))),
            "covariance": [[float(c) for c in row] for row in self.covariance],
            "principal_moments": [float(m) for m in moments],
            "principal_moments_std": [float(m) for m in moments_std],
            "principal_axes": [[float(c) for c in v] for v in vectors],
            "principal_axes_tilt_std_deg": [
                float(np.degrees(t)) if np.isfinite(t) else None for t in tilt_std
            ],
            "expanded_uncertainty": self.expanded_uncertainty.to_dict(),
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
                "tensor": dict(zip(ENTRY_KEYS, map(float, self.node_entries))),
                "tensor_std": dict(zip(ENTRY_KEYS, map(float, node_std))),
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
                "pass_gain": [
                    {
                        "run": format_run(key),
                        "fitted": gain is not None,
                        "value": None if gain is None else gain[0],
                        "std": None if gain is None else gain[1],
                    }
                    for key, gain in zip(self.runs, self._pass_gains())
                ],
                "warming": {
                    "fitted": self.warming is not None,
                    "coefficient": None if self.warming is None else float(self.warming[0]),
                    "std": None if self.warming is None else float(self.warming[1]),
                    "drift": [
                        {
                            "run": format_run(key),
                            "value": None if self.warming is None else float(d[0]),
                            "std": None if self.warming is None else float(d[1]),
                        }
                        for key, d in zip(
                            self.runs,
                            self.warming_drift
                            if self.warming_drift is not None
                            else [(None, None)] * len(self.runs),
                        )
                    ],
                },
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
                "model_tests": [test.to_dict() for test in self.model_tests],
                "std_budget": {
                    source: {
                        "axes_J_std": [float(v) for v in part["axes"]],
                        "tensor_std": dict(zip(ENTRY_KEYS, map(float, part["tensor"]))),
                    }
                    for source, part in self.std_budget.items()
                },
            },
            "calibration": None if self.calibration is None else self.calibration.to_dict(),
            "temperature_compensation": {
                "compensated": self.tempco is not None,
                "tempco": None if self.tempco is None else float(self.tempco[0]),
                "tempco_std": None
                if self.tempco is None or self.tempco[1] is None
                else float(self.tempco[1]),
                "source": None if self.tempco is None else self.tempco[2],
            },
            "warnings": list(self.warnings),
            "pendulum": None if self.pendulum is None else self.pendulum.to_dict(),
            "provenance": self.provenance,
            "record": None if self.record is None else self.record.to_dict(),
            "decision": None if self.decision is None else self.decision.to_dict(),
        }


def _pass_gain(value: float, std: float) -> list[float] | None:
    """(d, std) of one run's pass gain for JSON, None when it was not fitted."""
    return [float(value), float(std)] if np.isfinite(value) else None


def _finite_list(values) -> list[float] | None:
    """Plain floats for JSON, or None when the values are not estimated (NaN)."""
    values = np.asarray(values, dtype=float)
    return [float(v) for v in values] if np.all(np.isfinite(values)) else None
