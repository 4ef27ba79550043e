"""Both passes of a stage at common angles: the balance equations.

Reverse minus braking balance between two angles a < b covered by both passes
(docs/method.md §5), with S = Omega^2 + Omega'^2 the two passes' squared speeds at one angle and
W(phi) = A(release -> phi) + A'(phi7 -> phi) the motor work of both passes up to phi:

    1/2 M(phi_b) S_b - 1/2 M(phi_a) S_a + 2 (Pi_b - Pi_a) = W_b - W_a = A_ab - A'_ab

so that 1/2 M(phi) S(phi) + 2 Pi(phi) - W(phi) is the same constant C at every angle: one
equation per angle, differences of which are every pair's balance. Friction does not appear:
it does the same work on both passes at the same angle and speed.

Tracking mismatch. A closed-loop reverse runs at |Omega'| = |Omega| + delta, delta a few 1e-4
of the speed, and friction then does slightly different work on the two passes. With
F = friction's work (negative) and D(|Omega|) the dissipative torque of docs/method.md §3, the
braking pass's F_b(phi) from the release and the reverse's F_r(phi) from phi7 sum to

    F_b(phi) + F_r(phi) = const - int_phi^phi7 [D(|Omega'|) - D(|Omega|)] dphi
                        = const' + int_lo^phi [D(|Omega| + delta) - D(|Omega|)] dphi,

so the balance becomes 1/2 M S + 2 Pi - W - C = int_lo^phi [D(|Omega| + delta) - D(|Omega|)]
dphi. D itself stays unknown (the method must not need it); it is expanded to second order
about |Omega| with D'(Omega) = d1 + d2 Omega, hence D'' = d2:

    D(|Omega| + delta) - D(|Omega|) = d1 delta + d2 (|Omega| delta + delta^2 / 2),

exact for the paper's D = a1 + a2 Omega + a3 Omega^2 (d1 = a2, d2 = 2 a3; the law, its slopes
and these integrands: rsp_inertia.plant.model.FRICTION). d1, d2 join the
unknowns of each run with the regressors R1 = int_lo^phi delta dphi and
R2 = int_lo^phi (|Omega| delta + delta^2 / 2) dphi from the measured speeds. The second-order
part matters where the loop tracks loosely (a large delta); on an ideal reverse delta is only
speed noise and the slopes come out undetermined, at little cost.

The slopes' prior. Free, the slopes take information from the tensor wherever delta's shape
resembles M's harmonics, which a closed loop on a coarse encoder makes it do (its regulator
lags the mirror in angle by the feedforward's error over its position gain, and a lag in
angle is a speed mismatch at 2 phi). Both passes of the run determine the friction directly:
their equations of motion, fitted together by modulating functions
(rsp_inertia.estimation.modulated), give a1, a2, a3 with M absolutely (the reverse's changing
torque breaks the braking's scale degeneracy). :func:`friction_slope_prior` turns them into a
prior d = (a2, 2 a3) with the fit's covariance and a relative allowance
(FRICTION_PRIOR_ALLOWANCE) for what that fit assumes and a rig may break (one friction law for
both directions of motion, the logged torque as the one received); the least squares takes it
as two pseudo-equations and tests it against the balances
(rsp_inertia.estimation.gls, priors).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate import cumulative_trapezoid

from rsp_inertia.estimation.modulated import MODEL_UNKNOWNS, fit_modulated
from rsp_inertia.estimation.passes import (
    GAP_NEGLIGIBLE,
    AngleSample,
    PassEstimate,
    angle_work_noise,
)
from rsp_inertia.estimation.smoothing import (
    gap_speed_excess,
    largest_bridged_gap,
    median_step,
    smoother_bandwidth,
    top_speed,
)
from rsp_inertia.estimation.tempco import pass_tempco_work
from rsp_inertia.estimation.whitening import Noise, add_bands, scaled_band
from rsp_inertia.infra.errors import InputError
from rsp_inertia.plant.config import Device, Stage
from rsp_inertia.plant.friction import FRICTION
from rsp_inertia.plant.logs import Log, dropped_samples, mirrored_device, reverse_start_lag
from rsp_inertia.plant.model import potential, spring_parameters, static_torque
from rsp_inertia.plant.transducers import motor_rises

__all__ = [
    "EDGE_MARGIN",
    "FRICTION_PRIOR_ALLOWANCE",
    "MIN_SPEED_FRACTION",
    "NODE_GAP_WINDOW_DEG",
    "POSITION_SPACING_BANDWIDTHS",
    "HarmonicReach",
    "NodeGap",
    "StageBalance",
    "balance_range",
    "balance_spacing",
    "check_node_gaps",
    "friction_shape",
    "friction_slope_prior",
    "gap_allowance",
    "harmonic_reach",
    "heat_work",
    "mismatch_regressors",
    "short_overlap",
    "spring_potential",
    "spring_torque",
    "stage_balance",
    "usable_range",
    "warming_work",
]

MIN_SPEED_FRACTION = 0.2
"""Angles where the braking speed is below this fraction of its top speed are left out:
near rest the mirror cannot be exact (torque-rate limit, static friction, docs/method.md §4)."""

EDGE_MARGIN = 0.1
"""rad left out at each end of the common range (smoother start-up, release transient)."""

FRICTION_PRIOR_ALLOWANCE = 0.2
"""Relative std added to each friction slope of the prior (:func:`friction_slope_prior`), for
what the passes' joint fit assumes: one friction law for both directions of motion and the
logged torque as the one received (measured on the default stages in closed loop, against
the reverse's own friction: a backward friction 1.2 times the forward one moved d2 by 9%, a
driving efficiency of 0.9 by 10%, efficiencies of 0.95 and 0.92 by 5%; d1 stayed within the
fit's own std, which such a misfit inflates), and a friction law quadratic in the speed. The
slopes only multiply the small tracking mismatch, so even this allowance leaves the prior 5 to
500 times tighter than the balances' own estimate of them (default stages, 12 bits)."""

PRIOR_QUADRATURE = 4e-3
"""s between the samples whose regressors the prior's fit integrates (Simpson; the torque is
still summed over every sample): 4 ms against the smoothed speed's band (w_c = 10 x 2
Omega_max, 240 rad/s on the default stages, sampled at up to 785 rad/s), Simpson's error
~(2 Omega h)^4 / 180 ~ 5e-7 at the default top speed, far below the prior's allowance; a
quarter of the cost of every sample at 1 kHz."""

PRIOR_UNKNOWNS = MODEL_UNKNOWNS
"""What the passes' joint fit estimates (:func:`friction_slope_prior`): all of the model but
the spring, which device.toml gives (rsp_inertia.estimation.modulated.MODEL_UNKNOWNS)."""

POSITION_SPACING_BANDWIDTHS = 1.0
"""Balance angles are spaced by one smoother time constant (1 / w_c) at the top speed.
Measured on the default experiment (speed noise alone): spacing 3/w_c leaves J_k errors of
~1e-5, 1/w_c ~1e-6, 0.3/w_c no better (the smoother's errors are correlated over ~1/w_c)."""


NODE_GAP_WINDOW_DEG = 5.0
"""deg, how near a node's passage a gap of dropped samples too long to bridge is refused
(:func:`check_node_gaps`): about one smoother time constant's travel at the default stages'
top speeds (12 rad/s / 240 rad/s = 2.9 deg on stage 1), plus margin."""


def gap_allowance(est: PassEstimate, other: PassEstimate) -> float:
    """The most the smoother's own variance of a pass's speed may grow over a gap, in units of
    its stationary one, for the gap to be bridged: the balance's own variance of S there
    (docs/method.md §5, the gap section).

    A balance takes S = Omega^2 + Omega'^2; a gap in one pass adds 4 Omega^2 dvar to var S,
    whose stationary value is 4 Omega^2 (v + v'), v = r w_c^3 / 6 each pass's smoother's own
    stationary variance (rsp_inertia.estimation.smoothing.gap_speed_excess), the speeds equal
    in magnitude at a common angle. The gap is bridged while dvar <= v + v': its added std
    at most the balance's own, which is 1 + v' / v of the pass's own (2 for passes of the same
    top speed, as a braking and its mirror are).

    Parameters
    ----------
    est : PassEstimate
        The pass with the gap.
    other : PassEstimate
        The run's other pass.

    Returns
    -------
    float
        The allowance, in units of ``est``'s stationary variance.
    """

    def level(p: PassEstimate) -> float:
        return p.smoothed.noise_density * p.smoothed.bandwidth**3

    own = level(est)
    return 1.0 + level(other) / own if own > 0.0 else math.inf


@dataclass(frozen=True)
class NodeGap:
    """A gap of dropped samples near a node's passage that the smoother bridges
    (:func:`check_node_gaps`)."""

    source: str
    """The log's file."""
    row: int
    """The log's row before the gap (0-based)."""
    missing: int
    """Samples dropped in a row."""
    stage: int
    """Stage number, from 1."""
    node_deg: float
    """The node, deg."""
    ratio: float
    """The smoother's own added variance of the speed at worst over the balance's own
    variance of S there (:func:`gap_allowance`): at most 1."""
    largest: int
    """The most samples in a row bridged there."""
    where: str = ""
    """The file and its line (or row) after the gap; empty: the file and ``row + 3``."""

    def line(self) -> str:
        """One line saying so, for check."""
        return (
            f"{self.where or f'{self.source}, line {self.row + 3}'}: {self.missing} samples "
            "dropped within "
            f"{NODE_GAP_WINDOW_DEG:g} deg of node {self.node_deg:g} deg (stage {self.stage}): "
            "bridged by the smoother, adding at most "
            f"{math.sqrt(self.ratio):.2f} of the balance's own speed std there (up to "
            f"{self.largest} samples in a row are bridged there)"
        )


def _line_after(log: Log, source: str, k: int) -> str:
    """The file and the line (or row) of row ``k + 1`` of ``log``: through its own
    :attr:`~rsp_inertia.plant.logs.Log.where` (a layout's lines, glitches left out), else a
    CSV of ``source`` whose data start on line 2."""
    return log.where.at(k + 1) if log.where is not None else f"{source}, line {k + 3}"


def check_node_gaps(
    device: Device,
    stage: int,
    log: Log,
    source: str,
    lo: float = -math.inf,
    hi: float = math.inf,
    direction: int = 1,
    dropped: np.ndarray | None = None,
    h: float | None = None,
    allowance: float = 2.0,
) -> list[NodeGap]:
    """Refuse a gap of dropped samples within NODE_GAP_WINDOW_DEG of a node's passage in the
    balanced range [lo, hi] that is too long for the smoother to bridge: its own added
    variance of the speed (rsp_inertia.estimation.smoothing.gap_speed_excess) beyond
    ``allowance`` (:func:`gap_allowance`); the node formula takes the speed there, and the
    balances about the node are kept with the gap's added variance only when it is bridged.

    Parameters
    ----------
    device : Device
        The device (its encoder's sample rate, the stage's nodes).
    stage : int
        Stage number, from 1.
    log : Log
        The pass's log.
    source : str
        The log's file, for the message.
    lo, hi : float
        rad, the balanced range in the log's coordinate (default: all of it).
    direction : int
        -1: a backward run's log mirrored by rsp_inertia.plant.logs.mirror_log, its nodes at
        -node.
    dropped : np.ndarray, optional
        (n - 1,) int, the log's dropped samples after each row when already found
        (:attr:`rsp_inertia.estimation.passes.PassEstimate.dropped`); None: found here at the
        encoder's sample rate (rsp_inertia.plant.logs.dropped_samples).
    h : float, optional
        w_c dt of the pass's smoother (:attr:`rsp_inertia.estimation.passes.PassEstimate.h`);
        None: from the log's top speed (rsp_inertia.estimation.smoothing.smoother_bandwidth)
        at the encoder's sample rate.
    allowance : float
        :func:`gap_allowance`; by default 2, a run's other pass mirroring this one.

    Returns
    -------
    list of NodeGap
        The gaps near a node that count (rsp_inertia.estimation.passes.GAP_NEGLIGIBLE) and
        are bridged.

    Raises
    ------
    InputError
        Naming ``source`` (the log's file), the line after the gap, its size and times, the
        node and the most samples in a row bridged there.
    """
    rate = device.encoder.sample_rate
    if dropped is None:
        dropped = dropped_samples(log.t, rate)
    rows = np.flatnonzero(dropped)
    if rows.size == 0:
        return []
    if h is None:
        h = smoother_bandwidth(top_speed(log)) / rate
    st = device.stages[stage - 1]
    window = math.radians(NODE_GAP_WINDOW_DEG)
    phi, t = log.phi, log.t
    bridged = []
    for k, n in zip(rows.tolist(), dropped[rows].tolist()):
        excess = gap_speed_excess(int(n), h)
        if excess <= GAP_NEGLIGIBLE:
            continue
        a = min(phi[k], phi[k + 1]) - window
        b = max(phi[k], phi[k + 1]) + window
        if b < lo or a > hi:
            continue
        for node_deg, node in zip(st.nodes_deg, direction * st.nodes):
            passage = node + 2 * math.pi * math.ceil((a - node) / (2 * math.pi))
            if passage > b:
                continue
            largest = largest_bridged_gap(h, allowance)
            if excess > allowance:
                raise InputError(
                    f"{_line_after(log, source, k)}: {n} samples dropped between t = "
                    f"{float(t[k]):.6g} s and t = {float(t[k + 1]):.6g} s, within "
                    f"{NODE_GAP_WINDOW_DEG:g} deg of node {node_deg:g} deg (stage {stage}): "
                    "too long for the smoother to bridge (its own variance of the speed "
                    f"would grow by {excess / allowance:.3g} times the balance's there); at "
                    f"most {largest} samples in a row may be missing there"
                )
            bridged.append(
                NodeGap(
                    source, k, int(n), stage, float(node_deg), excess / allowance, largest,
                    _line_after(log, source, k),
                )
            )
    return bridged


def _outside_gaps(est: PassEstimate, times: np.ndarray, allowance: float) -> np.ndarray:
    """Which of ``times`` lie outside every gap of the pass too long to bridge (its
    smoother's own added variance of the speed beyond ``allowance``, :func:`gap_allowance`),
    each widened by one smoother time constant on either side: the balances there are left
    out (away from the nodes; near one :func:`check_node_gaps` refuses the gap)."""
    keep = np.ones(times.shape, dtype=bool)
    margin = 1.0 / est.smoothed.bandwidth
    t = est.log.t
    for gap in est.gaps:
        if gap.excess > allowance:
            keep &= (times < t[gap.row] - margin) | (times > t[gap.row + 1] + margin)
    return keep


SWITCH_REACH = 4.0
"""w_c x the time on either side of a two-level braking's switch within which the balances are
left out (:func:`_outside_switch`)."""


def _outside_switch(
    braking: PassEstimate, reverse: PassEstimate, b_times: np.ndarray, r_times: np.ndarray
) -> np.ndarray:
    """Which balance angles (their times in each pass) lie beyond SWITCH_REACH / w_c of a
    two-level braking's switch in both passes. The acceleration steps there, which the
    smoothed speed rounds off (on the default stage 2, 0 -> 0.24 N m, by up to 6 of its
    stds within 2 / w_c of the switch and within them beyond): those balances are left out,
    as a gap's are."""
    at = braking.smoothed.phi[braking.switch]
    t_b = braking.smoothed.t[braking.switch]
    t_r = float(reverse.sample_at(np.array([at])).time[0])
    reach_b = SWITCH_REACH / braking.smoothed.bandwidth
    reach_r = SWITCH_REACH / reverse.smoothed.bandwidth
    return (np.abs(b_times - t_b) > reach_b) & (np.abs(r_times - t_r) > reach_r)


def spring_potential(phi: np.ndarray, device: Device) -> np.ndarray:
    """Spring part of Pi (docs/method.md §3, rsp_inertia.plant.model); gravity is estimated,
    not known."""
    return potential(phi, spring_parameters(device.spring.stiffness, device.spring.zero_angle))


def spring_torque(phi: np.ndarray, device: Device) -> np.ndarray:
    """d/dphi of :func:`spring_potential`, N m (rsp_inertia.plant.model.static_torque)."""
    return static_torque(
        phi, spring_parameters(device.spring.stiffness, device.spring.zero_angle)
    )


MIN_TURNS = 2.0
"""Turns both passes must share at useful speed: every node then has at least one whole-turn
pair, and the least squares sees M's pattern repeat (docs/method.md §4: at least two turns)."""


def usable_range(braking: PassEstimate, reverse: PassEstimate, stage: int) -> tuple[float, float]:
    """Angles covered by both passes, at a braking speed worth balancing (constants above).

    Parameters
    ----------
    braking, reverse : PassEstimate
        The run's two passes (a backward run's mirrored).
    stage : int
        Stage number, from 1, for the message.

    Returns
    -------
    lo, hi : float
        rad, the range in the passes' coordinate.

    Raises
    ------
    InputError
        The passes share fewer than MIN_TURNS turns there, naming the log at fault
        (:func:`short_overlap`).
    """
    b, r = braking.smoothed, reverse.smoothed
    fast = b.omega >= MIN_SPEED_FRACTION * b.omega.max()
    last_fast = fast.size - 1 - int(np.argmax(fast[::-1]))  # (no index array of the pass)
    lo = max(b.phi[0], r.phi[-1]) + EDGE_MARGIN
    hi = min(b.phi[last_fast], r.phi[0]) - EDGE_MARGIN
    if hi - lo < MIN_TURNS * 2 * math.pi:
        raise InputError(short_overlap(braking, reverse, stage, float(b.phi[last_fast])))
    return lo, hi


def short_overlap(
    braking: PassEstimate, reverse: PassEstimate, stage: int, last_fast: float
) -> str:
    """Why two passes share fewer than MIN_TURNS turns at useful speed, naming the log at fault.

    The reverse mirrors the braking: it starts where the braking stopped and runs back past the
    release. When the braking alone covers MIN_TURNS turns at useful speed, the reverse is at
    fault: it stopped before it was back at the release, or its log starts short of where the
    braking stopped (its first rows missing). Otherwise the braking is too short, whatever
    the reverse did (a new braking needs a new program and reverse anyway).

    Parameters
    ----------
    braking, reverse : PassEstimate
        The run's two passes.
    stage : int
        Stage number, from 1.
    last_fast : float
        rad, the braking's last angle at useful speed.

    Returns
    -------
    str
        The message, naming the log at fault.
    """
    b, r = braking.smoothed, reverse.smoothed
    turn = 2 * math.pi
    alone = last_fast - b.phi[0] - 2 * EDGE_MARGIN
    if alone < MIN_TURNS * turn:
        return (
            f"{braking.source}: stage {stage}: the braking covers {max(alone, 0) / turn:.2f} "
            f"turns at useful speed (above {MIN_SPEED_FRACTION:.0%} of its top speed, "
            f"{EDGE_MARGIN:g} rad in from each end); the balances need at least {MIN_TURNS:g} "
            "(a longer braking: lower braking_torque or higher launch_speed)"
        )
    faults = []
    if r.phi[-1] > b.phi[0]:
        faults.append(
            f"the reverse run stopped early, {(r.phi[-1] - b.phi[0]) / turn:.2f} turns before "
            "the braking's release"
        )
    if r.phi[0] < last_fast:
        faults.append(
            f"its log starts {(b.phi[-1] - r.phi[0]) / turn:.2f} turns short of where the "
            "braking stopped (its first rows missing?)"
        )
    overlap = max(min(last_fast, r.phi[0]) - max(b.phi[0], r.phi[-1]) - 2 * EDGE_MARGIN, 0.0)
    return (
        f"{reverse.source}: stage {stage}: covers {(r.phi[0] - r.phi[-1]) / turn:.2f} turns of "
        f"the {(b.phi[-1] - b.phi[0]) / turn:.2f} the braking logged ({braking.source}); "
        f"{' and '.join(faults)}: the passes overlap over {overlap / turn:.2f} turns at useful "
        f"speed, the balances need at least {MIN_TURNS:g} (run the reverse pass again, and log "
        "all of it)"
    )


def balance_range(
    device: Device,
    stage: int,
    braking: PassEstimate,
    reverse: PassEstimate,
    direction: int = 1,
    bridged: list[NodeGap] | None = None,
) -> tuple[float, float]:
    """The range [lo, hi] where a run is balanced, checked: :func:`usable_range` (the passes
    share MIN_TURNS turns at useful speed), and no gap of dropped samples near a node's
    passage in it too long to bridge (:func:`check_node_gaps`, both logs, with the gaps each
    pass estimate found, each pass's allowance against the other, :func:`gap_allowance`).

    Parameters
    ----------
    device : Device
        The device.
    stage : int
        Stage number, from 1.
    braking, reverse : PassEstimate
        The run's two passes.
    direction : int
        -1: a backward run's mirrored passes.
    bridged : list of NodeGap, optional
        Gets the gaps near a node that the smoother bridges.

    Returns
    -------
    lo, hi : float
        rad, the range in the passes' coordinate.

    Raises
    ------
    InputError
        Naming the log at fault.
    """
    lo, hi = usable_range(braking, reverse, stage)
    for est, other in ((braking, reverse), (reverse, braking)):
        found = check_node_gaps(
            device, stage, est.log, est.source, lo, hi, direction, est.dropped, est.h,
            gap_allowance(est, other),
        )
        if bridged is not None:
            bridged.extend(found)
    return lo, hi


@dataclass(frozen=True)
class StageBalance:
    """One run's balance equations at common angles (module docstring).

    A run is one stage in one direction of rotation. A backward run (phi decreasing during
    its braking) is balanced in the mirrored coordinate phi_m = -phi, in which it is a forward
    run (:func:`mirror_log`): motor work, speeds and the cumulative regressors are the same
    numbers in either coordinate, while ``phi`` holds the body's true angles for M(phi) and
    the potential.
    """

    stage: int
    """Stage number, from 1."""
    gear_ratio: float
    """lambda."""
    tare_inertia: float
    """M_tare, kg m^2 (device.toml's)."""
    phi: np.ndarray
    """rad, the body's angles of the balance, in the order of the braking's motion."""
    speed_sq: np.ndarray
    """S = Omega^2 + Omega'^2, rad^2/s^2."""
    speed_sq_band: np.ndarray
    """(w, n) lower band of the covariance of S from the smoothers' speed errors
    (rsp_inertia.estimation.whitening: band[d, i] = cov(S_{i+d}, S_i)): to first order
    dS = 2 Omega dOmega + 2 Omega' dOmega', the passes independent, each pass's errors
    correlated as the smoother's derived autocovariance says, over its span only
    (rsp_inertia.estimation.smoothing)."""
    mismatch: np.ndarray
    """(n, 2) the tracking mismatch's friction regressors [R1, R2] (module docstring):
    int_lo^phi delta dphi (rad^2/s) and int_lo^phi (|Omega| delta + delta^2 / 2) dphi
    (rad^3/s^2)."""
    work: np.ndarray
    """W(phi) = A(release->phi) + A'(phi7->phi) minus 2 Pi_spring(phi), J."""
    braking_work_noise: Noise
    """The covariance of the braking pass's share of ``work`` (its torque log's noise,
    rsp_inertia.estimation.passes.PassEstimate.work_noise), J^2."""
    reverse_work_noise: Noise
    """The same for the reverse pass, J^2."""
    direction: int = 1
    """+1 for a forward run, -1 for a backward one (phi decreasing during the braking)."""
    spring: np.ndarray | None = None
    """2 Pi_spring(phi), J: ``work + spring`` is the logged motor work of both passes."""
    spring_slope: np.ndarray | None = None
    """d/dphi of ``spring`` at the balance angles, N m (phi the rig's angle, as ``phi``)."""
    friction_shape: np.ndarray | None = None
    """(n, 3) [int dphi, int |Omega| dphi, int Omega^2 dphi] from the first angle along the
    motion (rad, rad^2/s, rad^3/s^2), braking speeds: the work that a dissipative torque
    e1 + e2 |Omega| + e3 Omega^2 does over the balance range (:func:`friction_shape`)."""
    motor_work_back: np.ndarray | None = None
    """J, the back-driven part of ``motor_work`` (rsp_inertia.plant.logs.motor_work):
    the drive delivers h_d x (motor_work - this) + h_b x this (docs/method.md §3); None: no
    part is back-driven."""
    back_driven: tuple[bool, bool] = (True, False)
    """(braking, reverse): whether each pass's work is mainly back-driven, which sets the gain
    (h_b or h_d) on its torque log's noise."""
    angle_work_var: tuple[np.ndarray | None, np.ndarray | None] = (None, None)
    """(braking, reverse): each pass's random walk of the work's variance from its smoothed
    angle's error under a changing torque, at the balance angles (J^2, rsp_inertia.estimation
    .passes.angle_work_variance; None: a constant torque)."""
    slope_prior: tuple[np.ndarray, np.ndarray] | None = None
    """(mean (2,), covariance (2, 2)) of the friction slopes [d1, d2] from the passes' own
    dynamics (:func:`friction_slope_prior`); None: not made (a planned run) or not possible."""
    speed_sq_gap_band: np.ndarray | None = None
    """(w, n) lower band of what the passes' gaps of dropped samples add to the covariance of
    S (rsp_inertia.estimation.passes.PassEstimate.gap_speed_band, scaled as ``speed_sq_band``);
    None: no gap counts (rsp_inertia.estimation.passes.GAP_NEGLIGIBLE)."""
    reverse_work: np.ndarray | None = None
    """J, the reverse pass's share of :attr:`motor_work` at the balance angles (its logged
    torque's work from the mirror's start, phi7, to each angle): the column a torque scale
    that differs between the passes multiplies (docs/method.md §5, "A torque scale that
    differs between the passes"); None: not kept."""
    reverse_work_back: np.ndarray | None = None
    """J, the back-driven part of :attr:`reverse_work`; None: not kept."""
    compensated: bool = False
    """The passes' torque was compensated for the motor's magnet temperature
    (rsp_inertia.plant.logs.compensate_temperature)."""
    heat_work: np.ndarray | None = None
    """J N^2 m^2 s, both passes' motor work weighted by the motor's heat dissipated so far,
    at the balance angles (:func:`heat_work`): a torque scale that falls by c per unit of
    heat adds c times this to the balance; None: not kept."""
    heat_gap: float = 0.0
    """N^2 m^2 s, the heat the motor had dissipated, averaged over the reverse pass's work,
    less the same over the braking's (:func:`heat_work`): a torque scale that falls by c per
    unit of heat differs between the run's passes by about c times this."""
    warming_parts: np.ndarray | None = None
    """(n, 2) J N^2 m^2, both passes' motor work weighted by the magnets' modelled rise, its
    driving and back-driven parts (:func:`warming_work`): a motor that warms with the heat
    its logged torque dissipates adds c times these (times the drive's gains) to the balance,
    c the tensor fit's unknown (device.toml ``[motor] winding_time_constant``); None: not
    modelled."""
    warming_gap: float = 0.0
    """N^2 m^2, the magnets' modelled rise averaged over the reverse pass's work less the same
    over the braking's (:func:`warming_work`): the torque's scale differs between the run's
    passes by about c times this."""
    tempco_work_parts: np.ndarray | None = None
    """(n, 2) d :attr:`motor_work_parts` / d alpha, J K: how the work parts move with the torque
    constant's tempco that compensated the logs (rsp_inertia.estimation.tempco.pass_tempco_work;
    calibrate's column of alpha); None: the logs carry no temperature or were not compensated."""
    pass_gain: bool = False
    """The run's braking held two levels (device.toml ``braking_torque_2``): the reverse
    pass's torque scale against the braking's, the pass gain d, is one of the tensor fit's
    unknowns, its column :attr:`reverse_work` (rsp_inertia.estimation.tensor_fit; docs/method.md,
    "A torque scale that differs between the passes")."""

    @property
    def work_noise(self) -> Noise:
        """The covariance of ``work``: both passes' torque logs (independent noise) and their
        smoothed angles' errors (:meth:`encoder_work_noise`), J^2."""
        return self.braking_work_noise + self.reverse_work_noise + self.encoder_work_noise()

    def encoder_work_noise(self, scales: tuple[float, float] = (1.0, 1.0)) -> Noise:
        """The covariance of ``work`` from both passes' smoothed angles' errors, each pass's
        random walk min(v_i, v_j) times its gain squared (``scales``: (braking, reverse), as
        :meth:`work_scales` gives), J^2."""
        n = len(self.phi)
        return sum(
            (angle_work_noise(v, n).times(scale**2) for v, scale in zip(self.angle_work_var, scales)),
            Noise(n),
        )

    @property
    def motor_work(self) -> np.ndarray:
        """W(phi), J: the logged motor work of both passes, spring potential not taken off."""
        return self.work if self.spring is None else self.work + self.spring

    @property
    def motor_work_parts(self) -> np.ndarray:
        """(n, 2) [driving, back-driven] parts of :attr:`motor_work`, J: the columns the drive's
        gains h_d and h_b multiply."""
        back = np.zeros(len(self.phi)) if self.motor_work_back is None else self.motor_work_back
        return np.column_stack([self.motor_work - back, back])

    def received_work(self, gains: tuple[float, float]) -> np.ndarray:
        """J, the work the body received from the drive of gains (h_d, h_b):
        :attr:`motor_work_parts` @ gains (rsp_inertia.plant.transducers.drive_gains)."""
        return self.motor_work_parts @ np.asarray(gains, dtype=float)

    def work_scales(self, gains: tuple[float, float]) -> tuple[float, float]:
        """(braking, reverse): the gain of each pass's main power flow (:attr:`back_driven`)."""
        return tuple(gains[1] if back else gains[0] for back in self.back_driven)



def friction_shape(phi: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """Work of a dissipative torque e . basis(|Omega|) from phi[0], per coefficient.

    The friction law's basis (rsp_inertia.plant.model.FRICTION.basis; for the paper's
    D = a1 + a2 |Omega| + a3 Omega^2 the columns int dphi, int |Omega| dphi, int Omega^2 dphi),
    integrated by the trapezoid rule along ``phi`` (ascending; the constant exactly). A
    friction that differs between the directions of rotation, D_backward - D_forward =
    e . basis(|Omega|), leaves exactly this shape in a run's balance (the reverse pass runs in
    the other direction): + e . shape in a forward run, - e . shape in a backward one.
    """
    w = np.abs(omega)
    return np.column_stack(
        [
            phi - phi[0] if n == 0 else cumulative_trapezoid(f, phi, initial=0.0)
            for n, f in zip(FRICTION.powers, FRICTION.basis(w))
        ]
    )


def stage_balance(
    device: Device,
    stage: int,
    braking: PassEstimate,
    reverse: PassEstimate,
    direction: int = 1,
    slope_prior: bool = True,
) -> StageBalance:
    """The balance equations of one run of stage ``stage`` at evenly spaced common angles.

    Parameters
    ----------
    device : Device
        The device.
    stage : int
        Stage number, from 1.
    braking, reverse : PassEstimate
        The run's two passes.
    direction : int
        -1: the passes are a backward run's, mirrored by rsp_inertia.plant.logs.mirror_log.
    slope_prior : bool
        Make the friction slopes' prior (:func:`friction_slope_prior`; a planned run of exact
        passes has no tracking mismatch and needs none).

    Returns
    -------
    StageBalance
        The run's balance equations.

    Raises
    ------
    InputError
        From :func:`balance_range`, naming the log at fault.
    """
    st: Stage = device.stages[stage - 1]
    lo, hi = balance_range(device, stage, braking, reverse, direction)
    phi = np.arange(lo, hi, balance_spacing(braking, reverse))
    b = braking.sample_at(phi)
    r = reverse.sample_at(phi)
    keep = _outside_gaps(braking, b.time, gap_allowance(braking, reverse)) & _outside_gaps(
        reverse, r.time, gap_allowance(reverse, braking)
    )
    if braking.switch is not None:
        keep &= _outside_switch(braking, reverse, b.time, r.time)
    if not keep.all():  # gaps too long to bridge, away from the nodes: left out
        phi = phi[keep]
        b = braking.sample_at(phi)
        r = reverse.sample_at(phi)
    S = b.omega**2 + r.omega**2
    # cov(S_i, S_j) = 4 Omega_i Omega_j cov(Omega_i, Omega_j) per pass, as bands.
    S_band = add_bands(
        scaled_band(braking.speed_error_band(b), 2 * b.omega),
        scaled_band(reverse.speed_error_band(r), 2 * r.omega),
    )
    gap_bands = [
        scaled_band(band, 2 * a.omega)
        for band, a in ((braking.gap_speed_band(b), b), (reverse.gap_speed_band(r), r))
        if band is not None
    ]
    spring = 2 * spring_potential(direction * phi, device)
    work = b.work + r.work - spring
    hb, gap_b, heat_b = heat_work(braking, b, 0.0)
    hr, gap_r, _ = heat_work(reverse, r, heat_b)
    warming = _warming(device.motor, braking, b, reverse, r)
    tempco = [
        pass_tempco_work(device.motor, est, a, lag)
        for est, a, lag in (
            (braking, b, 0.0), (reverse, r, reverse_start_lag(braking.log, device.motor))
        )
    ]
    mismatch = mismatch_regressors(phi, b.omega, r.omega)
    return StageBalance(
        stage=stage,
        gear_ratio=st.gear_ratio,
        tare_inertia=st.tare_inertia,
        phi=direction * phi,
        speed_sq=S,
        speed_sq_band=S_band,
        speed_sq_gap_band=add_bands(*gap_bands) if gap_bands else None,
        tempco_work_parts=None if None in tempco else np.column_stack(
            [tempco[0][0] + tempco[1][0] - tempco[0][1] - tempco[1][1], tempco[0][1] + tempco[1][1]]
        ),
        mismatch=mismatch,
        work=work,
        braking_work_noise=braking.work_noise(b),
        reverse_work_noise=reverse.work_noise(r),
        direction=direction,
        spring=spring,
        spring_slope=2 * spring_torque(direction * phi, device),
        friction_shape=friction_shape(phi, b.omega),
        motor_work_back=b.work_back + r.work_back,
        back_driven=(braking.mainly_back_driven, reverse.mainly_back_driven),
        angle_work_var=(b.work_var_angle, r.work_var_angle),
        slope_prior=(
            friction_slope_prior(device, braking, reverse, direction) if slope_prior else None
        ),
        reverse_work=r.work,
        reverse_work_back=r.work_back,
        heat_work=hb + hr,
        heat_gap=gap_r - gap_b,
        warming_parts=None if warming is None else warming[0],
        warming_gap=0.0 if warming is None else warming[1],
        compensated=braking.log.torque_factor is not None
        or reverse.log.torque_factor is not None,
        pass_gain=st.braking_torque_2 is not None,
    )


def _warming(motor, braking: PassEstimate, b: AngleSample, reverse: PassEstimate, r: AngleSample):
    """(StageBalance.warming_parts, StageBalance.warming_gap) of a run where device.toml
    models the motor's warming (``[motor] winding_time_constant``), else None: the run starts
    with the motor at rest (no rise), the reverse where the braking left it, cooled over
    ``reverse_delay``."""
    tau_w = motor.winding_time_constant
    if tau_w is None:
        return None
    tau_m = motor.temperature_lag
    wb, gap_b, end = warming_work(braking, b, (0.0, 0.0), tau_w, tau_m)
    if motor.reverse_delay:
        winding, magnet = motor_rises([0.0], [0.0, motor.reverse_delay], tau_w, tau_m, end)
        end = (float(winding[-1]), float(magnet[-1]))
    wr, gap_r, _ = warming_work(reverse, r, end, tau_w, tau_m)
    return wb + wr, gap_r - gap_b


def heat_work(
    estimate: PassEstimate, a: AngleSample, start_heat: float
) -> tuple[np.ndarray, float, float]:
    """A pass's motor work weighted by the motor's heat dissipated so far, at the angles of
    ``a`` (its :meth:`PassEstimate.sample_at`).

    A motor's winding dissipates I^2 R, I = torque / k_t; where its torque constant falls by
    c per unit of heat dissipated (a motor warming through a run, slower than the run's
    heat reaches it), the body receives u (1 + c H(t)) of a logged torque u, H(t) the
    integral of u^2 dt from the run's start (N^2 m^2 s: the heat up to R / k_t^2). Its work
    then exceeds the logged one by c sum u H dphi, this sum (to each row; the held torque's
    mean for a constant-torque pass, whose heat is the mean squared; a logged torque's noise
    variance taken off its square). It is the shape of a warming motor's drift in the
    balance (rsp_inertia.estimation.model_tests WARMING_PROBE): growing through both passes,
    more in the reverse, which comes after the braking and works harder.

    Parameters
    ----------
    estimate : PassEstimate
        The pass.
    a : AngleSample
        The pass at the balance angles.
    start_heat : float
        N^2 m^2 s, the heat dissipated before the pass (the braking's, for the reverse).

    Returns
    -------
    tuple
        (the weighted work at the angles, J N^2 m^2 s; the heat averaged over the pass's work
        |dW|, N^2 m^2 s; the heat at the pass's end, N^2 m^2 s).
    """
    step_heat = _heat_rate(estimate) * np.diff(estimate.log.t)
    before = start_heat + np.concatenate([[0.0], np.cumsum(step_heat)])
    mid = before[:-1] + 0.5 * step_heat  # the heat at each step's middle
    at, _, mean_heat = _weighted_work(estimate, a, mid, start_heat)
    return at, mean_heat, float(before[-1])


def warming_work(
    estimate: PassEstimate,
    a: AngleSample,
    start: tuple[float, float],
    tau_w: float,
    tau_m: float | None,
) -> tuple[np.ndarray, float, tuple[float, float]]:
    """A pass's motor work weighted by the magnets' modelled rise, at the angles of ``a``:
    the shape of a motor that warms with the heat its logged torque dissipates, its
    temperature not logged (device.toml ``[motor] winding_time_constant``).

    The winding dissipates I^2 R = u^2 R / k_t^2; through its thermal time constant tau_w and
    the magnets' lag tau_m (rsp_inertia.plant.transducers.motor_rises, driven by u^2, the
    logged torque's noise variance taken off) the magnets rise by m(t) per unit of
    R_th R / k_t^2, and the body receives u (1 + c m(t)) of a logged u, c = alpha R_th R /
    k_t^2 (1/(N^2 m^2)). Its work then exceeds the logged one by c sum u m dphi: this sum, split
    as the drive's gains split the work (the driving and the back-driven rows).

    Parameters
    ----------
    estimate : PassEstimate
        The pass.
    a : AngleSample
        The pass at the balance angles.
    start : (float, float)
        The winding's and the magnets' rises at the pass's first row, N^2 m^2.
    tau_w, tau_m : float
        s, the winding's time constant and the magnets' lag (None: none).

    Returns
    -------
    tuple
        ((n, 2) the weighted work's driving and back-driven parts at the angles, J N^2 m^2;
        the rise averaged over the pass's work |dW|, N^2 m^2; the rises at the pass's last
        row).
    """
    winding, magnet = motor_rises(_heat_rate(estimate), estimate.log.t, tau_w, tau_m, start)
    mid = 0.5 * (magnet[:-1] + magnet[1:])  # the rise over each step
    at, back, mean_rise = _weighted_work(estimate, a, mid, start[1])
    return np.column_stack([at - back, back]), mean_rise, (float(winding[-1]), float(magnet[-1]))


def _heat_rate(estimate: PassEstimate) -> np.ndarray:
    """N^2 m^2, the logged torque's square over each step [t_k, t_k+1) (the level's mean for a
    constant-torque pass, each level's for a two-level braking; a logged torque's noise
    variance taken off its square): the winding's dissipation up to R / k_t^2."""
    log = estimate.log
    if estimate.torque_mean is not None:
        level = np.full(len(log.t) - 1, estimate.torque_mean)
        if estimate.torque_mean_2 is not None:
            level[estimate.switch :] = estimate.torque_mean_2
        return level**2
    u = np.asarray(log.torque[:-1], dtype=float)  # held over [t_k, t_k+1)
    return np.maximum(u * u - estimate.sigma_torque**2, 0.0)


def _weighted_work(
    estimate: PassEstimate, a: AngleSample, mid: np.ndarray, start: float
) -> tuple[np.ndarray, np.ndarray, float]:
    """The pass's work weighted by ``mid`` (one value per step), to each angle of ``a``: the
    whole and its back-driven part; and ``mid`` averaged over the pass's work |dW| (``start``
    for a pass without work)."""
    log = estimate.log
    dW = np.diff(estimate.work)
    dW_back = np.diff(estimate.work_back)
    weighted = np.concatenate([[0.0], np.cumsum(dW * mid)])
    weighted_back = np.concatenate([[0.0], np.cumsum(dW_back * mid)])
    rows = np.clip(np.searchsorted(log.t, a.time, side="right") - 1, 0, len(mid) - 1)
    at = weighted[rows] + (a.work - estimate.work[rows]) * mid[rows]
    back = weighted_back[rows] + (a.work_back - estimate.work_back[rows]) * mid[rows]
    total = float(np.sum(np.abs(dW)))
    mean = float(np.sum(np.abs(dW) * mid) / total) if total > 0 else start
    return at, back, mean


def friction_slope_prior(
    device: Device, braking: PassEstimate, reverse: PassEstimate, direction: int = 1
) -> tuple[np.ndarray, np.ndarray] | None:
    """The friction slopes [d1, d2] = [a2, 2 a3] of a run from its passes' dynamics, with
    their covariance (module docstring, the slopes' prior).

    Both passes' modulated equations of motion, fitted together
    (rsp_inertia.estimation.modulated.fit_modulated, the unknowns PRIOR_UNKNOWNS, the
    regressors every PRIOR_QUADRATURE), in the passes' coordinate (a backward run's mirrored,
    its spring's zero angle with it). The covariance is the fit's plus
    (FRICTION_PRIOR_ALLOWANCE d)^2 on each slope.

    Parameters
    ----------
    device : Device
        The device (its spring, which the fit takes as known).
    braking, reverse : PassEstimate
        The run's two passes.
    direction : int
        -1: a backward run's mirrored passes.

    Returns
    -------
    tuple of np.ndarray, or None
        (mean (2,), covariance (2, 2)) of [d1, d2]; None when the passes are too short for
        the fit or its covariance is not positive definite.
    """
    if direction < 0:
        device = mirrored_device(device)
    passes = [(braking.log, braking.smoothed), (reverse.log, reverse.smoothed)]
    step = max(1, round(PRIOR_QUADRATURE / median_step(braking.smoothed.t)))
    try:
        values, cov = fit_modulated(
            device, passes, PRIOR_UNKNOWNS, f"{braking.source} and {reverse.source}", step,
            torque_noise=[braking.sigma_torque] * 2,  # the torque channel's, both passes
        )
    except InputError:
        return None
    index = [PRIOR_UNKNOWNS.index(name) for name in FRICTION.sloped]
    jacobian = FRICTION.slope_jacobian  # d1 = a2, d2 = 2 a3 (module docstring)
    mean = jacobian @ np.array([values[name] for name in FRICTION.sloped])
    covariance = jacobian @ cov[np.ix_(index, index)] @ jacobian
    covariance = covariance + np.diag((FRICTION_PRIOR_ALLOWANCE * mean) ** 2)
    if not np.all(np.isfinite(covariance)) or np.linalg.eigvalsh(covariance)[0] <= 0.0:
        return None
    return mean, covariance


def balance_spacing(braking: PassEstimate, reverse: PassEstimate) -> float:
    """rad between the balance angles: POSITION_SPACING_BANDWIDTHS smoother time constants
    at the passes' top speed."""
    bandwidth = min(braking.smoothed.bandwidth, reverse.smoothed.bandwidth)
    # max |Omega| as max(max Omega, -min Omega): no float copy of either pass for np.abs.
    top = max(max(s.omega.max(), -s.omega.min()) for s in (braking.smoothed, reverse.smoothed))
    return POSITION_SPACING_BANDWIDTHS / bandwidth * top


@dataclass(frozen=True)
class HarmonicReach:
    """A reverse's regulator bandwidth against its braking's speed harmonics over the
    balances (:func:`harmonic_reach`)."""

    bandwidth: float
    """w, rad/s."""
    slowest: float
    """rad/s, the braking's speed at the balances' slowest (MIN_SPEED_FRACTION of the top)."""
    counts: float
    """Encoder counts per sample at that speed."""

    @property
    def follows(self) -> bool:
        """Whether w reaches the 2 Omega harmonic there (else the reverse tracks the mirror on
        its feedforward alone)."""
        return self.bandwidth >= 2 * self.slowest


def harmonic_reach(device: Device, bandwidth: float, top_speed: float) -> HarmonicReach:
    """Whether a regulator follows the speed harmonics 2 Omega of a braking over the balances'
    range, and the encoder's counts per sample at its slowest speed
    (rsp_inertia.ocp.regulator sets the bandwidth; check and plan ask this).

    Parameters
    ----------
    device : Device
        The device (its encoder).
    bandwidth : float
        rad/s, the regulator's bandwidth w.
    top_speed : float
        rad/s, the braking's top speed.

    Returns
    -------
    HarmonicReach
        The bandwidth against the slowest speed balanced.
    """
    slowest = MIN_SPEED_FRACTION * top_speed
    return HarmonicReach(
        bandwidth=bandwidth,
        slowest=slowest,
        counts=slowest * device.encoder.dt / device.encoder.quantum,
    )


def mismatch_regressors(phi: np.ndarray, omega: np.ndarray, omega_rev: np.ndarray) -> np.ndarray:
    """[R1, R2] of the module docstring from ``phi[0]``: int delta dphi and
    int (|Omega| delta + delta^2 / 2) dphi, delta = |Omega'| - |Omega| (trapezoid); one
    column per slope of the friction law (rsp_inertia.plant.model.FrictionLaw.mismatch_integrands).

    Parameters
    ----------
    phi : np.ndarray, shape (n,), rad
        The balance angles, ascending.
    omega, omega_rev : np.ndarray, shape (n,), rad/s
        The braking's and the reverse's speeds there.

    Returns
    -------
    np.ndarray, shape (n, 2)
        R1 (rad^2/s) and R2 (rad^3/s^2) at each angle (n, len(FRICTION.slope_names)).
    """
    delta = np.abs(omega_rev) - np.abs(omega)
    return np.column_stack(
        [
            cumulative_trapezoid(f, phi, initial=0.0)
            for f in FRICTION.mismatch_integrands(np.abs(omega), delta)
        ]
    )
