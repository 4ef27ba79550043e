"""The mirrored reference (ocp/reference.py) against the braking it reflects and its truth.

The mirror is phi'(t') = phi(T - t'), Omega'(t') = -Omega(T - t'), eps'(t') = eps(T - t')
(docs/method.md §4) with T, phi7 the braking's rest. It is built from the smoothed braking, so
against the virtual device's truth it carries the smoother's errors (estimation/smoothing.py:
a fraction of a count in angle, the reported omega_std in speed) and nothing more.
"""

import math

import numpy as np
import pytest

from rsp_inertia.estimation.smoothing import Smoothed
from rsp_inertia.infra.errors import InputError
from rsp_inertia.ocp.reference import braking_states_at, mirror, rest_fit
from rsp_inertia.virtual import device as vd
from tests.ocp.conftest import (
    NODE_SPEED_FRACTION,
    STAGES,
    braking_truth_at,
    exact_states,
    true_accelerations,
)


def as_smoothed(ref) -> Smoothed:
    """A mirror seen as a smoothed pass (its omega is the derivative of its phi, eps of omega)."""
    zero = np.zeros_like(ref.t)
    return Smoothed(ref.t, ref.phi, ref.omega, ref.eps, zero, 0.0, 0.0)


@pytest.mark.parametrize("stage", STAGES)
def test_mirror_starts_at_rest_at_the_rest_angle_and_runs_back(stage, programs):
    ref = programs[stage].mirror
    assert ref.t[0] == 0.0
    assert ref.phi[0] == ref.rest_angle
    # Omega'(0) = -Omega(T) = 0 by the definition of T (docs/method.md §4: the reverse starts from
    # the held rest), and from there on the body runs back: Omega' < 0, phi' decreasing.
    assert ref.omega[0] == 0.0, f"the reference starts at {ref.omega[0]:.3g} rad/s"
    assert np.all(ref.omega[1:] < 0.0), f"{np.sum(ref.omega[1:] >= 0)} samples run forward"
    # eps'(0) = eps(T): the braking's deceleration at rest now speeds the body up backwards.
    assert ref.eps[0] < 0.0


@pytest.mark.parametrize("stage", STAGES)
def test_mirror_spans_the_braking_at_the_sample_rate(stage, default_device, programs):
    ref = programs[stage].mirror
    dt = default_device.encoder.dt
    np.testing.assert_array_equal(ref.t, np.arange(ref.t.size) * dt)
    # Every sample of [0, T], and no more: the last lies within one sample before T.
    assert ref.t[-1] <= ref.rest_time < ref.t[-1] + dt


@pytest.mark.parametrize("stage", STAGES)
def test_mirror_of_the_mirror_is_the_braking(stage, default_device, smoothed, programs):
    sm = smoothed[stage]
    ref = programs[stage].mirror
    T = ref.rest_time
    # Reflect the mirror about the same T, at the braking's samples (but the first, which lies
    # a fraction of a sample past the mirror's last sample).
    # Over the braking's last REST_WINDOW the mirror is the fitted deceleration, not the
    # smoother (ocp/reference.py): the identity holds before that.
    dt = default_device.encoder.dt
    keep = (sm.t > sm.t[0]) & (sm.t < ref.fitted_from - dt)
    t = sm.t[keep]
    phi, omega, eps = braking_states_at(as_smoothed(ref), T - t, (T, ref.phi[-1]))
    # The reflected times fall off the mirror's grid by delta = T mod dt. The interpolation
    # carries phi and Omega with their derivatives (cubic Hermite) and eps linearly, so what it
    # misses over one sample is bounded by the acceleration's change over a sample.
    jump = np.abs(np.diff(sm.eps)).max()
    assert np.abs(phi - sm.phi[keep]).max() <= jump * dt * dt
    assert np.abs(-omega - sm.omega[keep]).max() <= jump * dt
    assert np.abs(eps - sm.eps[keep]).max() <= jump


@pytest.mark.parametrize("stage", STAGES)
def test_mirror_is_the_true_braking_run_backwards(
    stage, default_device, default_virtual, brakings, smoothed, programs
):
    braking = brakings[stage]
    sm = smoothed[stage]
    ref = programs[stage].mirror
    params = vd.true_parameters(default_device, stage, default_virtual)
    # At the same instant of the braking, T - t' with T the mirror's own rest time (its error,
    # milliseconds on stage 1, see below, shifts the whole mirror in time and leaves its
    # (phi, Omega) pairs alone), where the body moves well (the smoother is over-confident
    # near rest, smoothing.py).
    t_braking = ref.rest_time - ref.t
    phi, omega = braking_truth_at(braking, params, np.clip(t_braking, 0.0, None))
    moving = (t_braking >= 0.0) & (omega > NODE_SPEED_FRACTION * braking.truth.omega.max())
    q = default_device.encoder.quantum
    # The smoothed angle is good to a fraction of the reading's count.
    assert np.abs(ref.phi[moving] - phi[moving]).max() < q
    # The speed is good to the smoother's reported omega_std: 5 sigma, as the largest of
    # ~10^4 samples correlated over the smoother's ~5 ms memory (a few thousand independent).
    std = np.interp(t_braking[moving], sm.t, sm.omega_std)
    assert np.all(np.abs(-ref.omega[moving] - omega[moving]) <= 5 * std)


@pytest.mark.parametrize("stage", STAGES)
def test_mirror_speed_is_the_braking_speed_at_the_same_angle(
    stage, default_device, brakings, smoothed, programs
):
    braking = brakings[stage]
    ref = programs[stage].mirror
    sm = smoothed[stage]
    tr = braking.truth
    # At every node passage the mirror's speed is minus the true braking speed there: this is
    # what makes friction's work cancel between the passes (docs/method.md §4).
    nodes = default_device.stages[stage - 1].nodes
    turns = np.arange(-1, math.ceil((tr.phi[-1] - tr.phi[0]) / (2 * math.pi)) + 1)
    angles = (nodes[:, None] + 2 * math.pi * turns[None, :]).ravel()
    angles = angles[(angles > tr.phi[0]) & (angles < tr.phi[-1])]
    truth = np.interp(angles, tr.phi, tr.omega)
    fast = truth > NODE_SPEED_FRACTION * tr.omega.max()
    angles, truth = angles[fast], truth[fast]
    assert angles.size >= 2 * nodes.size  # at least two turns' worth of nodes
    order = np.argsort(ref.phi)  # the mirror's phi decreases: sort it for interpolation
    mirrored = -np.interp(angles, ref.phi[order], ref.omega[order])
    std = np.interp(angles, sm.phi, sm.omega_std)
    # Smoother noise only (the angle's error of < 1 count moves the speed by eps/Omega x that,
    # ~1e-5 of omega_std here): 5 sigma, as above.
    assert np.all(np.abs(mirrored - truth) <= 5 * std)


@pytest.mark.parametrize("stage", STAGES)
def test_rest_point_of_the_exact_states_is_the_true_stop(
    stage, default_device, default_virtual, brakings
):
    braking = brakings[stage]
    params = vd.true_parameters(default_device, stage, default_virtual)
    exact = exact_states(braking, params)
    fit = rest_fit(exact, "braking.csv", default_device.encoder.quantum)
    T, phi7 = fit.rest_time, fit.phi7
    tr = braking.truth
    # rest_fit fits a straight line to the speed over the last window W. A jerk j over the
    # window bends the speed by j s^2 / 2; the least-squares line through s^2 on [-W, 0] misses
    # it at s = 0 by W^2 / 6 and has slope -W: speed error j W^2 / 12, deceleration error
    # j W / 2. So T is off by at most (j W^2 / 12 + tau j W / 2) / |eps| (tau < dt the time
    # still to go), and phi7, the line's distance over the window, by at most j W^3 / 12.
    dt = default_device.encoder.dt
    W = exact.t[-1] - fit.start
    eps = true_accelerations(braking, params)
    jerk = np.abs(np.diff(eps[-round(W / dt) - 1 :])).max() / dt
    assert abs(T - tr.end_time) <= (jerk * W * W / 12 + dt * jerk * W / 2) / abs(eps[-1]) + 1e-12
    assert abs(phi7 - tr.end_phi) <= jerk * W**3 / 12 + 1e-12


@pytest.mark.parametrize("stage", STAGES)
def test_rest_point_of_the_smoothed_braking_is_the_true_stop(
    stage, default_device, brakings, smoothed
):
    braking = brakings[stage]
    sm = smoothed[stage]
    fit = rest_fit(sm, "braking.csv", default_device.encoder.quantum)
    T, phi7 = fit.rest_time, fit.phi7
    tr = braking.truth
    dt = default_device.encoder.dt
    # With exact states T would be right to a small fraction of a sample (test above). The
    # smoothed speed carries the smoother's error, which the line over the window averages and
    # the extrapolation turns into a time error of delta Omega / |eps|; if it pushes the fitted
    # end speed to <= 0 the rest is put at the last sample, less than a sample early. So: one
    # sample plus 4 sigma of the end speed over the deceleration (4, not 2: the smoother is
    # over-confident near rest; the window's average is bounded by its last, widest sigma).
    assert abs(T - tr.end_time) <= dt + 4 * sm.omega_std[-1] / abs(sm.eps[-1])
    # The angle hardly depends on that: phi7 - phi_n = Omega_n^2 / (2|eps|) is second order in
    # the slow final speed. Near rest the body crosses a count in several samples, so the
    # readings no longer average its position below a count: phi7 within one count.
    assert abs(phi7 - tr.end_phi) <= default_device.encoder.quantum


def test_mirror_refuses_a_braking_that_does_not_stop(smoothed, default_device):
    sm = smoothed[1]
    # Cut the pass where gravity is speeding it up (half of each slow turn on stage 1): the
    # body is not coming to rest there, and no mirror can start from it.
    k = int(np.flatnonzero((sm.eps > 0) & (sm.omega > 0))[0]) + 1
    cut = Smoothed(sm.t[:k], sm.phi[:k], sm.omega[:k], sm.eps[:k], sm.omega_std[:k], 0.0, 0.0)
    with pytest.raises(InputError, match="stage1/braking.csv: .*did not reach rest"):
        mirror(cut, default_device.encoder.sample_rate, default_device.encoder.quantum, "stage1/braking.csv")
