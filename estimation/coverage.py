"""GUM statements of a tensor result: expanded uncertainties (JCGM 100) and the principal
moments' and axes' coverage intervals by Monte Carlo (JCGM 101), docs/method.md §5
"Expanded uncertainty and coverage intervals".

The tensor's entries and the centre of mass are the estimates themselves (or linear in
them), so their expanded uncertainty is ``U = k u`` exactly. The principal moments and axes
are nonlinear in the entries: their coverage intervals come from draws of the entries'
joint Gaussian distribution (JCGM 101 §6.4.8), as many as the adaptive procedure of
JCGM 101 §7.9 needs, and are compared with the first-order ones (JCGM 101 §8).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from statistics import NormalDist

import numpy as np

from rsp_inertia.infra.errors import InputError
from rsp_inertia.plant.geometry import (
    ENTRY_KEYS,
    bilinear_gradient,
    principal,
    principal_uncertainty,
    tensor_from_entries,
)

__all__ = [
    "DEFAULT_COVERAGE_FACTOR",
    "DEFAULT_SEED",
    "ExpandedUncertainty",
    "PrincipalIntervals",
    "check_coverage_factor",
    "coverage_probability",
    "expanded_uncertainty",
    "linearised_tilt_quantile",
    "numerical_tolerance",
    "principal_determined",
    "principal_monte_carlo",
]

DEFAULT_COVERAGE_FACTOR = 2.0
"""k of ``U = k u`` unless the user sets another (JCGM 100 §6.3.3: k = 2 is the norm)."""

DEFAULT_SEED = 101
"""Seed of the Monte Carlo's draws (numpy's default generator, PCG64): the same result gives
the same intervals."""

SIGNIFICANT_DIGITS = 2
"""n_dig of JCGM 101 §7.9.2: the digits of a standard uncertainty held meaningful; the Monte
Carlo runs until its results are stable to half a unit of the last of them."""

MIN_BATCH = 10_000
"""JCGM 101 §7.9.4 b): a batch holds at least 10^4 draws (and at least 100 / (1 - p))."""

MAX_DRAWS = 2_000_000
"""Draws after which the Monte Carlo stops even unstabilised (a k far above 3 needs more
than this for its tails; ``monte_carlo.converged`` then says false)."""

NEAR_EQUAL_STDS = 3.0
"""Two principal moments closer than this many stds of their difference leave their axes
undetermined (the issue's criterion)."""


def coverage_probability(k: float) -> float:
    """The coverage probability of ``y +- k u`` for a normal distribution, erf(k / sqrt 2)
    (JCGM 100 §G.1.3, table G.1: k = 2 gives 0.9545).

    Parameters
    ----------
    k : float
        The coverage factor, > 0.

    Returns
    -------
    float
        p in (0, 1).
    """
    return math.erf(k / math.sqrt(2.0))


def check_coverage_factor(
    k: object, setting: str = "the coverage factor (identify --coverage-factor K, coverage_factor=K)"
) -> float:
    """``k`` as a float, or an InputError naming ``setting`` when it is not a finite number
    above 0.

    Parameters
    ----------
    k : object
        The coverage factor as given.
    setting : str, optional
        How the user gives it, named in the error (default: the command line's option and
        the API's argument).

    Returns
    -------
    float
        k.

    Raises
    ------
    InputError
        k is not a number, not finite, or not above 0.
    """
    try:
        value = float(k)
    except (TypeError, ValueError):
        value = math.nan
    if isinstance(k, bool) or not math.isfinite(value) or value <= 0.0:
        raise InputError(
            f"{setting} = {k!r}: k must be a finite number above 0 (k = 2, the default, gives "
            "a coverage probability of about 95 %); nothing was written"
        )
    return value


def numerical_tolerance(u: float, digits: int = SIGNIFICANT_DIGITS) -> float:
    """JCGM 101 §7.9.2: ``u`` written with ``digits`` significant digits as c x 10^l, the
    tolerance is 10^l / 2 (0 for u = 0).

    Parameters
    ----------
    u : float
        A standard uncertainty, >= 0.
    digits : int, optional
        Its significant digits.

    Returns
    -------
    float
        delta, in u's unit.
    """
    if not u > 0.0:
        return 0.0
    exponent = math.floor(math.log10(u)) - (digits - 1)
    if round(u / 10.0**exponent) >= 10**digits:  # u rounds up to one more digit
        exponent += 1
    return 0.5 * 10.0**exponent


def principal_determined(
    entries: np.ndarray, cov: np.ndarray, stds: float = NEAR_EQUAL_STDS
) -> np.ndarray:
    """Whether each principal axis is determined: its moment differs from every other one by
    more than ``stds`` standard deviations of their difference.

    The difference I_j - I_i of two principal moments moves, to first order, by
    (v_j v_j^T - v_i v_i^T) : dJ, so its variance is (g_j - g_i)^T cov (g_j - g_i) with g_i the
    gradient of I_i in the six entries (rsp_inertia.plant.geometry.principal_uncertainty).

    Parameters
    ----------
    entries : numpy.ndarray, shape (6,)
        kg m^2, ``[Jx, Jy, Jz, Jxy, Jyz, Jxz]``.
    cov : numpy.ndarray, shape (6, 6)
        kg^2 m^4.
    stds : float, optional
        The criterion, in stds of the difference.

    Returns
    -------
    numpy.ndarray of bool, shape (3,)
        In the order of the ascending moments.
    """
    moments, vectors = principal(entries)
    gradients = [bilinear_gradient(v, v) for v in vectors]
    determined = np.ones(3, dtype=bool)
    for i in range(3):
        for j in range(i + 1, 3):
            g = gradients[j] - gradients[i]
            std = math.sqrt(max(float(g @ cov @ g), 0.0))
            if abs(moments[j] - moments[i]) <= stds * std:
                determined[i] = determined[j] = False
    return determined


def linearised_tilt_quantile(
    entries: np.ndarray, cov: np.ndarray, p: float
) -> np.ndarray:
    """The tilt of each principal axis not exceeded with probability ``p``, to first order.

    Axis i tilts towards axis j by t_j = (v_j^T dJ v_i) / (I_i - I_j) (docs/method.md §5), a
    linear function of the entries, so the two tilts are jointly Gaussian with covariance
    C = A cov A^T; the tilt angle is |t|. With sigma_1, sigma_2 the standard deviations along
    C's principal directions, P(|t| <= r) = 1 / (2 pi sigma_1 sigma_2) integral over psi of
    (1 - exp(-r^2 q / 2)) / q, q = cos^2 psi / sigma_1^2 + sin^2 psi / sigma_2^2 (a periodic
    integrand: the trapezoid rule is exact to rounding), solved for r by bisection.

    Parameters
    ----------
    entries : numpy.ndarray, shape (6,)
        kg m^2.
    cov : numpy.ndarray, shape (6, 6)
        kg^2 m^4.
    p : float
        The coverage probability.

    Returns
    -------
    numpy.ndarray, shape (3,)
        rad; infinite for an axis whose moment equals another's.
    """
    moments, vectors = principal(entries)
    out = np.empty(3)
    for i in range(3):
        rows = []
        for j in range(3):
            if j == i:
                continue
            gap = moments[i] - moments[j]
            h = bilinear_gradient(vectors[j], vectors[i])
            if gap == 0.0:
                rows = None
                break
            rows.append(h / gap)
        if rows is None:
            out[i] = math.inf
            continue
        a = np.array(rows)
        sigma2 = np.sort(np.clip(np.linalg.eigvalsh(a @ cov @ a.T), 0.0, None))[::-1]
        out[i] = _rayleigh_quantile(np.sqrt(sigma2), p)
    return out


def _rayleigh_quantile(sigma: np.ndarray, p: float) -> float:
    """r with P(|x| <= r) = p for x ~ N(0, diag(sigma^2)) in the plane, sigma descending."""
    s1, s2 = float(sigma[0]), float(sigma[1])
    if s1 == 0.0:
        return 0.0
    if p >= 1.0:  # k beyond 8.3: p is 1 in double precision
        return math.inf
    if s2 <= 1e-9 * s1:  # one-dimensional: |x_1| <= r
        return s1 * NormalDist().inv_cdf(0.5 + p / 2.0)
    psi = np.linspace(0.0, 2.0 * np.pi, 512, endpoint=False)
    q = np.cos(psi) ** 2 / s1**2 + np.sin(psi) ** 2 / s2**2

    def probability(r: float) -> float:
        return float(np.mean(-np.expm1(-0.5 * r**2 * q) / q)) / (s1 * s2)

    low, high = 0.0, s1 * math.sqrt(-2.0 * math.log1p(-p)) * 1.01
    for _ in range(100):
        mid = 0.5 * (low + high)
        low, high = (mid, high) if probability(mid) < p else (low, mid)
    return 0.5 * (low + high)


@dataclass(frozen=True)
class PrincipalIntervals:
    """The principal moments' and axes' coverage intervals from the adaptive Monte Carlo
    (:func:`principal_monte_carlo`); moments in kg m^2, tilts in degrees (the unit they are
    reported and held to their digits in), ascending moments' order."""

    p: float
    """The coverage probability."""
    moments_low: np.ndarray
    """(3,) lower ends of the probabilistically symmetric intervals (the (1 - p) / 2
    quantiles of the draws, JCGM 101 §7.7.1)."""
    moments_high: np.ndarray
    """(3,) their upper ends (the (1 + p) / 2 quantiles)."""
    moments_mean: np.ndarray
    """(3,) mean of the drawn moments."""
    moments_std: np.ndarray
    """(3,) their standard deviation (the moments' standard uncertainty by Monte Carlo)."""
    tilt: np.ndarray
    """(3,) the tilt not exceeded with probability p: the p quantile of the angle between a
    drawn axis and the estimated one (sign aside), deg; NaN for an axis not determined."""
    tilt_std: np.ndarray
    """(3,) the standard deviation of the drawn tilts, deg; NaN for an axis not determined."""
    determined: np.ndarray
    """(3,) bool: the axis is determined (:func:`principal_determined`)."""
    tolerance_moments: np.ndarray
    """(3,) the numerical tolerance delta of each moment (JCGM 101 §7.9.2), kg m^2."""
    tolerance_tilt: np.ndarray
    """(3,) the tolerance of each determined axis's tilt, deg (NaN: not determined)."""
    draws: int
    """Draws used, h x batch."""
    batch: int
    """M, draws per batch."""
    seed: int
    """The generator's seed."""
    converged: bool
    """Every result stabilised (JCGM 101 §7.9.4 i) before :data:`MAX_DRAWS`."""

    @property
    def moments_U(self) -> np.ndarray:
        """(3,) kg m^2, half the width of each moment's coverage interval."""
        return 0.5 * (self.moments_high - self.moments_low)


def principal_monte_carlo(
    entries: np.ndarray,
    cov: np.ndarray,
    p: float,
    seed: int = DEFAULT_SEED,
    *,
    digits: int = SIGNIFICANT_DIGITS,
    max_draws: int = MAX_DRAWS,
) -> PrincipalIntervals:
    """Coverage intervals of the principal moments and axes by the adaptive Monte Carlo of
    JCGM 101 §7.9.4.

    Draws of the entries from N(entries, cov) (JCGM 101 §6.4.8: cov's square root by its
    eigendecomposition, negative rounding eigenvalues taken as 0) give drawn tensors, their
    ascending principal moments and, per axis, the angle between the drawn axis and the
    estimated one (atan2 of its components across and along the estimated axis, sign
    aside). Batches of M = max(10^4, 100 / (1 - p)) draws (at most half ``max_draws``) run
    until, for every moment, twice the standard deviation of the batch means of its mean,
    std and interval ends, and for every determined axis the same of its tilt's mean, std and
    p quantile, is at most the tolerance of the std over all draws (:func:`numerical_tolerance`);
    the results are then computed from all draws.

    Parameters
    ----------
    entries : numpy.ndarray, shape (6,)
        kg m^2, ``[Jx, Jy, Jz, Jxy, Jyz, Jxz]``.
    cov : numpy.ndarray, shape (6, 6)
        kg^2 m^4, their covariance.
    p : float
        The coverage probability (:func:`coverage_probability`).
    seed : int, optional
        The generator's seed.
    digits : int, optional
        n_dig, the significant digits the results are held to.
    max_draws : int, optional
        Stop after this many draws, stable or not.

    Returns
    -------
    PrincipalIntervals

    Examples
    --------
    >>> mc = principal_monte_carlo(np.array([1.0, 2.0, 3.0, 0, 0, 0]),
    ...                            np.diag([1e-6] * 3 + [0.5e-6] * 3), 0.9545)
    >>> mc.converged
    True
    """
    entries = np.asarray(entries, dtype=float)
    cov = np.asarray(cov, dtype=float)
    _, vectors = principal(entries)
    determined = principal_determined(entries, cov)
    w, v = np.linalg.eigh(0.5 * (cov + cov.T))
    root = v * np.sqrt(np.clip(w, 0.0, None))
    wanted = math.ceil(100.0 / (1.0 - p)) if p < 1.0 else max_draws
    batch = min(max(MIN_BATCH, wanted), max(max_draws // 2, 1))
    rng = np.random.default_rng(seed)
    tails = ((1.0 - p) / 2.0, (1.0 + p) / 2.0)

    moments_all, tilts_all, summaries = [], [], []
    while True:
        z = rng.standard_normal((batch, 6))
        # axes[n, :, i] is the axis of m[n, i]
        m, axes = np.linalg.eigh(tensor_from_entries(entries + z @ root.T))
        # components of each drawn axis along the estimated ones: cosine and sine of the tilt
        c = np.einsum("ak,nki->nai", vectors, axes)
        along = np.abs(np.einsum("nii->ni", c))
        across = np.sqrt(np.maximum(np.sum(c**2, axis=1) - along**2, 0.0))
        t = np.degrees(np.arctan2(across, along))
        moments_all.append(m)
        tilts_all.append(t)
        summaries.append(_summary(m, t, tails, p))
        h = len(summaries)
        if h < 2:
            continue
        stats = np.array(summaries)  # (h, 7 results, 3 outputs)
        spread = 2.0 * stats.std(axis=0, ddof=1) / math.sqrt(h)
        u_m, u_t = _pooled_std(stats[:, 0], stats[:, 1], batch), _pooled_std(
            stats[:, 4], stats[:, 5], batch
        )
        tol_m = np.array([numerical_tolerance(u, digits) for u in u_m])
        tol_t = np.array([numerical_tolerance(u, digits) for u in u_t])
        stable = bool(
            np.all(spread[:4] <= tol_m) and np.all(spread[4:, determined] <= tol_t[determined])
        )
        if stable or (h + 1) * batch > max_draws:
            break

    m = np.concatenate(moments_all)
    t = np.concatenate(tilts_all)
    low, high = np.quantile(m, tails, axis=0)
    nan = np.where(determined, 1.0, np.nan)
    return PrincipalIntervals(
        p=p,
        moments_low=low,
        moments_high=high,
        moments_mean=m.mean(axis=0),
        moments_std=u_m,
        tilt=np.quantile(t, p, axis=0) * nan,
        tilt_std=u_t * nan,
        determined=determined,
        tolerance_moments=tol_m,
        tolerance_tilt=tol_t * nan,
        draws=h * batch,
        batch=batch,
        seed=seed,
        converged=stable,
    )


def _summary(m: np.ndarray, t: np.ndarray, tails: tuple[float, float], p: float) -> np.ndarray:
    """One batch's results, (7, 3): the moments' mean, std, low and high ends; the tilts'
    mean, std and p quantile."""
    low, high = np.quantile(m, tails, axis=0)
    return np.array([
        m.mean(axis=0), m.std(axis=0, ddof=1), low, high,
        t.mean(axis=0), t.std(axis=0, ddof=1), np.quantile(t, p, axis=0),
    ])


def _pooled_std(means: np.ndarray, stds: np.ndarray, n: int) -> np.ndarray:
    """The standard deviation of all draws from h batches of n draws, each batch's mean and
    std (rows): within-batch and between-batch sums of squares added."""
    h = means.shape[0]
    squares = (n - 1) * np.sum(stds**2, axis=0) + n * np.sum((means - means.mean(axis=0)) ** 2, axis=0)
    return np.sqrt(squares / (h * n - 1))


METHOD = (
    "tensor and centre of mass: U = k u, the estimates' own standard uncertainties (JCGM 100 "
    "§6.2); principal moments and axes: JCGM 101 Monte Carlo from the six entries' joint "
    "covariance (adaptive, §7.9; probabilistically symmetric intervals of the moments, §7.7; "
    "the axes' tilt as a one-sided quantile), the first-order (linearised) intervals given "
    "beside them and checked against them (JCGM 101 §8)"
)
"""result.json's ``expanded_uncertainty.method``."""


@dataclass(frozen=True)
class ExpandedUncertainty:
    """The GUM statement of a result: the coverage factor, its coverage probability and the
    expanded uncertainty of every quantity (docs/files.md, result.json
    ``expanded_uncertainty``)."""

    k: float
    """The coverage factor."""
    tensor: np.ndarray
    """(6,) kg m^2, U = k u of each entry."""
    com: np.ndarray | None
    """m, U = k u of each centre-of-mass coordinate the result has (None: no centre of
    mass)."""
    com_keys: tuple[str, ...]
    """The coordinates of ``com`` (x, y; or x, y, z for a combined body)."""
    principal: PrincipalIntervals
    """The Monte Carlo's intervals of the principal moments and axes."""
    linearised_moments: np.ndarray
    """(3,) kg m^2, k times the first-order std of each principal moment."""
    linearised_tilt: np.ndarray
    """(3,) rad, the first-order tilt quantile (:func:`linearised_tilt_quantile`); NaN for
    an axis not determined."""
    estimate_moments: np.ndarray
    """(3,) kg m^2, the principal moments of the estimated tensor."""

    @property
    def p(self) -> float:
        """The coverage probability of k for a normal distribution."""
        return coverage_probability(self.k)

    @property
    def validated(self) -> np.ndarray:
        """(3,) bool: JCGM 101 §8.2, the linearised interval's ends, estimate -+ U, lie
        within the tolerance (of the first-order std) of the Monte Carlo's."""
        mc = self.principal
        u = self.linearised_moments / self.k
        tol = np.array([numerical_tolerance(v) for v in u])
        d_low = np.abs(self.estimate_moments - self.linearised_moments - mc.moments_low)
        d_high = np.abs(self.estimate_moments + self.linearised_moments - mc.moments_high)
        return (d_low <= tol) & (d_high <= tol)

    def to_dict(self) -> dict:
        """result.json's (and body.json's) ``expanded_uncertainty``."""
        mc = self.principal
        return {
            "k": self.k,
            "coverage_probability": round(self.p, 4),
            "coverage": f"{100 * self.p:.2f} % (k = {self.k:g}, normal distribution)",
            "tensor": dict(zip(ENTRY_KEYS, map(float, self.tensor))),
            "com": None if self.com is None
            else dict(zip(self.com_keys, map(float, self.com))),
            "principal_moments": _floats(mc.moments_U),
            "principal_moments_interval": [
                [float(lo), float(hi)] for lo, hi in zip(mc.moments_low, mc.moments_high)
            ],
            "principal_axes_tilt_deg": _floats(mc.tilt),
            "principal_axes_determined": [bool(d) for d in mc.determined],
            "method": METHOD,
            "linearised": {
                "principal_moments": _floats(self.linearised_moments),
                "principal_axes_tilt_deg": _floats(np.degrees(self.linearised_tilt)),
                "validated": [bool(v) for v in self.validated],
            },
            "monte_carlo": {
                "draws": mc.draws,
                "batch": mc.batch,
                "seed": mc.seed,
                "significant_digits": SIGNIFICANT_DIGITS,
                "converged": mc.converged,
                "interval": "probabilistically symmetric",
                "principal_moments_mean": _floats(mc.moments_mean),
                "principal_moments_std": _floats(mc.moments_std),
                "principal_axes_tilt_std_deg": _floats(mc.tilt_std),
                "tolerance_principal_moments": _floats(mc.tolerance_moments),
                "tolerance_principal_axes_tilt_deg": _floats(mc.tolerance_tilt),
            },
        }

    def lines(self) -> list[str]:
        """What the printed output says of it, one line each (no final newline)."""
        mc = self.principal
        k, percent = f"{self.k:g}", f"{100 * self.p:.2f} %"
        meaning = (
            "std (u): the standard uncertainty, the standard deviation of the values that could "
            "reasonably be attributed to the measurand (JCGM 100 §2.3.1); U = k u with "
            f"k = {k}: the interval y +- U is expected to contain about {percent} of those "
            f"values (the coverage probability of k = {k} for a normal distribution; "
            "JCGM 100 §6)"
        )
        entries = ", ".join(f"{key} {u:.2g}" for key, u in zip(ENTRY_KEYS, self.tensor))
        com = "" if self.com is None else "; centre of mass " + ", ".join(
            f"{key} {u * 1e3:.2g}" for key, u in zip(self.com_keys, self.com)
        ) + " mm"
        stable = "" if mc.converged else ", NOT stabilised"
        draws = f"JCGM 101: {mc.draws} draws, seed {mc.seed}{stable}"
        out = [
            meaning,
            f"expanded uncertainty U: {entries} kg m^2{com}",
            f"principal moments and axes by Monte Carlo ({draws}), {percent} intervals:",
        ]
        if not mc.converged:
            out.insert(-1, (
                f"the Monte Carlo did not stabilise within {mc.draws} draws (JCGM 101 §7.9; "
                f"k = {k} needs more for its tails): its intervals hold fewer digits than "
                "they show"
            ))
        for i in range(3):
            tilt = (
                f"axis tilt <= {mc.tilt[i]:.2g} deg "
                f"(linearised {np.degrees(self.linearised_tilt[i]):.2g})"
                if mc.determined[i]
                else f"axis NOT determined (moment within {NEAR_EQUAL_STDS:g} stds of another)"
            )
            out.append(
                f"  I{i + 1} = {self.estimate_moments[i]:.8f}, interval [{mc.moments_low[i]:.8f}, "
                f"{mc.moments_high[i]:.8f}], U = {mc.moments_U[i]:.2g} (linearised "
                f"{self.linearised_moments[i]:.2g}), {tilt}"
            )
        return out


def expanded_uncertainty(
    entries: np.ndarray,
    cov: np.ndarray,
    k: float = DEFAULT_COVERAGE_FACTOR,
    com_std: np.ndarray | None = None,
    com_keys: tuple[str, ...] = ("x", "y"),
    seed: int = DEFAULT_SEED,
) -> ExpandedUncertainty:
    """The GUM statement of a tensor (and centre of mass): U = k u of every entry and
    coordinate, the principal moments' and axes' Monte Carlo intervals at the coverage
    probability of k, and the first-order ones beside them (docs/method.md §5).

    Parameters
    ----------
    entries : numpy.ndarray, shape (6,)
        kg m^2, ``[Jx, Jy, Jz, Jxy, Jyz, Jxz]``.
    cov : numpy.ndarray, shape (6, 6)
        kg^2 m^4, their covariance.
    k : float, optional
        The coverage factor (default 2).
    com_std : numpy.ndarray, optional
        m, the centre of mass's stds, when the result has one.
    com_keys : tuple of str, optional
        Their coordinates' names.
    seed : int, optional
        The Monte Carlo's seed.

    Returns
    -------
    ExpandedUncertainty

    Raises
    ------
    InputError
        k is not a finite number above 0.
    """
    k = check_coverage_factor(k)
    entries = np.asarray(entries, dtype=float)
    cov = np.asarray(cov, dtype=float)
    p = coverage_probability(k)
    moments, _ = principal(entries)
    moments_std, _ = principal_uncertainty(entries, cov)
    mc = principal_monte_carlo(entries, cov, p, seed)
    tilt = linearised_tilt_quantile(entries, cov, p)
    return ExpandedUncertainty(
        k=k,
        tensor=k * np.sqrt(np.clip(np.diag(cov), 0.0, None)),
        com=None if com_std is None else k * np.asarray(com_std, dtype=float),
        com_keys=tuple(com_keys),
        principal=mc,
        linearised_moments=k * moments_std,
        linearised_tilt=np.where(mc.determined, tilt, np.nan),
        estimate_moments=moments,
    )


def _floats(values) -> list[float | None]:
    """Plain floats for JSON, None for NaN and infinities."""
    return [float(v) if np.isfinite(v) else None for v in np.asarray(values, dtype=float)]
