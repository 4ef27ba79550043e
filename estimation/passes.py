"""A pass (braking or reverse) ready for work-energy balances (docs/method.md §3-5).

A pass is turned into functions of the angle: the speed (smoothed), the motor work from the
start of the pass (Stieltjes sum of the logged torque over encoder increments), and the
variance that the torque log's noise puts into that work. The node formula and the least
squares both read a stage through :meth:`PassEstimate.sample_at`.

Motor work: the Stieltjes sum of the logged torque over the *smoothed* angle's increments,
W_K = sum_{k<K} u_k (phi^_{k+1} - phi^_k) (rsp_inertia.plant.logs.motor_work, the package's
one zero-order-hold sum), not over the raw readings y. Over readings the sum differs from the true
work by sum u_k (e_{k+1} - e_k), e = y - phi the quantization error; that telescopes to nothing
only while u is independent of e. Under closed-loop control it is not: the regulator feeds back
the reading, u_k contains -k_phi e_k, and the sum gains k_phi sum (e_k^2 - e_k e_{k+1}) ~ k_phi
N q^2/12 of spurious work (3e-3 J, 6e-4 of the kinetic energy, on the default stage 2). The
smoothed angle's error is ~0.05 q and nearly free of the reading's sample-to-sample error,
which removes the bias. Between rows the work is W(phi*) = W_K + u_K (phi* - phi^_K), K the
last row at or before phi*.

The angle's own error. By parts, the sum up to row K is u_{K-1} phi^_K - u_0 phi^_0 -
sum_{0<k<K} phi^_k (u_k - u_{k-1}); evaluated where the smoothed angle is phi* (as every
balance is), its end terms are exact, and what the smoothed angle's error e^ leaves in the
work between two angles is -sum e^_k du_k over the rows between, du_k = u_k - u_{k-1}: nothing
for a constant torque, but a closed-loop reverse's torque moves with every count the drive
reads (its regulator's response to the quantization), and on a coarse encoder that error
reaches 10 times the torque noise's (3e-4 J over a 10-bit default stage 1 against 3e-5 J).
With e^ the smoother's stationary angle error (autocovariance R_phi,
rsp_inertia.estimation.smoothing), the error is a random walk along the pass with increments
du_k sum_j R_phi(t_k - t_j) du_j, whose cumulative sum is ``work_var_angle``
(:func:`angle_work_variance`, the budget's "encoder (work)"). It takes e^ independent of the
torque; a drive that regulates on the same readings makes them correlate a little, which
leaves a bias that grows with the regulator's response to one count (the program keeps that
response small, rsp_inertia.ocp.regulator). A Monte Carlo over reading offsets
(tests/estimation/test_coarse.py) finds 0.8-0.9 of the predicted variance at 2-8 counts per
sample and 0.65 at 0.6 counts per sample, where the quantization lines put less of the angle
error's power at the low frequencies the torque's changes weigh (conservative).

Braking pass: a constant torque. By protocol the motor holds one constant braking torque
(or none) over the whole braking pass (docs/method.md §4); the log is that constant plus the
channel's white noise. Then the best estimate of the applied torque is the mean of every
row of the log, u_bar, and the work is W(phi) = u_bar (phi - phi^_0): its error
(u_bar - u)(phi - phi^_0) has variance sigma^2 / N (phi - phi^_0)^2, N the rows, instead of
the sample-by-sample sum's random walk sigma^2 sum dphi_k^2. The assumption is checked on the
log itself (:func:`constancy_p_value`, a chi^2 test of quarter-turn means, at the level
:func:`constancy_level` that keeps the false alarms to :data:`CONSTANCY_TAIL` per experiment,
however many braking logs it has): a braking torque that drifts or ripples beyond its noise
falls back to the sample-by-sample sum, which is exact for any applied torque, and identify
says so.

A two-level braking (device.toml ``braking_torque_2``: the torque switches once, at a given
turn) is held constant on either side of its switch. The switch is found in the logged
torque itself (rsp_inertia.plant.logs.switch_row: the row that best splits the log into two means, a
real logger's file as the virtual device's), each level is the mean of its rows and is tested
for constancy as above (:func:`two_level_p_value`), and the work is u_bar_1 (phi - phi^_0)
before the switch and u_bar_1 (phi_s - phi^_0) + u_bar_2 (phi - phi_s) after: two shared
errors, two rank-one terms.

Dropped samples (rsp_inertia.plant.logs.dropped_samples: a logger may lose rows; the drive
still acted at those instants; :func:`estimate_pass` finds them once and the estimate keeps
them, :attr:`PassEstimate.dropped`, for the balances' checks). Over a gap of n missing rows
between rows k and k+1 the zero-order-hold sum would hold u_k over the whole gap, while the
drive set n unlogged torques there. A constant
torque's mean is not affected; a sample-by-sample sum is (a closed-loop reverse's torque
moves by the regulator's response to every count). The gap's missing
instants are taken evenly spaced between its two rows, their torques linearly interpolated
between u_k and u_k+1 and their angles from the smoothed motion (Hermite), and the work
over the gap is summed with them (:func:`gap_work`). The interpolation's error is unknown
per gap but its size is not: the log's own rows, interpolated across the same gap length
where nothing is missing, give its mean square, which enters the work's variance as an
independent term per gap (``work_var_gaps``).

The speed over a gap. The smoother bridges a gap with the readings on either side; the
speed's error near it grows (rsp_inertia.estimation.smoothing.gap_speed_covariance). A pass
keeps its gaps that count (:attr:`PassEstimate.gaps`: the smoother's own added variance of
the speed above GAP_NEGLIGIBLE of its stationary one somewhere) and gives what they add to
the speed's error covariance at any instants (:meth:`PassEstimate.gap_speed_band`); whether
a gap is bridged at all is the balance's decision (rsp_inertia.estimation.balance).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from scipy.signal import oaconvolve
from scipy.stats import chi2

from rsp_inertia.estimation.smoothing import (
    GAP_REACH,
    KERNEL_SPAN,
    Smoothed,
    angle_error_autocovariance,
    gap_speed_covariance,
    gap_speed_excess,
    hermite,
    median_step,
    smooth_log,
)
from rsp_inertia.estimation.whitening import Noise
from rsp_inertia.plant.logs import Log, dropped_samples, motor_work, switch_row, torque_noise
from rsp_inertia.plant.transducers import power_flow_split

__all__ = [
    "ANGLE_BLOCK_SPAN",
    "CONSTANCY_CHUNK",
    "CONSTANCY_TAIL",
    "GAP_NEGLIGIBLE",
    "AngleSample",
    "Gap",
    "PassEstimate",
    "angle_work_noise",
    "angle_work_variance",
    "constancy_level",
    "constancy_p_value",
    "estimate_pass",
    "gap_work",
    "two_level_p_value",
    "two_level_work",
]

CONSTANCY_CHUNK = math.pi / 2
"""rad of braking per chunk in the constant-torque test (a quarter turn: a drift over the
pass and a ripple once per turn both move the chunks' means)."""

CONSTANCY_TAIL = 1e-3
"""The constant-torque test's false-alarm rate per experiment: an experiment whose every
braking log is honest (a constant torque plus white noise) sees one or more of them flagged
with this probability, whatever its number of logs (each log is tested at
:func:`constancy_level`; a false alarm only costs some accuracy: that log's work is summed
row by row)."""


def constancy_level(logs: int, rate: float = CONSTANCY_TAIL) -> float:
    """The level at which each of an experiment's braking logs is tested, so that the
    experiment raises a false alarm with probability ``rate`` (docs/method.md, "Motor work").

    Šidák's correction, exact for independent tests (each log has its own noise):
    ``1 - (1 - rate)^(1 / logs)``, a little above ``rate / logs`` (Bonferroni). One test per
    log at ``rate`` would raise a false alarm in ``1 - (1 - rate)^logs`` of the experiments,
    growing with their logs.

    Parameters
    ----------
    logs : int
        The experiment's braking logs (device.toml: its stages' directions), >= 1.
    rate : float, optional
        The false-alarm rate per experiment (default :data:`CONSTANCY_TAIL`).

    Returns
    -------
    float
        The per-log level: a log whose p-value is below it is flagged.

    Examples
    --------
    >>> round(constancy_level(4), 9)
    0.000250094
    """
    return -math.expm1(math.log1p(-rate) / max(int(logs), 1))


GAP_NEGLIGIBLE = 0.1
"""A gap of dropped samples counts for the speed (:attr:`PassEstimate.gaps`) when the
smoother's own added variance of the speed exceeds this fraction of its stationary one
somewhere (rsp_inertia.estimation.smoothing.gap_speed_excess): below it, the readings' noise
adds a few percent of the speed noise's variance over a few 1 / w_c, less than the noise
model's own approximations (the quantization lines move the speed noise's level by 0.1 to 10
times along a coarse pass), and the pass is taken as if nothing were missing there. On the
default stage 1 (w_c dt = 0.24) a single dropped sample stays below it (0.051) and two count
(0.106); on stage 2 (0.07) up to 8 in a row stay below it, at 10 kHz on stage 1 up to 26."""


@dataclass(frozen=True)
class Gap:
    """A gap of dropped samples in a pass that counts for its speed (:attr:`PassEstimate.gaps`)."""

    row: int
    """The log's row before the gap (0-based)."""
    number: int
    """That row's sample number (periods from the first row: rows and dropped samples
    before it), which places the gap in the smoother's blocks
    (rsp_inertia.estimation.smoothing.block_starts)."""
    missing: int
    """Samples dropped in a row."""
    excess: float
    """The smoother's own largest added variance of the speed over the gap, over its
    stationary one (rsp_inertia.estimation.smoothing.gap_speed_excess)."""


@dataclass(frozen=True)
class AngleSample:
    """A pass's quantities at given angles (:meth:`PassEstimate.sample_at`)."""

    phi: np.ndarray
    """rad, the angles asked for."""
    time: np.ndarray
    """s, when the pass is there (smoothed angle)."""
    omega: np.ndarray
    """rad/s, speed there (signed)."""
    omega_std: np.ndarray
    """rad/s, std of ``omega``."""
    work: np.ndarray
    """J, motor work from the pass's first row to there."""
    work_back: np.ndarray
    """J, its back-driven part (:attr:`PassEstimate.work_back`)."""
    work_var_steps: np.ndarray
    """rad^2, sum of squared encoder increments to there (torque-noise variance factor)."""
    work_var_gaps: np.ndarray | None = None
    """J^2, the work's variance from the gaps of dropped samples to there (None: none)."""
    work_var_angle: np.ndarray | None = None
    """J^2, the work's variance from the smoothed angle's error to there (None: a constant
    torque)."""

    def received_work(self, gains: tuple[float, float]) -> np.ndarray:
        """J, the work the body received up to the sample's angles: h_d x the logged work's
        driving part + h_b x its back-driven part (``gains`` = (h_d, h_b),
        rsp_inertia.plant.transducers.drive_gains)."""
        return gains[0] * (self.work - self.work_back) + gains[1] * self.work_back


@dataclass(frozen=True)
class PassEstimate:
    """One pass, ready for energy balances: what :func:`estimate_pass` found in its log, and
    the pass read at any angle (:meth:`sample_at`) with its noise (:meth:`work_noise`,
    :meth:`speed_error_band`)."""

    log: Log
    """The encoder log."""
    smoothed: Smoothed
    """Smoothed angle, speed, acceleration at every row."""
    work: np.ndarray
    """J, motor work from the first row to each row (Stieltjes sum, ZOH)."""
    work_back: np.ndarray
    """J, the back-driven part of ``work`` (where torque x angle increment < 0: the body
    drives the motor, rsp_inertia.plant.transducers.power_flow_split); ``work - work_back``
    is the driving part."""
    work_var_steps: np.ndarray
    """rad^2, cumulative sum of squared angle increments to each row: var(work) = sigma^2 x it."""
    sigma_torque: float
    """N m, std of the torque log's noise."""
    source: str
    """Name of the log for messages."""
    dropped: np.ndarray
    """(n - 1,) int, the samples missing after each row of the log
    (rsp_inertia.plant.logs.dropped_samples at the sample rate :func:`estimate_pass` was
    given), found once: the work over the gaps (:func:`gap_work`) and the balances' checks
    near the nodes (rsp_inertia.estimation.balance) read it."""
    torque_mean: float | None = None
    """N m: the applied torque as the mean of the whole log when the pass is modelled with a
    constant torque (module docstring); None when the work is the sample-by-sample sum."""
    constancy_p: float | None = None
    """p-value of the constant-torque test, when it was made."""
    torque_mean_2: float | None = None
    """N m: a two-level braking's second level (the mean of the rows from :attr:`switch`
    on), when the levels passed their test; ``torque_mean`` is then the first level's."""
    switch: int | None = None
    """A two-level braking's first row held at the second level
    (rsp_inertia.plant.logs.switch_row), found
    in the logged torque (also when the levels failed their test: the balances leave the
    angles about it out, rsp_inertia.estimation.balance); None: one level."""
    work_var_gaps: np.ndarray | None = None
    """J^2, cumulative variance of the work over the log's gaps of dropped samples to each
    row (:func:`gap_work`); None: no gap, or a constant torque."""
    work_var_angle: np.ndarray | None = None
    """J^2, cumulative variance of the work from the smoothed angle's error under the torque's
    changes, to each row (:func:`angle_work_variance`); None for a constant torque."""

    def sample_at(self, phi: np.ndarray) -> AngleSample:
        """Speed, motor work and their noise factors where the pass is at angles ``phi`` (rad).

        The smoothed angle is monotone along a pass; the instant it reaches phi* is found by
        linear interpolation between rows and one Newton step with the smoothed speed; the
        speed there by cubic Hermite interpolation with the smoothed acceleration.
        """
        sm = self.smoothed
        phi = np.asarray(phi, dtype=float)
        rising = sm.phi[-1] > sm.phi[0]
        order = slice(None) if rising else slice(None, None, -1)
        ang = sm.phi[order]
        if np.any(ang[1:] <= ang[:-1]):  # (not np.diff: no float array of the pass's length)
            # Near rest the smoothed angle can stall; keep the monotone envelope for the search.
            ang = np.maximum.accumulate(ang)
        idx = np.clip(np.searchsorted(ang, phi, side="right") - 1, 0, len(ang) - 2)
        rows = idx if rising else len(ang) - 1 - idx  # row index in the log's order
        nxt = rows + 1 if rising else rows - 1
        a0, a1 = sm.phi[rows], sm.phi[nxt]
        frac = np.where(a1 != a0, (phi - a0) / np.where(a1 != a0, a1 - a0, 1.0), 0.0)
        t = sm.t[rows] + frac * (sm.t[nxt] - sm.t[rows])
        # One Newton step on phi(t) = phi* with the Hermite form of the smoothed angle.
        k = np.minimum(rows, nxt)
        t0, t1 = sm.t[k], sm.t[k + 1]
        p = hermite(t0, t1, sm.phi[k], sm.omega[k], sm.phi[k + 1], sm.omega[k + 1], t)
        w_lin = sm.omega[k] + (sm.omega[k + 1] - sm.omega[k]) * (t - t0) / (t1 - t0)
        t = t + np.where(w_lin != 0, (phi - p) / np.where(w_lin != 0, w_lin, 1.0), 0.0)
        t = np.clip(t, t0, t1)
        s = (t - t0) / (t1 - t0)
        omega = hermite(t0, t1, sm.omega[k], sm.eps[k], sm.omega[k + 1], sm.eps[k + 1], t)
        omega_std = sm.omega_std[k] + (sm.omega_std[k + 1] - sm.omega_std[k]) * s
        # Motor work at the smoothed angle (module docstring): last row at or before time t.
        K = k
        held = self.log.torque[K] if self.torque_mean is None else self.torque_mean
        if self.torque_mean_2 is not None:
            held = np.where(K >= self.switch, self.torque_mean_2, self.torque_mean)
        rest = phi - sm.phi[K]
        work = self.work[K] + held * rest
        work_back = self.work_back[K] + power_flow_split(held, rest)[1] * rest
        return AngleSample(
            phi=phi,
            time=t,
            omega=omega,
            omega_std=omega_std,
            work=work,
            work_back=work_back,
            work_var_steps=self.work_var_steps[K],
            work_var_gaps=None if self.work_var_gaps is None else self.work_var_gaps[K],
            work_var_angle=None if self.work_var_angle is None else self.work_var_angle[K],
        )

    def work_noise(self, a: AngleSample) -> Noise:
        """The covariance that the torque log's noise puts into the pass's motor work at the
        angles of ``a`` (this pass's :meth:`sample_at`), by structure
        (rsp_inertia.estimation.whitening), J^2.

        Sample-by-sample sum: a random walk, sigma^2 min(s_i, s_j) with s the sum of squared
        angle increments from the pass's start, plus the gaps' interpolation variance, another
        random walk (:func:`gap_work`). Constant-torque model: one shared error of the mean
        torque, rank one: sigma^2 / N (a_i - phi^_0)(a_j - phi^_0) (module docstring).
        """
        n = a.phi.size
        sigma2 = self.sigma_torque**2
        if self.torque_mean_2 is not None:  # two levels: two shared errors
            start, at = self.smoothed.phi[0], self.smoothed.phi[self.switch]
            sign = math.copysign(1.0, at - start)
            first = np.where((a.phi - at) * sign < 0.0, a.phi, at) - start
            second = np.where((a.phi - at) * sign > 0.0, a.phi - at, 0.0)
            rows = (self.switch, len(self.log) - self.switch)
            return Noise(
                n,
                rank_one=(
                    math.sqrt(sigma2 / rows[0]) * first,
                    math.sqrt(sigma2 / rows[1]) * second,
                ),
            )
        if self.torque_mean is not None:
            start = self.smoothed.phi[0]
            return Noise(n, rank_one=(math.sqrt(sigma2 / len(self.log)) * (a.phi - start),))
        walks = (sigma2 * a.work_var_steps,)
        if a.work_var_gaps is not None:
            walks += (a.work_var_gaps,)
        return Noise(n, walks=walks)

    def work_covariance(self, a: AngleSample) -> np.ndarray:
        """(n, n) :meth:`work_noise`, whole (a few angles: the node formula's passages), J^2."""
        return self.work_noise(a).dense()

    def speed_error_band(self, a: AngleSample) -> np.ndarray:
        """(w, n) lower band of the covariance of the pass's smoothed speed at the angles of
        ``a`` (this pass's :meth:`sample_at`), rad^2/s^2 (rsp_inertia.estimation.smoothing: the
        derived error autocovariance at the instants the pass is there, zero beyond its
        span), without the gaps' share (:meth:`gap_speed_band`): within their reach the
        smoother's own covariance does not scale it (its rise there is the gaps')."""
        return self.smoothed.speed_error_band(a.time, a.omega_std, self.near_gaps(a.time))

    @functools.cached_property
    def h(self) -> float:
        """w_c dt: the smoother's bandwidth times the log's sample period (its median step)."""
        return self.smoothed.bandwidth * median_step(self.smoothed.t)

    @functools.cached_property
    def gaps(self) -> list[Gap]:
        """The pass's gaps of dropped samples that count for its speed: the smoother's own
        added variance above GAP_NEGLIGIBLE of its stationary one (module docstring)."""
        rows = np.flatnonzero(self.dropped)
        missing = self.dropped[rows]
        numbers = rows + np.cumsum(missing) - missing
        found = []
        for k, number, n in zip(rows.tolist(), numbers.tolist(), missing.tolist()):
            excess = gap_speed_excess(int(n), self.h)
            if excess > GAP_NEGLIGIBLE:
                found.append(Gap(row=k, number=int(number), missing=int(n), excess=excess))
        return found

    def near_gaps(self, times: np.ndarray) -> np.ndarray | None:
        """Which of ``times`` (s) lie within GAP_REACH / w_c of a gap of :attr:`gaps` (None:
        the pass has none)."""
        if not self.gaps:
            return None
        t, reach = self.log.t, GAP_REACH / self.smoothed.bandwidth
        near = np.zeros(np.shape(times), dtype=bool)
        for gap in self.gaps:
            near |= (times > t[gap.row] - reach) & (times < t[gap.row + 1] + reach)
        return near

    def gap_speed_band(self, a: AngleSample) -> np.ndarray | None:
        """(w, n) lower band of what the pass's gaps (:attr:`gaps`) add to the covariance of
        its smoothed speed at the angles of ``a`` (this pass's :meth:`sample_at`), rad^2/s^2:
        the readings' noise through the smoother bridging each gap
        (rsp_inertia.estimation.smoothing.gap_speed_covariance, its noise part, times
        r w_c^3), at the instants within GAP_REACH / w_c of it; None: no gap counts.

        Each gap's part is its positive part (its eigenvalues clipped at zero): bridging also
        lowers the error's variance along a few combinations of the speeds about the gap
        (the smoother's weights on the readings move), which a source of the uncertainty
        budget cannot carry as a negative variance. At the balances' spacing (one 1 / w_c)
        the clipped part's largest variance is within 10 % of the exact one and its trace
        1.2 to 1.5 times the exact trace (default stage 1, 3 to 14 samples): conservative.

        An instant's place is counted in periods from the row before the gap, on the log's
        own time stamps: periods before it, the gap's rows' interval in proportion, periods
        after the row that follows it."""
        if not self.gaps:
            return None
        sm, t = self.smoothed, self.log.t
        times = np.asarray(a.time, dtype=float)
        dt = self.h / sm.bandwidth
        reach = GAP_REACH / sm.bandwidth
        unit = sm.noise_density * sm.bandwidth**3
        found = []
        for gap in self.gaps:
            t0, t1 = t[gap.row], t[gap.row + 1]
            inside = np.flatnonzero((times > t0 - reach) & (times < t1 + reach))
            if inside.size == 0:
                continue
            tau = times[inside]
            offsets = np.where(
                tau <= t0,
                (tau - t0) / dt,
                np.where(
                    tau >= t1,
                    gap.missing + 1 + (tau - t1) / dt,
                    (tau - t0) / (t1 - t0) * (gap.missing + 1),
                ),
            )
            added, _ = gap_speed_covariance(gap.missing, self.h, offsets, gap.number)
            values, vectors = np.linalg.eigh(added)
            found.append((inside, unit * (vectors * np.maximum(values, 0.0)) @ vectors.T))
        if not found:
            return None
        band = np.zeros((max(int(np.ptp(inside)) + 1 for inside, _ in found), times.size))
        for inside, added in found:
            i, j = np.meshgrid(inside, inside, indexing="ij")
            lower = i >= j
            np.add.at(band, ((i - j)[lower], j[lower]), added[lower])
        return band

    @property
    def mainly_back_driven(self) -> bool:
        """Whether most of the pass's work is back-driven (a braking), not driving (a reverse):
        its main direction of power flow sets the gain (h_b or h_d) on its torque log's
        noise."""
        back = abs(float(self.work_back[-1]))
        return back > abs(float(self.work[-1]) - float(self.work_back[-1]))


def constancy_p_value(log: Log, phi: np.ndarray, sigma: float) -> float:
    """p-value of "the applied torque is constant" on a log with white noise of std sigma.

    The rows are grouped by angle into chunks of CONSTANCY_CHUNK; with n_j rows and mean m_j
    per chunk and u_bar the mean of all rows, sum_j n_j (m_j - u_bar)^2 / sigma^2 is chi^2
    with (chunks - 1) degrees of freedom when the torque is constant. A noise-free log
    (sigma = 0) is constant only if every row is equal.

    Parameters
    ----------
    log : Log
        The pass's log; its torque is tested (over its :attr:`Log.torque_factor`, the
        logged torque, when a temperature's compensation scaled it).
    phi : np.ndarray, shape (n,), rad
        The smoothed angle at each row, which groups the rows into chunks.
    sigma : float
        N m, the std of the torque log's white noise.

    Returns
    -------
    float
        The test's p-value (1 or 0 for a noise-free log).
    """
    u = np.asarray(log.torque, dtype=float)
    if log.torque_factor is not None:  # the protocol holds the logged torque constant
        u = u / log.torque_factor
    if sigma <= 0.0:
        return 1.0 if np.ptp(u) == 0.0 else 0.0
    chunk = np.floor((phi - phi.min()) / CONSTANCY_CHUNK).astype(int)
    n = np.bincount(chunk)
    keep = n > 0
    means = np.bincount(chunk, weights=u)[keep] / n[keep]
    stat = float(np.sum(n[keep] * (means - u.mean()) ** 2) / sigma**2)
    dof = int(keep.sum()) - 1
    return float(chi2.sf(stat, dof)) if dof > 0 else 1.0


def two_level_p_value(log: Log, phi: np.ndarray, sigma: float, switch: int) -> float:
    """p-value of "the applied torque is constant on either side of row ``switch``": each
    level's :func:`constancy_p_value`, combined as the smaller of two independent ones
    (1 - (1 - min p)^2).

    Parameters
    ----------
    log : Log
        The braking's log.
    phi : np.ndarray, shape (n,), rad
        The smoothed angle at each row.
    sigma : float
        N m, the std of the torque log's white noise.
    switch : int
        The second level's first row (rsp_inertia.plant.logs.switch_row).

    Returns
    -------
    float
        The test's p-value.
    """
    parts = (slice(0, switch), slice(switch, None))
    p = min(
        constancy_p_value(
            Log(
                t=log.t[part], phi=log.phi[part], torque=log.torque[part],
                torque_factor=None if log.torque_factor is None else log.torque_factor[part],
            ),
            phi[part], sigma,
        )
        for part in parts
    )
    return 1.0 - (1.0 - p) ** 2


def two_level_work(
    torque: np.ndarray, phi: np.ndarray, switch: int, factor: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, float, float]:
    """:func:`rsp_inertia.plant.logs.motor_work` of a two-level braking held at its levels'
    means (module docstring).

    Parameters
    ----------
    torque : numpy.ndarray, shape (n,)
        N m, the logged torque.
    phi : numpy.ndarray, shape (n,)
        rad, the angle at each row.
    switch : int
        The second level's first row (rsp_inertia.plant.logs.switch_row).
    factor : numpy.ndarray, shape (n,), optional
        The known factor each row's torque carries (rsp_inertia.plant.logs.Log.torque_factor).

    Returns
    -------
    work, back, steps : numpy.ndarray, shape (n,)
        J, the work from the first row; its back-driven part; rad^2, the squared increments'
        running sum.
    mean, mean_2 : float
        N m, the two levels (the logged torque over ``factor``).
    """
    logged = torque if factor is None else torque / factor
    means = float(np.mean(logged[:switch])), float(np.mean(logged[switch:]))
    held = np.where(np.arange(phi.size - 1) < switch, *means)
    if factor is not None:
        held = held * np.asarray(factor[:-1], dtype=float)
    dphi = np.diff(phi)
    zero = np.zeros(1)
    work = np.concatenate([zero, np.cumsum(held * dphi)])
    back = np.concatenate([zero, np.cumsum(power_flow_split(held, dphi)[1] * dphi)])
    steps = np.concatenate([zero, np.cumsum(dphi * dphi)])
    return work, back, steps, means[0], means[1]


def estimate_pass(
    log: Log,
    quantum: float,
    source: str,
    sigma_torque: float | None = None,
    constant_torque: bool = False,
    smoothed: Smoothed | None = None,
    sample_rate: float | None = None,
    constancy_logs: int = 1,
    two_levels: bool = False,
) -> PassEstimate:
    """Smooth a pass and accumulate its motor work (docs/method.md §3, Stieltjes sum; see above).

    Parameters
    ----------
    log : Log
        The pass's encoder/torque log.
    quantum : float
        rad, the encoder's q (the smoother's quantization).
    source : str
        The log's name in messages.
    sigma_torque : float, optional
        N m, the torque channel's logging noise; by default it is estimated from this log
        (right for a braking log, see rsp_inertia.plant.logs.torque_noise).
    constant_torque : bool
        The protocol holds the applied torque constant (a braking pass); the log is tested
        for it and, unless the test rejects it, the work is the log's mean torque times the
        angle.
    smoothed : Smoothed, optional
        The log's smoothed states when already computed (``smooth_log`` of this very log, as
        ``program`` does for a braking).
    sample_rate : float, optional
        Hz, the encoder's: the log's dropped samples are found at it
        (rsp_inertia.plant.logs.dropped_samples, kept as :attr:`PassEstimate.dropped`) and
        the sample-by-sample sum fills their gaps (:func:`gap_work`); by default it is taken
        from the log's median step.
    constancy_logs : int, optional
        With ``constant_torque``: the experiment's braking logs, whose constant-torque tests
        share the false-alarm rate :data:`CONSTANCY_TAIL` (the log is tested at
        :func:`constancy_level` of them); 1 by default (the log alone).
    two_levels : bool, optional
        With ``constant_torque``: the protocol holds two levels, switching once (device.toml
        ``braking_torque_2``); the switch is found in the log
        (rsp_inertia.plant.logs.switch_row), each
        level tested and held at its mean (module docstring).

    Returns
    -------
    PassEstimate
        The pass, ready for energy balances.
    """
    if smoothed is None:
        smoothed = smooth_log(log, quantum, source)
    sigma = torque_noise(log) if sigma_torque is None else sigma_torque
    switch = mean_2 = None
    if constant_torque and two_levels:
        factor = log.torque_factor
        switch = switch_row(log.torque if factor is None else log.torque / factor)
        p_value = two_level_p_value(log, smoothed.phi, sigma, switch)
    else:
        p_value = constancy_p_value(log, smoothed.phi, sigma) if constant_torque else None
    constant = p_value is not None and p_value >= constancy_level(constancy_logs)
    # The angle term first: its convolution's temporaries come before the work's arrays.
    angle = None if constant else angle_work_variance(log.torque, smoothed)
    if constant and switch is not None:
        work, work_back, steps, mean, mean_2 = two_level_work(
            log.torque, smoothed.phi, switch, log.torque_factor
        )
    else:
        work, work_back, steps, mean = motor_work(
            log.torque, smoothed.phi, constant, log.torque_factor
        )
    rate = 1.0 / median_step(log.t) if sample_rate is None else sample_rate
    dropped = dropped_samples(log.t, rate)
    gaps = None
    if mean is None:
        correction, correction_back, gaps = gap_work(log, smoothed, dropped)
        if gaps is not None:
            work += correction  # motor_work's own arrays, added to in place
            work_back += correction_back
    return PassEstimate(
        log=log,
        smoothed=smoothed,
        work=work,
        work_back=work_back,
        work_var_steps=steps,
        sigma_torque=sigma,
        source=source,
        dropped=dropped,
        torque_mean=mean,
        constancy_p=p_value,
        work_var_gaps=gaps,
        work_var_angle=angle,
        torque_mean_2=mean_2,
        switch=switch,
    )


ANGLE_BLOCK_SPAN = 200.0
"""w_c x the duration of the stretches over which :func:`angle_work_variance` keeps its random
walk from falling (five times the kernel's span)."""


def angle_work_variance(torque: np.ndarray, smoothed: Smoothed) -> np.ndarray:
    """J^2, the variance the smoothed angle's error puts into the work from the first row to
    each row of a sample-by-sample sum (module docstring).

    The cumulative sum of du_k sum_j R_phi((k - j) dt) du_j over the rows k = 1 .. K - 1,
    du_k = u_k - u_{k-1} each scaled by the quantization lines' angle error at its row over the
    white one (:meth:`rsp_inertia.estimation.smoothing.Smoothed.line_scale`), dt the log's
    median step (R_phi: :func:`rsp_inertia.estimation.smoothing.angle_error_autocovariance`,
    zero beyond w_c |tau| = KERNEL_SPAN). A single increment is a product of one draw of the
    torque's changes and can be negative; over a stretch of ANGLE_BLOCK_SPAN / w_c their sum is
    the stretch's variance, which is spread evenly over its rows (never below zero): a random
    walk, so that min(v_i, v_j) is a covariance.
    """
    u = np.asarray(torque, dtype=float)
    n = u.size
    du = np.diff(u)
    if du.size == 0:
        return np.zeros(n)
    dt = median_step(smoothed.t)
    reach = min(int(KERNEL_SPAN / (smoothed.bandwidth * dt)), du.size - 1)
    half = angle_error_autocovariance(
        np.arange(reach + 1) * dt, smoothed.bandwidth, smoothed.noise_density
    )
    kernel = np.concatenate([half[:0:-1], half])  # lags -reach .. reach
    du *= smoothed.line_scale("angle", slice(1, None))
    # Overlap-add FFT convolution: the kernel spans KERNEL_SPAN / w_c of rows, 3,300 at 10 kHz
    # on the default stage 1, which a direct sum would pay at every row.
    smeared = oaconvolve(du, kernel, mode="same")
    stretch = max(math.ceil(ANGLE_BLOCK_SPAN / (smoothed.bandwidth * dt)), 1)
    # The increments, padded with zeros to whole stretches, each stretch's sum then spread
    # over its rows in place: no more arrays of the log's length than these and the result.
    increments = np.zeros(math.ceil(du.size / stretch) * stretch)
    increments[: du.size] = du
    increments[: du.size] *= smeared
    del du, smeared
    stretches = increments.reshape(-1, stretch)
    share = np.maximum(stretches.sum(axis=1), 0.0)
    stretches[:] = (share / stretch)[:, None]
    out = np.zeros(n)
    np.cumsum(increments[: n - 2], out=out[2:])
    return out


def gap_work(
    log: Log, smoothed: Smoothed, dropped: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """What the zero-order-hold sum misses over the log's gaps of dropped samples (module
    docstring), as cumulative arrays per row.

    Parameters
    ----------
    log : Log
        The pass's log.
    smoothed : Smoothed
        Its smoothed states (the missing instants' angles, by Hermite interpolation).
    dropped : np.ndarray, shape (n - 1,), int
        The samples missing after each row (rsp_inertia.plant.logs.dropped_samples).

    Returns
    -------
    correction : np.ndarray, shape (n,), J
        Work to add to the sample-by-sample sum from the first row to each row.
    correction_back : np.ndarray, shape (n,), J
        Its back-driven part (rsp_inertia.plant.logs.motor_work).
    variance : np.ndarray, shape (n,), J^2, or None
        Cumulative variance of that work from the interpolated torques' errors; None (and a
        zero correction) when nothing is missing.
    """
    n = len(log)
    rows = np.flatnonzero(dropped)
    if rows.size == 0:
        return np.zeros(n), np.zeros(n), None
    u, t, sm = log.torque, log.t, smoothed
    add = np.zeros(n)
    add_back = np.zeros(n)
    var = np.zeros(n)
    for gap in np.unique(dropped[rows]).tolist():
        at = rows[dropped[rows] == gap]
        frac = np.arange(1, gap + 1) / (gap + 1)  # where the missing instants fall, (gap,)
        mean_square = _interpolation_mean_square(u, dropped, gap, frac)
        t0, t1 = t[at, None], t[at + 1, None]
        tm = t0 + (t1 - t0) * frac  # (gaps, gap) missing instants
        args = (sm.phi[at, None], sm.omega[at, None], sm.phi[at + 1, None], sm.omega[at + 1, None])
        phi_m = hermite(t0, t1, args[0], args[1], args[2], args[3], tm)
        edges = np.column_stack([phi_m, sm.phi[at + 1]])  # ends of the missing rows' holds
        held = np.diff(edges, axis=1)  # (gaps, gap) angle each missing torque acts over
        u_m = u[at, None] + (u[at + 1] - u[at])[:, None] * frac
        add[at + 1] += np.sum((u_m - u[at, None]) * held, axis=1)
        back_m = power_flow_split(u_m, held)[1]
        back_k = power_flow_split(np.broadcast_to(u[at, None], held.shape), held)[1]
        add_back[at + 1] += np.sum((back_m - back_k) * held, axis=1)
        var[at + 1] += held**2 @ mean_square
    return np.cumsum(add), np.cumsum(add_back), np.cumsum(var)


def _interpolation_mean_square(
    u: np.ndarray, missing: np.ndarray, gap: int, frac: np.ndarray
) -> np.ndarray:
    """N^2 m^2, the mean square error of torques linearly interpolated across ``gap`` rows,
    at each of the ``frac`` positions, measured on the log's own rows where none is missing
    (the same interpolation over stretches the logger kept whole)."""
    span = gap + 1
    if u.size <= span:
        return np.full(gap, float(np.var(u)))
    start = np.arange(u.size - span)
    whole = np.convolve(missing, np.ones(span, dtype=int), "valid")[: start.size] == 0
    start = start[whole] if whole.any() else start
    a, b = u[start], u[start + span]
    inner = u[start[:, None] + np.arange(1, span)]
    errors = inner - (a[:, None] + (b - a)[:, None] * frac)
    return np.mean(errors**2, axis=0)


def angle_work_noise(variance: np.ndarray | None, n: int) -> Noise:
    """The covariance that the smoothed angle's error puts into a pass's motor work under a
    changing torque, J^2: the random walk min(v_i, v_j) of its variance at the angles
    (:attr:`AngleSample.work_var_angle`; module docstring); none for None (a constant
    torque)."""
    return Noise(n) if variance is None else Noise(n, walks=(variance,))
