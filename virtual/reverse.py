"""The reverse pass: a torque program run in closed loop on the virtual device.

:func:`run_program` is the drive executing program.csv (docs/files.md) at its sampling
instants: feedforward plus state feedback on the encoder reading and the speed observer's
estimate, clipped to the motor's torque and rate limits. :func:`simulate_ideal_reverse` runs
the exact mirror of a braking pass (:func:`ideal_program`) on an ideal drive instead, so that
identification can be tested apart from the optimal-control work.
"""

from __future__ import annotations

import math

import numpy as np

from rsp_inertia.plant.config import Device
from rsp_inertia.plant.direction import Direction
from rsp_inertia.plant.friction import FRICTION
from rsp_inertia.plant.logs import Program
from rsp_inertia.plant.model import (
    PARAMETER_NAMES,
    acceleration,
    motor_torque,
    reduced_inertia,
    static_torque,
)
from rsp_inertia.plant.transducers import delivered_torque, logged_torque, thermal_gains
from rsp_inertia.virtual.config import Virtual
from rsp_inertia.virtual.drive import (
    STREAM_CLOCK,
    STREAM_REVERSE,
    STREAM_REVERSE_BACKWARD,
    PassTruth,
    ProgramDrive,
    SimulatedPass,
    SpeedObserver,
    braking_torque,
    logged,
    sampling_instants,
    with_temperature,
)
from rsp_inertia.virtual.integrate import BLOCK, advance, step_block, true_pair, true_parameters
from rsp_inertia.virtual.thermal import COLD, MotorState, advance_motor, heating_power

__all__ = ["IDEAL_BANDWIDTH", "ideal_program", "run_program", "simulate_ideal_reverse"]

_COULOMB = PARAMETER_NAMES.index(FRICTION.static)
"""Index of a1 in the parameter vector: the static friction at rest."""

IDEAL_BANDWIDTH = 5.0
"""rad/s: closed-loop bandwidth of the ideal reverse's feedback (it only mops up the
zero-order-hold residue; the feedforward is the exact inverse dynamics)."""


def run_program(
    device: Device,
    stage: int,
    virtual: Virtual,
    program: Program,
    start: tuple[float, float],
    *,
    ideal: bool = False,
    direction: Direction = Direction.FORWARD,
    coarse: bool = False,
    motor: MotorState = COLD,
) -> SimulatedPass:
    """Execute ``program`` in closed loop on the virtual device (docs/files.md, program.csv).

    At each of its sampling instants (regular, or jittered by ``[logger] time_jitter``:
    :func:`rsp_inertia.virtual.drive.sampling_instants`; the program interpolated there) the
    controller reads the encoder, updates its speed estimate
    (:class:`rsp_inertia.virtual.drive.SpeedObserver`), computes

        u = clip(torque_ff - k_phi (phi - phi_ref) - k_omega (omega - omega_ref), +-torque_limit)

    limits the change from the previous sample to torque_rate_limit times the step
    (:class:`rsp_inertia.virtual.drive.ProgramDrive`), and holds u until its next instant; with a wrapping position counter (``counter_bits``) phi - phi_ref
    is taken modulo the counter's range. The encoder reads phi + e(phi) (``[rig]``'s reading
    error): the drive regulates on what it reads. u is the drive's command: the log records it
    (plus noise), the body receives h_d u while the motor drives it and h_b u while the body
    back-drives it (``[rig]``, rsp_inertia.plant.transducers.delivered_torque; from rest, the
    direction the net torque moves it). Before the program the motor holds the body at rest,
    so the rate limiter starts from the command that held it there (the static torque at the
    start angle over h_d).

    Parameters
    ----------
    device : Device
        The gimbal.
    stage : int
        The stage number, from 1.
    virtual : Virtual
        The virtual device's truth.
    program : Program
        The torque program.
    start : (phi, Omega)
        True state at the start of the program (rad, rad/s), e.g. the braking's rest.
    ideal : bool
        An ideal drive for the ideal reverse: no torque or rate limit, feedback on the true
        state instead of the encoder and the speed observer, and u applied physically exactly
        (the log records the command that gives u: u / h_d driving, u / h_b back-driven).
        The log is still the encoder's.
    direction : Direction
        The direction of the stage's run whose reverse pass this is; it only selects the
        pass's noise stream (the motion follows the program, in whichever direction).
    coarse : bool
        One RK4 step per sample instead of SUBSTEPS (4x faster): for a rehearsal on a
        nominal model (rsp_inertia.design.rehearsal), where the body's motion over a sample,
        h w ~ 0.01 at the 2 Omega harmonic, leaves an RK4 error ~(h w)^5 / 120, far below
        what the model knows.
    motor : MotorState
        The motor's temperatures at the start (the braking's ``truth.end_motor``; default the
        ambient). On a rig with a thermal model (rsp_inertia.virtual.thermal) each sample's
        command heats the winding, the body receives the torque above times 1 + alpha
        (T_magnet - ambient) at the sample's start (plus ``[rig]
        reverse_temperature_offset``), and the log records the winding's temperature.

    Returns
    -------
    SimulatedPass
        The log and the true states; ``truth.torque`` is the physical torque.
    """
    s = float(direction.sign)
    pair = true_pair(device, stage, virtual)
    gains = virtual.rig.drive_gains
    enc = device.encoder
    dt = enc.dt
    q = enc.quantum
    n = len(program.t)
    stream = STREAM_REVERSE if s > 0 else STREAM_REVERSE_BACKWARD
    # The drive's sampling instants (jittered: ``[logger] time_jitter``), one more for the
    # end of the last sample; it applies program.csv at each, interpolated in time.
    instants = sampling_instants(virtual, (stage, stream + STREAM_CLOCK), n + 1, dt)
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
    observer = SpeedObserver(
        float(virtual.rig.reading(x[0], q)),
        x[1],
        virtual.controller.speed_observer_bandwidth,
        dt,
    )
    phi_true = np.empty(n)
    omega_true = np.empty(n)
    applied = np.empty(n)
    commands = np.empty(n)
    at = instants[:-1]
    # The command that held the body at rest (a drive that holds, drives: power_flow_split).
    drive = ProgramDrive(
        program, at, u_max, rate_max, span, held if ideal else logged_torque(held, 0.0, gains)
    )
    rig = virtual.rig
    # The motor's temperatures at each sample's start (rises above the ambient, the
    # prescribed offset included), on a rig whose motor's temperature moves.
    thermal = rig.thermal
    offset = rig.reverse_temperature_offset
    winding = np.empty(n) if thermal else None
    magnet = np.empty(n) if thermal else None
    h_prev = dt
    for k in range(n):
        phi_true[k], omega_true[k] = x
        y = float(virtual.rig.reading(x[0], q))
        omega_hat = observer.update(y, h_prev)
        if ideal:
            y, omega_hat = x
        u = drive.command(k, y, omega_hat, h_prev)
        g = gains
        if thermal:
            winding[k], magnet[k] = motor.winding + offset, motor.magnet + offset
            g = thermal_gains(gains, rig.torque_constant_tempco, magnet[k])
        if ideal:  # u is the torque the body receives; the log has the command that gives it
            motion = _motion(x, u, pair)
            applied[k], commands[k] = u, logged_torque(u, motion, g)
        else:  # u is the command
            applied[k], commands[k] = _received(x, u, g, pair), u
        physical = applied[k]
        h_prev = float(steps[k])
        x = advance(x, physical, h_prev, pair, coarse)
        if thermal:
            power = heating_power(rig, commands[k])
            motor = MotorState(*advance_motor(rig, motor, power, h_prev))
    truth = PassTruth(
        t=at,
        phi=phi_true,
        omega=omega_true,
        torque=applied,
        end_time=float(instants[-1]),
        end_phi=float(x[0]),
        end_omega=float(x[1]),
        winding=winding,
        magnet=magnet,
        end_motor=motor,
    )
    sim = logged(truth, commands, virtual, (stage, stream), q)
    if thermal:
        sim = with_temperature(sim, virtual, sim.truth.winding, (stage, stream))
    return sim


def _motion(x: np.ndarray, torque: float, pair) -> float:
    """The direction the body moves in over the next sample under the torque it receives:
    its speed's sign, or from rest the sign of the net torque (``torque`` less the static
    one; 0 if they balance)."""
    if x[1] != 0.0:
        return math.copysign(1.0, x[1])
    return float(np.sign(torque - static_torque(x[0], pair[0])))


def _received(x: np.ndarray, command: float, gains: tuple[float, float], pair) -> float:
    """The torque the body receives over the next sample for the drive's ``command``.

    Moving, h_d or h_b times the command by the direction of power flow
    (rsp_inertia.plant.transducers.delivered_torque). From rest the body moves in the
    direction d whose delivered torque (h_d u if d is the command's, h_b u against it) beats
    the static torque and the static friction in d: at most one does, h_b >= h_d. If neither
    does, the body stays, and the transmission passes whatever torque between h_d u and h_b u
    holds it (a lossy transmission self-locks when h_d u < static torque < h_b u); outside
    that band the nearer bound, the rest held by static friction.
    """
    if x[1] != 0.0:
        return delivered_torque(command, math.copysign(1.0, x[1]), gains)
    static = float(static_torque(x[0], pair[0]))
    for d, p in ((1.0, pair[0]), (-1.0, pair[1])):
        torque = delivered_torque(command, d, gains)
        if d * (torque - static) > p[_COULOMB]:
            return torque
    low, high = sorted((gains[0] * command, gains[1] * command))
    return min(max(static, low), high)


def ideal_program(
    device: Device,
    stage: int,
    virtual: Virtual,
    braking: SimulatedPass,
    direction: Direction = Direction.FORWARD,
) -> Program:
    """The exact mirror of a simulated braking pass, as a program (docs/method.md §4).

    The reference is the braking trajectory run backwards from its true rest point:
    x_ref(t') = (phi(T - t'), -Omega(T - t')), obtained by integrating the braking's own
    dynamics (its physical torque, the friction of its direction of motion s) with a negative
    step from (phi7, 0), so no interpolation enters. The feedforward is the true model's
    inverse dynamics along it (:func:`rsp_inertia.plant.model.motor_torque`, with the
    friction of the reverse's direction -s), averaged over each sample for the zero-order
    hold: a physical torque, which the ideal drive of :func:`run_program` applies exactly.
    The gains put both closed-loop poles at -IDEAL_BANDWIDTH with the true M(phi_ref).

    Parameters
    ----------
    device : Device
        The gimbal.
    stage : int
        The stage number, from 1.
    virtual : Virtual
        The virtual device's truth.
    braking : SimulatedPass
        The braking pass of ``direction`` (:func:`rsp_inertia.virtual.device.simulate_braking`).
    direction : Direction
        The direction of the braking: a backward braking's mirror moves phi up.

    Returns
    -------
    Program
        The mirror's reference, its feedforward (a physical torque, N m) and the gains.

    Raises
    ------
    ValueError
        The braking pass does not run in ``direction``.
    """
    s = float(direction.sign)
    if not braking.truth.omega[0] * s > 0.0:
        raise ValueError(f"the braking pass does not run {direction}")
    st = device.stages[stage - 1]
    p = true_parameters(device, stage, virtual, s).vector
    p_reverse = true_parameters(device, stage, virtual, -s).vector
    dt = device.encoder.dt
    T = braking.truth.end_time
    n = math.floor(T / dt + 1e-9) + 1
    _, u_b = braking_torque(st, virtual, s)
    truth = braking.truth
    if np.ptp(truth.torque) > 0.0:
        # A warming motor's braking torque drifts (rsp_inertia.virtual.thermal), a two-level
        # braking's switches (device.toml braking_torque_2): step k back
        # covers [T - k dt, T - (k-1) dt] under the braking's torque at its middle, and sample
        # k's acceleration is that at T - k dt.
        def torque_at(times: np.ndarray) -> np.ndarray:
            rows = np.searchsorted(truth.t, times, side="right") - 1
            return truth.torque[np.clip(rows, 0, truth.t.size - 1)]

        k = np.arange(n + BLOCK)
        u_steps = torque_at(T - (k - 0.5) * dt)
        u_samples = torque_at(T - k[:n] * dt)
    else:
        u_steps = u_samples = None
    # Braking states at times T - k dt, k = 0..n-1, by backward integration.
    back = np.empty((n, 2))
    back[0] = (braking.truth.end_phi, 0.0)
    x = back[0]
    for start in range(1, n, BLOCK):
        count = min(BLOCK, n - start)
        u = u_b if u_steps is None else u_steps[start : start + BLOCK].reshape(1, BLOCK)
        block = step_block(x, u, s, p, -dt)[:count]
        back[start : start + count] = block
        x = block[-1]
    phi_ref = back[:, 0]
    omega_ref = -back[:, 1]
    # The braking's acceleration at the mirrored states is the reverse's acceleration.
    u_eps = u_b if u_samples is None else u_samples
    eps_ref = acceleration(back[:, 0], back[:, 1], u_eps, p, direction=s * np.ones(n))
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
    direction: Direction = Direction.FORWARD,
) -> SimulatedPass:
    """The ideal reverse pass: the exact mirror driven by an ideal drive.

    Ideal actuator (no torque or rate limit, the physical torque applied exactly whatever
    the torque gain; the log records the command, torque_gain times it) and ideal sensing
    (feedback on the true state); the feedforward is the true inverse dynamics
    (:func:`ideal_program`). The speed matches the braking's at the same angle to about
    1e-6 rad/s, so identification can be tested apart from the optimal-control work. The
    log is the encoder's, as always.

    Parameters
    ----------
    device : Device
        The gimbal.
    stage : int
        The stage number, from 1.
    virtual : Virtual
        The virtual device's truth.
    braking : SimulatedPass
        The braking pass of ``direction``; the reverse starts at its rest point.
    direction : Direction
        The braking's direction (a backward braking's mirror moves phi up); it selects the
        pass's noise stream.

    Returns
    -------
    SimulatedPass
        The log and the true states of the reverse pass.
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
        motor=braking.truth.end_motor,
    )
