"""Identification from an experiment's logs in memory: tensor and centre of mass out.

Takes what a rig produces (the device and the logs,
:class:`rsp_inertia.estimation.runs.ExperimentLogs`) and what its calibration knows
(:class:`rsp_inertia.estimation.known_terms.KnownTerms`), never the virtual device's truth;
opens no file (rsp_inertia.estimation.reading reads a folder). Steps, each in its own
function: smoothing and motor work (rsp_inertia.estimation.passes), balances
(rsp_inertia.estimation.balance), least squares (rsp_inertia.estimation.tensor_fit), the
node formula (rsp_inertia.estimation.nodes; here :func:`axis_nodes`, :func:`node_moments`),
the axes' tensor (rsp_inertia.estimation.axes), the centre of mass (:func:`centre_of_mass`),
the warnings (:func:`fit_warnings`) and the pendulum baseline (:func:`pendulum_baseline`).

Two estimates of the tensor are reported:

- **least squares** (the headline): every stage's balance angles over all covered turns in
  one weighted least-squares problem (docs/method.md §5), tensor and gravity terms together;
- **node formula**: M at each node from its whole-turn pairs, J_k = (M - M_tare)/(1+lam^2),
  and the tensor from the J_k through V (the paper's six-axis solve, (8)).

The torsion-pendulum baseline (:func:`pendulum_baseline`) reduces the pendulum logs.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence

import numpy as np

from rsp_inertia.estimation.axes import axis_values, tensor_from_axes
from rsp_inertia.estimation.best_practice import best_practice_inertia, half_cycle_fit
from rsp_inertia.estimation.columns import format_run
from rsp_inertia.estimation.known_terms import KnownTerms
from rsp_inertia.estimation.layout import SHARED_LAYOUT
from rsp_inertia.estimation.model_tests import coarse_encoder_warnings, model_warnings
from rsp_inertia.estimation.nodes import NodeEstimate, node_estimates, node_passages
from rsp_inertia.estimation.pendulum import PendulumEstimate, estimate_pendulum
from rsp_inertia.estimation.results import AxisResult, Identification, PendulumResult
from rsp_inertia.estimation.runs import ExperimentLogs, balance_runs, corrected_log
from rsp_inertia.estimation.tensor_fit import TensorFit, fit_tensor
from rsp_inertia.infra.errors import InputError
from rsp_inertia.infra.progress import say
from rsp_inertia.plant.config import Device, Pendulum
from rsp_inertia.plant.geometry import (
    AxisDesign,
    axis_direction,
    axis_nodes_deg,
    device_design,
    physical_warnings,
)
from rsp_inertia.plant.logs import Log

__all__ = [
    "MAX_CONDITION",
    "TEMPCO_SOURCE",
    "WARN_CONDITION",
    "add_consider_line",
    "axial_moment",
    "axial_std",
    "axis_nodes",
    "centre_of_mass",
    "checked_design",
    "fit_warnings",
    "identify_logs",
    "node_moments",
    "pendulum_baseline",
    "pendulum_settings",
    "reduce_pendulum_run",
    "std_budget",
]

MAX_CONDITION = 1e3
"""cond(V) above which the axis design is refused: the tensor would be noise."""

WARN_CONDITION = 10.0
"""cond(V) above which the design is accepted with a warning."""

TEMPCO_SOURCE = "torque constant vs temperature"
"""Budget line of the torque constant's tempco's std (device.toml ``[motor]
torque_constant_tempco_std``; docs/method.md §3, "Temperature")."""

ENTRIES = SHARED_LAYOUT.slice("entries")
"""The tensor's entries among the least squares' shared unknowns (TensorFit.cov)."""


def axial_moment(M, stage, empty=None) -> np.ndarray | float:
    """J_e = (M - M_tare) / (1 + lam^2) about a stage's axis (docs/method.md §2).

    Parameters
    ----------
    M : float or array_like
        kg m^2, the reduced inertia at the node.
    stage : Stage
        The stage (its gear ratio lam and tare).
    empty : float, optional
        kg m^2, the empty system's reduced inertia at the node (tare and fixture, from a
        calibration); device.toml's tare by default.

    Returns
    -------
    float or numpy.ndarray
        J_e, kg m^2, shaped like ``M``.
    """
    tare = stage.tare_inertia if empty is None else empty
    return (np.asarray(M) - tare) / (1.0 + stage.gear_ratio**2)


def axial_std(M_std, stage) -> np.ndarray | float:
    """Standard deviation of :func:`axial_moment` (the tare is exact)."""
    return np.asarray(M_std) / (1.0 + stage.gear_ratio**2)


def checked_design(device: Device, source: str = "device.toml") -> AxisDesign:
    """The device's axis design (rsp_inertia.plant.geometry.device_design), refused when
    ill-conditioned (cond(V) not below MAX_CONDITION); ``source`` names device.toml.

    Raises
    ------
    InputError
        cond(V) >= MAX_CONDITION: the tensor would be noise.
    """
    design = device_design(device)
    cond = design.condition
    if not cond < MAX_CONDITION:
        raise InputError(
            f"{source}: stage: the node axes are ill-conditioned "
            f"(cond(V) = {cond:.3g} > {MAX_CONDITION:g}); choose gear ratios and nodes that "
            "spread the axes (see rsp-inertia design)"
        )
    return design


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
        M_parts=tuple(float(np.mean([n.M_parts[j] for n in found])) for j in range(2)),
    )


def identify_logs(
    logs: ExperimentLogs,
    known: KnownTerms,
    *,
    pendulum_stiffness: tuple[float, float] | None = None,
    warnings: Sequence[str] = (),
    conventions: str = "",
) -> Identification:
    """Identify the tensor (and centre of mass) from every run's braking and reverse logs.

    The steps, each a function: the balances and the least squares
    (rsp_inertia.estimation.runs.balance_runs, rsp_inertia.estimation.tensor_fit.fit_tensor),
    the node formula at each axis (:func:`axis_nodes`, :func:`node_moments`), the centre of
    mass (:func:`centre_of_mass`), the warnings (:func:`fit_warnings`) and the pendulum
    baseline (:func:`pendulum_baseline`).

    Parameters
    ----------
    logs : ExperimentLogs
        The device, every run's logs and the pendulum logs present, with their names.
    known : KnownTerms
        What the balances take as known about the rig: a calibration's terms
        (rsp_inertia.estimation.calibration), or device.toml's
        (rsp_inertia.estimation.calibration.device_known_terms).
    pendulum_stiffness : (c, std), optional
        N m/rad, the calibrated torsion stiffness (calibration.toml ``[pendulum]``) for the
        best-practice pendulum; device.toml's ``[pendulum]`` one without it.
    warnings : sequence of str
        Warnings found before (by the reader of the inputs): the result's list starts with them.
    conventions : str
        The calibration's line on the rig's conventions (calibration.toml
        ``calibration.conventions``), carried into the result's ``calibration``.

    Returns
    -------
    Identification
        The tensor by least squares and by the node formula, the centre of mass, the axes,
        the std budget, the model tests, the pendulum baseline and the warnings.

    Raises
    ------
    InputError
        Malformed logs, logs that do not overlap, too few turns for a node, a braking whose
        speed reverses, an ill-conditioned axis design.
    ValueError
        ``logs.runs`` are not the device's runs (rsp_inertia.estimation.runs.balance_runs).
    """
    device = logs.device
    warnings = list(warnings)
    # Refused before any log is read: device.toml alone says so. The axes are the device's
    # design (a lambda = 0 stage gives one, whatever its nodes), in its order.
    design = checked_design(device, logs.sources.device)
    balances, passages = balance_runs(
        logs, warnings, known.encoder, _at_nodes(device, known), zero=known.zero
    )
    fit = fit_tensor(balances, known, drift_std=device.motor.torque_constant_drift_std)
    nodes = axis_nodes(device, passages, fit)
    warnings += fit_warnings(fit, balances, device)
    directions = design.directions
    cond = design.condition
    if cond > WARN_CONDITION:
        warnings.append(f"the axis design is poorly conditioned: cond(V) = {cond:.3g}")
    J_ls, J_ls_std = axis_values(fit.entries, fit.entries_cov, directions)
    J_node, J_node_std, J_plain, J_plain_std = node_moments(device, known, nodes)
    node_entries, node_cov = tensor_from_axes(
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
    com, com_std = centre_of_mass(device, fit.gravity, gravity_std)
    warnings += physical_warnings(fit.entries, fit.entries_cov)
    pendulum = pendulum_baseline(
        logs, known, fit.gravity, fit.gravity_cov, pendulum_stiffness, warnings
    )
    return Identification(
        entries=fit.entries,
        covariance=fit.cov,
        node_entries=node_entries,
        node_entries_cov=node_cov,
        axes=axes,
        com=com,
        com_std=com_std,
        gravity=fit.gravity,
        gravity_std=gravity_std,
        condition_number=cond,
        chi2_dof=fit.chi2_dof,
        n_equations=fit.n_equations,
        speed_noise_scale=fit.speed_noise_scale,
        friction_slope=fit.friction_slope,
        friction_slope_std=fit.friction_slope_std,
        pass_gain=fit.pass_gain,
        pass_gain_std=fit.pass_gain_std,
        warming=fit.warming,
        warming_drift=fit.warming_drift,
        std_budget=std_budget(fit, directions),
        warnings=warnings,
        pendulum=pendulum,
        runs=fit.runs,
        friction_asymmetry=fit.friction_asymmetry,
        friction_asymmetry_std=fit.friction_asymmetry_std,
        model_tests=fit.tests,
        calibration=known.summary(fit.known_after, conventions),
    )


def _at_nodes(device: Device, known: KnownTerms) -> Callable:
    """The node formula's sampler of a run's passes for balance_runs (rsp_inertia.estimation
    .runs): (stage, sign, braking, reverse) -> the passages at the stage's axis nodes."""

    def at_nodes(stage, sign, braking, reverse):
        # The node formula's samples of the passes, taken before they are let go; the fit's
        # speed-noise scales and friction slopes are applied after it (node_estimates).
        nodes_deg = axis_nodes_deg(device.stages[stage - 1])
        return node_passages(device, stage, braking, reverse, nodes_deg, sign, known.gains)

    return at_nodes


def axis_nodes(device: Device, passages: list, fit: TensorFit) -> list[NodeEstimate]:
    """The node formula's M at each axis's node (docs/method.md §4), in the design's order:
    every run's estimate with the least squares' speed-noise scale and friction slopes of its
    run (rsp_inertia.estimation.nodes.node_estimates), a node's runs combined.

    Parameters
    ----------
    device : Device
        The gimbal (its stages' axis nodes).
    passages : list
        Per run, the passages sampled at its stage's nodes (rsp_inertia.estimation.runs
        .balance_runs).
    fit : TensorFit
        The least squares of the same runs, in the same order.

    Returns
    -------
    list of NodeEstimate
        One per axis.
    """
    by_node = {
        (stage, node_deg): []
        for stage, st in enumerate(device.stages, 1)
        for node_deg in axis_nodes_deg(st)
    }
    for k, run_passages in enumerate(passages):
        for n in node_estimates(
            run_passages, fit.speed_noise_scale[k], fit.friction_slope[k],
            fit.friction_slope_cov[k],
        ):
            by_node[n.stage, n.node_deg].append(n)
    return [_combine_directions(found) for found in by_node.values()]


def node_moments(device: Device, known: KnownTerms, nodes: list[NodeEstimate]) -> tuple[list, ...]:
    """J_k = (M - M_empty) / (1 + lam^2) of each node's M (:func:`axial_moment`), the full
    and the plain node formula's, with stds that hold the known terms' uncertainty
    (KnownTerms.node_variance: a calibration's, or device.toml's stated stds) besides the
    node formula's own.

    Parameters
    ----------
    device : Device
        The gimbal (its stages' gear ratios).
    known : KnownTerms
        The rig's known terms (the empty system's M and its variance).
    nodes : list of NodeEstimate
        The node formula's M per axis (:func:`axis_nodes`).

    Returns
    -------
    J_node, J_node_std, J_plain, J_plain_std : list
        kg m^2, per axis.
    """
    J_node, J_node_std, J_plain, J_plain_std = [], [], [], []
    for n in nodes:
        st = device.stages[n.stage - 1]
        phi = math.radians(n.node_deg)
        empty = known.empty_inertia(n.stage, phi)
        # The known terms' uncertainty (calibration, or device.toml's stated stds) adds to
        # the node formula's own, as it does to the least squares'.
        known_var = known.node_variance(n.stage, phi, n.M_parts, n.M) if known.calibrated else 0.0
        J_node.append(axial_moment(n.M, st, empty))
        J_node_std.append(axial_std(math.sqrt(n.M_std**2 + known_var), st))
        J_plain.append(axial_moment(n.M_plain, st, empty))
        # The plain formula's shares as the full one's, scaled to its M.
        plain_parts = [part * n.M_plain / n.M for part in n.M_parts] if n.M else n.M_parts
        plain_var = (
            known.node_variance(n.stage, phi, plain_parts, n.M_plain) if known.calibrated else 0.0
        )
        J_plain_std.append(axial_std(math.sqrt(n.M_plain_std**2 + plain_var), st))
    return J_node, J_node_std, J_plain, J_plain_std


def centre_of_mass(
    device: Device, gravity: np.ndarray, gravity_std: np.ndarray
) -> tuple[np.ndarray | None, np.ndarray | None]:
    """[x_c, y_c] = [Gs, Gc] / (m g), m, with stds; (None, None) without device.toml's
    ``[body] mass`` (docs/method.md §5).

    Parameters
    ----------
    device : Device
        The gimbal (its body's mass and gravity).
    gravity : numpy.ndarray, shape (2,)
        N m, the body's gravity terms [Gs, Gc].
    gravity_std : numpy.ndarray, shape (2,)
        N m, their stds.

    Returns
    -------
    com, com_std : numpy.ndarray or None
        m.
    """
    if device.body is None:
        return None, None
    weight = device.body.mass * device.gravity
    return gravity / weight, gravity_std / weight


def fit_warnings(fit: TensorFit, balances: list, device: Device) -> list[str]:
    """What the least squares' checks found, one line each: the model tests and the runs'
    speed-noise scales (rsp_inertia.estimation.model_tests.model_warnings), the friction
    slopes' priors the balances rejected, and a coarse encoder.

    Parameters
    ----------
    fit : TensorFit
        The least squares.
    balances : list of StageBalance
        Its runs' balances.
    device : Device
        The gimbal (its encoder's quantum and sampling interval).

    Returns
    -------
    list of str
        The warnings, in that order.
    """
    labels = [format_run(key) for key in fit.runs]
    warnings = model_warnings(fit.tests, fit.speed_noise_scale, labels)
    warnings += fit.prior_warnings
    warnings += coarse_encoder_warnings(
        balances, device.encoder.quantum, device.encoder.dt, labels
    )
    return warnings


def std_budget(fit: TensorFit, directions: np.ndarray) -> dict[str, dict[str, np.ndarray]]:
    """The least squares' uncertainty budget: per noise source, the stds of the axes' J_k and
    of the tensor's entries that its share of the covariance gives (Identification.std_budget).

    Parameters
    ----------
    fit : TensorFit
        The least squares (its ``cov_parts``).
    directions : numpy.ndarray, shape (k, 3)
        The axes' unit directions.

    Returns
    -------
    dict
        Source -> {"axes": stds of J_k, "tensor": stds of the entries}, kg m^2.
    """
    return {
        source: {
            "axes": axis_values(fit.entries, part[ENTRIES, ENTRIES], directions)[1],
            # A fitted line's share can dip a rounding below zero on an entry the fitted
            # unknowns barely touch (the lines are attributions: tensor_fit._with_pass_gain_share).
            "tensor": np.sqrt(np.maximum(np.diag(part[ENTRIES, ENTRIES]), 0.0)),
        }
        for source, part in fit.cov_parts.items()
    }


def pendulum_baseline(
    logs: ExperimentLogs,
    known: KnownTerms | None = None,
    gravity: np.ndarray | None = None,
    gravity_cov: np.ndarray | None = None,
    stiffness: tuple[float, float] | None = None,
    warnings: list[str] | None = None,
) -> PendulumResult | None:
    """The torsion-pendulum baseline from the pendulum logs of ``logs`` (one per node run).

    The classic and damped reductions take device.toml's ``[pendulum]`` stiffness.

    Parameters
    ----------
    logs : ExperimentLogs
        The device and the logs; its pendulum logs are reduced.
    known : KnownTerms, optional
        The calibration: the empty system's inertia at the node is the calibration's when
        ``known`` has one (the same tare and fixture as the RSP result), else device.toml's
        tare; it also gives the fixture's gravity terms and the encoder's error.
    gravity : numpy.ndarray, shape (2,), optional
        The body's [Gs, Gc], N m (the RSP least squares'): it feeds the best-practice
        reduction's gravity stiffness, with the fixture's from ``known``; without it that
        reduction is skipped.
    gravity_cov : numpy.ndarray, shape (2, 2), optional
        Its covariance (the RSP least squares').
    stiffness : tuple of float, optional
        (c, std), N m/rad, the calibrated stiffness the best practice takes; device.toml's
        without it.
    warnings : list of str, optional
        A run the best-practice reduction cannot take (too few half cycles) gets None there
        and a line here, as does each glitch the reader left out of a run
        (rsp_inertia.plant.logs.Log.warnings).

    Returns
    -------
    PendulumResult or None
        The reductions of every run and, when every node has one, their tensors; None when
        there is no pendulum log.

    Raises
    ------
    InputError
        Pendulum logs without device.toml's ``[pendulum]`` table; a log too short to reduce.
    """
    device = logs.device
    found = [
        (stage, k)
        for stage, st in enumerate(device.stages, 1)
        for k in range(1, len(st.nodes) + 1)
        if (stage, k) in logs.pendulum
    ]
    if not found:
        return None
    pendulum_settings(device, logs.sources.device)
    encoder = () if known is None else known.encoder
    zero = 0.0 if known is None else known.zero
    pendulum_logs, runs, directions = {}, [], []
    for stage, k in found:
        st = device.stages[stage - 1]
        log = logs.pendulum[stage, k]
        if warnings is not None:
            warnings.extend(log.warnings)  # glitches the reader left out
        pendulum_logs[stage, k], run = reduce_pendulum_run(
            device, log, stage, k, logs.sources.pendulum_log(stage, k), encoder, zero
        )
        runs.append(run)
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
            logs, pendulum_logs, found, runs, known, gravity, gravity_cov, stiffness, warnings,
            complete,
        )
    say(f"pendulum: {len(runs)} run(s) reduced")
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


def pendulum_settings(device: Device, source: str = "device.toml") -> Pendulum:
    """device.toml's ``[pendulum]`` settings, which pendulum logs need (the stiffness);
    ``source`` names device.toml.

    Raises
    ------
    InputError
        The table is missing.
    """
    if device.pendulum is None:
        raise InputError(
            f"{source}: pendulum: pendulum logs are present but the [pendulum] table (its "
            "stiffness) is missing"
        )
    return device.pendulum


def reduce_pendulum_run(
    device: Device,
    log: Log,
    stage: int,
    node: int,
    source: str,
    encoder=(),
    zero: float = 0.0,
) -> tuple[Log, PendulumEstimate]:
    """One pendulum run reduced as :func:`pendulum_baseline` reduces it: its readings taken
    back to the true angle with the encoder's error coefficients (the RSP runs' encoder,
    rsp_inertia.estimation.runs.corrected_log), then
    rsp_inertia.estimation.pendulum.estimate_pendulum with the stiffness of
    :func:`pendulum_settings`.

    Parameters
    ----------
    device : Device
        The gimbal, with its ``[pendulum]`` table.
    log : Log
        The pendulum run's log.
    stage : int
        The stage number, from 1.
    node : int
        The node's number in the stage, from 1.
    source : str
        Names the log in messages.
    encoder : sequence of float, optional
        theta_e, rad, the encoder's error coefficients (none: the readings as they are).
    zero : float, optional
        rad, the encoder's zero offset, taken off with them.

    Returns
    -------
    log : Log
        The corrected log.
    estimate : PendulumEstimate
        Its reduction.

    Raises
    ------
    InputError
        No ``[pendulum]`` table; a log with too few oscillations, naming ``source``.
    """
    stiffness = pendulum_settings(device).stiffness
    log = corrected_log(log, encoder, zero)
    nodes_deg = device.stages[stage - 1].nodes_deg
    return log, estimate_pendulum(log, stiffness, stage, nodes_deg[node - 1], source)


def _best_practice(
    logs, pendulum_logs, found, runs, known, gravity, gravity_cov, calibrated, warnings, complete
) -> dict:
    """The best-practice reduction of every pendulum run (rsp_inertia.estimation.pendulum) and, when
    every node has one, its tensor through V with the axes at the runs' equilibria.
    ``calibrated``: the calibrated stiffness (c, std), or None for device.toml's."""
    device = logs.device
    G = np.asarray(gravity, dtype=float)
    G_cov = np.zeros((2, 2)) if gravity_cov is None else np.asarray(gravity_cov, dtype=float)
    if known is not None:
        G = G + known.gravity
        G_cov = G_cov + known.cov[known.gravity_slice, known.gravity_slice]
    if calibrated is not None:
        c, c_std, source = *calibrated, "calibration.toml"
    else:
        c, c_std, source = device.pendulum.stiffness, device.pendulum.stiffness_std, "device.toml"
        if c_std is None:
            c_std = 0.0
            if warnings is not None:
                warnings.append(
                    f"{logs.sources.device}: pendulum: no stiffness_std and no calibrated "
                    "stiffness (calibration.toml [pendulum]): the best-practice pendulum takes "
                    "the stiffness as exact, and its error is not in the stds (calibrate with "
                    "pendulum runs in the empty and reference folders)"
                )
    best, budgets, J, J_std, phi = [], [], [], [], []
    for (stage, k), run in zip(found, runs):
        st = device.stages[stage - 1]
        log = pendulum_logs[stage, k]
        try:
            fit = half_cycle_fit(
                log, run.period, device.encoder.quantum, logs.sources.pendulum_log(stage, k)
            )
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
        entries, cov = tensor_from_axes(J, J_std, dirs)
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


def _rss(std, shift):
    """sqrt(std^2 + shift^2), entry by entry."""
    return np.hypot(np.asarray(std, dtype=float), np.asarray(shift, dtype=float))


def add_consider_line(found: Identification, shifted: Identification, source: str) -> Identification:
    """``found`` with a known quantity's uncertainty added as the budget line ``source``:
    ``shifted`` is the same identification with that quantity moved by one std, so that the
    difference of every estimate is its response to it (a consider parameter, exact to first
    order: the balances are linear in it; docs/method.md §3, "Temperature").

    Parameters
    ----------
    found : Identification
        The identification.
    shifted : Identification
        The same logs identified with the quantity one std off.
    source : str
        The budget line's name.

    Returns
    -------
    Identification
        ``found`` with the rank-one covariance d d^T added to ``covariance`` and
        ``node_entries_cov`` (d the shift of [entries, gravity] and of the node entries), the
        shifts added in quadrature to every axis's stds, the gravity's and the centre of
        mass's, and the budget line ``source`` (the shifts of the axes' J_k and the entries).
    """
    d = np.concatenate([shifted.entries - found.entries, shifted.gravity - found.gravity])
    d_node = shifted.node_entries - found.node_entries
    axes = [
        dataclasses.replace(
            a,
            J_std=float(_rss(a.J_std, b.J - a.J)),
            J_node_std=float(_rss(a.J_node_std, b.J_node - a.J_node)),
            J_plain_std=float(_rss(a.J_plain_std, b.J_plain - a.J_plain)),
        )
        for a, b in zip(found.axes, shifted.axes, strict=True)
    ]
    com_std = found.com_std
    if com_std is not None and shifted.com is not None:
        com_std = _rss(com_std, shifted.com - found.com)
    budget = dict(found.std_budget)
    budget[source] = {
        "axes": np.abs([b.J - a.J for a, b in zip(found.axes, shifted.axes, strict=True)]),
        "tensor": np.abs(d[:6]),
    }
    return dataclasses.replace(
        found,
        covariance=found.covariance + np.outer(d, d),
        node_entries_cov=found.node_entries_cov + np.outer(d_node, d_node),
        axes=axes,
        gravity_std=_rss(found.gravity_std, d[6:]),
        com_std=com_std,
        std_budget=budget,
    )
