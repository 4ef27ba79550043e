"""The torsion-pendulum baseline's best-practice reduction (rsp_inertia.estimation.pendulum)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy.optimize import brentq

from rsp_inertia.cli import main
from rsp_inertia.estimation.best_practice import best_practice_inertia, half_cycle_fit
from rsp_inertia.estimation.pendulum import crossing_period
from rsp_inertia.infra.errors import InputError
from rsp_inertia.plant.geometry import axis_direction, design_matrix, entries_from_tensor
from rsp_inertia.plant.logs import Log
from rsp_inertia.plant.model import reduced_inertia, static_torque
from rsp_inertia.plant.transducers import encoder_reading
from rsp_inertia.scenarios import create_default_experiment
from rsp_inertia.virtual.device import pendulum_parameters, simulate_pendulum

Q = 2 * math.pi / 65536


def _coulomb_viscous_oscillation(w_d, delta, shift, x0, duration, dt=1e-3):
    """The exact motion of M x'' + a2 x' + a1 sgn x' + k x = 0 from rest at x0: on each half
    cycle a damped oscillation about the centre +-a1/k (``shift``) opposite to the motion,
    until a turn within the shift, where static friction holds it."""
    t = np.arange(0.0, duration, dt)
    x = np.empty_like(t)
    start, x_start, half = 0.0, x0, math.pi / w_d
    k = 0
    while start < duration:
        if abs(x_start) <= shift:  # the spring no longer beats static friction: it sticks
            x[k:] = x_start
            break
        c = shift if x_start > 0 else -shift  # moving toward -x: friction pushes +x
        s = t[(t >= start) & (t < start + half)] - start
        x[k : k + s.size] = c + (x_start - c) * np.exp(-delta * s) * (
            np.cos(w_d * s) + delta / w_d * np.sin(w_d * s)
        )
        k += s.size
        x_start = c - (x_start - c) * math.exp(-delta * half)
        start += half
    return t, x


@pytest.mark.parametrize("bits, tolerance, delta_tolerance", [(16, 1e-4, 3e-3), (12, 3e-4, 1e-2)])
def test_half_cycle_fit_recovers_coulomb_and_viscous_oscillator(bits, tolerance, delta_tolerance):
    """Coulomb friction shifts each half cycle's centre and leaves w_d alone; viscous
    friction's decay gives w_n^2 = w_d^2 + delta^2. The fit recovers w_n within 3 of its std
    and ``tolerance``, and the equilibrium within a tenth of a count, from the quantized
    readings. At 12 bits (a 5 deg amplitude is 57 counts, the body stays on a count for up
    to tens of samples) the readings themselves biased w_n by +2.4e-3, 3.1 stds, and gave a
    negative delta; the encoder's edges do not (measured: w_n 16 bits 1.2e-5, 12 bits
    4.7e-5; delta 0.0208 and 0.0269)."""
    q = 2 * math.pi / 2**bits
    w_d, delta, shift = 6.3, 0.02, 4e-4
    t, x = _coulomb_viscous_oscillation(w_d, delta, shift, math.radians(5.0), 30.0)
    log = Log(t=t, phi=encoder_reading(x, q), torque=np.zeros_like(t))
    period, _ = crossing_period(log, "synthetic")
    fit = half_cycle_fit(log, period, q, "synthetic")
    w_n = math.hypot(w_d, delta)
    assert abs(fit.omega_n - w_n) <= 3 * fit.omega_n_std
    assert abs(fit.omega_n / w_n - 1) < tolerance
    assert abs(fit.delta - delta) < delta_tolerance
    assert abs(fit.centre) < 0.1 * q
    assert fit.residual_rms < 0.3 * q  # an edge's error is at most a count's, q / sqrt 12


def test_too_few_half_cycles_is_refused():
    """Coulomb friction that stops the pendulum within three half cycles: refused, saying
    how many it had and what to change."""
    t, x = _coulomb_viscous_oscillation(6.3, 0.02, 0.008, math.radians(5.0), 30.0)
    log = Log(t=t, phi=encoder_reading(x, Q), torque=np.zeros_like(t))
    with pytest.raises(InputError, match="half cycles of the oscillation.*needs 6"):
        half_cycle_fit(log, 2 * math.pi / 6.3, Q, "synthetic")


@pytest.mark.parametrize("stage, node", [(1, 0), (2, 1)])
def test_best_practice_on_the_virtual_pendulum(default_device, default_virtual, stage, node):
    """On the virtual device (Coulomb, viscous and quadratic friction, an off-centre body,
    M varying with the angle), with the true gravity terms: M at the oscillation's
    equilibrium within 3 of its std, and at least 5x closer than the classic formula's M to
    the node's (measured: 16x on stage 1 node 0 with 60 half cycles, 7x on stage 2 node 1
    with 12)."""
    device = default_device
    sim = simulate_pendulum(device, stage, default_virtual, node)
    p = pendulum_parameters(device, stage, default_virtual, node)
    phi_k = device.stages[stage - 1].nodes[node]
    period, _ = crossing_period(sim.log, "virtual")
    fit = half_cycle_fit(sim.log, period, device.encoder.quantum, "virtual")
    phi_eq = brentq(lambda a: float(np.ravel(static_torque(np.array([a]), p))[0]), phi_k - 0.3, phi_k + 0.3)
    assert fit.centre == pytest.approx(phi_eq, abs=5e-4)
    G = np.array([p.gravity_sin, p.gravity_cos])
    best = best_practice_inertia(fit, device.pendulum.stiffness, 0.0, fit.centre, G, np.zeros((2, 2)))
    M_eq = float(np.ravel(reduced_inertia(np.array([fit.centre]), p))[0])
    M_node = float(np.ravel(reduced_inertia(np.array([phi_k]), p))[0])
    assert abs(best.M - M_eq) <= 3 * best.M_std
    classic = device.pendulum.stiffness * (period / (2 * math.pi)) ** 2
    assert abs(best.M / M_eq - 1) < 0.2 * abs(classic / M_node - 1)
    assert set(best.budget) == {"fit", "stiffness", "gravity", "damping model", "amplitude"}


def test_identify_reports_the_best_practice_pendulum(tmp_path, capsys):
    """result.json's pendulum axes carry J_best, its std, its axis angle and budget, and
    tensor_best is within 3 of its stds of the truth (the gravity from the RSP fit)."""
    root = create_default_experiment(tmp_path / "exp")
    for part in ("braking", "pendulum"):
        assert main(["simulate", str(root), "--part", part]) == 0
    assert main(["simulate", str(root), "--part", "reverse", "--ideal"]) == 0
    assert main(["identify", str(root)]) == 0
    capsys.readouterr()
    result = json.loads((root / "result.json").read_text())
    pend = result["pendulum"]
    from rsp_inertia.plant.config import load_device
    from rsp_inertia.virtual.config import load_virtual

    device = load_device(root / "device.toml")
    truth = entries_from_tensor(load_virtual(root / "virtual.toml").body.tensor)
    for axis in pend["axes"]:
        st = device.stages[axis["stage"] - 1]
        d = axis_direction(math.radians(axis["phi_best_deg"]), st.gear_ratio)
        J_true = float((design_matrix(d[None, :]) @ truth)[0])
        assert abs(axis["J_best"] - J_true) <= 3 * axis["J_best_std"]
        assert set(axis["best_budget"]) == {
            "fit", "stiffness", "gravity", "damping model", "amplitude", "empty system"
        }
    assert pend["best_stiffness"] == {"value": 2.0, "std": 0.0, "source": "device.toml"}
    best = np.array(list(pend["tensor_best"].values()))
    std = np.array(list(pend["tensor_best_std"].values()))
    assert np.all(np.abs(best - truth) <= 3 * std)
    classic = np.array(list(pend["tensor_classic"].values()))
    assert np.abs(best - truth).max() < 0.2 * np.abs(classic - truth).max()
