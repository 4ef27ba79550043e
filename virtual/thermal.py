"""The virtual motor's temperature: a winding heated by its current, magnets that lag behind.

A lumped two-node model (virtual.toml ``[rig]``), in kelvin above the ambient: the winding
(rise w) dissipates P = I^2 R with I = the logged command / ``torque_constant`` and loses heat
to the ambient through R_th; the magnets (rise m) follow the winding through a first-order lag:

    tau_w dw/dt = P R_th - w,        tau_m dm/dt = w - m      (tau_m = 0: m = w).

The drive holds its command over each sample, so P is constant there and a sample's step is
the closed form (:func:`advance_motor`): w(t) = w_inf + a e^{-t/tau_w}, w_inf = P R_th,
a = w0 - w_inf, and

    m(t) = w_inf + c e^{-t/tau_w} + (m0 - w_inf - c) e^{-t/tau_m},  c = a tau_w / (tau_w - tau_m)

(tau_m = tau_w: m(t) = w_inf + ((m0 - w_inf) + a t / tau_m) e^{-t/tau_m}). The resistance's own
temperature coefficient is left out (copper's +0.39%/K changes P by a fraction of a percent
over the rises of a run).

The torque constant follows the magnets: over a sample the body receives the factor 1 + alpha
m at the sample's start (rsp_inertia.plant.transducers.thermal_gains); the magnets move by
about 1e-4 K in a 1 ms sample, a factor of 1e-7.

What carries from pass to pass, deterministically: every run (a braking and its reverse)
starts with winding and magnets at the ambient (the motor has cooled between runs, and
calibration and loaded runs are separate folders), or, with ``[rig] run_start_rise``, run k
of the experiment k times that above it (:func:`run_start`: a motor not left to cool, whose
runs span the magnets' temperature, as a calibration that measures the tempco needs); the reverse starts at the braking's end
temperatures, at once (no pause between the passes); pilot and pendulum runs stay at the
ambient. ``[rig] reverse_temperature_offset`` adds a prescribed rise to the whole motor for
every reverse pass on top of this. The logger records the winding's temperature (a sensor on
the winding or the housing), with ``temperature_noise`` and rounded to 0.1 K; the magnets'
is never logged.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rsp_inertia.plant.config import Device
from rsp_inertia.plant.direction import Direction
from rsp_inertia.virtual.config import Rig

__all__ = [
    "COLD",
    "TEMPERATURE_QUANTUM",
    "MotorState",
    "advance_motor",
    "heating_power",
    "logged_temperature",
    "run_start",
]

TEMPERATURE_QUANTUM = 0.1
"""K, the logged temperature's resolution."""


@dataclass(frozen=True)
class MotorState:
    """The motor's temperatures above the ambient (virtual.toml ``[rig] ambient_temperature``)."""

    winding: float = 0.0
    """K, the winding's rise."""
    magnet: float = 0.0
    """K, the magnets' rise."""


COLD = MotorState()
"""A motor at the ambient: every run starts so."""


def run_start(rig: Rig, device: Device, stage: int, direction: Direction) -> MotorState:
    """The motor's rises at the start of the run of ``stage`` in ``direction``: k x ``[rig]
    run_start_rise`` for both winding and magnets, k the run's place (from 0) in the order the
    device makes its runs, stage by stage, its directions in device.toml's order
    (:data:`COLD` when the key is 0, today's runs).

    Parameters
    ----------
    rig : Rig
        virtual.toml ``[rig]``.
    device : Device
        The gimbal: its stages and their directions.
    stage : int
        The stage, from 1.
    direction : Direction
        The run's direction.

    Returns
    -------
    MotorState
        The rises, K.
    """
    if rig.run_start_rise == 0.0:
        return COLD
    before = sum(len(st.directions) for st in device.stages[: stage - 1])
    k = before + list(device.stages[stage - 1].directions).index(direction)
    rise = k * rig.run_start_rise
    return MotorState(winding=rise, magnet=rise)


def heating_power(rig: Rig, command):
    """W, the winding's dissipation I^2 R, I = ``command`` / ``rig.torque_constant``.

    Parameters
    ----------
    rig : Rig
        virtual.toml ``[rig]``: its torque constant and winding resistance.
    command : float or array_like
        N m, the logged command (reduced to phi, as the torque constant).

    Returns
    -------
    float or numpy.ndarray
        W, shaped like ``command``.
    """
    current = np.asarray(command, dtype=float) / rig.torque_constant
    power = current * current * rig.winding_resistance
    return float(power) if np.ndim(power) == 0 else power


def advance_motor(rig: Rig, state: MotorState, power: float, h):
    """The winding's and the magnets' rises after ``h`` seconds at the constant ``power``
    (module docstring: the closed form).

    Parameters
    ----------
    rig : Rig
        virtual.toml ``[rig]``: thermal resistance, winding time constant, magnet lag.
    state : MotorState
        The rises at the start.
    power : float
        W, the winding's dissipation, held.
    h : float or array_like
        s, >= 0: one time or several from the same start.

    Returns
    -------
    winding, magnet : float or numpy.ndarray
        K, the rises at ``h``, shaped like it.
    """
    h = np.asarray(h, dtype=float)
    tw, tm = rig.winding_time_constant, rig.magnet_lag
    w_inf = power * rig.thermal_resistance
    a = state.winding - w_inf
    ew = np.exp(-h / tw)
    w = w_inf + a * ew
    if tm == 0.0:
        m = w
    else:
        em = np.exp(-h / tm)
        if abs(tw - tm) <= 1e-9 * tw:  # the double root: the limit of the general form
            m = w_inf + ((state.magnet - w_inf) + a * h / tm) * em
        else:
            c = a * tw / (tw - tm)
            m = w_inf + c * ew + (state.magnet - w_inf - c) * em
    if w.ndim == 0:
        return float(w), float(m)
    return w, m


def logged_temperature(rig: Rig, winding, seed: list[int]) -> np.ndarray:
    """degC, what the logger records: the ambient plus the winding's rise, plus the sensor's
    noise (``[rig] temperature_noise``, drawn on ``seed``), rounded to
    :data:`TEMPERATURE_QUANTUM`.

    Parameters
    ----------
    rig : Rig
        virtual.toml ``[rig]``.
    winding : array_like
        K, the winding's rise at each row.
    seed : list of int
        The random stream of the noise.

    Returns
    -------
    numpy.ndarray
        degC, one per row.
    """
    winding = np.asarray(winding, dtype=float)
    noise = rig.temperature_noise
    reading = rig.ambient_temperature + winding
    if noise > 0.0:
        reading = reading + np.random.default_rng(seed).normal(0.0, noise, winding.shape)
    return np.round(reading / TEMPERATURE_QUANTUM) * TEMPERATURE_QUANTUM
