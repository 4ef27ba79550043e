"""The virtual device's true model and its integration (docs/method.md §4).

:func:`true_parameters` is the one place the true model of a stage comes from: device.toml's
gimbal with virtual.toml's moving system, rig and friction. The friction depends on the
direction of motion, so every integration carries a pair of parameter vectors (forward for
Omega > 0, backward for Omega < 0) and uses the one of the current direction.

The integrator is the model's fixed-step RK4 (:func:`rsp_inertia.plant.model.rk4_step`),
``SUBSTEPS`` steps per encoder sample, the torque held constant over each sample; CasADi maps
it over ``BLOCK`` samples per call while the torque and the direction of motion stay the
same. Stops are events: the instant the speed crosses zero inside a sample is found by
Brent's method on the step length, and static friction then decides whether the body stays at
rest (|u - static torque| <= a1) or breaks away (:func:`advance`). With no dissipation and no
torque the mechanical energy is conserved to better than 1e-9 relative over 10 s
(tests/plant/test_virtual.py).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import casadi as ca
import numpy as np
from scipy.optimize import brentq

from rsp_inertia.infra.errors import InputError
from rsp_inertia.plant.config import Device
from rsp_inertia.plant.friction import FRICTION
from rsp_inertia.plant.model import (
    MODEL,
    PARAMETER_NAMES,
    ModelParameters,
    inertia_harmonics,
    rk4_step,
    static_torque,
)
from rsp_inertia.virtual.config import Virtual, placed_body

__all__ = [
    "BLOCK",
    "SUBSTEPS",
    "Pair",
    "advance",
    "integrate_free",
    "integrate_to_stop",
    "pendulum_parameters",
    "samples_to_angle",
    "step_block",
    "true_pair",
    "true_parameters",
]

SUBSTEPS = 8
"""RK4 steps per encoder sample (integration step dt/8: 0.125 ms at 1 kHz)."""

BLOCK = 1000
"""Samples integrated per call while the torque and the direction of motion are constant."""

_COULOMB = PARAMETER_NAMES.index(FRICTION.static)
"""Index of a1 in the parameter vector: the static friction at rest."""

Pair = tuple[np.ndarray, np.ndarray]
"""(p_forward, p_backward): parameter vectors for Omega > 0 and Omega < 0."""


def _build_step(substeps: int = SUBSTEPS) -> ca.Function:
    """``step(x, u, direction, p, h)``: advance x = (phi, Omega) by h with u held constant."""
    x = ca.SX.sym("x", 2)
    u, direction, h = ca.SX.sym("u"), ca.SX.sym("direction"), ca.SX.sym("h")
    f = MODEL.state_derivative()
    end = rk4_step(lambda z: f(z, u, direction, MODEL.p), x, h, substeps)
    return ca.Function("step", [x, u, direction, MODEL.p, h], [end])


_STEP = _build_step()
_STEP_BLOCK = _STEP.mapaccum(BLOCK)
_COARSE_STEP = _build_step(1)
_COARSE_BLOCK = _COARSE_STEP.mapaccum(BLOCK)


def _step(x: np.ndarray, u: float, direction: float, p: np.ndarray, h: float, fn: ca.Function):
    return np.asarray(fn(x, u, direction, p, h)).ravel()


def step_block(x: np.ndarray, u: float, direction: float, p: np.ndarray, h: float) -> np.ndarray:
    """The states (phi, Omega) after each of ``BLOCK`` steps of length ``h`` from ``x``, with
    the inputs held throughout (``SUBSTEPS`` RK4 steps each).

    Parameters
    ----------
    x : numpy.ndarray, shape (2,)
        The initial state (phi, Omega), rad and rad/s.
    u : float
        N m, the motor torque.
    direction : float
        The friction sign, +1 or -1.
    p : numpy.ndarray, shape (12,)
        The model's parameter vector.
    h : float
        s, the step length; a negative ``h`` integrates back.

    Returns
    -------
    numpy.ndarray, shape (BLOCK, 2)
        The states after each step.
    """
    return np.asarray(_STEP_BLOCK(x, u, direction, p, h)).T


def integrate_to_stop(
    x0: np.ndarray,
    u: float | Callable[[int, int], np.ndarray],
    direction: float,
    p: np.ndarray,
    dt: float,
    max_time: float,
    coarse: bool = False,
) -> tuple[np.ndarray, np.ndarray, float, float] | None:
    """A motion under the torque ``u`` from ``x0`` until the speed first reaches zero.

    RK4 (``SUBSTEPS`` per sample) of the model, whole blocks of samples per call; the stop
    is an event located inside its sample by Brent's method on the step length.

    Parameters
    ----------
    x0 : numpy.ndarray, shape (2,)
        The initial state (phi, Omega), rad and rad/s.
    u : float or callable
        N m, the constant motor torque; or ``u(k, count)``, the torques held over the samples
        k, ..., k + count - 1 (an array of ``count``: a torque that drifts from sample to
        sample, held over each, as a warming motor's: rsp_inertia.virtual.thermal).
    direction : float
        The friction sign: the sign of the speed, +1 or -1.
    p : numpy.ndarray, shape (12,)
        The model's parameter vector.
    dt : float
        s, the sampling period.
    max_time : float
        s, how long the body may move before giving up.
    coarse : bool, optional
        One RK4 step per sample, for planning (at 1 kHz and the 2 Omega harmonic of a
        15 rad/s pass, h w = 0.03: a local error ~(h w)^5 / 120 = 2e-10 of the state per step).

    Returns
    -------
    tuple or None
        The sample times (s), the states (phi, Omega) at every sample before the stop (and
        at the stop if it falls on a sample), the stop's time (s) and angle (rad); None if
        the body still moves after ``max_time`` seconds.
    """
    step_blocks, step = (_COARSE_BLOCK, _COARSE_STEP) if coarse else (_STEP_BLOCK, _STEP)
    x = np.asarray(x0, dtype=float)
    states = [x[None, :]]
    max_samples = int(max_time / dt)
    n = 1
    torques = u if callable(u) else None
    while True:
        if torques is not None:  # the block's samples n - 1, ..., n + BLOCK - 2, one row
            u = np.asarray(torques(n - 1, BLOCK), dtype=float).reshape(1, BLOCK)
        block = np.asarray(step_blocks(x, u, direction, p, dt)).T  # (BLOCK, 2)
        stopped = np.nonzero(block[:, 1] * direction <= 0.0)[0]
        if stopped.size:
            k = stopped[0]
            states.append(block[:k])
            n += k
            x = block[k - 1] if k > 0 else x
            if torques is not None:  # the torque of the sample the stop falls in
                u = float(np.asarray(torques(n - 1, 1)).ravel()[0])
            break
        states.append(block)
        n += BLOCK
        x = block[-1]
        if n > max_samples:
            return None
    h_stop = brentq(
        lambda h: _step(x, u, direction, p, h, step)[1] * direction,
        0.0, dt, xtol=1e-15, rtol=1e-15,
    )
    end = _step(x, u, direction, p, h_stop, step)
    traj = np.concatenate(states)
    t = np.arange(n) * dt
    if h_stop >= dt * (1 - 1e-12):  # the stop falls on a sample: it belongs to the log
        traj = np.vstack([traj, [end[0], 0.0]])
        t = np.arange(n + 1) * dt
    return t, traj, (n - 1) * dt + h_stop, float(end[0])


def samples_to_angle(
    x0: np.ndarray,
    u: float,
    direction: float,
    p: np.ndarray,
    dt: float,
    angle: float,
    max_time: float,
) -> int | None:
    """The first sample at which a motion from ``x0`` under the constant torque ``u`` has
    covered ``angle`` (rad, > 0, in the direction of motion): where a two-level braking's
    drive switches its torque.

    Same integration as :func:`integrate_to_stop` (whose samples up to the returned one it
    reproduces).

    Parameters
    ----------
    x0 : numpy.ndarray, shape (2,)
        The initial state (phi, Omega), rad and rad/s.
    u : float
        N m, the motor torque, held.
    direction : float
        The friction sign: the sign of the speed, +1 or -1.
    p : numpy.ndarray, shape (12,)
        The model's parameter vector.
    dt : float
        s, the sampling period.
    angle : float
        rad, > 0: the angle to cover.
    max_time : float
        s, how long the body may move before giving up.

    Returns
    -------
    int or None
        The sample's index (sample 0 is ``x0``); None if the body stops first or still has
        not covered ``angle`` after ``max_time`` seconds.
    """
    x = np.asarray(x0, dtype=float)
    start = float(x[0])
    n = 1
    while n <= int(max_time / dt):
        block = np.asarray(_STEP_BLOCK(x, u, direction, p, dt)).T
        stopped = np.nonzero(block[:, 1] * direction <= 0.0)[0]
        end = stopped[0] if stopped.size else BLOCK
        past = np.nonzero((block[:end, 0] - start) * direction >= angle)[0]
        if past.size:
            return n + int(past[0])
        if stopped.size:
            return None
        n += BLOCK
        x = block[-1]
    return None


def true_parameters(
    device: Device, stage: int, virtual: Virtual, direction: float = 1
) -> ModelParameters:
    """The true model of stage ``stage`` (1-based) while the body moves in ``direction``.

    device.toml's gimbal with virtual.toml's moving system. The moving system is the body,
    placed on the rig by its mounting (:func:`rsp_inertia.virtual.config.placed_body`), and the
    fixture (either may be absent): their tensors, both about O in rig axes, add
    (docs/method.md §2), and so do their gravity terms Gs = sum m g x_c, Gc = sum m g y_c
    (docs/method.md §3). The tare is the rig's true one (``[rig] tare_inertia``, else
    device.toml's, :meth:`rsp_inertia.virtual.config.Rig.true_tare`); the friction that of the
    direction of motion (:meth:`rsp_inertia.virtual.config.Virtual.friction_for`).

    Parameters
    ----------
    device : Device
        The gimbal.
    stage : int
        The stage number, from 1.
    virtual : Virtual
        The virtual device's truth.
    direction : {+1, -1}
        The sign of Omega: +1 forward motion, -1 backward motion.

    Returns
    -------
    ModelParameters
        The parameters of :mod:`rsp_inertia.plant.model`, the same in both directions but for
        friction; ``virtual.models``' entry for the stage when it has them.

    Raises
    ------
    InputError
        ``[rig] tare_inertia`` does not have one entry per stage of the device.
    """
    if direction not in (1, -1):
        raise ValueError(f"direction must be +1 or -1 (the sign of Omega), got {direction!r}")
    if virtual.models is not None:
        return virtual.models[stage - 1]
    st = device.stages[stage - 1]
    parts = [part for part in (placed_body(device, virtual), virtual.fixture) if part is not None]
    g = device.gravity
    inertia = sum((part.inertia for part in parts), np.zeros(6))
    tare = virtual.rig.true_tare(device, stage)
    friction = virtual.friction_for(direction)
    gravity_sin = sum(part.mass * g * part.com[0] for part in parts)
    gear_ratio = -st.gear_ratio if virtual.rig.gear_reversed else st.gear_ratio
    if virtual.rig.phi_left_handed:  # the truth mirrored in x, read the stated way
        inertia = inertia * np.array([1.0, 1.0, 1.0, -1.0, 1.0, -1.0])
        gravity_sin = -gravity_sin
    return ModelParameters(
        inertia_harmonics=inertia_harmonics(inertia, gear_ratio, tare),
        stiffness=device.spring.stiffness,
        zero_angle=device.spring.zero_angle,
        gravity_sin=gravity_sin,
        gravity_cos=sum(part.mass * g * part.com[1] for part in parts),
        **FRICTION.fields_of(friction),
    )


def true_pair(device: Device, stage: int, virtual: Virtual) -> Pair:
    """(p_forward, p_backward) of :func:`true_parameters`.

    Parameters
    ----------
    device : Device
        The gimbal.
    stage : int
        The stage number, from 1.
    virtual : Virtual
        The virtual device's truth.

    Returns
    -------
    Pair
        The parameter vectors for Omega > 0 and Omega < 0.
    """
    forward = true_parameters(device, stage, virtual, 1).vector
    return forward, true_parameters(device, stage, virtual, -1).vector


def pendulum_parameters(
    device: Device, stage: int, virtual: Virtual, node: int, direction: float = 1
) -> ModelParameters:
    """The true model during the pendulum run at node ``node`` (0-based) of a stage.

    The torsion element of device.toml's ``[pendulum]`` is attached and zeroed at the node,
    with the rig's true stiffness (virtual.toml ``[rig] pendulum_stiffness``, else
    device.toml's); everything else (body, fixture, gravity, the friction of ``direction``)
    is the stage's (:func:`true_parameters`).

    Parameters
    ----------
    device : Device
        The gimbal, with its ``[pendulum]`` table.
    stage : int
        The stage number, from 1.
    virtual : Virtual
        The virtual device's truth.
    node : int
        The node's index in the stage, from 0.
    direction : {+1, -1}
        The sign of Omega, whose friction applies.

    Returns
    -------
    ModelParameters
        The stage's true model with the pendulum's spring.

    Raises
    ------
    InputError
        device.toml has no ``[pendulum]`` table.
    """
    if device.pendulum is None:
        raise InputError("device.toml: pendulum: missing [pendulum] table (its stiffness)")
    return dataclasses.replace(
        true_parameters(device, stage, virtual, direction),
        stiffness=(
            device.pendulum.stiffness
            if virtual.rig.pendulum_stiffness is None
            else virtual.rig.pendulum_stiffness
        ),
        zero_angle=float(device.stages[stage - 1].nodes[node]),
    )


def _pick(pair: Pair, direction: float) -> np.ndarray:
    """The parameter vector of the direction of motion ``direction`` (+1 or -1)."""
    return pair[0] if direction > 0 else pair[1]


def advance(
    x: np.ndarray, u: float, h: float, pair: Pair, coarse: bool = False
) -> np.ndarray:
    """Advance the true state over h with the physical torque u held, with stops and static
    friction.

    Between stops the direction of motion is fixed, and so is the parameter vector (``pair``:
    forward, backward); a zero crossing of the speed inside the interval is located (Brent),
    the body is set at rest there, and static friction decides (docs/method.md §4): it stays
    while |u - static torque| <= a1, a1 that of the direction the net torque would move it,
    else it breaks away in that direction.

    Parameters
    ----------
    x : numpy.ndarray, shape (2,)
        The true state (phi, Omega), rad and rad/s.
    u : float
        N m, the physical torque, held over the interval.
    h : float
        s, the interval's length.
    pair : Pair
        The parameter vectors (forward, backward).
    coarse : bool, optional
        One RK4 step instead of ``SUBSTEPS``.

    Returns
    -------
    numpy.ndarray, shape (2,)
        The state after ``h``.
    """
    fn = _COARSE_STEP if coarse else _STEP
    remaining = h
    for _ in range(8):  # at most a few stops per sample
        if remaining <= 0.0:
            return x
        if x[1] == 0.0:
            net = u - static_torque(x[0], pair[0])
            direction = math.copysign(1.0, net)
            if abs(net) <= _pick(pair, direction)[_COULOMB]:
                return x
        else:
            direction = math.copysign(1.0, x[1])
        p = _pick(pair, direction)
        nxt = _step(x, u, direction, p, remaining, fn)
        if nxt[1] * direction > 0.0:
            return nxt

        def speed_along(h, x=x, direction=direction, p=p):
            return _step(x, u, direction, p, h, fn)[1] * direction

        h_stop = brentq(speed_along, 0.0, remaining, xtol=1e-15)
        x = _step(x, u, direction, p, h_stop, fn)
        x[1] = 0.0
        remaining -= h_stop
    return x


def integrate_free(x0: np.ndarray, pair: Pair, n: int, dt: float) -> np.ndarray:
    """True states at n samples of a motion with the motor off (u = 0), stops included.

    Between stops whole blocks are integrated at once, with the parameter vector of the
    direction of motion; the sample holding a stop goes through :func:`advance` (event and
    static friction).

    Parameters
    ----------
    x0 : numpy.ndarray, shape (2,)
        The initial state (phi, Omega), rad and rad/s.
    pair : Pair
        The parameter vectors (forward, backward).
    n : int
        How many samples, the first being ``x0``.
    dt : float
        s, the sampling period.

    Returns
    -------
    numpy.ndarray, shape (n, 2)
        The states at the samples.
    """
    x = np.array(x0, dtype=float)
    traj = np.empty((n, 2))
    traj[0] = x
    k = 1
    while k < n:
        if x[1] == 0.0:  # at rest: static friction decides, sample by sample
            x = advance(x, 0.0, dt, pair)
            traj[k] = x
            k += 1
            continue
        direction = math.copysign(1.0, x[1])
        block = step_block(x, 0.0, direction, _pick(pair, direction), dt)
        count = min(BLOCK, n - k)
        turned = np.nonzero(block[:count, 1] * direction <= 0.0)[0]
        good = turned[0] if turned.size else count
        traj[k : k + good] = block[:good]
        k += good
        x = block[good - 1] if good > 0 else x
        if turned.size and k < n:
            x = advance(x, 0.0, dt, pair)
            traj[k] = x
            k += 1
    return traj
