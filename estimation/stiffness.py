"""The torsion pendulum's stiffness from the calibration folders (added-known-inertia method).

A pendulum user calibrates the torsion element the way the RSP side calibrates its rig: with
the empty fixture and with the reference body. At a node, the empty fixture oscillates at

    w_e^2 = (c + k_f(phi_e)) / M_e(phi_e),

and the fixture with the reference body at

    w_r^2 = (c + k_f(phi_r) + k_r(phi_r)) / (M_e(phi_r) + M_r(phi_r)),

w the undamped frequencies at zero amplitude (rsp_inertia.estimation.best_practice.half_cycle_fit), phi_e and
phi_r the oscillations' equilibria, k = -(Gs sin phi + Gc cos phi) the gravity stiffnesses
(docs/method.md §3) of the fixture (calibrated by the RSP calibration) and of the reference body
(its mass and centre of mass, reference.toml), and M_r the reference body's reduced inertia
(its tensor, docs/method.md §2). The RSP calibration's empty harmonics give the small change
d = M_e(phi_r) - M_e(phi_e) between the two equilibria. Eliminating M_e = M_e(phi_e):

    M_e = [w_r^2 (d + M_r) - k_f(phi_r) - k_r(phi_r) + k_f(phi_e)] / (w_e^2 - w_r^2),
    c = w_e^2 M_e - k_f(phi_e)

(with k = d = 0 the textbook two-period formula c = M_r w_e^2 w_r^2 / (w_e^2 - w_r^2)).
Each node with both runs gives one c; their weighted mean is the calibrated stiffness, its
std that of the mean, scaled up by sqrt(chi^2 / dof) when the nodes disagree beyond their
stds. A frequency's std is the best-practice budget's (fit, damping model, amplitude).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rsp_inertia.estimation.best_practice import (
    best_practice_inertia,
    gravity_stiffness,
    half_cycle_fit,
)
from rsp_inertia.estimation.conventions import reference_terms
from rsp_inertia.estimation.pendulum import crossing_period
from rsp_inertia.estimation.runs import ExperimentLogs
from rsp_inertia.infra.errors import InputError
from rsp_inertia.plant.config import TrueBody
from rsp_inertia.plant.model import inertia_basis

__all__ = ["StiffnessCalibration", "calibrate_stiffness"]


@dataclass(frozen=True)
class StiffnessCalibration:
    """The torsion element's stiffness from the calibration folders' pendulum runs."""

    stiffness: float
    """c, N m/rad."""
    stiffness_std: float
    """N m/rad."""
    per_node: list[tuple[int, float, float, float]]
    """(stage, node deg, c, std) of every node with an empty and a reference run."""
    chi2_dof: float
    """Of the nodes' c about their mean (NaN with one node)."""
    paths: list[str]
    """The pendulum logs used (their names, rsp_inertia.estimation.runs.Sources)."""


def _frequency(logs: ExperimentLogs, stage: int, k: int) -> tuple[float, float, float]:
    """(w_n, its std, the equilibrium phi) of the pendulum run at node k (1-based) of ``logs``."""
    log = logs.pendulum[stage, k]
    source = logs.sources.pendulum_log(stage, k)
    period, _ = crossing_period(log, source)
    fit = half_cycle_fit(log, period, logs.device.encoder.quantum, source)
    # The best practice's relative budget of M = 1 / w^2 (unit stiffness, no gravity): a
    # frequency's relative std is half of it.
    b = best_practice_inertia(fit, 1.0, 0.0, fit.centre, np.zeros(2), np.zeros((2, 2)))
    parts = [b.budget[name] for name in ("fit", "damping model", "amplitude")]
    return fit.omega_n, 0.5 * fit.omega_n * math.sqrt(sum(v * v for v in parts)) / b.M, fit.centre


def _two_period(w_e, w_r, Gf, Gr, phi_e, phi_r, d, M_r) -> float:
    """c from the two frequencies (module docstring): fixture gravity Gf and reference body
    gravity Gr ([Gs, Gc], N m), equilibria phi_e and phi_r, d = M_e(phi_r) - M_e(phi_e), and
    the reference's reduced inertia M_r at phi_r."""
    k_fe, k_fr = gravity_stiffness(Gf, phi_e), gravity_stiffness(Gf, phi_r)
    k_r = gravity_stiffness(Gr, phi_r)
    m_e = (w_r**2 * (d + M_r) - k_fr - k_r + k_fe) / (w_e**2 - w_r**2)
    return w_e**2 * m_e - k_fe


def calibrate_stiffness(
    empty: ExperimentLogs,
    reference: ExperimentLogs,
    body: TrueBody,
    fixture_gravity: np.ndarray,
    fixture_gravity_cov: np.ndarray,
    empty_inertia: np.ndarray,
) -> StiffnessCalibration | None:
    """c from every node that has a pendulum log in both experiments (module docstring).

    Parameters
    ----------
    empty : ExperimentLogs
        The empty-fixture experiment's logs, with its pendulum logs.
    reference : ExperimentLogs
        The reference experiment's logs, with its pendulum logs.
    body : TrueBody
        The reference body (reference.toml): mass, centre of mass and tensor.
    fixture_gravity : np.ndarray
        [Gs, Gc] of the fixture, N m: the RSP calibration's.
    fixture_gravity_cov : np.ndarray
        Their 2 x 2 covariance.
    empty_inertia : np.ndarray
        (stages, 5) harmonics of the empty system's reduced inertia, kg m^2: the RSP
        calibration's.

    Returns
    -------
    StiffnessCalibration or None
        The weighted mean of the nodes' c with its std; None when no node has both logs or
        the empty experiment's device has no ``[pendulum]`` table.

    Raises
    ------
    InputError
        A run the best-practice fit cannot take; a reference run no slower than the empty one
        (the reference adds no inertia there).
    """
    device = empty.device
    if device.pendulum is None:
        return None
    values, variances, per_node, paths = [], [], [], []
    for stage, st in enumerate(device.stages, 1):
        terms = reference_terms(body, st.gear_ratio, device.gravity)
        ref_harmonics, body_gravity = terms[:5], terms[5:]
        for k, node_deg in enumerate(st.nodes_deg, 1):
            if not all((stage, k) in logs.pendulum for logs in (empty, reference)):
                continue
            pair = [logs.sources.pendulum_log(stage, k) for logs in (empty, reference)]
            w_e, s_e, phi_e = _frequency(empty, stage, k)
            w_r, s_r, phi_r = _frequency(reference, stage, k)
            if not w_r < w_e:
                raise InputError(
                    f"{pair[1]}: the reference body's oscillation ({w_r:.6g} rad/s) is not "
                    f"slower than the empty fixture's ({w_e:.6g} rad/s, {pair[0]})"
                )
            basis = inertia_basis(np.array([phi_e, phi_r]))
            M_e = basis @ empty_inertia[stage - 1]
            d = float(M_e[1] - M_e[0])
            M_r = float(basis[1] @ ref_harmonics)

            def c_of(w_e, w_r, Gf, at=(phi_e, phi_r, d, M_r), Gb=body_gravity):
                return _two_period(w_e, w_r, Gf, Gb, *at)

            c = c_of(w_e, w_r, fixture_gravity)
            # First-order propagation: the two frequencies and the fixture's gravity terms.
            h_e, h_r = w_e * 1e-7, w_r * 1e-7
            grad_w = np.array([
                (c_of(w_e + h_e, w_r, fixture_gravity) - c) / h_e,
                (c_of(w_e, w_r + h_r, fixture_gravity) - c) / h_r,
            ])
            step = 1e-6
            grad_g = np.array([
                (c_of(w_e, w_r, fixture_gravity + step * e) - c) / step for e in np.eye(2)
            ])
            var = float((grad_w * [s_e, s_r]) @ (grad_w * [s_e, s_r]))
            var += float(grad_g @ fixture_gravity_cov @ grad_g)
            values.append(c)
            variances.append(var)
            per_node.append((stage, node_deg, c, math.sqrt(var)))
            paths += pair
    if not values:
        return None
    values, variances = np.array(values), np.array(variances)
    weights = 1.0 / variances
    mean = float(weights @ values / weights.sum())
    std = math.sqrt(1.0 / weights.sum())
    chi2_dof = math.nan
    if values.size > 1:
        chi2_dof = float(weights @ (values - mean) ** 2) / (values.size - 1)
        std *= math.sqrt(max(chi2_dof, 1.0))
    return StiffnessCalibration(mean, std, per_node, chi2_dof, paths)
