"""The paper's node formula: M at a node from the whole-turn pairs of both passes.

Nodes phi_a and phi_b = phi_a + 2 pi m (the same axis, M equal at both), braking speeds
Omega_a, Omega_b, reverse speeds (magnitudes) Omega'_a, Omega'_b, motor work A on the braking
pass (from a to b) and A' on the reverse (from b back to a), dPi = Pi(phi_b) - Pi(phi_a)
(docs/method.md §5):

    M = 2 (A' - A + 2 dPi) / (Omega_a^2 + Omega'_a^2 - Omega_b^2 - Omega'_b^2)

A and A' the work the body received: the drive's gains h_d and h_b times the logged work's
driving and back-driven parts (docs/method.md §3, rsp_inertia.plant.transducers). With
perfect symmetry (Omega' = Omega) it is the paper's formula (6),
M = (A' - A + 2 dPi) / (Omega_a^2 - Omega_b^2). The passes, their common range and the
tracking mismatch's regressors are the stage balance's (rsp_inertia.estimation.balance).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from rsp_inertia.estimation.balance import (
    balance_spacing,
    mismatch_regressors,
    spring_potential,
    usable_range,
)
from rsp_inertia.estimation.passes import PassEstimate, angle_work_noise
from rsp_inertia.infra.errors import InputError
from rsp_inertia.plant.config import Device

__all__ = ["NodeEstimate", "NodePassages", "node_estimates", "node_formula", "node_passages"]


@dataclass(frozen=True)
class NodeEstimate:
    """Reduced inertia at one node from its whole-turn pairs (docs/method.md §5)."""

    stage: int
    """Stage number, from 1."""
    node_deg: float
    """Node angle, deg."""
    M: float
    """kg m^2, RSP formula with the measured reverse speeds (inverse-variance mean of pairs)."""
    M_std: float
    """kg m^2."""
    M_plain: float
    """kg m^2, the paper's formula (6)/(7): braking speeds only."""
    M_plain_std: float
    """kg m^2."""
    pairs: int
    """Number of one-turn pairs used."""
    M_parts: tuple[float, float] = (0.0, 0.0)
    """kg m^2, the shares of ``M`` from the drive's driving and back-driven work (h_d and h_b
    times the logged works' parts): dM/dh_d = M_parts[0] / h_d, likewise h_b."""


@dataclass(frozen=True)
class NodePassages:
    """What the node formula takes from one run's passes at one node (:func:`node_passages`):
    the pairs' numerators and the passages' speeds, before the least squares gives the run's
    speed-noise scale and friction slopes. Arrays of the node's pairs or passages: the passes
    themselves can be let go once it is made."""

    stage: int
    """Stage number, from 1."""
    node_deg: float
    """Node angle, deg."""
    parts: tuple[np.ndarray, np.ndarray]
    """J, each pair's received work from the drive's driving and back-driven parts."""
    num: np.ndarray
    """J, each pair's numerator A' - A + 2 dPi (without the mismatch's correction)."""
    num_cov: np.ndarray
    """J^2, (pairs, pairs) covariance of ``num``."""
    mismatch: np.ndarray
    """(pairs, 2) R_a - R_b, the mismatch regressors' change over each pair."""
    speed_sq: tuple[np.ndarray, np.ndarray]
    """rad^2/s^2, the braking's and the reverse's squared speeds at the passages."""
    speed_sq_var: tuple[np.ndarray, np.ndarray]
    """rad^4/s^4, their variances at a speed-noise scale of 1."""


def node_formula(
    device: Device,
    stage: int,
    braking: PassEstimate,
    reverse: PassEstimate,
    nodes_deg: Sequence[float],
    speed_noise_scale: float = 1.0,
    direction: int = 1,
    gains: tuple[float, float] = (1.0, 1.0),
    friction_slope: np.ndarray | None = None,
    friction_slope_cov: np.ndarray | None = None,
) -> list[NodeEstimate]:
    """M at each node from every one-turn pair (phi_a, phi_a + 2 pi).

    docs/method.md §5: M = 2 (A' - A + 2 dPi) / (Omega_a^2 + Omega'_a^2 - Omega_b^2 - Omega'_b^2),
    and the paper's plain form M = (A' - A + 2 dPi) / (Omega_a^2 - Omega_b^2). Gravity cancels
    over whole turns; dPi is the spring's. Pairs are combined by generalised least squares
    (:func:`_combine_pairs`): speed noise from the smoothers' derived error variance times
    ``speed_noise_scale``, and work noise from the torque logs (rsp_inertia.estimation.passes).

    With the friction slopes d = [d1, d2] the balance of a pair reads
    1/2 M (S_a - S_b) = N + (R_a - R_b) . d, R the mismatch regressors at the passages, so
    the correction joins every pair's numerator and its uncertainty the numerators'
    covariance (the pairs share d). Without them the mismatch's friction work is left in M.

    The two steps, :func:`node_passages` (from the passes) and :func:`node_estimates` (with
    the least squares' scale and slopes), one after the other.

    Parameters
    ----------
    device : Device
        The device.
    stage : int
        Stage number, from 1.
    braking, reverse : PassEstimate
        The run's two passes.
    nodes_deg : sequence of float
        deg, the nodes.
    speed_noise_scale : float
        The calibration of the smoothers' speed-error variance that the least squares finds
        on its residuals (rsp_inertia.estimation.tensor_fit).
    direction : int
        -1: a backward run's passes, mirrored by :func:`rsp_inertia.plant.logs.mirror_log`;
        its node phi sits at -phi in the mirrored coordinate.
    gains : tuple of float
        (h_d, h_b), the drive's gains that make the logged motor work's driving and
        back-driven parts the work the body received
        (rsp_inertia.plant.transducers.drive_gains; a calibration's,
        rsp_inertia.estimation.calibration).
    friction_slope : np.ndarray, optional
        [d1, d2], the run's tracking-mismatch slopes that the least squares fits (module
        docstring); None: no correction.
    friction_slope_cov : np.ndarray, optional
        (2, 2) their covariance.

    Returns
    -------
    list of NodeEstimate
        One per node, in the order of ``nodes_deg``.
    """
    return node_estimates(
        node_passages(device, stage, braking, reverse, nodes_deg, direction, gains),
        speed_noise_scale,
        friction_slope,
        friction_slope_cov,
    )


def node_passages(
    device: Device,
    stage: int,
    braking: PassEstimate,
    reverse: PassEstimate,
    nodes_deg: Sequence[float],
    direction: int = 1,
    gains: tuple[float, float] = (1.0, 1.0),
) -> list[NodePassages]:
    """The node formula's first step (:func:`node_formula`): the passes sampled at every
    node's passages, a turn apart over their usable range.

    Parameters
    ----------
    device : Device
        The device.
    stage : int
        Stage number, from 1.
    braking, reverse : PassEstimate
        The run's two passes.
    nodes_deg : sequence of float
        deg, the nodes.
    direction : int
        -1: a backward run's mirrored passes (:func:`node_formula`).
    gains : tuple of float
        (h_d, h_b), the drive's gains (:func:`node_formula`).

    Returns
    -------
    list of NodePassages
        One per node, in the order of ``nodes_deg``.

    Raises
    ------
    InputError
        A node with fewer than two passages in the passes' common range.
    """
    nodes = np.radians(np.asarray(nodes_deg, dtype=float))
    lo, hi = usable_range(braking, reverse, stage)
    found = []
    for node_deg, node in zip(nodes_deg, direction * nodes):
        first = node + 2 * math.pi * math.ceil((lo - node) / (2 * math.pi))
        passages = np.arange(first, hi, 2 * math.pi)
        if passages.size < 2:
            raise InputError(
                f"{braking.source}: stage {stage}: node {node_deg:g} deg: the passes cover no "
                f"whole turn from it at useful speed ({passages.size} passage(s) in the common "
                "range); the braking must cover more turns"
            )
        b = braking.sample_at(passages)
        r = reverse.sample_at(passages)
        a_, b_ = slice(None, -1), slice(1, None)
        # Received work [driving, back-driven] of each pair: braking a -> b (negative) taken
        # from the reverse's b -> a (positive when driving).
        parts = []
        for h, kind in zip(gains, ("driving", "back")):
            wb = b.work_back if kind == "back" else b.work - b.work_back
            wr = r.work_back if kind == "back" else r.work - r.work_back
            parts.append(h * ((wr[a_] - wr[b_]) - (wb[b_] - wb[a_])))
        true_angle = direction * passages
        dPi = spring_potential(true_angle[b_], device) - spring_potential(true_angle[a_], device)
        # Work errors at the passages, differenced into the pairs' numerators; each torque
        # log's noise times the gain of its pass's power flow.
        step = np.diff(np.eye(passages.size), axis=0)
        scale_b, scale_r = (
            gains[1] if p.mainly_back_driven else gains[0] for p in (braking, reverse)
        )
        n = passages.size
        cov_b = braking.work_covariance(b) + angle_work_noise(b.work_var_angle, n).dense()
        cov_r = reverse.work_covariance(r) + angle_work_noise(r.work_var_angle, n).dense()
        num_cov = step @ (scale_b**2 * cov_b + scale_r**2 * cov_r) @ step.T
        R = _mismatch_at(braking, reverse, lo, passages)
        wb2, wr2 = b.omega**2, r.omega**2
        # Passages a turn apart: their speed errors are independent (R decays in ~40 / w_c,
        # a gap's added covariance within GAP_REACH / w_c of it).
        found.append(
            NodePassages(
                stage=stage,
                node_deg=float(node_deg),
                parts=(parts[0], parts[1]),
                num=parts[0] + parts[1] + 2 * dPi,
                num_cov=num_cov,
                mismatch=R[a_] - R[b_],
                speed_sq=(wb2, wr2),
                speed_sq_var=(
                    4 * wb2 * _speed_error_variance(braking, b),
                    4 * wr2 * _speed_error_variance(reverse, r),
                ),
            )
        )
    return found


def node_estimates(
    passages: Sequence[NodePassages],
    speed_noise_scale: float = 1.0,
    friction_slope: np.ndarray | None = None,
    friction_slope_cov: np.ndarray | None = None,
) -> list[NodeEstimate]:
    """The node formula's second step (:func:`node_formula`): M at each node of
    :func:`node_passages`, with the run's speed-noise scale and friction slopes.

    Parameters
    ----------
    passages : sequence of NodePassages
        The first step's, one per node.
    speed_noise_scale : float
        The least squares' calibration of the speed-error variance (:func:`node_formula`).
    friction_slope : np.ndarray, optional
        [d1, d2], the run's friction slopes; None: no correction.
    friction_slope_cov : np.ndarray, optional
        (2, 2) their covariance.

    Returns
    -------
    list of NodeEstimate
        One per node of ``passages``.
    """
    estimates = []
    a_, b_ = slice(None, -1), slice(1, None)
    for p in passages:
        num, num_cov = p.num, p.num_cov
        plain_num, plain_cov = num, num_cov
        if friction_slope is not None and np.all(np.isfinite(friction_slope)):
            dR = p.mismatch
            num = num + dR @ friction_slope
            if friction_slope_cov is not None:
                num_cov = num_cov + dR @ friction_slope_cov @ dR.T
        wb2, wr2 = p.speed_sq
        vb = p.speed_sq_var[0] * speed_noise_scale
        vr = p.speed_sq_var[1] * speed_noise_scale
        den = wb2[a_] + wr2[a_] - wb2[b_] - wr2[b_]
        M = 2 * num / den
        M_plain = plain_num / (wb2[a_] - wb2[b_])
        M_mean, M_std, weights = _combine_pairs(M, num_cov, den, vb + vr)
        P_mean, P_std, _ = _combine_pairs(M_plain, plain_cov / 4, wb2[a_] - wb2[b_], vb)
        estimates.append(
            NodeEstimate(
                stage=p.stage,
                node_deg=p.node_deg,
                M=M_mean,
                M_std=M_std,
                M_plain=P_mean,
                M_plain_std=P_std,
                pairs=int(M.size),
                M_parts=tuple(float(weights @ (2 * part / den)) for part in p.parts),
            )
        )
    return estimates


def _speed_error_variance(est: PassEstimate, a) -> np.ndarray:
    """rad^2/s^2, the variance of a pass's smoothed speed at the passages ``a`` (its
    :meth:`~rsp_inertia.estimation.passes.PassEstimate.sample_at`): the stationary error's and
    what the pass's gaps of dropped samples add there (a gap near a node that the smoother
    bridges, rsp_inertia.estimation.balance.check_node_gaps)."""
    variance = est.speed_error_band(a)[0]
    gaps = est.gap_speed_band(a)
    return variance if gaps is None else variance + gaps[0]


def _mismatch_at(braking: PassEstimate, reverse: PassEstimate, lo: float, at: np.ndarray):
    """(len(at), 2) the mismatch regressors of
    :func:`rsp_inertia.estimation.balance.stage_balance` at the angles ``at``,
    integrated from ``lo`` on the balance's own grid, then interpolated."""
    phi = np.append(np.arange(lo, at.max(), balance_spacing(braking, reverse)), at.max())
    R = mismatch_regressors(phi, braking.sample_at(phi).omega, reverse.sample_at(phi).omega)
    return np.column_stack([np.interp(at, phi, R[:, j]) for j in range(2)])


def _combine_pairs(M, num_cov, den, passage_var) -> tuple[float, float, np.ndarray]:
    """Generalised mean of the consecutive pairs' M, with its standard deviation and the
    pairs' weights (summing to 1).

    Pair i runs from passage i to i+1, so consecutive pairs share a passage: the speed error
    there enters pair i's denominator with a minus sign and pair i+1's with a plus sign. To
    first order dM_i = 2 dN_i / den_i - M_i dden_i / den_i with dden_i = dS_i - dS_{i+1};
    the work errors dN_i have covariance ``num_cov`` (diagonal for sample-by-sample sums over
    disjoint stretches, full when a constant braking torque's mean is shared), the passages'
    speed errors dS_j are independent, which makes the speed part tridiagonal:

        cov_ij = (2/den_i)(2/den_j) cov(N_i, N_j)
                 + (M_i/den_i)^2 (var S_i + var S_{i+1})            (i = j)
                 - (M_i/den_i)(M_{i+1}/den_{i+1}) var S_{i+1}       (j = i + 1)

    ``passage_var`` holds var S_j at every passage (len(M) + 1 of them). For the plain
    formula M = N / den, pass cov N / 4 (the factor 2 above).
    """
    g = M / den
    cov = np.outer(2 / den, 2 / den) * num_cov
    cov += np.diag(g**2 * (passage_var[:-1] + passage_var[1:]))
    off = -g[:-1] * g[1:] * passage_var[1:-1]
    cov += np.diag(off, 1) + np.diag(off, -1)
    ones = np.ones_like(M)
    try:
        weights = np.linalg.solve(cov, ones)
    except np.linalg.LinAlgError:  # noise-free logs (a synthetic test): no error to weigh
        weights = np.linalg.pinv(cov) @ ones
    total = float(ones @ weights)
    if not total > 0.0 or not math.isfinite(total):
        return float(np.mean(M)), 0.0, ones / ones.size
    return float(weights @ M / total), float(1 / math.sqrt(total)), weights / total
