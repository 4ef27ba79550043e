"""The reduced model (docs/method.md §1-3): the harmonic form is the 3-D kinetic energy, the
derivatives are derivatives, forward and inverse dynamics are one equation, energy balances."""

import math

import casadi as ca
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rsp_inertia.plant.geometry import axis_direction, entries_from_tensor
from rsp_inertia.plant.model import (
    PARAMETER_NAMES,
    ModelParameters,
    acceleration,
    dissipation,
    force_curvature_regressor,
    force_regressor,
    gravity_basis,
    harmonics_matrix,
    inertia_harmonics,
    mechanical_energy,
    momentum_regressor,
    motor_torque,
    potential,
    reduced_inertia,
    reduced_inertia_slope,
    rk4_step,
    static_torque,
    tensor_basis,
)

# Each example costs a handful of CasADi calls (~0.1 ms): 200 of them per property are cheap.
PROPERTY = settings(max_examples=200, deadline=None)

EPS = np.finfo(float).eps
TINY = np.finfo(float).tiny

unit = st.floats(-1.0, 1.0)
angles = st.floats(-20.0, 20.0)
speeds = st.tuples(st.floats(0.05, 20.0), st.sampled_from([-1.0, 1.0])).map(
    lambda pair: pair[0] * pair[1]
)


@st.composite
def tensors(draw) -> np.ndarray:
    """A symmetric positive-definite inertia tensor, kg m^2, entries up to ~0.1."""
    a = np.array(draw(st.lists(unit, min_size=9, max_size=9))).reshape(3, 3)
    return 0.05 * (a @ a.T + 0.01 * np.eye(3))


def six(J: np.ndarray) -> np.ndarray:
    """[Jx, Jy, Jz, Jxy, Jyz, Jxz] of a 3x3 tensor (products as tensor entries, METHOD §2)."""
    return np.array([J[0, 0], J[1, 1], J[2, 2], J[0, 1], J[1, 2], J[0, 2]])


@st.composite
def stage_parameters(draw) -> tuple[ModelParameters, np.ndarray, float, float]:
    """A random body on a random stage, with spring, gravity and friction: (p, J, lam, tare)."""
    J = draw(tensors())
    lam = draw(st.floats(0.0, 6.0))
    tare = draw(st.floats(0.0, 0.1))
    params = ModelParameters(
        inertia_harmonics=inertia_harmonics(six(J), lam, tare),
        stiffness=draw(st.floats(0.0, 1.0)),
        zero_angle=draw(st.floats(-3.0, 3.0)),
        gravity_sin=draw(st.floats(-0.5, 0.5)),
        gravity_cos=draw(st.floats(-0.5, 0.5)),
        coulomb=draw(st.floats(0.0, 1e-2)),
        viscous=draw(st.floats(0.0, 1e-2)),
        quadratic=draw(st.floats(0.0, 1e-2)),
    )
    return params, J, lam, tare


def torque_scale(params: ModelParameters, Omega: float, u: float = 0.0) -> float:
    """Sum of the magnitudes of every torque term at speed Omega: the size of rounding errors."""
    h = np.abs(params.inertia_harmonics)
    return (
        abs(u)
        + 4.0 * h.sum() * Omega**2
        + params.stiffness * (40.0 + abs(params.zero_angle))
        + abs(params.gravity_sin)
        + abs(params.gravity_cos)
        + params.coulomb
        + params.viscous * abs(Omega)
        + params.quadratic * Omega**2
    )


# --- rotations of the gimbal (docs/method.md §1), written independently of rsp_inertia.plant.model ---------


def rot_z(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def rot_z_prime(a: float) -> np.ndarray:
    """d rot_z / da."""
    c, s = math.cos(a), math.sin(a)
    return np.array([[-s, -c, 0.0], [c, -s, 0.0], [0.0, 0.0, 0.0]])


def rot_x(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


THETA = math.pi / 2  # nutation: the inner shaft is horizontal


def attitude(phi: float, lam: float) -> np.ndarray:
    """Body-to-inertial rotation R = Rz(psi) Rx(theta) Rz(phi), Euler ZXZ with psi = lam phi."""
    return rot_z(lam * phi) @ rot_x(THETA) @ rot_z(phi)


def attitude_rate(phi: float, Omega: float, lam: float) -> np.ndarray:
    """dR/dt along phi(t) = phi0 + Omega t: the product rule with dpsi/dt = lam Omega."""
    return Omega * (
        lam * rot_z_prime(lam * phi) @ rot_x(THETA) @ rot_z(phi)
        + rot_z(lam * phi) @ rot_x(THETA) @ rot_z_prime(phi)
    )


def body_angular_velocity(phi: float, Omega: float, lam: float) -> np.ndarray:
    """omega in body coordinates from the skew matrix R^T dR/dt."""
    W = attitude(phi, lam).T @ attitude_rate(phi, Omega, lam)
    return np.array([W[2, 1], W[0, 2], W[1, 0]])


# --- 1. the harmonic form is the 3-D kinetic energy ----------------------------------------


@PROPERTY
@given(phi=angles, Omega=speeds, lam=st.floats(0.0, 6.0))
def test_attitude_rate_is_the_derivative_of_the_attitude(phi, Omega, lam):
    # Guards the hand-written derivative the next test relies on. Central difference in phi
    # with h = 1e-6: truncation h^2/6 |R'''| <= 1e-12/6 (1+lam)^3 < 1e-10 and rounding
    # eps/h ~ 2e-10, times |Omega|. The step is the difference of the two representable
    # angles, so that the rounding of phi +- h (ulp(20) = 3.6e-15, 4e-9 of h) does not
    # masquerade as an error. The precession angle psi = lam phi is rounded once more, by up
    # to ulp(lam phi) / 2 at each end: over the step 2h that is ulp(lam |phi|) / (2h)
    # relative, times the rate lam |Omega| (7e-9 at phi = 18, lam = 3.7).
    h = 1e-6
    ahead, behind = phi + h, phi - h
    numeric = Omega * (attitude(ahead, lam) - attitude(behind, lam)) / (ahead - behind)
    psi_rounding = np.spacing(lam * abs(phi) + 1.0) / (2 * h) * lam
    np.testing.assert_allclose(
        attitude_rate(phi, Omega, lam),
        numeric,
        rtol=0,
        atol=(1e-9 * (1 + lam) + 2 * psi_rounding) * abs(Omega),
    )
    # R^T dR/dt of a rotation is skew-symmetric: an angular velocity.
    W = attitude(phi, lam).T @ attitude_rate(phi, Omega, lam)
    np.testing.assert_allclose(W, -W.T, rtol=0, atol=1e-13 * (1 + lam) * abs(Omega))


@PROPERTY
@given(J=tensors(), lam=st.floats(0.0, 6.0), tare=st.floats(0.0, 0.1), phi=angles, Omega=speeds)
def test_reduced_inertia_is_twice_the_kinetic_energy_over_omega_squared(J, lam, tare, phi, Omega):
    omega = body_angular_velocity(phi, Omega, lam)
    # METHOD §1: omega = Omega (lam sin phi, lam cos phi, 1) follows from the rotations.
    expected = Omega * np.array([lam * math.sin(phi), lam * math.cos(phi), 1.0])
    np.testing.assert_allclose(omega, expected, rtol=0, atol=1e-13 * (1 + lam) * abs(Omega))

    kinetic = 0.5 * omega @ J @ omega + 0.5 * tare * Omega**2
    M_3d = 2 * kinetic / Omega**2
    M = reduced_inertia(phi, ModelParameters(inertia_harmonics(six(J), lam, tare)))
    # Both sides are exact closed forms of the same quantity; they part only by rounding,
    # a few eps times the largest term (1+lam)^2 |J|_max + tare. Cancellation between signed
    # products of J is what makes a bound on the scale, not on M itself, the right one
    # (M can be ~1e-3 of the scale for a thin tensor). A wrong coefficient would miss by
    # ~|J| lam, nine orders of magnitude above this.
    scale = (1 + lam) ** 2 * np.abs(J).max() + tare
    assert abs(M_3d - M) <= 1e-13 * scale
    assert abs(M_3d - M) <= 1e-9 * M


@PROPERTY
@given(phi=angles, lam=st.floats(0.0, 6.0))
def test_vertical_in_body_coordinates(phi, lam):
    # METHOD §1: k1 = R^T e_z1 = (sin phi, cos phi, 0), whatever psi = lam phi (a turn about
    # the vertical leaves the vertical alone). cos(pi/2) = 6e-17 in floating point.
    k1 = attitude(phi, lam).T @ np.array([0.0, 0.0, 1.0])
    np.testing.assert_allclose(k1, [math.sin(phi), math.cos(phi), 0.0], rtol=0, atol=1e-15)


@PROPERTY
@given(
    phi=angles,
    lam=st.floats(0.0, 6.0),
    mass=st.floats(0.1, 10.0),
    com=st.lists(st.floats(-0.05, 0.05), min_size=3, max_size=3),
)
def test_gravity_potential_is_the_height_of_the_centre_of_mass(phi, lam, mass, com):
    g = 9.80665
    height = (attitude(phi, lam).T @ np.array([0.0, 0.0, 1.0])) @ np.array(com)
    params = ModelParameters(
        inertia_harmonics=[1.0, 0, 0, 0, 0],
        gravity_sin=mass * g * com[0],
        gravity_cos=mass * g * com[1],
    )
    # z_c enters only through cos(theta) = 6e-17: the centre of mass moves horizontally.
    assert potential(phi, params) == pytest.approx(mass * g * height, rel=0, abs=1e-14)


# --- 2. the slopes are derivatives ---------------------------------------------------------


@PROPERTY
@given(params=stage_parameters(), phi=angles)
def test_inertia_slope_and_static_torque_are_derivatives(params, phi):
    params = params[0]
    # Central difference, h = 1e-5: truncation h^2/6 |f'''| and rounding eps |f|/h, for
    # harmonics up to 2 phi (f''' <= 8 sum|coefficients|) and a spring c/2 (phi-phi0)^2
    # (f''' = 0, |f| <= c/2 (|phi|+|phi0|)^2). Both are below 1e-9 of the scale.
    # The step is the difference of the representable angles (phi +- h rounds by 4e-10 of h).
    # TINY keeps a tolerance where the scale is subnormal (1e-9 of it rounds to zero).
    ahead, behind = phi + 1e-5, phi - 1e-5
    dM = (reduced_inertia(ahead, params) - reduced_inertia(behind, params)) / (ahead - behind)
    scale_M = np.abs(params.inertia_harmonics).sum()
    assert reduced_inertia_slope(phi, params) == pytest.approx(dM, rel=0, abs=1e-9 * scale_M + TINY)

    dPi = (potential(ahead, params) - potential(behind, params)) / (ahead - behind)
    scale_Pi = (
        abs(params.gravity_sin)
        + abs(params.gravity_cos)
        + params.stiffness * (abs(phi) + abs(params.zero_angle) + 1.0) ** 2
    )
    assert static_torque(phi, params) == pytest.approx(dPi, rel=0, abs=1e-9 * scale_Pi + TINY)


# --- 3-5. one equation of motion ---------------------------------------------------------


@PROPERTY
@given(params=stage_parameters(), phi=angles, Omega=speeds, u=st.floats(-1.0, 1.0))
def test_inverse_dynamics_undoes_forward_dynamics(params, phi, Omega, u):
    params = params[0]
    direction = math.copysign(1.0, Omega)
    eps = acceleration(phi, Omega, u, params)
    # Lagrange's equation solved for eps and then evaluated at eps: only rounding of the
    # torque terms separates the two.
    assert motor_torque(phi, Omega, eps, params, direction) == pytest.approx(
        u, rel=0, abs=1e-13 * torque_scale(params, Omega, u)
    )


@PROPERTY
@given(params=stage_parameters(), phi=angles, direction=st.sampled_from([-1.0, 1.0]))
def test_forward_and_inverse_dynamics_at_rest(params, phi, direction):
    params = params[0]
    u = 0.3
    eps = acceleration(phi, 0.0, u, params, direction)
    assert motor_torque(phi, 0.0, eps, params, direction) == pytest.approx(
        u, rel=0, abs=1e-13 * torque_scale(params, 0.0, u)
    )


@PROPERTY
@given(params=stage_parameters(), Omega=speeds)
def test_dissipation_is_odd_in_the_motion(params, Omega):
    params = params[0]
    s = math.copysign(1.0, Omega)
    # Negation is exact in floating point and every operation rounds symmetrically, so the
    # law is odd bit for bit.
    assert dissipation(-Omega, params, -s) == -dissipation(Omega, params, s)
    # It opposes the motion (all coefficients >= 0) and defaults to direction = sign(Omega).
    assert dissipation(Omega, params) * Omega >= 0.0
    assert dissipation(Omega, params) == dissipation(Omega, params, s)


@PROPERTY
@given(params=stage_parameters(), phi=angles, Omega=speeds, u=st.floats(-1.0, 1.0))
def test_energy_balance_along_the_equation_of_motion(params, phi, Omega, u):
    params = params[0]
    M = reduced_inertia(phi, params)
    eps = acceleration(phi, Omega, u, params)
    # E = M Omega^2 / 2 + Pi, so dE/dt = (M'/2 Omega^2 + S) Omega + M Omega eps.
    assert mechanical_energy(phi, Omega, params) == pytest.approx(
        M * Omega**2 / 2 + potential(phi, params), rel=1e-14, abs=1e-14
    )
    dE_dt = (reduced_inertia_slope(phi, params) * Omega**2 / 2 + static_torque(phi, params)) * (
        Omega
    ) + M * Omega * eps
    power = (u - dissipation(Omega, params)) * Omega
    # The motor and the dissipation are the only sources of mechanical power (METHOD §3).
    # Rounding: a few eps on each torque term, times Omega.
    assert dE_dt == pytest.approx(
        power, rel=0, abs=1e-13 * torque_scale(params, Omega, u) * abs(Omega)
    )


@PROPERTY
@given(params=stage_parameters(), phi=angles, Omega=speeds, u=st.floats(-1.0, 1.0))
def test_momentum_form_is_lagranges_equation(params, phi, Omega, u):
    # d(M Omega)/dt = M eps + M' Omega^2 = u + F, F = 1/2 M' Omega^2 - D - S: the momentum
    # form the modulated fit uses (rsp_inertia.estimation.modulated), from its regressors,
    # which give M Omega and F exactly (but the spring's part of F, not linear in (c, phi0):
    # -S_spring, added here).
    params = params[0]
    direction = math.copysign(1.0, Omega)
    M = reduced_inertia(phi, params)
    eps = acceleration(phi, Omega, u, params)
    p = params.vector.copy()
    spring = ModelParameters(
        inertia_harmonics=np.zeros(5), stiffness=params.stiffness, zero_angle=params.zero_angle
    )
    p[[PARAMETER_NAMES.index("c"), PARAMETER_NAMES.index("phi0")]] = 0.0
    assert momentum_regressor(phi, Omega, params) @ p == pytest.approx(M * Omega, rel=1e-14)
    F = force_regressor(phi, Omega, params, direction) @ p - static_torque(phi, spring)
    dp_dt = M * eps + reduced_inertia_slope(phi, params) * Omega**2
    assert dp_dt == pytest.approx(
        u + F, rel=0, abs=1e-13 * torque_scale(params, Omega, u) * (1 + abs(Omega))
    )
    # F is quadratic in Omega: its second difference is h^2 F'' exactly, up to rounding.
    h = 0.1
    second = (
        force_regressor(phi, Omega + h, params, direction)
        + force_regressor(phi, Omega - h, params, direction)
        - 2 * force_regressor(phi, Omega, params, direction)
    ) @ p / h**2
    curvature = force_curvature_regressor(phi, Omega, params, direction) @ p
    scale = torque_scale(params, Omega, u) * (1 + Omega**2)
    assert second == pytest.approx(curvature, rel=0, abs=1e-9 * scale)


# --- 6. numeric functions broadcast --------------------------------------------------------

DEFAULTISH = ModelParameters(
    inertia_harmonics=[0.04, 0.001, 0.0007, 0.002, -0.001],
    stiffness=0.1,
    zero_angle=0.2,
    gravity_sin=0.06,
    gravity_cos=-0.04,
    coulomb=1e-4,
    viscous=1e-4,
    quadratic=1e-3,
)

# Each numeric function with the state arguments it takes, in order.
FUNCTIONS = {
    "reduced_inertia": (reduced_inertia, ("phi",)),
    "reduced_inertia_slope": (reduced_inertia_slope, ("phi",)),
    "potential": (potential, ("phi",)),
    "static_torque": (static_torque, ("phi",)),
    "dissipation": (dissipation, ("Omega",)),
    "acceleration": (acceleration, ("phi", "Omega", "u")),
    "motor_torque": (motor_torque, ("phi", "Omega", "eps")),
    "mechanical_energy": (mechanical_energy, ("phi", "Omega")),
}


@pytest.mark.parametrize("name", sorted(FUNCTIONS))
def test_numeric_functions_broadcast(name):
    function, names = FUNCTIONS[name]
    rng = np.random.default_rng(7)
    arrays = [rng.uniform(-2.0, 2.0, (2, 3)) for _ in names]

    out = function(*arrays, DEFAULTISH)
    assert isinstance(out, np.ndarray) and out.shape == (2, 3) and out.dtype == float
    # Element-wise: every entry is the scalar evaluation, and scalars give a Python float.
    for index in np.ndindex(2, 3):
        scalar = function(*(float(a[index]) for a in arrays), DEFAULTISH)
        assert type(scalar) is float
        assert out[index] == scalar
    # Mixed shapes broadcast as numpy does; 0-d arrays and numpy scalars count as scalars.
    column = [arrays[0][:, :1]] + [a[0] for a in arrays[1:]]
    expected = (2, 1) if len(names) == 1 else (2, 3)
    assert function(*column, DEFAULTISH).shape == expected
    zero_d = [np.float64(0.3)] + [np.array(0.7) for _ in names[1:]]
    assert type(function(*zero_d, DEFAULTISH)) is float
    empty = function(np.empty((0, 2)), *[0.5 for _ in names[1:]], DEFAULTISH)
    assert isinstance(empty, np.ndarray) and empty.shape == (0, 2)


# --- one RK4 step builder ------------------------------------------------------------------


def test_rk4_step_is_fourth_order():
    """On dx/dt = -x the step's error over a fixed span falls 2^4-fold per halved step."""
    x, h = ca.SX.sym("x"), ca.SX.sym("h")
    errors = []
    for substeps in (16, 32, 64):
        step = ca.Function("step", [x, h], [rk4_step(lambda z: -z, x, h, substeps)])
        errors.append(abs(float(step(1.0, 2.0)) - math.exp(-2.0)))
    assert errors[0] / errors[1] == pytest.approx(16, rel=0.1)
    assert errors[1] / errors[2] == pytest.approx(16, rel=0.1)


def _euler(derivative, x, h, substeps=1):
    """A stand-in for rk4_step: one explicit Euler step."""
    return x + h * derivative(x)


def test_the_simulator_and_the_ocp_step_with_rk4_step(monkeypatch):
    """rsp_inertia.virtual.integrate and rsp_inertia.ocp.feedforward build their steps with
    rk4_step: replaced by an Euler step, their step functions become Euler steps."""
    from rsp_inertia.ocp import feedforward
    from rsp_inertia.virtual import integrate

    params = ModelParameters(np.array([0.03, 0.001, 0.0, 0.0, 0.0]), 0.1, 0.2, 0.01, 0.0, 1e-3)
    x0, u, h = np.array([0.4, 3.0]), 0.05, 1e-3
    slope = np.array([3.0, acceleration(0.4, 3.0, u, params, direction=1.0)])
    monkeypatch.setattr(integrate, "rk4_step", _euler)
    step = integrate._build_step(8)
    np.testing.assert_allclose(
        np.asarray(step(x0, u, 1.0, params.vector, h)).ravel(), x0 + h * slope, rtol=1e-14
    )
    monkeypatch.setattr(feedforward, "rk4_step", _euler)
    step = feedforward._step_function(h)
    direction = feedforward._DIRECTION
    slope = np.array([3.0, acceleration(0.4, 3.0, u, params, direction=direction), 2.0])
    np.testing.assert_allclose(
        np.asarray(step([0.4, 3.0, u], 2.0, params.vector)).ravel(), [0.4, 3.0, u] + h * slope, rtol=1e-14
    )


# --- the least squares' bases are the model's -------------------------------------------


@PROPERTY
@given(J=tensors(), lam=st.floats(0.0, 6.0), tare=st.floats(0.0, 0.1), phi=angles)
def test_tensor_basis_is_the_models_reduced_inertia(J, lam, tare, phi):
    """tensor_basis(phi, lam) . J = M(phi) - M_tare = (1 + lam^2) e^T J e (docs/method.md §2)."""
    j6 = entries_from_tensor(J)
    row = tensor_basis(np.array([phi]), lam)[0]
    M = reduced_inertia(phi, ModelParameters(inertia_harmonics(j6, lam, tare)))
    scale = (1 + lam * lam) * np.abs(J).sum() + tare
    assert row @ j6 == pytest.approx(M - tare, rel=0, abs=1e-13 * scale)
    e = axis_direction(phi, lam)
    assert row @ j6 == pytest.approx((1 + lam * lam) * e @ J @ e, rel=0, abs=1e-13 * scale)
    np.testing.assert_allclose(
        harmonics_matrix(lam) @ j6 + [tare, 0, 0, 0, 0], inertia_harmonics(j6, lam, tare),
        rtol=0, atol=1e-15 * scale,
    )


@PROPERTY
@given(gs=unit, gc=unit, phi=angles)
def test_gravity_basis_is_the_models_gravity_potential(gs, gc, phi):
    params = ModelParameters(np.zeros(5), gravity_sin=gs, gravity_cos=gc)
    value = gravity_basis(np.array([phi]))[0] @ [gs, gc]
    assert value == pytest.approx(potential(phi, params), rel=0, abs=4 * EPS)
