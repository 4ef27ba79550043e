"""The virtual device: a simulated gimbal that writes logs as a real rig would (INTERFACES.md).

It integrates the model of :mod:`rsp_inertia.plant.model` (the true body of ``virtual.toml`` on the gimbal
of ``device.toml``) with a fixed-step fourth-order Runge-Kutta scheme, sample by sample, the
motor torque held over each sample (zero-order hold, METHOD.md §4). Stops are events: the
instant the speed crosses zero inside a sample is found by root-finding on the integrator's
step length, and static friction then decides whether the body stays at rest
(|u - static torque| <= a1) or breaks away (METHOD.md §4).

What leaves the device is what a rig produces: encoder readings floor(phi/q) q at the sample
rate and the logged torque with its noise. The true states are returned beside the log for
tests and benchmarks, never written where ``identify`` or ``program`` could read them.

A stage runs forward (phi increases while braking) or backward (the mirror: released at
-release_angle_deg with speed -launch_speed, phi decreases while braking and increases on the
reverse pass); one sign s = +1 / -1 carries the direction through every pass. The rig may be
imperfect (``virtual.toml``): a fixture on the shaft with the body, a true tare other than
device.toml's, friction that differs backward (Omega < 0) from forward, and a torque gain:
the log records the drive's command, the body receives command / torque_gain. The true model
of each direction of motion comes from one place, :func:`true_parameters`; every integration
picks the parameter vector of the current direction from the pair (forward, backward).

Integrator accuracy: ``SUBSTEPS`` RK4 steps per sample. With no dissipation and no torque the
mechanical energy is conserved to better than 1e-9 relative over 10 s (tests/plant).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import casadi as ca
import numpy as np
from scipy.optimize import brentq

from rsp_inertia.plant.config import DIRECTIONS, Device, Stage, Virtual
from rsp_inertia.plant.errors import InputError
from rsp_inertia.plant.logs import Log, Program
from rsp_inertia.plant.model import (
    MODEL,
    PARAMETER_NAMES,
    ModelParameters,
    acceleration,
    inertia_harmonics,
    motor_torque,
    reduced_inertia,
    rk4_step,
    static_torque,
)

__all__ = [
    "MAX_BRAKING_TIME",
    "PILOT_MAX_COAST",
    "PILOT_PEAK_FRACTION",
    "PILOT_TORQUE_FRACTION",
    "SUBSTEPS",
    "PassTruth",
    "SimulatedPass",
    "SpeedObserver",
    "encoder_reading",
    "free_motion",
    "ideal_program",
    "integrate_to_stop",
    "pendulum_parameters",
    "release_angle",
    "run_program",
    "simulate_braking",
    "simulate_ideal_reverse",
    "simulate_pendulum",
    "simulate_pilot",
    "true_parameters",
]

SUBSTEPS = 8
"""RK4 steps per encoder sample (integration step dt/8: 0.125 ms at 1 kHz)."""

MAX_BRAKING_TIME = 600.0
"""s: a braking pass that has not stopped by then is a protocol error."""

PILOT_TORQUE_FRACTION = 0.5
"""The pilot run's drive torque as a fraction of device.toml's torque_limit
(:func:`simulate_pilot`): half the limit accelerates the body well above its friction and
gravity torques while leaving the drive room, and takes the default stages to their launch
speeds in 2.7 s (stage 1, where the quadratic friction reaches 0.14 N m at 12 rad/s) and
12.5 s (stage 2)."""

PILOT_PEAK_FRACTION = 0.9
"""A pilot's spin-up ends when the speed falls below this fraction of its peak so far."""

PILOT_MAX_COAST = 30.0
"""s: the pilot's coast ends here if the body has not come to rest by then. Light friction on
a large inertia coasts for many minutes (the default stage 2 loses only 8% of its speed in
30 s, 15.6 turns); the coast's first half minute already shows the friction the planner
needs (the default stage 1 comes to rest after 20 s)."""

_BLOCK = 1000
"""Samples integrated per call while the torque and the direction of motion are constant."""

# Seeds of the independent random streams of one stage (numpy SeedSequence entropy words).
_STREAM_BRAKING = 0
_STREAM_REVERSE = 1
_STREAM_PENDULUM = 2
_STREAM_BRAKING_BACKWARD = 3
_STREAM_REVERSE_BACKWARD = 4
_STREAM_PILOT = 5
_STREAM_CLOCK = 100
"""Added to a pass's stream for its sampling instants' jitter (``[logger] time_jitter``)."""
_STREAM_DROPS = 200
"""Added to a pass's stream for the rows its logger drops (``[logger] dropped_fraction``)."""

_COULOMB = PARAMETER_NAMES.index("a1")
"""Index of a1 in the parameter vector: the static friction at rest."""

_Pair = tuple[np.ndarray, np.ndarray]
"""(p_forward, p_backward): parameter vectors for Omega > 0 and Omega < 0."""


def _build_step(substeps: int = SUBSTEPS) -> ca.Function:
    """``step(x, u, direction, p, h)``: advance x = (phi, Omega) by h with u held constant."""
    x = ca.SX.sym("x", 2)
    u, direction, h = ca.SX.sym("u"), ca.SX.sym("direction"), ca.SX.sym("h")
    f = MODEL.state_derivative()
    end = rk4_step(lambda z: f(z, u, direction, MODEL.p), x, h, substeps)
    return ca.Function("step", [x, u, direction, MODEL.p, h], [end])


_STEP = _build_step()
_STEP_BLOCK = _STEP.mapaccum(_BLOCK)
_COARSE_STEP = _build_step(1)
_COARSE_BLOCK = _COARSE_STEP.mapaccum(_BLOCK)


def _step(
    x: np.ndarray, u: float, direction: float, p: np.ndarray, h: float, fn: ca.Function = _STEP
) -> np.ndarray:
    return np.asarray(fn(x, u, direction, p, h)).ravel()


def integrate_to_stop(
    x0: np.ndarray,
    u: float,
    direction: float,
    p: np.ndarray,
    dt: float,
    max_time: float,
    coarse: bool = False,
) -> tuple[np.ndarray, np.ndarray, float, float] | None:
    """A motion under the constant torque ``u`` from ``x0`` until the speed first reaches zero.

    RK4 (``SUBSTEPS`` per sample) of the model with parameter vector ``p`` and friction
    sign ``direction`` (the sign of the speed), whole blocks of samples per call; the stop
    is an event located inside its sample by Brent's method on the step length. Returns the
    sample times, the states (phi, Omega) at every sample before the stop (and at the stop
    if it falls on a sample), the stop's time and angle; None if the body still moves after
    ``max_time`` seconds. ``coarse``: one RK4 step per sample, for planning (at 1 kHz and
    the 2 Omega harmonic of a 15 rad/s pass, h w = 0.03: a local error ~(h w)^5 / 120 = 2e-10
    of the state per step).
    """
    step_block, step = (_COARSE_BLOCK, _COARSE_STEP) if coarse else (_STEP_BLOCK, _STEP)
    x = np.asarray(x0, dtype=float)
    states = [x[None, :]]
    max_samples = int(max_time / dt)
    n = 1
    while True:
        block = np.asarray(step_block(x, u, direction, p, dt)).T  # (_BLOCK, 2)
        stopped = np.nonzero(block[:, 1] * direction <= 0.0)[0]
        if stopped.size:
            k = stopped[0]
            states.append(block[:k])
            n += k
            x = block[k - 1] if k > 0 else x
            break
        states.append(block)
        n += _BLOCK
        x = block[-1]
        if n > max_samples:
            return None
    h_stop = brentq(
        lambda h: np.asarray(step(x, u, direction, p, h)).ravel()[1] * direction, 0.0, dt, xtol=1e-15, rtol=1e-15
    )
    end = np.asarray(step(x, u, direction, p, h_stop)).ravel()
    traj = np.concatenate(states)
    t = np.arange(n) * dt
    if h_stop >= dt * (1 - 1e-12):  # the stop falls on a sample: it belongs to the log
        traj = np.vstack([traj, [end[0], 0.0]])
        t = np.arange(n + 1) * dt
    return t, traj, (n - 1) * dt + h_stop, float(end[0])


def true_parameters(
    device: Device, stage: int, virtual: Virtual, direction: float = 1
) -> ModelParameters:
    """The true model of stage ``stage`` (1-based) while the body moves in ``direction``.

    device.toml's gimbal with virtual.toml's moving system. The moving system is the body and
    the fixture (either may be absent): their tensors, both about O in the body frame, add
    (METHOD.md §2), and so do their gravity terms Gs = sum m g x_c, Gc = sum m g y_c
    (METHOD.md §3). The tare is the rig's true one (``[rig] tare_inertia``, else device.toml's,
    :meth:`rsp_inertia.plant.config.Rig.true_tare`); the friction that of the direction of motion
    (:meth:`rsp_inertia.plant.config.Virtual.friction_for`).

    Parameters
    ----------
    device, stage, virtual
        The gimbal, the stage number (from 1) and the virtual device's truth.
    direction : {+1, -1}
        The sign of Omega: +1 forward motion, -1 backward motion.

    Returns
    -------
    ModelParameters
        The parameters of :mod:`rsp_inertia.plant.model`, the same in both directions but for friction;
        ``virtual.models``' entry for the stage when it has them.

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
    parts = [part for part in (virtual.body, virtual.fixture) if part is not None]
    g = device.gravity
    inertia = sum((part.inertia for part in parts), np.zeros(6))
    tare = virtual.rig.true_tare(device, stage)
    friction = virtual.friction_for(direction)
    return ModelParameters(
        inertia_harmonics=inertia_harmonics(inertia, st.gear_ratio, tare),
        stiffness=device.spring.stiffness,
        zero_angle=device.spring.zero_angle,
        gravity_sin=sum(part.mass * g * part.com[0] for part in parts),
        gravity_cos=sum(part.mass * g * part.com[1] for part in parts),
        coulomb=friction.coulomb,
        viscous=friction.viscous,
        quadratic=friction.quadratic,
    )


def _true_pair(device: Device, stage: int, virtual: Virtual) -> _Pair:
    """(p_forward, p_backward) of :func:`true_parameters`."""
    forward = true_parameters(device, stage, virtual, 1).vector
    return forward, true_parameters(device, stage, virtual, -1).vector


def _pick(pair: _Pair, direction: float) -> np.ndarray:
    """The parameter vector of the direction of motion ``direction`` (+1 or -1)."""
    return pair[0] if direction > 0 else pair[1]


def _sign(direction: str) -> float:
    """s = +1.0 for a forward run, -1.0 for a backward one (METHOD.md §4 mirrored)."""
    if direction not in DIRECTIONS:
        raise ValueError(f"direction must be one of {DIRECTIONS}, got {direction!r}")
    return 1.0 if direction == "forward" else -1.0


def _braking_torque(stage: Stage, virtual: Virtual, s: float) -> tuple[float, float]:
    """The braking pass's motor torque, N m: (the logged command, the torque applied).

    The command is the constant braking torque against the motion, -s braking_torque; the
    drive applies command / torque_gain (``[rig]``).
    """
    command = -s * stage.braking_torque
    return command, command / virtual.rig.torque_gain


def release_angle(stage: Stage, virtual: Virtual) -> float:
    """deg, where a forward braking pass starts: the protocol's (device.toml ``[[stage]]
    release_angle_deg``) when it states one, else the virtual rig's own
    (virtual.toml ``[run] release_angle_deg``)."""
    if stage.release_angle_deg is not None:
        return stage.release_angle_deg
    return virtual.run.release_angle_deg


def encoder_reading(phi: np.ndarray, quantum: float) -> np.ndarray:
    """Incremental encoder: floor(phi / q) q (INTERFACES.md, logs)."""
    return np.floor(np.asarray(phi) / quantum) * quantum


@dataclass(frozen=True)
class PassTruth:
    """True states of the virtual device at the log's rows (never written to a log)."""

    t: np.ndarray
    """s, the log's time stamps."""
    phi: np.ndarray
    """rad, true angle at t."""
    omega: np.ndarray
    """rad/s, true speed at t."""
    torque: np.ndarray
    """N m, torque physically applied over [t_k, t_k+1); the log records the drive's command,
    torque_gain times it, plus noise."""
    end_time: float
    """s: braking, the exact instant the speed reaches zero; reverse, the end of the program."""
    end_phi: float
    """rad, true angle at end_time."""
    end_omega: float
    """rad/s, true speed at end_time."""


@dataclass(frozen=True)
class SimulatedPass:
    """One pass of the virtual device: the log a rig writes, and the truth beside it."""

    log: Log
    """What the rig writes (encoder angle, logged torque)."""
    truth: PassTruth
    """The simulator's true states."""


def _rng(virtual: Virtual, stage: int, stream: int) -> np.random.Generator:
    """Independent, reproducible random stream per (seed, stage, pass)."""
    return np.random.default_rng([virtual.run.seed, stage, stream])


def _make_log(t, phi_true, torque, quantum, noise, rng) -> Log:
    logged = torque + (rng.normal(0.0, noise, len(torque)) if noise > 0 else 0.0)
    return Log(t=np.asarray(t), phi=encoder_reading(phi_true, quantum), torque=np.asarray(logged))


def sampling_instants(virtual: Virtual, seed: tuple, n: int, dt: float) -> np.ndarray:
    """s, the drive's first ``n`` sampling instants (k + d_k) dt, d_0 = 0 and d_k uniform
    within +-``[logger] time_jitter`` (a fraction of the period); k dt exactly without jitter.

    ``seed`` names the pass's random stream (the same instants for the same pass).
    """
    jitter = virtual.logger.time_jitter
    k = np.arange(n, dtype=float)
    if jitter == 0.0 or n == 0:
        return k * dt
    offsets = np.random.default_rng([virtual.run.seed, *seed]).uniform(-jitter, jitter, n)
    offsets[0] = 0.0
    return (k + offsets) * dt


def _resample(truth: PassTruth, pair: _Pair, instants: np.ndarray) -> PassTruth:
    """The pass ``truth`` (states on the regular grid, the physical torque held over each
    grid sample) at the drive's sampling ``instants`` (from 0; an instant past the grid's
    last sample advances from that sample).

    Exact for the passes whose torque is constant between the grid's samples and the
    instants (braking, pendulum: one torque throughout; a pilot's switch-off is a grid
    sample, so its one row around the switch carries the command of the grid sample before
    it). Each state advances from the grid sample before it, stops and static friction
    included (:func:`_advance`).
    """
    if np.array_equal(instants, truth.t):
        return truth
    g = np.clip(np.searchsorted(truth.t, instants, side="right") - 1, 0, truth.t.size - 1)
    states = np.array(
        [
            _advance(np.array([truth.phi[j], truth.omega[j]]), truth.torque[j], h, pair)
            for j, h in zip(g.tolist(), (instants - truth.t[g]).tolist())
        ]
    )
    return dataclasses.replace(
        truth, t=instants, phi=states[:, 0], omega=states[:, 1], torque=truth.torque[g]
    )


def _jittered(
    truth: PassTruth, pair: _Pair, virtual: Virtual, seed: tuple, dt: float
) -> PassTruth:
    """``truth`` at the drive's jittered sampling instants before its end_time."""
    if virtual.logger.time_jitter == 0.0:
        return truth
    instants = sampling_instants(virtual, seed, truth.t.size + 2, dt)
    return _resample(truth, pair, instants[instants < truth.end_time])


def _logged(
    truth: PassTruth, command: np.ndarray, virtual: Virtual, seed: tuple, quantum: float
) -> SimulatedPass:
    """What the logger writes of a pass: encoder readings and the command plus noise at
    every sampling instant (noise drawn on the stream ``seed``), less the rows it drops
    (``[logger] dropped_fraction``: at random, never the first or the last); ``truth`` is
    cut to the rows kept."""
    rng = np.random.default_rng([virtual.run.seed, *seed])
    log = _make_log(truth.t, truth.phi, command, quantum, virtual.run.torque_noise, rng)
    fraction = virtual.logger.dropped_fraction
    if fraction > 0.0:
        drop_seed = (seed[0], seed[1] + _STREAM_DROPS, *seed[2:])
        lost = np.random.default_rng([virtual.run.seed, *drop_seed]).random(len(log)) < fraction
        lost[0] = lost[-1] = False
        keep = ~lost
        log = Log(t=log.t[keep], phi=log.phi[keep], torque=log.torque[keep])
        truth = dataclasses.replace(
            truth, t=truth.t[keep], phi=truth.phi[keep], omega=truth.omega[keep],
            torque=truth.torque[keep],
        )
    return SimulatedPass(log=log, truth=truth)


def simulate_braking(
    device: Device, stage: int, virtual: Virtual, direction: str = "forward"
) -> SimulatedPass:
    """The braking pass of METHOD.md §4 for stage ``stage`` (1-based).

    Forward: release at the release angle (:func:`release_angle`) with the stage's launch
    speed. Backward, the mirror: release at minus that angle with -launch speed. The drive's command is the
    constant ``braking_torque`` against the motion (-braking_torque forward, +braking_torque
    backward), which the log records; the body receives command / torque_gain. The pass ends
    at the first instant the speed reaches zero (an event located inside its sample by
    Brent's method on the step length). The log holds every sample up to that instant.

    Parameters
    ----------
    device, stage, virtual
        The gimbal, the stage number (from 1) and the virtual device's truth.
    direction : {"forward", "backward"}
        The direction of the run (``rsp_inertia.plant.config.DIRECTIONS``); each has its own noise stream.

    Returns
    -------
    SimulatedPass
        The log and the true states; ``truth.torque`` is the physical torque.

    Raises
    ------
    InputError
        If the body does not stop within ``MAX_BRAKING_TIME``.
    """
    s = _sign(direction)
    st = device.stages[stage - 1]
    p = true_parameters(device, stage, virtual, s).vector
    dt = device.encoder.dt
    command, u = _braking_torque(st, virtual, s)
    x0 = np.array([s * math.radians(release_angle(st, virtual)), s * st.launch_speed])
    stop = integrate_to_stop(x0, u, s, p, dt, MAX_BRAKING_TIME)
    if stop is None:
        run = "braking pass" if s > 0 else "backward braking pass"
        raise InputError(
            f"stage {stage}: the {run} does not stop within {MAX_BRAKING_TIME:g} s; "
            "raise braking_torque or lower launch_speed in device.toml"
        )
    t, traj, end_time, end_phi = stop
    truth = PassTruth(
        t=t,
        phi=traj[:, 0],
        omega=traj[:, 1],
        torque=np.full(len(t), u),
        end_time=end_time,
        end_phi=end_phi,
        end_omega=0.0,
    )
    stream = _STREAM_BRAKING if s > 0 else _STREAM_BRAKING_BACKWARD
    pair = _true_pair(device, stage, virtual)
    truth = _jittered(truth, pair, virtual, (stage, stream + _STREAM_CLOCK), dt)
    command = np.full(len(truth.t), command)
    return _logged(truth, command, virtual, (stage, stream), device.encoder.quantum)


class SpeedObserver:
    """The virtual controller's speed estimate from the encoder alone.

    A third-order tracking loop (an alpha-beta-gamma tracker: angle, speed and acceleration
    states), run once per sample on the quantized angle y_k:

        predict  phi^- = phi + omega dt + acc dt^2/2,  omega^- = omega + acc dt
        correct  e = y_k - phi^-
                 phi = phi^- + l1 e,  omega = omega^- + l2 e,  acc = acc + l3 e

    with l1 = 3 w dt, l2 = 3 w^2 dt, l3 = w^3 dt: the characteristic polynomial (s + w)^3,
    w the bandwidth of virtual.toml's ``speed_observer_bandwidth``. Being type 3, the loop
    follows a constant speed and a constant acceleration without steady error (a type-2
    alpha-beta tracker would trail an acceleration a by about 2a/w); the quantization's
    fluctuation reaches the estimate only through the loop's low-pass. This is the kind of
    estimate a real drive's controller has.
    """

    def __init__(self, phi0: float, omega0: float, bandwidth: float, dt: float) -> None:
        self.phi = phi0
        self.omega = omega0
        self.acc = 0.0
        self.dt = dt
        self.bandwidth = bandwidth
        self.l1 = 3.0 * bandwidth * dt
        self.l2 = 3.0 * bandwidth**2 * dt
        self.l3 = bandwidth**3 * dt

    def update(self, y: float, dt: float | None = None) -> float:
        """Take the encoder reading of this sample, ``dt`` s after the previous one (default:
        the nominal period; a jittered drive knows its own); return the speed estimate, rad/s.
        """
        if dt is None or dt == self.dt:
            l1, l2, l3 = self.l1, self.l2, self.l3
            dt = self.dt
        else:
            w = self.bandwidth
            l1, l2, l3 = 3.0 * w * dt, 3.0 * w * w * dt, w**3 * dt
        predicted = self.phi + self.omega * dt + self.acc * dt * dt / 2
        error = y - predicted
        self.phi = predicted + l1 * error
        self.omega += self.acc * dt + l2 * error
        self.acc += l3 * error
        return self.omega


def _advance(
    x: np.ndarray, u: float, h: float, pair: _Pair, fn: ca.Function = _STEP
) -> np.ndarray:
    """Advance the true state over h with the physical torque u held, with stops and static
    friction.

    Between stops the direction of motion is fixed, and so is the parameter vector (``pair``:
    forward, backward); a zero crossing of the speed inside the interval is located (Brent),
    the body is set at rest there, and static friction decides (METHOD.md §4): it stays while
    |u - static torque| <= a1, a1 that of the direction the net torque would move it, else it
    breaks away in that direction.
    """
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


def run_program(
    device: Device,
    stage: int,
    virtual: Virtual,
    program: Program,
    start: tuple[float, float],
    *,
    ideal: bool = False,
    direction: str = "forward",
    coarse: bool = False,
) -> SimulatedPass:
    """Execute ``program`` in closed loop on the virtual device (INTERFACES.md, program.csv).

    At each of its sampling instants (regular, or jittered by ``[logger] time_jitter``:
    :func:`sampling_instants`; the program interpolated there) the controller reads the
    encoder, updates its speed estimate (:class:`SpeedObserver`), computes

        u = clip(torque_ff - k_phi (phi - phi_ref) - k_omega (omega - omega_ref), +-torque_limit)

    limits the change from the previous sample to torque_rate_limit times the step, and holds
    u until its next instant; with a wrapping position counter (``counter_bits``) phi - phi_ref
    is taken modulo the counter's range. u is the drive's command: the log records it (plus noise), the body receives
    u / torque_gain (``[rig]``). Before the program the motor holds the body at rest, so the
    rate limiter starts from the command that held it there (torque_gain times the static
    torque at the start angle).

    Parameters
    ----------
    device, stage, virtual
        The gimbal, the stage number (from 1) and the virtual device's truth.
    program : Program
        The torque program.
    start : (phi, Omega)
        True state at the start of the program (rad, rad/s), e.g. the braking's rest.
    ideal : bool
        An ideal drive for the ideal reverse: no torque or rate limit, feedback on the true
        state instead of the encoder and the speed observer, and u applied physically exactly
        (the log records the command torque_gain u). The log is still the encoder's.
    direction : {"forward", "backward"}
        The direction of the stage's run whose reverse pass this is; it only selects the
        pass's noise stream (the motion follows the program, in whichever direction).
    coarse : bool
        One RK4 step per sample instead of SUBSTEPS (4x faster): for a rehearsal on a
        nominal model (rsp_inertia.ocp.rehearsal), where the body's motion over a sample, h w ~ 0.01 at
        the 2 Omega harmonic, leaves an RK4 error ~(h w)^5 / 120, far below what the
        model knows.

    Returns
    -------
    SimulatedPass
        The log and the true states; ``truth.torque`` is the physical torque.
    """
    s = _sign(direction)
    pair = _true_pair(device, stage, virtual)
    gain = virtual.rig.torque_gain
    enc = device.encoder
    dt = enc.dt
    q = enc.quantum
    n = len(program.t)
    stream = _STREAM_REVERSE if s > 0 else _STREAM_REVERSE_BACKWARD
    # The drive's sampling instants (jittered: ``[logger] time_jitter``), one more for the
    # end of the last sample; it applies program.csv at each, interpolated in time.
    instants = sampling_instants(virtual, (stage, stream + _STREAM_CLOCK), n + 1, dt)
    # Without jitter every step is the period itself (differences of k dt are off by ulps).
    steps = np.diff(instants) if virtual.logger.time_jitter else np.full(n, dt)
    # A drive whose position counter wraps (device.toml counter_bits) knows phi only modulo
    # the counter's range, as its logs do: program.csv, made from such a log, may be whole
    # ranges off the true angle, and the drive takes the position error modulo the range.
    span = None if enc.counter_bits is None else 2**enc.counter_bits * q
    u_max = math.inf if ideal else device.motor.torque_limit
    rate_max = math.inf if ideal else device.motor.torque_rate_limit

    x = np.array(start, dtype=float)
    held = float(static_torque(x[0], pair[0]))
    u_prev = held if ideal else held * gain
    observer = SpeedObserver(
        float(encoder_reading(x[0], q)), x[1], virtual.controller.speed_observer_bandwidth, dt
    )
    phi_true = np.empty(n)
    omega_true = np.empty(n)
    applied = np.empty(n)
    commands = np.empty(n)
    at = instants[:-1]
    if np.array_equal(at, program.t):
        columns = (program.torque_ff, program.k_phi, program.k_omega)
        ref_columns = (program.phi_ref, program.omega_ref)
    else:
        columns = tuple(
            np.interp(at, program.t, c) for c in (program.torque_ff, program.k_phi, program.k_omega)
        )
        ref_columns = tuple(np.interp(at, program.t, c) for c in (program.phi_ref, program.omega_ref))
    ff, kp, kw = columns
    ref_phi, ref_omega = ref_columns
    h_prev = dt
    for k in range(n):
        phi_true[k], omega_true[k] = x
        y = math.floor(x[0] / q) * q
        omega_hat = observer.update(y, h_prev)
        if ideal:
            y, omega_hat = x
        error = y - ref_phi[k]
        if span is not None:  # a counter's position error, modulo its range
            error -= span * round(error / span)
        u = ff[k] - kp[k] * error - kw[k] * (omega_hat - ref_omega[k])
        u = min(max(u, -u_max), u_max)
        du_max = rate_max * h_prev
        u = min(max(u, u_prev - du_max), u_prev + du_max)
        physical = u if ideal else u / gain
        applied[k] = physical
        commands[k] = u * gain if ideal else u
        u_prev = u
        h_prev = float(steps[k])
        x = _advance(x, physical, h_prev, pair, _COARSE_STEP if coarse else _STEP)
    truth = PassTruth(
        t=at,
        phi=phi_true,
        omega=omega_true,
        torque=applied,
        end_time=float(instants[-1]),
        end_phi=float(x[0]),
        end_omega=float(x[1]),
    )
    return _logged(truth, commands, virtual, (stage, stream), q)


IDEAL_BANDWIDTH = 5.0
"""rad/s: closed-loop bandwidth of the ideal reverse's feedback (it only mops up the
zero-order-hold residue; the feedforward is the exact inverse dynamics)."""


def ideal_program(
    device: Device,
    stage: int,
    virtual: Virtual,
    braking: SimulatedPass,
    direction: str = "forward",
) -> Program:
    """The exact mirror of a simulated braking pass, as a program (METHOD.md §4).

    The reference is the braking trajectory run backwards from its true rest point:
    x_ref(t') = (phi(T - t'), -Omega(T - t')), obtained by integrating the braking's own
    dynamics (its physical torque, the friction of its direction of motion s) with a negative
    step from (phi7, 0), so no interpolation enters. The feedforward is the true model's
    inverse dynamics along it (:func:`rsp_inertia.plant.model.motor_torque`, with the friction of the
    reverse's direction -s), averaged over each sample for the zero-order hold: a physical
    torque, which the ideal drive of :func:`run_program` applies exactly. The gains put both
    closed-loop poles at -IDEAL_BANDWIDTH with the true M(phi_ref).

    Parameters
    ----------
    device, stage, virtual
        The gimbal, the stage number (from 1) and the virtual device's truth.
    braking : SimulatedPass
        The braking pass of ``direction`` (:func:`simulate_braking`).
    direction : {"forward", "backward"}
        The direction of the braking: a backward braking's mirror moves phi up.
    """
    s = _sign(direction)
    if not braking.truth.omega[0] * s > 0.0:
        raise ValueError(f"the braking pass does not run {direction}")
    st = device.stages[stage - 1]
    p = true_parameters(device, stage, virtual, s).vector
    p_reverse = true_parameters(device, stage, virtual, -s).vector
    dt = device.encoder.dt
    T = braking.truth.end_time
    n = math.floor(T / dt + 1e-9) + 1
    _, u_b = _braking_torque(st, virtual, s)
    # Braking states at times T - k dt, k = 0..n-1, by backward integration.
    back = np.empty((n, 2))
    back[0] = (braking.truth.end_phi, 0.0)
    x = back[0]
    for start in range(1, n, _BLOCK):
        count = min(_BLOCK, n - start)
        block = np.asarray(_STEP_BLOCK(x, u_b, s, p, -dt)).T[:count]
        back[start : start + count] = block
        x = block[-1]
    phi_ref = back[:, 0]
    omega_ref = -back[:, 1]
    # The braking's acceleration at the mirrored states is the reverse's acceleration.
    eps_ref = acceleration(back[:, 0], back[:, 1], u_b, p, direction=s * np.ones(n))
    u_needed = motor_torque(phi_ref, omega_ref, eps_ref, p_reverse, direction=-s * np.ones(n))
    torque_ff = np.empty(n)
    torque_ff[:-1] = (u_needed[:-1] + u_needed[1:]) / 2
    torque_ff[-1] = u_needed[-1]
    M = reduced_inertia(phi_ref, p)
    w = IDEAL_BANDWIDTH
    return Program(
        t=np.arange(n) * dt,
        phi_ref=phi_ref,
        omega_ref=omega_ref,
        torque_ff=torque_ff,
        k_phi=M * w * w,
        k_omega=2.0 * M * w,
    )


def simulate_ideal_reverse(
    device: Device,
    stage: int,
    virtual: Virtual,
    braking: SimulatedPass,
    direction: str = "forward",
) -> SimulatedPass:
    """The ideal reverse pass: the exact mirror driven by an ideal drive.

    Ideal actuator (no torque or rate limit, the physical torque applied exactly whatever
    the torque gain; the log records the command, torque_gain times it) and ideal sensing
    (feedback on the true state); the feedforward is the true inverse dynamics
    (:func:`ideal_program`). The speed matches the braking's at the same angle to about
    1e-6 rad/s, so identification can be tested apart from the optimal-control work. The
    log is the encoder's, as always. ``direction`` is the braking's (a backward braking's
    mirror moves phi up) and selects the pass's noise stream.
    """
    program = ideal_program(device, stage, virtual, braking, direction)
    return run_program(
        device,
        stage,
        virtual,
        program,
        (braking.truth.end_phi, 0.0),
        ideal=True,
        direction=direction,
    )


def pendulum_parameters(
    device: Device, stage: int, virtual: Virtual, node: int, direction: float = 1
) -> ModelParameters:
    """The true model during the pendulum run at node ``node`` (0-based) of a stage.

    The torsion element of device.toml's ``[pendulum]`` is attached and zeroed at the node,
    with the rig's true stiffness (virtual.toml ``[rig] pendulum_stiffness``, else
    device.toml's); everything else (body, fixture, gravity, the friction of ``direction``, the sign of
    Omega) is the stage's (:func:`true_parameters`).
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


def _free_motion(x0: np.ndarray, pair: _Pair, n: int, dt: float) -> np.ndarray:
    """True states at n samples of a motion with the motor off (u = 0), stops included.

    Between stops whole blocks are integrated at once, with the parameter vector of the
    direction of motion (``pair``: forward, backward); the sample holding a stop goes
    through :func:`_advance` (event and static friction).
    """
    x = np.array(x0, dtype=float)
    traj = np.empty((n, 2))
    traj[0] = x
    k = 1
    while k < n:
        if x[1] == 0.0:  # at rest: static friction decides, sample by sample
            x = _advance(x, 0.0, dt, pair)
            traj[k] = x
            k += 1
            continue
        direction = math.copysign(1.0, x[1])
        block = np.asarray(_STEP_BLOCK(x, 0.0, direction, _pick(pair, direction), dt)).T
        count = min(_BLOCK, n - k)
        turned = np.nonzero(block[:count, 1] * direction <= 0.0)[0]
        good = turned[0] if turned.size else count
        traj[k : k + good] = block[:good]
        k += good
        x = block[good - 1] if good > 0 else x
        if turned.size and k < n:
            x = _advance(x, 0.0, dt, pair)
            traj[k] = x
            k += 1
    return traj


def simulate_pendulum(device: Device, stage: int, virtual: Virtual, node: int) -> SimulatedPass:
    """Torsion-pendulum run at node ``node`` (0-based) of a stage: motor off, free oscillation.

    Released at rest, ``amplitude_deg`` past the node, and logged for ``duration`` seconds;
    each stop (twice a period) is an event with static friction, as in every pass.
    The logged torque is the motor's: zero, plus the log's noise.
    """
    params = pendulum_parameters(device, stage, virtual, node)
    pair = (params.vector, pendulum_parameters(device, stage, virtual, node, -1).vector)
    dt = device.encoder.dt
    n = round(device.pendulum.duration / dt) + 1
    x0 = np.array([params.zero_angle + math.radians(device.pendulum.amplitude_deg), 0.0])
    traj = _free_motion(x0, pair, n, dt)
    t = np.arange(n) * dt
    truth = PassTruth(
        t=t,
        phi=traj[:, 0],
        omega=traj[:, 1],
        torque=np.zeros(n),
        end_time=float(t[-1]),
        end_phi=float(traj[-1, 0]),
        end_omega=float(traj[-1, 1]),
    )
    # The drive's n instants of the run (the last may fall a fraction of a period past the
    # grid's last sample: _resample advances from there).
    clock = (stage, _STREAM_PENDULUM + _STREAM_CLOCK, node)
    truth = _resample(truth, pair, sampling_instants(virtual, clock, n, dt))
    truth = dataclasses.replace(
        truth,
        end_time=float(truth.t[-1]),
        end_phi=float(truth.phi[-1]),
        end_omega=float(truth.omega[-1]),
    )
    seed = (stage, _STREAM_PENDULUM, node)
    return _logged(truth, np.zeros(len(truth.t)), virtual, seed, device.encoder.quantum)


def free_motion(
    device: Device, stage: int, virtual: Virtual, duration: float, damped: bool
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The body released as for the braking pass but with the motor off (paper Fig. 3).

    ``damped`` keeps the friction (free damped motion); otherwise friction is removed too
    (free undamped motion: energy is conserved). Returns true (t, phi, Omega).
    """
    pair = _true_pair(device, stage, virtual)
    if not damped:
        params = dataclasses.replace(
            true_parameters(device, stage, virtual), coulomb=0.0, viscous=0.0, quadratic=0.0
        )
        pair = (params.vector, params.vector)
    dt = device.encoder.dt
    n = round(duration / dt) + 1
    st = device.stages[stage - 1]
    x0 = np.array([math.radians(release_angle(st, virtual)), st.launch_speed])
    traj = _free_motion(x0, pair, n, dt)
    return np.arange(n) * dt, traj[:, 0], traj[:, 1]


def simulate_pilot(device: Device, stage: int, virtual: Virtual) -> SimulatedPass:
    """A pilot run of stage ``stage`` (1-based): spin-up at a known torque, then a free coast.

    The short run from which the planner estimates the stage's mean reduced inertia and its
    friction before the experiment (``stageN/pilot.csv``, the log format of braking.csv;
    rsp_inertia.ocp.pilot fits it). Protocol, forward only:

    1. The body starts at rest at the release angle (``virtual.run.release_angle_deg``).
    2. Powered part: the drive commands the constant torque PILOT_TORQUE_FRACTION x
       ``motor.torque_limit`` (forward), held sample by sample, until the first sample at
       which the true speed has reached the stage's ``launch_speed``, or has fallen below
       PILOT_PEAK_FRACTION of its highest value so far (a spring wound up against the motor;
       the within-turn exchange with M(phi) moves the speed by a few percent only).
    3. Coast: from that sample on the command is 0 (the motor is off; the log still records
       0 plus the channel's noise) and the body coasts until it comes to rest (the first
       instant the speed reaches zero, an event located inside its sample as in
       :func:`simulate_braking`) or until PILOT_MAX_COAST seconds of coast, whichever
       comes first.

    The log records the command plus ``run.torque_noise``; the body receives command /
    ``rig.torque_gain``, like every pass. Samples at the encoder rate, t from 0; when the
    body comes to rest the log ends at the last sample before the stop (at the stop if it
    falls on a sample), otherwise at the last sample within PILOT_MAX_COAST of the switch-off.
    The command steps at t = 0 and at the switch-off: the drive's torque rate limit is not
    modelled (0.0125 s at the default 20 N m/s for the default 0.25 N m). The noise has its
    own random stream: the run is deterministic for a given seed.

    Parameters
    ----------
    device, stage, virtual
        The gimbal, the stage number (from 1) and the virtual device's truth.

    Returns
    -------
    SimulatedPass
        The log and the true states; ``truth.torque`` is the physical torque; ``end_time``
        is the instant of rest (or the log's last sample when the coast was cut),
        ``end_omega`` the speed there.

    Raises
    ------
    InputError
        If the pilot torque cannot turn the body forward from the release angle (friction and
        static torques hold it), or the launch speed is not reached within MAX_BRAKING_TIME.
    """
    st = device.stages[stage - 1]
    pair = _true_pair(device, stage, virtual)
    p = pair[0]
    dt = device.encoder.dt
    command = PILOT_TORQUE_FRACTION * device.motor.torque_limit
    u = command / virtual.rig.torque_gain
    # Powered part, whole blocks at once: states up to the first sample at the launch speed.
    x = np.array([math.radians(virtual.run.release_angle_deg), 0.0])
    states = [x[None, :]]
    n = 1
    top_so_far = 0.0
    while True:
        block = np.asarray(_STEP_BLOCK(x, u, 1.0, p, dt)).T  # (_BLOCK, 2)
        top = np.maximum.accumulate(np.concatenate([[top_so_far], block[:, 1]]))[1:]
        peaked = block[:, 1] < PILOT_PEAK_FRACTION * top
        reached = np.nonzero((block[:, 1] >= st.launch_speed) | peaked)[0]
        if np.any(block[: reached[0] if reached.size else _BLOCK, 1] <= 0.0):
            raise InputError(
                f"stage {stage}: the pilot torque ({command:g} N m) does not turn the body "
                "forward from the release angle: friction and static torques hold it"
            )
        if reached.size:
            states.append(block[: reached[0] + 1])
            n += reached[0] + 1
            break
        states.append(block)
        n += _BLOCK
        x = block[-1]
        top_so_far = float(top[-1])
        if n * dt > MAX_BRAKING_TIME:
            raise InputError(
                f"stage {stage}: the pilot torque ({command:g} N m) does not reach the "
                f"launch speed {st.launch_speed:g} rad/s within {MAX_BRAKING_TIME:g} s"
            )
    powered = np.concatenate(states)
    switch = len(powered) - 1  # the first sample of the coast
    # Coast, motor off, until rest or PILOT_MAX_COAST.
    stop = integrate_to_stop(powered[-1], 0.0, 1.0, p, dt, PILOT_MAX_COAST)
    if stop is not None and stop[2] <= PILOT_MAX_COAST:
        _, coast, end_time, end_phi = stop
        end_time, end_omega = switch * dt + end_time, 0.0
    else:  # still moving: no stop within the coast's samples, so no event to handle
        coast = _free_motion(powered[-1], pair, math.floor(PILOT_MAX_COAST / dt + 1e-9) + 1, dt)
        end_phi, end_omega = coast[-1]
        end_time = (switch + len(coast) - 1) * dt
    traj = np.concatenate([powered[:-1], coast])
    t = np.arange(len(traj)) * dt
    commands = np.where(np.arange(len(t)) < switch, command, 0.0)
    truth = PassTruth(
        t=t,
        phi=traj[:, 0],
        omega=traj[:, 1],
        torque=commands / virtual.rig.torque_gain,
        end_time=float(end_time),
        end_phi=float(end_phi),
        end_omega=float(end_omega),
    )
    truth = _jittered(truth, pair, virtual, (stage, _STREAM_PILOT + _STREAM_CLOCK), dt)
    commands = np.where(truth.t < switch * dt, command, 0.0)
    return _logged(truth, commands, virtual, (stage, _STREAM_PILOT), device.encoder.quantum)
