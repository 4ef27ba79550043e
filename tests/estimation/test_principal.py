"""The principal moments' and axes' uncertainty (rsp_inertia.plant.geometry
.principal_uncertainty) against a closed form and against sampling."""

import numpy as np
import pytest

from rsp_inertia.plant.geometry import principal, principal_uncertainty


def test_a_diagonal_tensor_has_the_closed_form():
    # J = diag(1, 2, 3): I_i = J_ii, so std(I_i) = std(J_ii); the x axis tilts towards y by
    # Jxy / (1 - 2) and towards z by Jxz / (1 - 3).
    entries = np.array([1.0, 2.0, 3.0, 0.0, 0.0, 0.0])
    s = np.array([1e-3, 2e-3, 3e-3, 4e-3, 5e-3, 6e-3])
    moments_std, tilt = principal_uncertainty(entries, np.diag(s**2))
    assert moments_std == pytest.approx(s[:3], rel=1e-12)
    # Jxy (s[3]) links x-y, Jyz (s[4]) y-z, Jxz (s[5]) x-z.
    expected = np.sqrt([
        (s[3] / 1) ** 2 + (s[5] / 2) ** 2,
        (s[3] / 1) ** 2 + (s[4] / 1) ** 2,
        (s[5] / 2) ** 2 + (s[4] / 1) ** 2,
    ])
    assert tilt == pytest.approx(expected, rel=1e-12)


def test_equal_moments_leave_the_axes_undefined():
    entries = np.array([2.0, 2.0, 3.0, 0.0, 0.0, 0.0])
    _, tilt = principal_uncertainty(entries, np.eye(6) * 1e-8)
    assert np.isinf(tilt[0]) and np.isinf(tilt[1]) and np.isfinite(tilt[2])


def test_first_order_stds_agree_with_sampling():
    rng = np.random.default_rng(7)
    entries = np.array([0.025, 0.028, 0.022, 0.0012, -0.0009, 0.0015])
    a = rng.normal(size=(6, 6)) * 2e-6
    cov = a @ a.T
    moments_std, tilt = principal_uncertainty(entries, cov)
    _, axes = principal(entries)
    draws = rng.multivariate_normal(entries, cov, size=20000)
    sampled_moments, sampled_tilt = [], []
    for d in draws:
        m, v = principal(d)
        sampled_moments.append(m)
        cosine = np.clip(np.abs(np.sum(v * axes, axis=1)), 0.0, 1.0)
        sampled_tilt.append(np.arccos(cosine))
    assert np.std(sampled_moments, axis=0) == pytest.approx(moments_std, rel=0.03)
    rms = np.sqrt(np.mean(np.square(sampled_tilt), axis=0))
    assert rms == pytest.approx(tilt, rel=0.03)
