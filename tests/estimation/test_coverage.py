"""GUM statements (rsp_inertia.estimation.coverage): U = k u, coverage probabilities, the
principal moments' and axes' adaptive Monte Carlo against independent truths."""

import dataclasses
import math
from statistics import NormalDist

import numpy as np
import pytest

from rsp_inertia.estimation.coverage import (
    check_coverage_factor,
    coverage_probability,
    expanded_uncertainty,
    numerical_tolerance,
    principal_determined,
    principal_monte_carlo,
)
from rsp_inertia.infra.errors import InputError

STD = np.array([1.3e-7, 1.4e-7, 4.4e-7, 4.4e-8, 5.5e-8, 5.5e-8])
"""kg m^2, stds of the entries like the default experiment's (Jx ... Jxz)."""
COV = np.diag(STD**2)


def test_coverage_probability_is_the_normal_distributions():
    # JCGM 100 table G.1: k = 1, 2, 3 give 68.27 %, 95.45 %, 99.73 %; the truth here is the
    # normal distribution's own cdf.
    normal = NormalDist()
    for k, table in ((1.0, 0.6827), (2.0, 0.9545), (3.0, 0.9973)):
        p = coverage_probability(k)
        assert p == pytest.approx(normal.cdf(k) - normal.cdf(-k), abs=1e-12)
        assert round(p, 4) == table


@pytest.mark.parametrize("k", [0, -1.0, math.nan, math.inf, -math.inf, "two", None, True])
def test_a_coverage_factor_that_is_not_a_finite_positive_number_is_bad_input(k):
    with pytest.raises(InputError, match="finite number above 0"):
        check_coverage_factor(k)


def test_the_numerical_tolerance_is_half_a_unit_of_the_last_significant_digit():
    # JCGM 101 §7.9.2's example: u = 0.000 35 to two digits is 35 x 10^-5, delta 0.5 x 10^-5.
    assert numerical_tolerance(0.00035) == pytest.approx(0.5e-5)
    assert numerical_tolerance(0.00035, digits=1) == pytest.approx(0.5e-4)
    # 1.0e-6 is 10 x 10^-7 to two digits, and so is 9.96e-7 once rounded
    assert numerical_tolerance(1.0e-6) == pytest.approx(0.5e-7)
    assert numerical_tolerance(9.96e-7) == pytest.approx(0.5e-7)
    assert numerical_tolerance(9.9e-7) == pytest.approx(0.5e-8)
    assert numerical_tolerance(0.0) == 0.0


def test_U_is_k_times_the_std_of_every_entry_and_coordinate():
    entries = np.array([0.021, 0.025, 0.028, 0.0, 0.0, 0.0])
    com_std = np.array([6e-8, 6.1e-8])
    for k in (2.0, 1.0):
        stated = expanded_uncertainty(entries, COV, k, com_std=com_std)
        assert np.array_equal(stated.tensor, k * STD)
        assert np.array_equal(stated.com, k * com_std)
        document = stated.to_dict()
        assert document["k"] == k
        assert document["tensor"]["Jz"] == k * STD[2]
        assert document["com"] == {"x": k * com_std[0], "y": k * com_std[1]}
    assert expanded_uncertainty(entries, COV).to_dict()["coverage_probability"] == 0.9545


def test_separated_moments_monte_carlo_agrees_with_the_linearised_intervals():
    """The issue's target: a diagonal tensor of well-separated moments (gaps of thousands of
    stds) has principal moments equal to its diagonal to first order, so the linearised U is
    k times the diagonal entries' stds, and the axes' tilts are those of the products over the
    gaps; the Monte Carlo must agree within 5 %."""
    entries = np.array([0.021, 0.025, 0.028, 0.0, 0.0, 0.0])
    stated = expanded_uncertainty(entries, COV, 2.0)
    mc = stated.principal
    assert mc.converged and mc.determined.all()
    assert np.allclose(mc.moments_U, 2.0 * STD[:3], rtol=0.05)
    # the intervals sit on the estimate: ends within 5 % of U of estimate -+ 2 std
    assert np.allclose(mc.moments_low, entries[:3] - 2 * STD[:3], rtol=0, atol=0.05 * 2 * STD[:3])
    assert np.allclose(mc.moments_high, entries[:3] + 2 * STD[:3], rtol=0, atol=0.05 * 2 * STD[:3])
    # tilt of axis i towards j: J_ij / (I_i - I_j); Rayleigh-like with those two stds
    products = {(0, 1): STD[3], (1, 2): STD[4], (0, 2): STD[5]}
    moments = entries[:3]
    for i in range(3):
        sigmas = [products[tuple(sorted((i, j)))] / abs(moments[i] - moments[j])
                  for j in range(3) if j != i]
        draws = np.random.default_rng(7).standard_normal((400_000, 2)) * sigmas
        truth = np.degrees(np.quantile(np.hypot(*draws.T), coverage_probability(2.0)))
        assert mc.tilt[i] == pytest.approx(truth, rel=0.05)
        assert np.degrees(stated.linearised_tilt[i]) == pytest.approx(truth, rel=0.01)
    assert stated.validated.all()


def test_two_equal_moments_leave_their_axes_undetermined_and_the_monte_carlo_decides():
    """Jx = Jy: the top-left 2 x 2 block's eigenvalues are, exactly,
    a + (x + y) / 2 -+ sqrt(((x - y) / 2)^2 + p^2) (x, y, p its drawn errors), an independent
    truth for the two lower moments; they repel, so their intervals are narrower than the
    linearised ones, and the Monte Carlo's are the ones stated."""
    a = 0.025
    entries = np.array([a, a, 0.028, 0.0, 0.0, 0.0])
    stated = expanded_uncertainty(entries, COV, 2.0)
    mc = stated.principal
    assert list(mc.determined) == [False, False, True]
    assert np.isnan(mc.tilt[:2]).all() and np.isfinite(mc.tilt[2])
    document = stated.to_dict()
    assert document["principal_axes_determined"] == [False, False, True]
    assert document["principal_axes_tilt_deg"][:2] == [None, None]
    assert document["principal_moments"] == pytest.approx(list(mc.moments_U), rel=0, abs=0)
    assert sum("NOT determined" in line for line in stated.lines()) == 2

    z = np.random.default_rng(11).standard_normal((1_000_000, 3)) * STD[[0, 1, 3]]
    x, y, p = z.T
    half = np.sqrt(((x - y) / 2) ** 2 + p**2)
    p95 = coverage_probability(2.0)
    for moment, values in ((0, a + (x + y) / 2 - half), (1, a + (x + y) / 2 + half)):
        low, high = np.quantile(values, [(1 - p95) / 2, (1 + p95) / 2])
        # tolerance: the Monte Carlo's ends are stable to its tolerance (2 x its batch
        # spread), this truth's quantiles to about 1e-3 of U at 10^6 draws
        tol = mc.tolerance_moments[moment] + 2e-3 * (high - low)
        assert mc.moments_low[moment] == pytest.approx(low, abs=tol)
        assert mc.moments_high[moment] == pytest.approx(high, abs=tol)
    # the linearised U misses the repulsion: far wider than the truth
    assert (mc.moments_U[:2] < 0.9 * stated.linearised_moments[:2]).all()
    assert not stated.validated[:2].any()


def test_nearly_equal_moments_within_three_stds_are_flagged_and_beyond_are_not():
    # I2 - I1 has std sqrt(2) 1.35e-7 (uncorrelated Jx, Jy of about equal stds): 3 stds
    # is about 5.7e-7
    std = np.sqrt(STD[0] ** 2 + STD[1] ** 2)
    near = np.array([0.025, 0.025 + 2.5 * std, 0.028, 0.0, 0.0, 0.0])
    far = np.array([0.025, 0.025 + 3.5 * std, 0.028, 0.0, 0.0, 0.0])
    assert list(principal_determined(near, COV)) == [False, False, True]
    assert list(principal_determined(far, COV)) == [True, True, True]


def test_the_adaptive_monte_carlo_stops_when_stable_and_repeats_with_its_seed():
    entries = np.array([0.021, 0.025, 0.028, 2e-4, -1e-4, 3e-4])
    p = coverage_probability(2.0)
    first = principal_monte_carlo(entries, COV, p, seed=5)
    again = principal_monte_carlo(entries, COV, p, seed=5)
    assert first.converged
    assert first.draws % first.batch == 0 and first.draws >= 2 * first.batch
    assert first.batch == 10_000  # JCGM 101 §7.9.4 b): max(10^4, 100 / (1 - p))
    for name in ("moments_low", "moments_high", "moments_std", "tilt"):
        assert np.array_equal(getattr(first, name), getattr(again, name))
    assert first.draws == again.draws
    # one batch fewer is not yet stable: the procedure stopped at the first stable batch
    short = principal_monte_carlo(entries, COV, p, seed=5, max_draws=first.draws - first.batch)
    assert not short.converged
    # another seed: other draws, the same intervals within the tolerance
    other = principal_monte_carlo(entries, COV, p, seed=6)
    assert not np.array_equal(other.moments_low, first.moments_low)
    tol = 2 * first.tolerance_moments
    assert np.allclose(other.moments_low, first.moments_low, rtol=0, atol=tol)
    assert np.allclose(other.moments_high, first.moments_high, rtol=0, atol=tol)
    # JCGM 101 §7.9.4 b): a larger k needs larger batches for its tails, 100 / (1 - p)
    p3 = coverage_probability(3.0)
    wide = principal_monte_carlo(entries, COV, p3, max_draws=2 * 37_040)
    assert wide.batch == math.ceil(100 / (1 - p3)) == 37_040
    assert wide.draws == 2 * wide.batch


def test_an_exact_tensor_has_zero_intervals():
    entries = np.array([0.021, 0.025, 0.028, 0.0, 0.0, 0.0])
    stated = expanded_uncertainty(entries, np.zeros((6, 6)), 2.0)
    assert stated.principal.converged
    assert np.array_equal(stated.principal.moments_U, np.zeros(3))
    assert np.array_equal(stated.tensor, np.zeros(6))


def test_an_unstabilised_monte_carlo_says_so():
    entries = np.array([0.021, 0.025, 0.028, 0.0, 0.0, 0.0])
    stated = expanded_uncertainty(entries, COV, 2.0)
    assert not any("did not stabilise" in line for line in stated.lines())
    short = dataclasses.replace(
        stated, principal=principal_monte_carlo(entries, COV, stated.p, max_draws=20_000)
    )
    assert not short.principal.converged and short.principal.draws == 20_000
    assert any("did not stabilise within 20000 draws" in line for line in short.lines())
    assert short.to_dict()["monte_carlo"]["converged"] is False
