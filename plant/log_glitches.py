"""Glitches in a log: isolated rows whose angle or torque disagrees with their neighbours
(docs/files.md, Logs, *A glitch*).

A logger may corrupt a single row (a bit flipped on a serial link, a framing error, a torque
read in the middle of its update): its angle a few tens of counts off, or its torque many
times the braking's. Such a row passes every check of the file's format, yet the balances
take it as real motion or real work (one braking torque x20 moves the default Jx by 1.8 of
its std). :func:`find_glitches` finds them, each by one of two tests on the row against its
neighbours, each with a local robust scale, so that no genuine log trips them:

- **angle**: the reading against a cubic in time fitted to the 4 rows on each side
  (leave-one-out, the true time stamps: jitter and dropped rows are taken as they are).
  Its residual r is compared with T_ANGLE = :data:`ANGLE_THRESHOLD` times the largest of:
  the quantization's own std of that residual, (1 + sum w_j^2)^(1/2) q / sqrt(12) (w the
  fit's weights), the neighbours' scatter about their own fit (a row among neighbours that
  disagree with each other, such as a held body's dithering reading, is no isolated
  glitch), and the residuals' robust scale (1.4826 x their median absolute value) over the
  :data:`SCALE_BLOCK` rows around it (an interpolating readhead's noise). An encoder whose
  readings are floor(phi / q) q puts at most (1 + sum |w_j|) q / 2 into r, which is below
  10 x that std for any weights (sum |w_j| <= sqrt(8) |w|): quantization alone never
  trips the test, whatever the speed, the jitter or the gaps.
- **torque**: the torque against the interval its two neighbours span. A row between them
  is no glitch (a step, a ramp: a pilot's switch-off, the hold torque, the rate-limited
  start of a reverse, the regulator's step at each count); a glitch lies outside it by r.
  r is compared with T_TORQUE = :data:`TORQUE_THRESHOLD` times the torque's robust
  sample-to-sample scale (1.4826 x the median absolute change over sqrt 2) over the
  :data:`SCALE_BLOCK` rows around it: the logging noise on a braking, the regulator's
  response to the counts on a closed-loop reverse (k_phi q, hundreds of times the noise on
  a coarse encoder). For white Gaussian noise of std sigma, r > T sigma needs the row to
  exceed both neighbours by T sigma, probability at most 2 Q(T / sqrt 2) = 1.5e-12 per row
  at T = 10: under 1e-6 per log of 300,000 rows (30 s at 10 kHz, the longest logs).

The scales are the largest over the row's block and the blocks on either side (a row near
a noisier stretch takes its scale), so a scale that happens to come out low needs all three
blocks low (about 1e-3 each for 30% low from 128 rows; 1e-9 together). Rows without
neighbours on both sides (the first and last :data:`ANGLE_NEIGHBOURS` rows for the angle,
the first and last row for the torque) are not tested: a glitch there is not told from the
start or the end of the motion. Nor is a log shorter than :data:`MIN_ROWS`, too short to set
its scales.

Measured on the virtual device's logs (docs/method.md §5, *Glitches*): every kind of log
(braking, ideal and closed-loop reverse, pilot, pendulum), 10- to 16-bit encoders at 1 and
10 kHz, jittered, with dropped rows, a held braking's dither (up to 30 counts) and
backlash, up to 416,000 rows: no glitch; the largest statistic r / scale was 3.3 for the
angle and 5.2 for the torque (the Gaussian maximum over 10^5 rows), against 10. One
corrupted row in the default logs (benchmarks/glitches.py): named in 20 of 20 seeds.

Too many: more than :data:`MAX_GLITCHES` in one log is refused (InputError), naming the
first few lines: isolated corruptions are rare events; a log with many has a faulty logger
or channel, whose other rows cannot be trusted either.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from rsp_inertia.infra.errors import InputError
from rsp_inertia.plant.log_checks import EncoderLike, Rows

__all__ = [
    "ANGLE_NEIGHBOURS",
    "ANGLE_THRESHOLD",
    "MAX_GLITCHES",
    "MIN_ROWS",
    "SCALE_BLOCK",
    "TORQUE_RESOLUTION",
    "TORQUE_THRESHOLD",
    "Glitches",
    "angle_residuals",
    "find_glitches",
    "torque_residuals",
]

ANGLE_NEIGHBOURS = 4
"""Rows on each side of a row to which its angle test fits a cubic in time (4 parameters,
8 rows: 4 degrees of freedom for the neighbours' own scatter)."""

ANGLE_THRESHOLD = 10.0
"""T_ANGLE: a row's angle is a glitch when it is off the neighbours' cubic by more than this
many times its scale (module docstring): quantization alone stays below (1 + sqrt(8) |w|) / 2
counts, under 10 x its std for any weights."""

TORQUE_THRESHOLD = 10.0
"""T_TORQUE: a row's torque is a glitch when it lies outside its neighbours' interval by more
than this many times the torque's local scale: 2 Q(T / sqrt 2) = 1.5e-12 per row for white
Gaussian noise (module docstring)."""

SCALE_BLOCK = 128
"""Rows per block of the local robust scales (the largest over a row's block and the two
next to it is its scale): long enough for a median of 30% precision at worst 1e-3, short
enough to follow a reverse whose regulator works harder where it goes faster."""

TORQUE_RESOLUTION = 1e-9
"""The torque scale's floor, relative to the log's largest |torque|: below any drive's
resolution and far above the rounding of a printed float, so that a torque computed
exactly (a noise-free simulation) is no glitch where it wiggles by the last digit."""

MAX_GLITCHES = 5
"""Glitches one log may have; more are refused. A healthy logger corrupts a row rarely
(a serial link's bit errors: one in 10^5 rows would be a bad link): a few per log are
isolated events, left out at the cost of a dropped sample each; more mean a faulty logger
or channel, whose other rows are suspect too."""

MIN_ROWS = 2 * SCALE_BLOCK
"""Rows a log needs for its glitches to be looked for (a quarter second at 1 kHz; every
pass of a rig is longer): the scales are medians over blocks of :data:`SCALE_BLOCK`."""

NAMED = 3
"""Lines named when too many glitches are refused."""


@dataclass(frozen=True)
class Glitches:
    """The rows of a log that :func:`find_glitches` found inconsistent with their
    neighbours."""

    rows: np.ndarray
    """int, shape (g,), 0-based data rows of the log, increasing."""
    warnings: tuple[str, ...]
    """One line per glitch naming the file, its line and what was wrong."""

    def keep(self, n: int) -> np.ndarray:
        """bool, shape (n,): the rows of an ``n``-row log to keep (False at a glitch)."""
        mask = np.ones(n, dtype=bool)
        mask[self.rows] = False
        return mask


def find_glitches(
    rows: Rows,
    t: np.ndarray,
    phi: np.ndarray,
    torque: np.ndarray,
    encoder: EncoderLike,
) -> Glitches:
    """The isolated rows whose angle or torque is inconsistent with their neighbours beyond
    the encoder's quantization and noise and the torque's noise (module docstring).

    Parameters
    ----------
    rows : Rows
        Where the log's data rows are in its file, for the messages.
    t : np.ndarray, shape (n,), s
        Time stamps, strictly increasing (rsp_inertia.plant.log_checks.check_time first).
    phi : np.ndarray, shape (n,), rad
        The angle on the encoder grid, unwrapped.
    torque : np.ndarray, shape (n,), N m
        The logged torque.
    encoder : encoder-like
        ``quantum`` (rad) and ``sample_rate`` (Hz).

    Returns
    -------
    Glitches
        The rows to leave out and a warning for each (none in a log shorter than
        :data:`MIN_ROWS`).

    Raises
    ------
    InputError
        More than :data:`MAX_GLITCHES`, naming the first :data:`NAMED` lines.
    """
    if len(t) < MIN_ROWS:
        return Glitches(rows=np.zeros(0, dtype=np.int64), warnings=())
    q = float(encoder.quantum)
    rate = float(encoder.sample_rate)
    with np.errstate(over="ignore", invalid="ignore"):  # torques near 1e308 overflow a change
        angle = _AngleTest(t, phi, q, rate)
        torque_test = _TorqueTest(torque)
        bad = np.zeros(len(t), dtype=bool)
        for start in range(0, len(t), _BLOCK):  # a block of rows at a time: bounded memory
            stop = min(start + _BLOCK, len(t))
            r, scale = angle.at(start, stop)
            bad[start:stop] = np.abs(r) > ANGLE_THRESHOLD * scale
            r, scale = torque_test.at(start, stop)
            bad[start:stop] |= r > TORQUE_THRESHOLD * scale
    found = np.flatnonzero(bad)
    if found.size > MAX_GLITCHES:
        lines = ", ".join(rows.at(int(k)).rpartition(", ")[2] for k in found[:NAMED])
        raise InputError(
            f"{rows.at(int(found[0]))}: {found.size} rows whose angle or torque disagrees with "
            f"their neighbours ({lines}, ...): more than {MAX_GLITCHES} glitches in one log "
            "is a faulty logger or channel, not isolated corruptions (docs/files.md, Logs)"
        )
    digits = max(0, math.ceil(-math.log10(q / 10)))  # angles to a tenth of a count
    warnings = []
    for k in found.tolist():
        what = []
        r_a, s_a = (float(v[0]) for v in angle.at(k, k + 1))
        r_t, s_t = (float(v[0]) for v in torque_test.at(k, k + 1))
        if abs(r_a) > ANGLE_THRESHOLD * s_a:
            what.append(
                f"phi {float(phi[k]):.{digits}f} rad where its neighbours give "
                f"{float(phi[k]) - r_a * q:.{digits}f} +- {s_a * q:.2g} rad "
                f"({r_a:+.0f} counts)"
            )
        if r_t > TORQUE_THRESHOLD * s_t:
            what.append(
                f"torque {float(torque[k]):.4g} N m where its neighbours give "
                f"{_interval(torque[k - 1], torque[k + 1])} +- {s_t:.2g} N m"
            )
        warnings.append(
            f"{rows.at(k)}: a glitch, {' and '.join(what)}: the row is left out (a dropped "
            "sample)"
        )
    return Glitches(rows=found, warnings=tuple(warnings))


def _interval(before: float, after: float) -> str:
    """The neighbours' torques, low to high, one number when they agree to 4 digits."""
    a, b = f"{min(before, after):.4g}", f"{max(before, after):.4g}"
    return a if a == b else f"{a} to {b}"


def angle_residuals(
    t: np.ndarray, phi: np.ndarray, quantum: float, sample_rate: float
) -> tuple[np.ndarray, np.ndarray]:
    """Each row's angle against a cubic in time through its :data:`ANGLE_NEIGHBOURS` rows on
    either side, in counts, and the scale it is tested against (module docstring).

    Parameters
    ----------
    t : np.ndarray, shape (n,), s
        Time stamps, strictly increasing.
    phi : np.ndarray, shape (n,), rad
        Angle on the encoder grid.
    quantum : float
        rad, one count.
    sample_rate : float
        Hz.

    Returns
    -------
    r : np.ndarray, shape (n,)
        Counts, the reading minus the neighbours' cubic at its time; 0 where untested.
    scale : np.ndarray, shape (n,)
        Counts, the largest of the quantization's std of r, the neighbours' scatter about
        their cubic and the block's robust scale of r; inf where untested.
    """
    return _AngleTest(t, phi, quantum, sample_rate).at(0, len(t))


def _loo_cubic(
    t: np.ndarray,
    phi: np.ndarray,
    start: int,
    stop: int,
    offsets: list[int],
    quantum: float,
    sample_rate: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For rows ``start`` to ``stop``: the cubic in time through the rows at ``offsets`` from
    each, evaluated at the row (counts from its own reading), the sum of its weights' squares
    and the neighbours' squared residuals about it.

    Least squares by its normal equations G c = b, G = sum a_j a_j^T, a_j = (1, x, x^2, x^3)
    at x_j = tau_j / max |tau| (in [-1, 1]: well conditioned), b = sum a_j y_j, each row's 4 x
    4 Cholesky factor L written out over the arrays (no per-row solve). With v = L^-1 e_0 and
    z = L^-1 b: the value at x = 0 is c_0 = v . z, the weights' squares sum to
    e_0^T G^-1 e_0 = |v|^2, and the residuals' squares to sum y^2 - |z|^2.
    """
    tk, pk = t[start:stop], phi[start:stop]
    taus = [(t[start + o : stop + o] - tk) * sample_rate for o in offsets]
    span = np.maximum(np.abs(taus[0]), np.abs(taus[-1]))  # the farthest neighbours
    S = [np.zeros(stop - start) for _ in range(7)]  # sum x^p, p = 0..6
    b = [np.zeros(stop - start) for _ in range(4)]  # sum x^p y, p = 0..3
    yy = np.zeros(stop - start)
    for o, tau in zip(offsets, taus):
        x = tau / span
        y = (phi[start + o : stop + o] - pk) / quantum
        power = np.ones_like(x)
        for d in range(7):
            S[d] += power
            if d < 4:
                b[d] += power * y
            power *= x
        yy += y * y
    l00 = np.sqrt(S[0])
    l10, l20, l30 = S[1] / l00, S[2] / l00, S[3] / l00
    l11 = np.sqrt(S[2] - l10**2)
    l21, l31 = (S[3] - l20 * l10) / l11, (S[4] - l30 * l10) / l11
    l22 = np.sqrt(S[4] - l20**2 - l21**2)
    l32 = (S[5] - l30 * l20 - l31 * l21) / l22
    l33 = np.sqrt(S[6] - l30**2 - l31**2 - l32**2)
    v0 = 1.0 / l00
    v1 = -l10 * v0 / l11
    v2 = -(l20 * v0 + l21 * v1) / l22
    v3 = -(l30 * v0 + l31 * v1 + l32 * v2) / l33
    z0 = b[0] / l00
    z1 = (b[1] - l10 * z0) / l11
    z2 = (b[2] - l20 * z0 - l21 * z1) / l22
    z3 = (b[3] - l30 * z0 - l31 * z1 - l32 * z2) / l33
    value = v0 * z0 + v1 * z1 + v2 * z2 + v3 * z3
    squares = v0**2 + v1**2 + v2**2 + v3**2
    residual = np.maximum(yy - z0**2 - z1**2 - z2**2 - z3**2, 0.0)
    return value, squares, residual


def torque_residuals(torque: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each row's torque outside the interval its two neighbours span, and the local scale it
    is tested against (module docstring).

    Parameters
    ----------
    torque : np.ndarray, shape (n,), N m
        The logged torque.

    Returns
    -------
    r : np.ndarray, shape (n,), N m
        The distance from the neighbours' interval (0 inside it, and at the first and last
        rows).
    scale : np.ndarray, shape (n,), N m
        The block's robust scale of the sample-to-sample changes over sqrt 2, at least
        :data:`TORQUE_RESOLUTION` of the largest |torque|; inf at the first and last rows.
    """
    return _TorqueTest(np.asarray(torque, dtype=float)).at(0, len(torque))


class _AngleTest:
    """:func:`angle_residuals` kept lean for a long log: each tested row's residual and the
    larger of its own two scales (quantization, the neighbours' scatter), 16 bytes a row, and
    the blocks' robust scales; :meth:`at` gives any rows' residual and scale."""

    def __init__(self, t: np.ndarray, phi: np.ndarray, quantum: float, sample_rate: float):
        n = len(t)
        m = ANGLE_NEIGHBOURS
        self.n, self.m = n, m
        self.r = np.zeros(n)
        self.own = np.full(n, np.inf)
        self.widest = np.zeros(0)
        if n < 2 * m + 1:
            return
        offsets = [*range(-m, 0), *range(1, m + 1)]
        for start in range(m, n - m, _BLOCK):
            stop = min(start + _BLOCK, n - m)
            value, squares, residual = _loo_cubic(t, phi, start, stop, offsets, quantum,
                                                  sample_rate)
            self.r[start:stop] = -value  # row k's reading is 0 counts from itself
            np.maximum(np.sqrt((1.0 + squares) / 12.0), np.sqrt(residual / (2 * m - 4)),
                       out=self.own[start:stop])
        tested = self.r[m : n - m]
        size = n - 2 * m
        self.widest = _widest(_medians(lambda a, b: 1.4826 * np.abs(tested[a:b]), size), size)

    def at(self, start: int, stop: int) -> tuple[np.ndarray, np.ndarray]:
        """Rows ``start`` to ``stop``: the residual (counts; 0 where untested) and its scale
        (inf where untested)."""
        r = self.r[start:stop].copy()
        scale = self.own[start:stop].copy()
        k = np.arange(start, stop)
        tested = (k >= self.m) & (k < self.n - self.m)
        local = self.widest[(k[tested] - self.m) // SCALE_BLOCK]
        scale[tested] = np.maximum(scale[tested], local)
        return r, scale


class _TorqueTest:
    """:func:`torque_residuals` kept lean for a long log: the blocks' robust scales of the
    sample-to-sample changes and the floor; :meth:`at` gives any rows' distance from their
    neighbours' interval and its scale from the torque itself."""

    def __init__(self, torque: np.ndarray):
        self.torque = torque
        n = len(torque)
        self.n = n
        self.widest = np.zeros(0)
        self.floor = 0.0
        if n < 3:
            return

        def changes(a: int, b: int) -> np.ndarray:  # the robust scale's entries a to b
            return 1.4826 / math.sqrt(2.0) * np.abs(np.diff(torque[a : b + 1]))

        self.widest = _widest(_medians(changes, n - 1), n - 1)
        self.floor = TORQUE_RESOLUTION * float(np.max(np.abs(torque)))

    def at(self, start: int, stop: int) -> tuple[np.ndarray, np.ndarray]:
        """Rows ``start`` to ``stop``: the distance from the neighbours' interval (N m; 0
        at the first and last rows) and its scale (inf there)."""
        u, n = self.torque, self.n
        r = np.zeros(stop - start)
        scale = np.full(stop - start, np.inf)
        a, b = max(start, 1), min(stop, n - 1)  # the rows with both neighbours
        if a >= b:
            return r, scale
        before, after, own = u[a - 1 : b - 1], u[a + 1 : b + 1], u[a:b]
        low = np.minimum(before, after) - own  # below both neighbours by this
        high = own - np.maximum(before, after)  # above both by this
        r[a - start : b - start] = np.maximum(np.maximum(low, high), 0.0)
        # the change into row k (index k - 1) and out of it (k) both belong to its blocks
        k = np.arange(a, b)
        inner = np.maximum(self.widest[(k - 1) // SCALE_BLOCK], self.widest[k // SCALE_BLOCK])
        scale[a - start : b - start] = np.maximum(inner, self.floor)
        return r, scale


def _medians(values: Callable[[int, int], np.ndarray], size: int) -> np.ndarray:
    """The median over each block of :data:`SCALE_BLOCK` entries of an array of ``size``
    entries, ``values(a, b)`` giving entries a to b: whole blocks a chunk at a time, the last
    block possibly short."""
    whole = size // SCALE_BLOCK
    out = np.empty(whole + (1 if size % SCALE_BLOCK else 0))
    chunk = _BLOCK // SCALE_BLOCK * SCALE_BLOCK
    for a in range(0, whole * SCALE_BLOCK, chunk):
        b = min(a + chunk, whole * SCALE_BLOCK)
        block = values(a, b).reshape(-1, SCALE_BLOCK)
        out[a // SCALE_BLOCK : b // SCALE_BLOCK] = np.median(block, axis=1)
    if size % SCALE_BLOCK:
        out[-1] = np.median(values(whole * SCALE_BLOCK, size))
    return out


def _widest(medians: np.ndarray, size: int) -> np.ndarray:
    """Per block of an array of ``size`` entries, the largest of its median and its
    neighbours' (a short last block, under half a block, takes its neighbour's too)."""
    medians = medians.copy()
    if medians.size == 0:
        return medians
    short = size % SCALE_BLOCK
    if medians.size > 1 and short and short < SCALE_BLOCK // 2:
        medians[-1] = max(medians[-1], medians[-2])
    padded = np.concatenate([medians[:1], medians, medians[-1:]])
    return np.maximum(np.maximum(padded[:-2], padded[1:-1]), padded[2:])


_BLOCK = 1 << 14
"""Rows fitted or tested at a time (a whole number of :data:`SCALE_BLOCK`): the memory of the
search does not grow with the log beyond 16 bytes a row."""
