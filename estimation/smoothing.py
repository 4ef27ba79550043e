"""Angle, speed and acceleration from a quantized encoder log: Kalman filter + RTS smoother.

Model (kinematic, so that nothing about the unknown body enters the estimates):
the state x = (phi, Omega, eps) follows a triple integrator driven by white jerk of spectral
density ``q_j`` (rad^2/s^5). Over a step T the transition is

    F = [[1, T, T^2/2], [0, 1, T], [0, 0, 1]],
    Q = q_j [[T^5/20, T^4/8, T^3/6], [T^4/8, T^3/3, T^2/2], [T^3/6, T^2/2, T]].

Measurement: the encoder reads y = floor(phi/q) q (docs/files.md), so phi lies in [y, y+q):
the measurement is z = y + q/2 with the quantization's variance q^2/12 (uniform error), each
reading independent (true when the body moves several counts per sample; near rest the
estimate is over-confident, and the energy balances avoid the last slow stretch anyway).

Speed. The filter takes the readings in *blocks* of B samples (T = B dt): the state lives at
the block's mid-time and the measurement function maps it to the block's readings with the
state's quadratic Taylor form. Each reading enters once, with its own variance, so no
information is lost; the filter runs B times fewer steps. Model and measurement are linear,
so the filter is the linear Kalman filter, with its update in information form: a block's
readings enter through the 3 x 3 sums H^T H / var and H^T z / var, computed for all blocks
at once, vectorised, and the Python loop over the blocks does 3 x 3 operations only
(:func:`smooth_log`). It smooths ~300,000 rows/s on this project's 2-core machine, 10 kHz logs
included (filterpy's UKF, used before, gave the same numbers, to its own rounding, at
~70,000 rows/s, ~150 us per block; its steady-state speed std wandered by 2e-8 of itself
where this filter's stays within 1e-13).

Block length, derived. The block model costs accuracy in two ways, both growing steeply with
w_c T (w_c the bandwidth below), so B is the largest length up to ``BLOCK`` with
w_c T <= ``BLOCK_BANDWIDTH`` = 2 (:func:`block_length`):

- Bias. The true reading adds j tau^3/6 to the Taylor form (j the jerk, tau the offset from
  the block's mid-time). For a constant jerk the steady-state smoother's error is the same
  e at every block (the problem is shift-invariant), the minimiser of the per-block cost
  |r - H e|^2 / sigma^2 + (w + (I - F) e)^T Q^-1 (w + (I - F) e), with r_i = j tau_i^3/6 the
  readings' residuals, H the Taylor rows, sigma^2 = q^2/12 and w = j (T^3/6, T^2/2, T) the
  true motion's step that the model calls process noise. r is odd in tau, so only the speed
  is biased: Omega^ - Omega = kappa j (:func:`block_speed_bias`). For a speed harmonic of
  relative amplitude a at nu <= 2 Omega_max = w_c / BANDWIDTH_FACTOR, j = a nu^2 Omega, so
  the relative speed bias is at most a kappa (w_c / BANDWIDTH_FACTOR)^2. At w_c = 390 rad/s
  (a 3-turn, 2 s braking against a spring, 20 rad/s) kappa = 6.9e-7 s^2 with B = 10
  (w_c T = 3.9), a speed bias of 1e-4 rad/s that follows the jerk over the whole pass; with
  B = 5 (w_c T = 1.95) kappa = 3.3e-9 s^2 and the bias factor kappa (w_c / 10)^2 is 5e-6.
- Aliasing. The block states sample the smoother's output at 1/T; the speed error's spectral
  density r w^2 H(w)^2 (below) peaks at 0.76 w_c and must have died out by the block rate's
  Nyquist frequency pi/T. At w_c T = 2, pi/T = 1.57 w_c, where the density is 2.4 % of its
  peak (12 % at w_c T = 2.4, 98 % at 3.9).

The default experiment's stage 1 (w_c = 240 rad/s) gets B = 8, its stage 2 (70 rad/s) B = 10.

Process noise, justified. The RTS smoother of this model is, in steady state, the two-sided
Wiener filter 1 / (1 + (w/w_c)^6) with w_c = (q_j / r)^(1/6), r = (q^2/12) dt the spectral
density of the reading noise. The speed of a body on the gimbal oscillates at the harmonics
of its rotation, the highest that matters at 2 Omega (M(phi) has cos 2phi terms, docs/method.md §2).
Putting w_c = ``BANDWIDTH_FACTOR`` x 2 Omega_max keeps the smoother's amplitude bias at that
harmonic below (1/BANDWIDTH_FACTOR)^6 = 1e-6, far below the target accuracy; a lower w_c
would average more noise out but bias exactly the harmonics that carry the tensor's products.
Hence q_j = r (2 BANDWIDTH_FACTOR Omega_max)^6, set from the log itself.

Irregular time stamps. A log's time stamps are the drive's sampling instants
(rsp_inertia.plant.logs.JITTER_LIMIT): they may jitter about the regular grid and skip
dropped samples. Block k holds the readings of sample numbers k B to (k + 1) B - 1 whatever
their jitter (:func:`block_starts`), so that no block spans a gap: one that did would stretch
its quadratic Taylor form over n + B periods, and its speed bias grows steeply with w_c T (the
block length above: on a 2 % speed harmonic at 2 Omega, a 20-sample gap inside a block of the
default stage 1 biased the speed there by 1.3 times the smoother's own error std, a 40-sample
one by 5 times; with the blocks cut at the gap, 0.13 at the 14 samples it bridges); and a gap
leaves every block away from it as it would be without it (a log's estimates there do not
move with it). The state
lives at the mid-time of a block's first and last readings, each reading enters with its own
offset from there, and each step between block states has its own transition F(T_k) and
process noise Q(T_k), in the filter and in the RTS pass: across a gap the model's motion
carries the state from one side to the other (:func:`gap_speed_covariance` gives what that
costs the speed). On a regular log this is the block smoother above. r keeps the median step:
jitter of a fraction of a period and one sample dropped in a thousand change the readings'
density by less than that.

The smoother's output is returned at every sample of the log by cubic Hermite interpolation
between block states (phi with its derivative Omega, Omega with its derivative eps).

Speed error, derived. The trajectory is smooth, so the smoother's error is the reading noise
passed through it: the estimate of phi is H(w) applied to the readings, its speed is
i w H(w) applied to them, and with white reading noise of density r the speed error is a
stationary process of spectral density r w^2 H(w)^2, autocovariance

    R(tau) = (1/pi) int_0^inf r w^2 H(w)^2 cos(w tau) dw = r w_c^3 g(w_c tau),
    g(s) = (1/pi) int_0^inf x^2 / (1 + x^6)^2 cos(x s) dx,    g(0) = 1/12

(g(0): substitute u = x^3, int du / (3 (1 + u^2)^2) = pi/12). The smoother's own covariance
is the model's r H, variance r w_c^3 / 6: twice the actual error's r w_c^3 / 12, because the
model expects a random jerk where the true motion is smooth. R(tau) changes sign at
w_c tau ~ 2.5 and decays like exp(-w_c tau / 2): the speed error has no low-frequency
content (its integral is the angle's error, a small fraction of a count), which is what makes
it nearly harmless to the energy balances' slow trends (rsp_inertia.estimation.balance).

Angle error, derived. The same reading noise through H(w) itself leaves the smoothed angle an
error of spectral density r H(w)^2, autocovariance

    R_phi(tau) = (1/pi) int_0^inf r H(w)^2 cos(w tau) dw = r w_c g_phi(w_c tau),
    g_phi(s) = (1/pi) int_0^inf cos(x s) / (1 + x^6)^2 dx,    g_phi(0) = 5/18

(:func:`angle_error_autocovariance`; g_phi(0): int_0^inf dx / (1 + x^6)^2 = 5 pi / 18): an RMS
error of sqrt(5 w_c dt / 216) of a count whatever the resolution, 0.075 at w_c = 240 rad/s
and 1 kHz (the default stage 1), where the virtual device's smoothed angles on a 10-bit
encoder are off by 0.06-0.07 of a count. It is harmless under a constant torque, whose work
is the torque times the angle travelled; under a torque that changes it is not (the motor
work's error, rsp_inertia.estimation.passes).

Quantization lines. Both derivations take the readings' errors as white, which holds when
the body moves many counts per sample. A coarse encoder breaks it: the error of a reading is
a sawtooth in the angle, e = q/2 - q frac(phi/q) = sum_n (q / (pi n)) sin(2 pi n phi / q),
and a body moving v = |Omega| dt / q counts per sample samples each harmonic n at the
aliased frequency w_n = 2 pi dist(n v, Z) / dt (dist to the nearest integer). The smoother
passes line n to the angle with gain H(w_n) and to the speed with w_n H(w_n), so the errors'
variances are, at the instant's v,

    var(e^_phi) = sum_n q^2 / (2 pi^2 n^2) H(w_n)^2,
    var(e^_Omega) = sum_n q^2 / (2 pi^2 n^2) w_n^2 H(w_n)^2

(:func:`quantization_error_variance`; harmonics beyond ``QUANTIZATION_LINES`` at their
average, the white level). Averaged over v they are the white values above; at a given v they
are not: below a count per sample few low harmonics alias into the smoother's band, and the
speed error's variance on the virtual device's 10-bit stage 2 (0.15-0.4 counts per sample) is
0.1-0.5 of the white value, while near a whole count per sample it is larger. Over 0.5 s stretches of the
virtual device's brakings the actual variance over the line value has a median of 1.0 to 1.7
and a 10-90% range of 2-7x from 10 to 14 bits, against a median of 0.08 to 1.1 and a range
of 10-100x for the white value. The nominal model of the torque program
(rsp_inertia.ocp.nominal) and the motor work's angle term (rsp_inertia.estimation.passes)
take their errors' levels from the lines.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from scipy.integrate import trapezoid

from rsp_inertia.infra.errors import InputError
from rsp_inertia.infra.progress import report
from rsp_inertia.plant.logs import Log

__all__ = [
    "BANDWIDTH_FACTOR",
    "BLOCK",
    "BLOCK_BANDWIDTH",
    "GAP_GRID",
    "GAP_REACH",
    "GAP_WINDOW",
    "KERNEL_SPAN",
    "LINE_AVERAGE",
    "QUANTIZATION_LINES",
    "Smoothed",
    "angle_error_autocovariance",
    "block_length",
    "block_speed_bias",
    "block_starts",
    "gap_speed_covariance",
    "gap_speed_excess",
    "hermite",
    "jerk_density",
    "largest_bridged_gap",
    "median_step",
    "noise_density",
    "quantization_error_variance",
    "smooth_log",
    "smoother_bandwidth",
    "speed_error_autocovariance",
    "top_speed",
]

BLOCK = 10
"""Largest number of encoder samples per filter step."""

BLOCK_BANDWIDTH = 2.0
"""Largest w_c T of a block (module docstring: block length)."""

BANDWIDTH_FACTOR = 10.0
"""Smoother bandwidth over the highest speed harmonic 2 Omega_max (bias (1/10)^6 = 1e-6)."""

LINE_AVERAGE = 0.05
"""s over which the quantization lines' variances are averaged (:meth:`Smoothed.line_scale`)."""

_MIN_BANDWIDTH = 20.0
"""rad/s: floor on the smoother bandwidth for very slow passes."""


@dataclass(frozen=True)
class Smoothed:
    """Smoothed states of one pass, at every sample of its log."""

    t: np.ndarray
    """s, the log's time stamps."""
    phi: np.ndarray
    """rad, angle (the quantization's half count restored)."""
    omega: np.ndarray
    """rad/s, speed."""
    eps: np.ndarray
    """rad/s^2, acceleration."""
    omega_std: np.ndarray
    """rad/s, standard deviation of ``omega`` (smoother covariance)."""
    jerk_density: float
    """q_j, rad^2/s^5: the process noise used."""
    bandwidth: float
    """w_c, rad/s: the smoother's bandwidth that q_j gives."""
    noise_density: float = 0.0
    """r = (q^2/12) dt, rad^2 s: spectral density of the readings' quantization noise."""

    @property
    def line_scales(self) -> tuple[np.ndarray, np.ndarray]:
        """(angle, speed) at every row: :meth:`line_scale` of both."""
        return self.line_scale("angle"), self.line_scale("speed")

    def line_scale(self, part: str, rows=slice(None)) -> np.ndarray:
        """The quantization lines' standard deviation of the smoothed angle's (``part``
        "angle") or speed's ("speed") error over the white value (module docstring) at every
        row, or at ``rows`` (an index of them), from the smoothed speed, averaged over
        ``LINE_AVERAGE`` s about the row (the speed's own ripple and noise smear the lines'
        resonances over that much); ones for exact states.

        Interpolated from :attr:`_line_variances` at each call: a pass keeps no array of its
        length for it (two per pass were 90 MB at 10 kHz over 600 s).
        """
        t = self.t[rows]
        if self.noise_density <= 0.0:  # exact states: no quantization
            return np.ones(t.size)
        times, variances = self._line_variances
        white = angle_error_autocovariance if part == "angle" else speed_error_autocovariance
        scale = np.interp(t, times, variances[part])
        scale /= float(white(0.0, self.bandwidth, self.noise_density))
        return np.sqrt(scale, out=scale)

    @functools.cached_property
    def _steady_omega_std(self) -> float:
        """rad/s, the median of ``omega_std``: the smoother's steady value, which the speed
        error's variance is scaled from (once per pass: the median copies the array)."""
        return float(np.median(self.omega_std))

    @functools.cached_property
    def _line_variances(self) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        """(times, {"angle": ..., "speed": ...}): the quantization lines' variances of the
        smoothed angle's and speed's errors (:func:`quantization_error_variance`) at the
        smoothed speed every LINE_AVERAGE / 10 s (the speed changes little in between) and
        the last row, each averaged over LINE_AVERAGE."""
        dt = median_step(self.t)
        quantum = math.sqrt(12.0 * self.noise_density / dt)
        stride = max(round(LINE_AVERAGE / dt / 10), 1)
        rows = np.unique(np.append(np.arange(0, self.t.size, stride), self.t.size - 1))
        angle, speed = quantization_error_variance(self.omega[rows], quantum, dt, self.bandwidth)
        width = 11 if rows.size > 11 else 1
        kernel = np.ones(width) / width
        pad = width // 2
        angle = np.convolve(np.pad(angle, pad, mode="edge"), kernel, mode="valid")
        speed = np.convolve(np.pad(speed, pad, mode="edge"), kernel, mode="valid")
        return self.t[rows], {"angle": angle, "speed": speed}

    def speed_error_variance(self, rows=slice(None)) -> np.ndarray:
        """rad^2/s^2, the variance of the smoothed speed's error at each row (or at ``rows``,
        an index of them): the derived stationary value (:func:`speed_error_autocovariance`
        at 0), larger where the smoother's own covariance says so (the pass's ends), times the
        quantization lines' share at the row's speed (:meth:`line_scale`); zeros for exact
        states."""
        if self.noise_density <= 0.0:
            return np.zeros(self.t[rows].size)
        stationary = float(speed_error_autocovariance(0.0, self.bandwidth, self.noise_density))
        ramp = self.omega_std[rows] / self._steady_omega_std * self.line_scale("speed", rows)
        return stationary * ramp**2

    def speed_error_band(
        self, t: np.ndarray, omega_std: np.ndarray, plain: np.ndarray | None = None
    ) -> np.ndarray:
        """(w, n) lower band of the covariance of the speed's errors at monotone times ``t``
        (module docstring, R): band[d, i] = cov(t_{i+d}, t_i), zero beyond the span, so that
        w - 1 is the widest offset still within w_c |tau| < KERNEL_SPAN.

        Stationary R(t_i - t_j), scaled at each end by the smoother's own standard deviation
        over its steady value: where the smoother starts up (the first and last few 1/w_c of
        a pass) its error is larger, as its covariance shows. The white readings' R: the
        quantization lines (:attr:`line_scales`) move the error's level along a coarse pass
        by up to 10x either way, but their resonances' places are known too roughly for
        weights (tried: more false alarms of the closure test at 12 and 14 bits); each run's
        speed-noise scale (rsp_inertia.estimation.gls) takes its level from its residuals.

        Parameters
        ----------
        t : np.ndarray, shape (n,)
            s, the instants, strictly monotone.
        omega_std : np.ndarray, shape (n,)
            rad/s, the smoother's own std of the speed there (its ramp at a pass's ends).
        plain : np.ndarray, shape (n,), bool, optional
            Instants left unscaled by ``omega_std``, where the smoother's own covariance
            rises for a gap of dropped samples whose added covariance is counted on its own
            (:func:`gap_speed_covariance`).

        Returns
        -------
        np.ndarray, shape (w, n)
            rad^2/s^2, the lower band.

        Raises
        ------
        ValueError
            ``t`` is not strictly monotone.
        """
        t = np.asarray(t, dtype=float)
        n = t.size
        steps = np.diff(t)
        if n > 1 and not (np.all(steps > 0) or np.all(steps < 0)):
            raise ValueError("the speed error's band needs strictly monotone times")
        span = KERNEL_SPAN / self.bandwidth
        # Each diagonal's smallest |tau| grows with its offset (monotone times): the first one
        # whose smallest |tau| reaches the span is all zeros.
        width = 1
        while width < n and np.min(np.abs(t[width:] - t[: n - width])) < span:
            width += 1
        ramp = np.asarray(omega_std) / self._steady_omega_std
        if plain is not None:
            ramp = np.where(plain, 1.0, ramp)
        band = np.zeros((width, n))
        for d in range(width):
            tau = t[d:] - t[: n - d]
            band[d, : n - d] = (
                speed_error_autocovariance(tau, self.bandwidth, self.noise_density)
                * ramp[d:]
                * ramp[: n - d]
            )
        return band



def _transition(T: float) -> np.ndarray:
    return np.array([[1.0, T, T * T / 2], [0.0, 1.0, T], [0.0, 0.0, 1.0]])


def _process_noise(T: float, q_j: float) -> np.ndarray:
    return q_j * np.array(
        [
            [T**5 / 20, T**4 / 8, T**3 / 6],
            [T**4 / 8, T**3 / 3, T**2 / 2],
            [T**3 / 6, T**2 / 2, T],
        ]
    )


def jerk_density(log: Log, quantum: float) -> tuple[float, float]:
    """q_j and the bandwidth w_c it gives, from the log's top speed (module docstring).

    Omega_max is taken from differences of the readings over BLOCK samples (robust to the
    quantization: BLOCK counts of error over BLOCK samples).
    """
    dt = median_step(log.t)
    bandwidth = smoother_bandwidth(top_speed(log))
    return noise_density(quantum, dt) * bandwidth**6, bandwidth


def top_speed(log: Log) -> float:
    """rad/s, a log's top speed from differences of its readings over BLOCK samples (robust to
    the quantization: a count of error over BLOCK samples); 0 for a log of one row."""
    span = min(BLOCK, len(log) - 1)
    if span < 1:
        return 0.0
    speeds = np.abs(log.phi[span:] - log.phi[:-span]) / (log.t[span:] - log.t[:-span])
    return float(speeds.max()) if speeds.size else 0.0


def median_step(t: np.ndarray) -> float:
    """s, the median of a log's time steps: its sample period, whatever its jitter and dropped
    samples. The steps are partitioned in place (one array of the log's length, not two)."""
    return float(np.median(np.diff(t), overwrite_input=True))


def smoother_bandwidth(omega_max: float) -> float:
    """w_c, rad/s, for a pass whose top speed is ``omega_max`` (module docstring: process noise)."""
    return max(2.0 * BANDWIDTH_FACTOR * omega_max, _MIN_BANDWIDTH)


def noise_density(quantum: float, dt: float) -> float:
    """r = (q^2/12) dt, rad^2 s: spectral density of the readings' quantization noise."""
    return quantum * quantum / 12.0 * dt


def block_length(bandwidth: float, dt: float) -> int:
    """Samples per filter step: the largest B <= BLOCK with w_c B dt <= BLOCK_BANDWIDTH, at least 1.

    Module docstring (block length): the block model's speed bias and the aliasing of the
    speed error both stay negligible up to w_c T = 2.
    """
    fit = math.floor(BLOCK_BANDWIDTH / (bandwidth * dt) * (1 + 1e-12))
    return max(1, min(BLOCK, fit))


def block_starts(t: np.ndarray, block: int, dt: float) -> np.ndarray:
    """The first row of each filter block: the rows whose sample number (periods from the
    first row, each step rounded to whole periods) falls in [k B, (k + 1) B) make block k, so that a gap of
    dropped samples leaves its own blocks shorter, or empty (left out), and every other block
    where it would be without it (module docstring: irregular time stamps).

    Parameters
    ----------
    t : np.ndarray, shape (n,), s
        The log's time stamps.
    block : int
        B, rows per block (:func:`block_length`).
    dt : float
        s, the sample period.

    Returns
    -------
    np.ndarray, int
        Ascending row indices, from 0; block k holds rows starts[k] to starts[k + 1] - 1, at
        most B of them.

    Examples
    --------
    >>> block_starts(np.array([0.0, 1, 2, 3, 4, 8, 9, 10]) * 1e-3, 3, 1e-3)
    array([0, 3, 5, 6])
    """
    n = t.size
    # Sample numbers step by step (a step of about m periods: m - 1 dropped samples, as
    # rsp_inertia.plant.logs.dropped_samples counts them), not from t - t[0]: the median step
    # of a jittered log is off the period by a little, which would add up along it.
    number = np.zeros(n, dtype=np.int64)
    np.cumsum(np.maximum(np.rint(np.diff(t) / dt), 1).astype(np.int64), out=number[1:])
    number //= block
    stretch = np.append(0, np.flatnonzero(np.diff(number)) + 1)
    del number
    # At most B rows per block even where jitter rounds two stamps to one sample number.
    lengths = np.diff(np.append(stretch, n))
    if np.all(lengths <= block):
        return stretch
    counts = -(-lengths // block)
    first = np.repeat(stretch, counts)
    within = np.arange(first.size) - np.repeat(np.cumsum(counts) - counts, counts)
    return first + block * within


def block_speed_bias(block: int, bandwidth: float, dt: float) -> float:
    """kappa, s^2: the steady-state speed bias per unit jerk of the block smoother.

    Module docstring (block length). In units of dt and with sigma = 1 (the bias does not
    depend on sigma: q_j = sigma^2 dt w_c^6 scales the whole cost), the minimiser is

        e = (H^T H + G^T Q^-1 G)^-1 (H^T r - G^T Q^-1 w),    G = I - F,

    and the step term vanishes: w = (j / q_j) x (Q's last column), so Q^-1 w is along eps, and
    G's last row is zero. What is left is the readings' cubic residual r seen through the
    smoother: kappa = e_Omega / j, times dt^2 to bring it to seconds. A one-sample block has
    r = 0 and no bias (the per-sample smoother is exact for polynomials up to degree 5).

    Parameters
    ----------
    block : int
        Samples per block.
    bandwidth : float
        rad/s, the smoother's w_c.
    dt : float
        s, the sample period.

    Returns
    -------
    float
        kappa, s^2.
    """
    T = float(block)
    tau = np.arange(block) - (block - 1) / 2
    H = np.column_stack([np.ones(block), tau, tau**2 / 2])
    G = np.eye(3) - _transition(T)
    Q = _process_noise(T, (bandwidth * dt) ** 6)
    A = H.T @ H + G.T @ np.linalg.solve(Q, G)
    e = np.linalg.solve(A, H.T @ (tau**3 / 6))
    return float(e[1] * dt * dt)


KERNEL_SPAN = 40.0
"""g(s) is taken as 0 beyond s = w_c tau = 40, where |g| / g(0) < 1e-6."""


@functools.cache
def _speed_kernel() -> tuple[np.ndarray, np.ndarray]:
    """g(s) of the module docstring on a grid of s in [0, 40] (trapezoid rule in x).

    The integrand falls like x^-10: cut at x = 8 it loses 1e-8 of g(0); 4,000 steps resolve
    cos(x s) to s = 40 (80 steps per period). Checked against g(0) = 1/12 in the tests.
    """
    s = np.linspace(0.0, KERNEL_SPAN, 2001)
    x = np.linspace(0.0, 8.0, 4001)
    return s, _cosine_transform(x * x / (1.0 + x**6) ** 2, x, s)


_COSINE_CHUNK = 256
"""Values of s per block of :func:`_cosine_transform` (a block is s x 4,001 values: 8 MB)."""


def _cosine_transform(f: np.ndarray, x: np.ndarray, s: np.ndarray) -> np.ndarray:
    """(1/pi) int f(x) cos(x s) dx at each of ``s`` (1-D), by the trapezoid rule on ``x``.

    In blocks of _COSINE_CHUNK values of s: the whole (s, x) table of cosines is 160 MB for
    the 1,668 lags of a 10 kHz log's angle error (each row's sum is the same either way)."""
    g = np.empty(s.size)
    for start in range(0, s.size, _COSINE_CHUNK):
        block = s[start : start + _COSINE_CHUNK, None]
        g[start : start + _COSINE_CHUNK] = trapezoid(f * np.cos(block * x), x, axis=1) / math.pi
    return g


def angle_error_autocovariance(tau, bandwidth: float, noise_density: float) -> np.ndarray:
    """R_phi(tau) = r w_c g_phi(w_c |tau|) of the smoothed angle's error, rad^2 (module
    docstring: angle error), zero beyond w_c |tau| = KERNEL_SPAN.

    g_phi by the trapezoid rule at each lag itself (not interpolated from a grid: the motor
    work's angle term, rsp_inertia.estimation.passes, lives on the differences
    R_phi(0) - R_phi(dt), ~1e-4 of R_phi(0) at 1 kHz, which a grid's linear interpolation
    would swamp). The integrand falls like x^-12: cut at x = 8; 4,000 steps resolve
    cos(x s) to s = 40.

    Parameters
    ----------
    tau : float or array_like
        s, the lags.
    bandwidth : float
        rad/s, the smoother's w_c.
    noise_density : float
        r, rad^2 s, the readings' quantization noise density (:func:`noise_density`).

    Returns
    -------
    np.ndarray
        rad^2, R_phi at each lag, of the shape of ``tau``.
    """
    s = np.abs(np.asarray(tau, dtype=float)) * bandwidth
    x = np.linspace(0.0, 8.0, 4001)
    f = 1.0 / (1.0 + x**6) ** 2
    flat = s.reshape(-1)
    g = np.zeros(flat.size)
    inside = flat < KERNEL_SPAN
    g[inside] = _cosine_transform(f, x, flat[inside])
    return noise_density * bandwidth * g.reshape(s.shape)


def speed_error_autocovariance(tau, bandwidth: float, noise_density: float) -> np.ndarray:
    """R(tau) = r w_c^3 g(w_c |tau|) of the smoothed speed's error (module docstring).

    Parameters
    ----------
    tau : float or array_like
        s, the lags.
    bandwidth : float
        rad/s, the smoother's w_c.
    noise_density : float
        r, rad^2 s, the readings' quantization noise density (:func:`noise_density`).

    Returns
    -------
    np.ndarray
        rad^2/s^2, R at each lag, of the shape of ``tau`` (zero beyond KERNEL_SPAN / w_c).
    """
    s_grid, g = _speed_kernel()
    s = np.abs(np.asarray(tau, dtype=float)) * bandwidth
    return noise_density * bandwidth**3 * np.interp(s, s_grid, g, right=0.0)


QUANTIZATION_LINES = 200
"""Harmonics of the reading error's sawtooth summed one by one (module docstring:
quantization lines); beyond them, 1 / QUANTIZATION_LINES / (pi^2 / 6) ~ 0.3% of the power, at
the white level."""

_LINES_CHUNK = 2048
"""Instants per block of the line sum (a block is instants x QUANTIZATION_LINES values)."""


def quantization_error_variance(
    omega, quantum: float, dt: float, bandwidth: float
) -> tuple[np.ndarray, np.ndarray]:
    """Variances of the smoothed angle's and speed's errors at given speeds from the reading
    error's sawtooth lines (module docstring: quantization lines).

    Parameters
    ----------
    omega : float or array_like
        rad/s, the speeds.
    quantum : float
        rad, the encoder's count q.
    dt : float
        s, the sample period.
    bandwidth : float
        rad/s, the smoother's w_c.

    Returns
    -------
    angle : np.ndarray, rad^2
        The smoothed angle's error variance at each speed (flattened).
    speed : np.ndarray, rad^2/s^2
        The smoothed speed's.
    """
    omega = np.abs(np.asarray(omega, dtype=float)).reshape(-1)
    n = np.arange(1, QUANTIZATION_LINES + 1, dtype=float)
    power = quantum**2 / (2 * math.pi**2 * n * n)
    r = noise_density(quantum, dt)
    tail = 1.0 - float(np.sum(1.0 / (n * n))) / (math.pi**2 / 6)
    angle = np.empty(omega.size)
    speed = np.empty(omega.size)
    for start in range(0, omega.size, _LINES_CHUNK):
        v = omega[start : start + _LINES_CHUNK, None] * dt / quantum * n
        w = 2 * math.pi * np.abs(v - np.round(v)) / dt
        H = 1.0 / (1.0 + (w / bandwidth) ** 6)
        angle[start : start + _LINES_CHUNK] = (power * H * H).sum(axis=1)
        speed[start : start + _LINES_CHUNK] = (power * (w * H) ** 2).sum(axis=1)
    angle += tail * float(angle_error_autocovariance(0.0, bandwidth, r))
    speed += tail * float(speed_error_autocovariance(0.0, bandwidth, r))
    return angle, speed


def hermite(t0, t1, f0, d0, f1, d1, t):
    """Cubic Hermite interpolation on [t0, t1] with values f and derivatives d (arrays).

    Parameters
    ----------
    t0, t1 : array_like
        The interval's ends.
    f0, d0 : array_like
        Value and derivative at t0.
    f1, d1 : array_like
        Value and derivative at t1.
    t : array_like
        Where to interpolate.

    Returns
    -------
    np.ndarray
        The cubic's values at ``t`` (broadcast shape).
    """
    h = t1 - t0
    s = (t - t0) / h
    s2, s3 = s * s, s * s * s
    return (
        (2 * s3 - 3 * s2 + 1) * f0
        + (s3 - 2 * s2 + s) * h * d0
        + (-2 * s3 + 3 * s2) * f1
        + (s3 - s2) * h * d1
    )


def smooth_log(log: Log, quantum: float, source: str = "log") -> Smoothed:
    """Smoothed angle, speed and acceleration of a pass (Kalman filter forward, RTS backward;
    module docstring), reporting its progress (rsp_inertia.infra.progress) as "SOURCE:
    smoothing".

    Parameters
    ----------
    log : rsp_inertia.plant.logs.Log
        The encoder log (validated: angles on the grid; its time stamps are the sampling
        instants, which may jitter and miss samples: every step uses the true times).
    quantum : float
        Encoder count q = 2 pi / counts_per_rev, rad.
    source : str
        Name of the log for error messages and the progress line.

    Returns
    -------
    Smoothed
        States at every row of the log, with the speed's standard deviation.
    """
    n = len(log)
    if n < 4 * BLOCK:
        raise InputError(f"{source}: {n} rows are too few to smooth (at least {4 * BLOCK})")
    t = np.asarray(log.t)
    dt = median_step(t)
    q_j, bandwidth = jerk_density(log, quantum)
    block = block_length(bandwidth, dt)
    starts = block_starts(t, block, dt)
    # State k lives at the mid-time of block k's span: of its first and last readings' time
    # stamps (jittered: the true instants), and for the log's last block, when shorter, of
    # ``block`` nominal periods from its first reading.
    ends = np.append(starts[1:], n) - 1
    centres = (t[starts] + t[ends]) / 2
    if ends[-1] - starts[-1] + 1 < block:
        centres[-1] = t[starts[-1]] + (block - 1) / 2 * dt
    steps = np.diff(centres)
    variance = quantum * quantum / 12.0
    z = np.asarray(log.phi) + quantum / 2

    # Start from a least-squares fit of the first blocks' kinematics with its own covariance
    # (readings' variance times (H^T H)^-1), widened for the model's error over those blocks.
    # A fixed wide P0 spans 13 orders of magnitude on a 20-bit encoder (q^2 ~ 4e-11 against
    # 100 rad^2/s^4) and rounding then breaks its positive definiteness.
    m = min(3 * block, n)
    tau = t[:m] - centres[0]
    H = np.column_stack([np.ones(m), tau, tau**2 / 2])
    x0, *_ = np.linalg.lstsq(H, z[:m], rcond=None)
    P0 = 100.0 * variance * np.linalg.inv(H.T @ H)

    # The transition and process noise of each step between block states (one per distinct
    # step length: regular blocks share theirs).
    lengths, which = np.unique(steps, return_inverse=True)
    F_of = np.stack([_transition(T) for T in lengths])  # indexed per step, not stacked per step
    Q_of = [_process_noise(T, q_j) for T in lengths]
    readings = functools.partial(_block_readings, t, z, centres, starts, block, variance)
    task = f"{source}: smoothing"
    means, covs, predicted = _kalman_filter(x0, P0, F_of, Q_of, which, readings, task)
    xs, speed_var = _rts_smoother(means, covs, predicted, F_of, which)
    del means, covs, predicted, readings, z  # before the rows' arrays are made

    # Every sample from the block states (Hermite between neighbours, Taylor outside), in
    # chunks of rows: the interpolation's temporaries stay small whatever the log's length.
    phi, omega, eps = np.empty(n), np.empty(n), np.empty(n)
    for start in range(0, n, _ROWS_CHUNK):
        rows = slice(start, start + _ROWS_CHUNK)
        phi[rows], omega[rows], eps[rows] = _block_states_at(centres, xs, t[rows])
    omega_std = np.interp(t, centres, speed_var)
    np.sqrt(omega_std, out=omega_std)
    return Smoothed(
        t=t,
        phi=phi,
        omega=omega,
        eps=eps,
        omega_std=omega_std,
        jerk_density=q_j,
        bandwidth=bandwidth,
        noise_density=noise_density(quantum, dt),
    )


_BLOCKS_CHUNK = 4096
"""Blocks whose readings' sums, or whose smoother gains, are computed at once."""

_ROWS_CHUNK = 1 << 16
"""Rows interpolated from the block states at once (their temporaries: ~10 MB)."""


def _block_readings(
    t: np.ndarray,
    z: np.ndarray,
    centres: np.ndarray,
    starts: np.ndarray,
    block: int,
    variance: float,
    blocks: slice,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """What the readings of ``blocks`` tell about their block states, summed over each block.

    With H the readings' Taylor rows [1, tau, tau^2/2] about the block's centre (readings =
    H x), the information A = H^T H / variance, (k, 3, 3), and b = H^T (z - z_ref) / variance,
    (k, 3), taken about the block's first reading z_ref (returned, (k,)): the update then
    works on differences of a few counts, not of whole angles, and loses no digits to them.
    Block k holds the rows from ``starts[k]`` to the next block's start (at most ``block``);
    a shorter block is padded with weight 0.
    """
    k0, k1 = blocks.start, blocks.stop
    first = starts[k0:k1]
    stop = starts[k1] if k1 < starts.size else t.size
    lengths = np.diff(np.append(first, stop))
    rows = first[:, None] + np.arange(block)
    inside = np.arange(block) < lengths[:, None]
    rows = np.where(inside, rows, first[:, None])
    tau = t[rows] - centres[k0:k1, None]
    reference = z[first]
    dz = z[rows] - reference[:, None]
    weight = np.where(inside, 1.0 / variance, 0.0)
    moments = [weight.sum(axis=1)]
    power = weight
    for _ in range(4):
        power = power * tau
        moments.append(power.sum(axis=1))
    m0, m1, m2, m3, m4 = moments
    A = np.empty((k1 - k0, 3, 3))
    A[:, 0] = np.column_stack([m0, m1, m2 / 2])
    A[:, 1] = np.column_stack([m1, m2, m3 / 2])
    A[:, 2] = np.column_stack([m2 / 2, m3 / 2, m4 / 4])
    wz = weight * dz
    b = np.column_stack([wz.sum(axis=1), (wz * tau).sum(axis=1), (wz * tau * tau).sum(axis=1) / 2])
    return A, b, reference


def _kalman_filter(x0, P0, F_of, Q_of, which, readings, task):
    """The forward Kalman filter over the block states, its update in information form.

    State k's prediction (x, P~) from state k - 1 is (F x, F P F^T + Q); the update adds block
    k's readings' information (:func:`_block_readings`): P_k = (P~^-1 + A_k)^-1, computed as
    P~ (I + A_k P~)^-1 (one 3 x 3 inverse), and x_k = x + P_k (b_k - A_k (x - z_ref e_1))
    (z_ref the block's reference reading). That is the update with the block's B readings
    (the Kalman gain through their B x B innovation covariance) rearranged: it needs 3 x 3
    matrices only. The sums A_k, b_k come vectorised, _BLOCKS_CHUNK blocks at a time;
    the blocks done before each chunk are reported as ``task``'s progress
    (rsp_inertia.infra.progress.report).

    State 0 is the start (x0, P0) itself, not updated: the start is the least-squares fit of
    the first blocks' readings, block 0's among them (filterpy's UKF, which this filter
    replaced, made no update before its first prediction; its numbers are kept).

    Step k's transition and process noise are ``F_of[which[k]]`` and ``Q_of[which[k]]``
    (one per distinct step length). Returns the filtered means (n, 3), covariances (n, 3, 3)
    and the predictions' covariances P~ (n, 3, 3; the RTS gains need them; P~_0 = P0).
    """
    n = which.size + 1
    means = np.empty((n, 3))
    covs = np.empty((n, 3, 3))
    predicted = np.empty((n, 3, 3))
    inv = np.linalg.inv
    identity = np.eye(3)
    x, P = np.asarray(x0, dtype=float), P0
    for start in range(0, n, _BLOCKS_CHUNK):
        report(task, start, n)
        A, b, reference = readings(slice(start, min(start + _BLOCKS_CHUNK, n)))
        for j in range(A.shape[0]):
            k = start + j
            if k == 0:  # the start already holds block 0's readings (docstring)
                means[0], covs[0], predicted[0] = x, P, P
                continue
            Fk = F_of[which[k - 1]]
            x = Fk @ x
            P = Fk @ P @ Fk.T + Q_of[which[k - 1]]
            predicted[k] = P
            P = P @ inv(identity + A[j] @ P)
            P = (P + P.T) / 2
            shifted = x.copy()
            shifted[0] -= reference[j]
            x = x + P @ (b[j] - A[j] @ shifted)
            means[k] = x
            covs[k] = P
    report(task, n, n)
    return means, covs, predicted


def _rts_smoother(means, covs, predicted, F_of, which) -> tuple[np.ndarray, np.ndarray]:
    """The Rauch-Tung-Striebel pass backward over the filter's output: smoothed means (n, 3)
    and the smoothed speed's variance (n,).

    With the gain G_k = P_k F_k^T P~_{k+1}^-1 (P the filtered covariance, P~ the predicted),
    x^_k = x_k + G_k (x^_{k+1} - F_k x_k) and P^_k = P_k + G_k (P^_{k+1} - P~_{k+1}) G_k^T;
    as G_k P~_{k+1} G_k^T = G_k F_k P_k these are x^_k = c_k + G_k x^_{k+1} and
    P^_k = C_k + G_k P^_{k+1} G_k^T with c_k = x_k - G_k F_k x_k, C_k = P_k - G_k F_k P_k,
    computed for _BLOCKS_CHUNK steps at a time, vectorised; the loop does the recursion.
    F_k is ``F_of[which[k]]`` (one matrix per distinct step length, as in the filter).
    """
    n = means.shape[0]
    xs = np.empty((n, 3))
    speed_var = np.empty(n)
    x, P = means[-1], covs[-1]
    xs[-1] = x
    speed_var[-1] = P[1, 1]
    for stop in range(n - 1, 0, -_BLOCKS_CHUNK):
        steps = slice(max(stop - _BLOCKS_CHUNK, 0), stop)
        F = F_of[which[steps]]
        # G = P F^T P~^-1, the transpose of P~^-1 F P (P and P~ symmetric).
        FP = F @ covs[steps]
        G = np.swapaxes(np.linalg.solve(predicted[steps.start + 1 : stop + 1], FP), 1, 2)
        GF = G @ F
        c = means[steps] - (GF @ means[steps, :, None])[:, :, 0]
        C = covs[steps] - GF @ covs[steps]
        for j in range(stop - steps.start - 1, -1, -1):
            x = c[j] + G[j] @ x
            P = C[j] + G[j] @ P @ G[j].T
            xs[steps.start + j] = x
            speed_var[steps.start + j] = P[1, 1]
    return xs, speed_var


def _block_states_at(centres: np.ndarray, xs: np.ndarray, t: np.ndarray):
    """(phi, Omega, eps) at times ``t`` from the block states ``xs`` at ``centres``: cubic
    Hermite between neighbouring states (phi with its derivative Omega, Omega with eps), eps
    linear; the Taylor form of the first or last state outside them."""
    last = centres.size - 1
    k = np.clip(np.searchsorted(centres, t, side="right") - 1, 0, last - 1)
    t0, t1 = centres[k], centres[k + 1]
    a, b = xs[k], xs[k + 1]
    phi = hermite(t0, t1, a[:, 0], a[:, 1], b[:, 0], b[:, 1], t)
    omega = hermite(t0, t1, a[:, 1], a[:, 2], b[:, 1], b[:, 2], t)
    eps = a[:, 2] + (b[:, 2] - a[:, 2]) * (t - t0) / (t1 - t0)
    outside = (t < centres[0]) | (t > centres[-1])
    if np.any(outside):
        j = np.where(t < centres[0], 0, last)[outside]
        tau = t[outside] - centres[j]
        phi[outside] = xs[j, 0] + xs[j, 1] * tau + xs[j, 2] * tau**2 / 2
        omega[outside] = xs[j, 1] + xs[j, 2] * tau
        eps[outside] = xs[j, 2]
    return phi, omega, eps


# ---------------------------------------------------------------------------------------------
# Gaps of dropped samples: what bridging them costs the smoothed speed

GAP_REACH = 12.0
"""w_c x the time beyond a gap's rows within which its added covariance of the smoothed speed
is kept (:func:`gap_speed_covariance`): 8 / w_c out of a 20-sample gap on the default stage 1
the added variance is 2e-3 of the stationary one, 10 / w_c out 1e-4."""

GAP_WINDOW = 20.0
"""w_c x the time of readings beyond the reach on either side in a gap's chain
(:func:`gap_speed_covariance`): the chain's own ends' start-up has died out by e^-10 there
(the smoother's errors decay like exp(-w_c tau / 2))."""

GAP_GRID = 0.25
"""w_c x the spacing of the instants where :func:`gap_speed_excess` looks for the smoother's
largest added variance (its profile changes over about 1 / w_c)."""


@dataclass(frozen=True)
class _GapChain:
    """The block smoother's model about one gap (or none) on a regular grid of samples, in
    units of 1/w_c for time, the reading noise's density r = 1 and the jerk's q_j = 1 (r w_c^6
    in the smoother: its model in these units, whatever the log); block states scaled to
    (phi, Omega T, eps T^2), T the block's nominal step, so that the information matrix's
    entries share their magnitude."""

    centres: np.ndarray
    """The block states' times."""
    factor: np.ndarray
    """Upper banded Cholesky factor of the information matrix (scipy.linalg.cholesky_banded,
    3 states per block, 5 diagonals above the main one)."""
    readings: np.ndarray
    """(blocks, 3, 3) each block's readings' information H^T H / var (the noise part's A)."""
    scale: np.ndarray
    """(3,) the states' scales (1, T, T^2)."""
    h: float
    """w_c dt."""
    missing: int
    """Samples dropped after the sample at offset 0 (0: none)."""


@functools.lru_cache(maxsize=256)
def _gap_chain(missing: int, h: float, phase: int, whole: bool) -> _GapChain:
    """The chain of :class:`_GapChain` for a gap of ``missing`` samples after the sample at
    offset 0 (``whole``: the same grid with nothing missing), GAP_REACH + GAP_WINDOW time
    constants of readings on either side, its samples in blocks of B = block_length as
    :func:`block_starts` groups a log's (``phase``: the sample number of the row before the
    gap, modulo B).

    The information matrix is the batch form of :func:`smooth_log`'s Kalman filter and RTS
    pass: with D_k = [-F(T_k), I] on the states of blocks k, k + 1 and the readings'
    information A_k = H_k^T H_k / var per block (H_k the readings' Taylor rows about the
    block's centre, var = q^2/12 = r / dt, 1 / h in these units), Lambda = sum_k D_k^T
    Q(T_k)^-1 D_k + sum_k A_k; its inverse is the smoother's covariance.
    """
    block = block_length(1.0, h)
    side = math.ceil((GAP_REACH + GAP_WINDOW) / h)
    offsets = np.arange(-side, missing + 2 + side)
    if not whole:
        offsets = offsets[(offsets <= 0) | (offsets > missing)]
    group = (offsets + phase + block * (side // block + 1)) // block
    starts = np.append(0, np.flatnonzero(np.diff(group)) + 1)
    stops = np.append(starts[1:], offsets.size)
    times = offsets * h
    centres = (times[starts] + times[stops - 1]) / 2
    m = centres.size
    T = block * h
    scale = np.array([1.0, T, T * T])
    # Each block's readings' information H^T H / var (1 / var = h), from the moments of
    # their offsets tau from its centre (in units of T), as smooth_log's _block_readings.
    which = np.repeat(np.arange(m), stops - starts)
    tau = (times - centres[which]) / T
    m0, m1, m2, m3, m4 = (h * np.bincount(which, tau**p, minlength=m) for p in range(5))
    readings = np.empty((m, 3, 3))
    readings[:, 0] = np.column_stack([m0, m1, m2 / 2])
    readings[:, 1] = np.column_stack([m1, m2, m3 / 2])
    readings[:, 2] = np.column_stack([m2 / 2, m3 / 2, m4 / 4])
    band = np.zeros((6, 3 * m))  # upper form: band[5 + i - j, j] = Lambda[i, j], i <= j
    for j in range(3):
        for i in range(j + 1):
            band[5 + i - j, j::3] += readings[:, i, j]
    steps = np.diff(centres)
    for step in np.unique(np.round(steps / h, 6)).tolist():
        dT = step * h
        F = scale[:, None] * _transition(dT) / scale[None, :]
        Qi = np.linalg.inv(scale[:, None] * _process_noise(dT, 1.0) * scale[None, :])
        D = np.hstack([-F, np.eye(3)])
        B = D.T @ Qi @ D
        k = np.flatnonzero(np.isclose(steps / h, step, rtol=0.0, atol=1e-6))
        for i in range(6):
            for j in range(i, 6):
                band[5 + i - j, 3 * k + j] += B[i, j]
    return _GapChain(
        centres=centres,
        factor=scipy.linalg.cholesky_banded(band),
        readings=readings,
        scale=scale,
        h=h,
        missing=0 if whole else missing,
    )


def _state_rows(chain: _GapChain, x: np.ndarray, part: str):
    """(k, 3 m) dense: the smoothed speed (``part`` "omega") or acceleration ("eps") at
    times ``x`` (units of 1 / w_c) as combinations of the chain's scaled block states, as
    :func:`smooth_log` gives them at a row (cubic Hermite of Omega with eps between the
    neighbouring block states; eps linear)."""
    c = chain.centres
    a = np.clip(np.searchsorted(c, x, side="right") - 1, 0, c.size - 2)
    span = c[a + 1] - c[a]
    s = (x - c[a]) / span
    T = chain.scale[1]
    L = np.zeros((x.size, 3 * c.size))
    rows = np.arange(x.size)
    if part == "omega":
        L[rows, 3 * a + 1] = (2 * s**3 - 3 * s**2 + 1) / T
        L[rows, 3 * a + 2] = (s**3 - 2 * s**2 + s) * span / T**2
        L[rows, 3 * a + 4] = (-2 * s**3 + 3 * s**2) / T
        L[rows, 3 * a + 5] = (s**3 - s**2) * span / T**2
    else:
        L[rows, 3 * a + 2] = (1 - s) / T**2
        L[rows, 3 * a + 5] = s / T**2
    return L


def _speed_functionals(chain: _GapChain, offsets: np.ndarray) -> np.ndarray:
    """(k, 3 m): the smoothed speed at ``offsets`` (periods from the row before the gap) as
    a combination of the chain's scaled block states, as the estimates take it
    (rsp_inertia.estimation.passes.PassEstimate.sample_at): between rows, which are as dense
    as the samples, the block states' Hermite itself; across the gap, the cubic Hermite
    between the gap's two rows with their speeds and accelerations."""
    h, n = chain.h, chain.missing
    u = np.asarray(offsets, dtype=float)
    L = _state_rows(chain, u * h, "omega")
    inside = (u > 0) & (u < n + 1) if n else np.zeros(u.size, dtype=bool)
    if np.any(inside):
        edges = np.array([0.0, (n + 1) * h])
        omega = _state_rows(chain, edges, "omega")
        eps = _state_rows(chain, edges, "eps")
        s = u[inside] / (n + 1)
        G = (n + 1) * h
        L[inside] = (
            np.outer(2 * s**3 - 3 * s**2 + 1, omega[0])
            + np.outer((s**3 - 2 * s**2 + s) * G, eps[0])
            + np.outer(-2 * s**3 + 3 * s**2, omega[1])
            + np.outer((s**3 - s**2) * G, eps[1])
        )
    return L


def _chain_speed_covariance(
    chain: _GapChain, offsets: np.ndarray, model_only: bool = False
) -> tuple[np.ndarray | None, np.ndarray]:
    """(noise, model): the covariance of the smoothed speed's error at ``offsets`` from the
    readings' white noise alone, L Lambda^-1 A Lambda^-1 L^T (A the readings' information),
    and the model's own, L Lambda^-1 L^T, in units of r w_c^3; ``model_only``: (None, the
    model's variances alone)."""
    L = _speed_functionals(chain, offsets)
    Y = scipy.linalg.cho_solve_banded((chain.factor, False), L.T)
    if model_only:
        return None, np.einsum("ij,ji->i", L, Y)
    m = chain.centres.size
    AY = np.einsum("kab,kbj->kaj", chain.readings, Y.reshape(m, 3, -1)).reshape(3 * m, -1)
    return Y.T @ AY, L @ Y


def gap_speed_covariance(
    missing: int, h: float, offsets: np.ndarray, phase: int = 0
) -> tuple[np.ndarray, np.ndarray]:
    """What a gap of ``missing`` dropped samples adds to the covariance of the smoothed
    speed's error at given instants near it, in units of r w_c^3.

    The smoother's model (module docstring) over a regular grid of samples about the gap,
    GAP_REACH + GAP_WINDOW time constants of readings on either side, in blocks as
    :func:`smooth_log` takes a log's, in its batch form: its information matrix Lambda (the
    Kalman filter and RTS pass compute its inverse's blocks), A its readings' part. Over the
    gap the smoother carries its state from the readings on either side, and the speed at an
    instant there is the cubic Hermite between the gap's two rows
    (rsp_inertia.estimation.passes.PassEstimate.sample_at). Two covariances, each that of
    the grid with the gap minus that of the same grid whole:

    - noise: the readings' white noise passed through the smoother, L Lambda^-1 A Lambda^-1
      L^T, L the speed's rows at the instants: what the speed's error actually is for a
      smooth motion (r w_c^3 / 12 stationary: the derived R(0)); the balances take it
      (rsp_inertia.estimation.balance);
    - model: the smoother's own covariance L Lambda^-1 L^T, which adds a random jerk's
      motion over the gap (r w_c^3 / 6 stationary): its own uncertainty of what the motion
      did where it has no reading, the measure of whether to bridge the gap at all
      (:func:`gap_speed_excess`).

    Parameters
    ----------
    missing : int
        Samples dropped in a row (>= 1).
    h : float
        w_c dt, the smoother's bandwidth times the sample period.
    offsets : np.ndarray, shape (k,)
        The instants, in periods from the row before the gap (the row after it is at
        missing + 1).
    phase : int
        The sample number of the row before the gap modulo the smoother's block length
        (:func:`block_starts`; 0 to B - 1).

    Returns
    -------
    noise, model : np.ndarray, shape (k, k)
        The added covariances, r w_c^3 (rsp_inertia.estimation.smoothing.noise_density r).

    Examples
    --------
    Five samples dropped on the default stage 1 (w_c = 240 rad/s at 1 kHz): the speed's
    error 2 / w_c past the gap grows by about a fifth of its stationary variance 1/12:

    >>> noise, model = gap_speed_covariance(5, 0.24, np.array([-100.0, 14.0]))
    >>> bool(abs(noise[0, 0]) < 1e-6), bool(0.005 < noise[1, 1] < 0.03)
    (True, True)
    """
    offsets = np.asarray(offsets, dtype=float)
    phase %= block_length(1.0, h)
    gap = _chain_speed_covariance(_gap_chain(missing, h, phase, False), offsets)
    whole = _chain_speed_covariance(_gap_chain(missing, h, phase, True), offsets)
    return gap[0] - whole[0], gap[1] - whole[1]


@functools.lru_cache(maxsize=64)
def gap_speed_excess(missing: int, h: float) -> float:
    """The smoother's own largest added variance of the speed over a gap of ``missing``
    dropped samples (:func:`gap_speed_covariance`, model), over its stationary variance
    r w_c^3 / 6: at instants GAP_GRID / w_c apart from GAP_REACH / w_c before the gap to as
    far after it, the largest over the gap's places in the smoother's blocks.

    Parameters
    ----------
    missing : int
        Samples dropped in a row (>= 1).
    h : float
        w_c dt.

    Returns
    -------
    float
        The ratio (0 for no gap).
    """
    if missing < 1:
        return 0.0
    reach = GAP_REACH / h
    offsets = np.arange(-reach, missing + 1 + reach, GAP_GRID / h)
    worst = 0.0
    for phase in range(block_length(1.0, h)):
        _, gap = _chain_speed_covariance(_gap_chain(missing, h, phase, False), offsets, True)
        _, whole = _chain_speed_covariance(_gap_chain(missing, h, phase, True), offsets, True)
        worst = max(worst, float(np.max(gap - whole)) * 6.0)
    return worst


def largest_bridged_gap(h: float, allowance: float, limit: int = 10_000) -> int:
    """The most samples a gap may miss in a row for :func:`gap_speed_excess` to stay within
    ``allowance`` (it grows with the gap).

    Parameters
    ----------
    h : float
        w_c dt.
    allowance : float
        The largest ratio accepted.
    limit : int
        Searched up to this many samples.

    Returns
    -------
    int
        Samples, 0 when not even one may be missing.
    """
    if gap_speed_excess(1, h) > allowance:
        return 0
    lo, hi = 1, 2
    while hi <= limit and gap_speed_excess(hi, h) <= allowance:
        lo, hi = hi, 2 * hi
    if hi > limit:
        return limit
    while hi - lo > 1:
        mid = (lo + hi) // 2
        lo, hi = (mid, hi) if gap_speed_excess(mid, h) <= allowance else (lo, mid)
    return lo
