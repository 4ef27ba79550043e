"""The reduced model (rsp_inertia.plant.model) against an independent 3-D engine (MuJoCo).

benchmarks.engine builds the gimbal from physical frames: an outer frame on a vertical hinge,
a shaft on a horizontal hinge it carries, the body and a fixture welded to the shaft, the
gear as a joint equality psi = lambda phi. The engine knows nothing of M(phi)'s harmonic
form, of Lagrange's equation reduced to phi or of the gravity terms Gs, Gc: its joint-space
mass matrix, its bias forces and its energies come from the rigid bodies alone. Here the
model's M(phi), energies and acceleration, with the harmonics of inertia_harmonics and the
truth built in this file from the parts, must agree with it to rounding.

Tolerances: both sides are exact formulas evaluated in double precision (the engine
diagonalises each part's central tensor and rebuilds it; the model sums five harmonics), so
they agree to about 1e-14 relative; 1e-12 (inertia, energy) and 1e-10 (acceleration, a
quotient of differences) leave room for the rounding of another platform's libm and BLAS.
"""

from __future__ import annotations

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

from benchmarks.engine import Gimbal, GimbalEngine
from rsp_inertia.plant.model import (
    ModelParameters,
    acceleration,
    dissipation,
    inertia_harmonics,
    potential,
    reduced_inertia,
)
from rsp_inertia.plant.reference_config import TrueBody

GRAVITY = 9.80665
GEAR_RATIOS = (0.0, 0.7639320225, 5.2360679775)
ANGLES = np.linspace(-3.0, 3.1, 7)
FRAME_INERTIA = 0.0013
"""kg m^2, the outer frame about the vertical."""


def random_part(rng: np.random.Generator, mass: float, size: float, offset: float) -> TrueBody:
    """A physical rigid part with every product non-zero: principal moments about its centre
    of mass that satisfy the triangle inequality, turned by a random rotation, its centre of
    mass ``offset`` m from O in a random direction; its tensor about O by the parallel-axis
    theorem J_O = J_G + m (|c|^2 1 - c c^T)."""
    a, b = rng.uniform(0.3, 1.0, 2) * size
    principal = np.array([a, b, rng.uniform(abs(a - b), a + b)])
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    rotation = q * np.sign(np.diag(r))
    J_G = rotation @ np.diag(principal) @ rotation.T
    c = rng.normal(size=3)
    c *= offset / np.linalg.norm(c)
    J_O = J_G + mass * (c @ c * np.eye(3) - np.outer(c, c))
    entries = [J_O[0, 0], J_O[1, 1], J_O[2, 2], J_O[0, 1], J_O[1, 2], J_O[0, 2]]
    assert min(abs(e) for e in entries[3:]) > 1e-6 * size
    return TrueBody(mass=mass, inertia=np.array(entries), com=c)


def bodies() -> list[tuple[TrueBody, TrueBody]]:
    """(body, fixture) pairs: seeded random parts, centres of mass from 0 to 5 cm off O."""
    rng = np.random.default_rng(20240601)
    pairs = []
    for offset in (0.0, 0.004, 0.05):
        body = random_part(rng, rng.uniform(0.5, 3.0), 0.03, offset)
        fixture = random_part(rng, 0.8, 0.005, 0.002)
        pairs.append((body, fixture))
    return pairs


def model_parameters(
    body: TrueBody, fixture: TrueBody, gear_ratio: float, friction=(0.0, 0.0, 0.0)
) -> ModelParameters:
    """The reduced model of body + fixture + outer frame (docs/method.md §2-3): the harmonics
    of each part on the shaft add, the outer frame adds lambda^2 I to the tare; the gravity
    terms are g sum m x_c, g sum m y_c."""
    harmonics = inertia_harmonics(body.inertia, gear_ratio, gear_ratio**2 * FRAME_INERTIA)
    harmonics = harmonics + inertia_harmonics(fixture.inertia, gear_ratio, 0.0)
    moment = body.mass * body.com + fixture.mass * fixture.com
    return ModelParameters(
        inertia_harmonics=harmonics,
        gravity_sin=GRAVITY * moment[0],
        gravity_cos=GRAVITY * moment[1],
        coulomb=friction[0],
        viscous=friction[1],
        quadratic=friction[2],
    )


def engine(body, fixture, gear_ratio, **options) -> GimbalEngine:
    return GimbalEngine(
        Gimbal(gear_ratio, body, fixture, frame_inertia=FRAME_INERTIA, gravity=GRAVITY, **options)
    )


def mirrored_x(part: TrueBody) -> TrueBody:
    """The part mirrored in x: Jxy, Jxz and x_c change sign."""
    return TrueBody(
        mass=part.mass,
        inertia=part.inertia * np.array([1, 1, 1, -1, 1, -1]),
        com=part.com * np.array([-1, 1, 1]),
    )


def flipped_odd(part: TrueBody) -> TrueBody:
    """The part with Jxz and Jyz negated (what a reversed gear does to the harmonics)."""
    return TrueBody(
        mass=part.mass, inertia=part.inertia * np.array([1, 1, 1, 1, -1, -1]), com=part.com
    )


@pytest.mark.parametrize("gear_ratio", GEAR_RATIOS)
@pytest.mark.parametrize("pair", range(3))
def test_reduced_inertia_is_the_engines_mass_matrix_along_the_gear(gear_ratio, pair):
    """M(phi) = g^T M2 g, g = (lambda, 1), M2 the engine's joint-space mass matrix."""
    body, fixture = bodies()[pair]
    gimbal = engine(body, fixture, gear_ratio)
    M_engine = np.array([gimbal.reduced_inertia(phi) for phi in ANGLES])
    M_model = reduced_inertia(ANGLES, model_parameters(body, fixture, gear_ratio))
    np.testing.assert_allclose(M_model, M_engine, rtol=1e-12, atol=0)


def test_the_outer_frames_other_moments_never_enter():
    """The outer frame only turns about z1: its moments about its own x and y are not in M."""
    body, fixture = bodies()[1]
    light = engine(body, fixture, 5.2360679775, frame_side_inertia=(0.001, 0.001))
    heavy = engine(body, fixture, 5.2360679775, frame_side_inertia=(0.5, 0.5))
    for phi in ANGLES:
        assert heavy.reduced_inertia(phi) == pytest.approx(light.reduced_inertia(phi), rel=1e-13)


@pytest.mark.parametrize("gear_ratio", GEAR_RATIOS)
@pytest.mark.parametrize("pair", range(3))
def test_energies_are_the_models(gear_ratio, pair):
    """The engine's kinetic energy at qvel = Omega (lambda, 1) is M Omega^2 / 2; its potential
    is the model's gravity potential (the outer frame's centre of mass sits at O: no
    constant)."""
    body, fixture = bodies()[pair]
    gimbal = engine(body, fixture, gear_ratio)
    params = model_parameters(body, fixture, gear_ratio)
    scale = GRAVITY * (body.mass * np.linalg.norm(body.com) + fixture.mass * 0.002)
    for phi, Omega in zip(ANGLES, np.linspace(-9.0, 12.0, ANGLES.size), strict=True):
        V, T = gimbal.energies(phi, Omega)
        assert T == pytest.approx(reduced_inertia(phi, params) * Omega**2 / 2, rel=1e-12)
        assert abs(V - potential(phi, params)) <= 1e-12 * scale


@pytest.mark.parametrize("gear_ratio", GEAR_RATIOS)
@pytest.mark.parametrize("pair", range(3))
def test_acceleration_is_lagranges_equation(gear_ratio, pair):
    """The engine's equations projected on the gear, g^T M2 g eps = g^T (tau - bias), give the
    model's eps = (u - 1/2 M' Omega^2 - static torque) / M, friction off."""
    body, fixture = bodies()[pair]
    gimbal = engine(body, fixture, gear_ratio)
    params = model_parameters(body, fixture, gear_ratio)
    for phi, Omega, u in zip(
        ANGLES, np.linspace(-9.0, 12.0, ANGLES.size), np.linspace(-0.3, 0.2, ANGLES.size),
        strict=True,
    ):
        eps = gimbal.acceleration(phi, Omega, u)
        assert eps == pytest.approx(acceleration(phi, Omega, u, params), rel=1e-10, abs=1e-12)


@pytest.mark.parametrize("gear_ratio", GEAR_RATIOS)
def test_acceleration_with_friction(gear_ratio):
    """A known dissipative torque: the joint's damping is the model's a2, and the Coulomb and
    quadratic terms applied as a joint force -(a1 + a3 W^2) sign W; the model's eps with
    friction a = (a1, a2, a3)."""
    body, fixture = bodies()[2]
    a = (2e-3, 3e-3, 4e-3)
    gimbal = engine(body, fixture, gear_ratio, viscous=a[1])
    params = model_parameters(body, fixture, gear_ratio, friction=a)
    without_viscous = model_parameters(body, fixture, gear_ratio, friction=(a[0], 0.0, a[2]))
    for phi, Omega, u in zip(
        ANGLES, np.linspace(-9.0, 12.0, ANGLES.size), np.linspace(-0.3, 0.2, ANGLES.size),
        strict=True,
    ):
        applied = -dissipation(Omega, without_viscous)
        eps = gimbal.acceleration(phi, Omega, u, applied=applied)
        assert eps == pytest.approx(acceleration(phi, Omega, u, params), rel=1e-10, abs=1e-12)


@pytest.mark.parametrize("gear_ratio", GEAR_RATIOS[1:])
def test_a_reversed_gear_is_the_model_with_jxz_and_jyz_flipped(gear_ratio):
    """psi = -lambda phi: the cone is swept the other way round, sin phi and cos phi's
    harmonics (2 lambda Jxz, 2 lambda Jyz) change sign. A lab that fits such a rig with
    lambda > 0 reads Jxz and Jyz with the wrong sign, and nothing else."""
    body, fixture = bodies()[1]
    reversed_gear = engine(body, fixture, -gear_ratio)
    flipped = model_parameters(flipped_odd(body), flipped_odd(fixture), gear_ratio)
    naive = model_parameters(body, fixture, gear_ratio)
    M_engine = np.array([reversed_gear.reduced_inertia(phi) for phi in ANGLES])
    np.testing.assert_allclose(reduced_inertia(ANGLES, flipped), M_engine, rtol=1e-12, atol=0)
    assert np.max(np.abs(reduced_inertia(ANGLES, naive) - M_engine)) > 1e-4 * M_engine.max()
    for phi, Omega, u in ((0.4, 3.0, 0.1), (2.5, -6.0, -0.05)):
        eps = reversed_gear.acceleration(phi, Omega, u)
        assert eps == pytest.approx(acceleration(phi, Omega, u, flipped), rel=1e-10)


@pytest.mark.parametrize("gear_ratio", GEAR_RATIOS)
def test_phi_read_from_the_other_end_is_the_body_mirrored_in_x(gear_ratio):
    """An encoder (and motor) on the other end of the shaft reads phi' = -phi and logs the
    torque u' = -u: the engine's motion, described in (phi', u'), is the model of the body
    mirrored in x (Jxy, Jxz, x_c negated), same gear ratio."""
    body, fixture = bodies()[2]
    gimbal = engine(body, fixture, gear_ratio)
    mirrored = model_parameters(mirrored_x(body), mirrored_x(fixture), gear_ratio)
    for phi_, Omega_, u_ in ((0.4, 3.0, 0.1), (2.5, -6.0, -0.05), (-1.3, 8.0, 0.0)):
        M = gimbal.reduced_inertia(-phi_)
        assert reduced_inertia(phi_, mirrored) == pytest.approx(M, rel=1e-12)
        V, _ = gimbal.energies(-phi_, 0.0)
        assert potential(phi_, mirrored) == pytest.approx(V, rel=1e-12, abs=1e-15)
        eps_ = -gimbal.acceleration(-phi_, -Omega_, -u_)
        assert eps_ == pytest.approx(acceleration(phi_, Omega_, u_, mirrored), rel=1e-10)


def test_the_engines_gear_holds_and_conserves_energy():
    """Free motion on the engine (RK4, no friction, motor off) over 0.5 s at speed: the soft
    gear constraint, made as stiff as MuJoCo allows, holds psi = lambda phi to 1e-9 rad and
    the mechanical energy stays within 1e-9 relative (the integrator's and the constraint's
    combined error), as the reduced model's own integrator does (tests/virtual)."""
    body, fixture = bodies()[2]
    gimbal = engine(body, fixture, 5.2360679775)
    gimbal.set_state(0.2, 4.0)
    m, d = gimbal.model, gimbal.data
    start = d.energy.sum()
    worst = 0.0
    for _ in range(50):
        mujoco.mj_step(m, d, nstep=100)
        worst = max(worst, abs(d.qpos[0] - 5.2360679775 * d.qpos[1]))
    mujoco.mj_forward(m, d)
    assert d.qpos[1] > 1.0  # it turned
    assert worst < 1e-9
    assert abs(d.energy.sum() - start) < 1e-9 * abs(d.energy[1])


@pytest.mark.slow
def test_the_calibrated_route_on_engine_made_logs(tmp_path):
    """The whole calibrated route on logs MuJoCo made (benchmarks.engine.calibrated_route):
    empty-fixture and reference-body folders and the body's, each stage braked to rest and
    its reverse, program.csv from `rsp-inertia program`, executed in closed loop on the
    engine; then calibrate and identify. The identified tensor is the body's within 3 of its
    stds and within 1e-4 of its largest moment (about 1 min)."""
    from benchmarks.engine import BODY, calibrated_route

    row = calibrated_route(tmp_path, 0)
    err = np.subtract(row["entries"], BODY.inertia)
    std = np.asarray(row["entries_std"])
    assert np.all(np.abs(err) <= 1e-4 * BODY.inertia[:3].max()), err
    assert np.all(np.abs(err) <= 3 * std), err / std
    # The engine's gimbal, built from frames as docs/method.md §1 states the conventions,
    # passes calibrate's check of them with the demo rig's turned reference, its encoder's
    # zero (the engine's is exactly 0) within 3 stds.
    assert row["conventions"].startswith("conventions verified by the reference"), row
    assert abs(row["zero_deg"]) <= 3 * row["zero_std_deg"]
