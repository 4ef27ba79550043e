"""The virtual device: a simulated gimbal that writes logs as a real rig would (docs/files.md).

It integrates the model of :mod:`rsp_inertia.plant.model` (the true body of ``virtual.toml``
placed on the gimbal of ``device.toml`` by its mounting, :func:`placed_body`,
:func:`true_parameters`) sample by sample, the motor torque held over each sample
(zero-order hold, docs/method.md §4), with stops as events decided by static friction
(:mod:`rsp_inertia.virtual.integrate`). What leaves the device is what a rig
produces: encoder readings floor(phi/q) q at the drive's sampling instants and the logged
command with its noise (:mod:`rsp_inertia.virtual.drive`); the true states are returned beside
the log.

The passes: :func:`simulate_braking` (the constant braking torque until rest), the reverse
pass :func:`run_program` and its ideal mirror :func:`simulate_ideal_reverse`
(:mod:`rsp_inertia.virtual.reverse`), the torsion-pendulum runs :func:`simulate_pendulum`, the
pilot run :func:`simulate_pilot` for planning, and :func:`free_motion` (motor off).

A stage runs forward (phi increases while braking) or backward (the mirror: released at
-release_angle_deg with speed -launch_speed, phi decreases while braking and increases on the
reverse pass); one sign s = +1 / -1 carries the direction through every pass. The rig may be
imperfect (``virtual.toml``): a fixture on the shaft with the body, a true tare other than
device.toml's, friction that differs backward (Omega < 0) from forward, a torque gain and a
transmission that loses power by its direction of flow (the log records the drive's command,
the body receives h_d or h_b times it), and an encoder that reads phi + e(phi)
(rsp_inertia.plant.transducers).

This module is the virtual device's interface: it also exposes the public names of
:mod:`rsp_inertia.virtual.integrate`, :mod:`rsp_inertia.virtual.drive` and
:mod:`rsp_inertia.virtual.reverse` that its callers use (``__all__``).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from rsp_inertia.infra.errors import InputError
from rsp_inertia.plant.config import Device, Stage
from rsp_inertia.plant.direction import Direction
from rsp_inertia.plant.friction import FRICTION
from rsp_inertia.plant.transducers import delivered_torque, thermal_gains
from rsp_inertia.virtual.config import Virtual, placed_body
from rsp_inertia.virtual.drive import (
    STREAM_BRAKING,
    STREAM_BRAKING_BACKWARD,
    STREAM_CLOCK,
    STREAM_PENDULUM,
    STREAM_PILOT,
    PassTruth,
    SimulatedPass,
    SpeedObserver,
    braking_torque,
    held_after_stop,
    jittered,
    logged,
    resample,
    sampling_instants,
    with_temperature,
)
from rsp_inertia.virtual.integrate import (
    BLOCK,
    SUBSTEPS,
    integrate_free,
    integrate_to_stop,
    pendulum_parameters,
    samples_to_angle,
    step_block,
    true_pair,
    true_parameters,
)
from rsp_inertia.virtual.reverse import ideal_program, run_program, simulate_ideal_reverse
from rsp_inertia.virtual.thermal import MotorState, advance_motor, heating_power, run_start

__all__ = [
    "MAX_BRAKING_TIME",
    "PILOT_MAX_COAST",
    "PILOT_PEAK_FRACTION",
    "PILOT_TORQUE_FRACTION",
    "PILOT_TURNS",
    "SUBSTEPS",
    "PassTruth",
    "SimulatedPass",
    "SpeedObserver",
    "free_motion",
    "ideal_program",
    "integrate_to_stop",
    "pendulum_parameters",
    "placed_body",
    "release_angle",
    "run_program",
    "samples_to_angle",
    "simulate_braking",
    "simulate_ideal_reverse",
    "simulate_pendulum",
    "simulate_pilot",
    "true_parameters",
]

MAX_BRAKING_TIME = 600.0
"""s: a braking pass that has not stopped by then is a protocol error."""

PILOT_TORQUE_FRACTION = 0.5
"""The pilot run's drive torque as a fraction of device.toml's torque_limit
(:func:`simulate_pilot`): half the limit accelerates the body well above its friction and
gravity torques while leaving the drive room, and takes the default stages to their launch
speeds in 2.7 s (stage 1, where the quadratic friction reaches 0.14 N m at 12 rad/s) and
12.5 s (stage 2)."""

PILOT_TURNS = 4.0
"""Turns of a pilot's spin-up on a stage whose device.toml states no ``launch_speed`` (a new
rig, before ``plan``; :func:`simulate_pilot`): the drive's known work over them,
PILOT_TORQUE_FRACTION x torque_limit x 2 pi PILOT_TURNS, sets the speed, so a light body
spins faster than a heavy one as its braking will. On the default stages they reach 13.7
and 3.9 rad/s, near the launch speeds plan chooses there from such pilots (13.8 and 4.26
rad/s within 100 s)."""

PILOT_PEAK_FRACTION = 0.9
"""A pilot's spin-up ends when the speed falls below this fraction of its peak so far."""

PILOT_MAX_COAST = 30.0
"""s: the pilot's coast ends here if the body has not come to rest by then. Light friction on
a large inertia coasts for many minutes (the default stage 2 loses only 8% of its speed in
30 s, 15.6 turns); the coast's first half minute already shows the friction the planner
needs (the default stage 1 comes to rest after 20 s)."""


def release_angle(stage: Stage, virtual: Virtual) -> float:
    """deg, where a forward braking pass starts: the protocol's (device.toml ``[[stage]]
    release_angle_deg``) when it states one, else the virtual rig's own
    (virtual.toml ``[run] release_angle_deg``)."""
    if stage.release_angle_deg is not None:
        return stage.release_angle_deg
    return virtual.run.release_angle_deg


def simulate_braking(
    device: Device, stage: int, virtual: Virtual, direction: Direction = Direction.FORWARD
) -> SimulatedPass:
    """The braking pass of docs/method.md §4 for stage ``stage`` (1-based).

    Forward: release at the release angle (:func:`release_angle`) with the stage's launch
    speed. Backward, the mirror: release at minus that angle with -launch speed. The
    drive's command is the constant ``braking_torque`` against the motion (-braking_torque
    forward, +braking_torque backward), which the log records; the body back-drives the motor
    and receives h_b x the command (``[rig]``), times 1 + alpha (T_magnet - ambient) on a
    motor that warms (``[rig]`` thermal keys, rsp_inertia.virtual.thermal: the command's
    current heats the winding from the ambient; the torque drifts from sample to sample,
    held over each). The pass ends at the first instant the speed
    reaches zero (an event located inside its sample by Brent's method on the step length).
    The log holds every sample up to that instant, and goes on while the drive holds the body
    for virtual.toml's ``[logger] hold_after_stop`` (rsp_inertia.virtual.drive.held_after_stop).

    Parameters
    ----------
    device : Device
        The gimbal.
    stage : int
        The stage number, from 1.
    virtual : Virtual
        The virtual device's truth.
    direction : Direction
        The direction of the run; each has its own noise stream.

    Returns
    -------
    SimulatedPass
        The log and the true states; ``truth.torque`` is the physical torque.

    Raises
    ------
    InputError
        If the body does not stop within ``MAX_BRAKING_TIME``.
    """
    s = float(direction.sign)
    st = device.stages[stage - 1]
    p = true_parameters(device, stage, virtual, s).vector
    dt = device.encoder.dt
    command, u = braking_torque(st, virtual, s)
    rig = virtual.rig
    power = heating_power(rig, command)  # W, constant: the command is
    start = run_start(rig, device, stage, direction)  # the motor at the run's start
    x0 = np.array([s * math.radians(release_angle(st, virtual)), s * st.launch_speed])
    switch = _switch_sample(st, x0, u, s, p, dt, stage)
    motor = None
    if switch is not None:  # a two-level braking: the command and the heating by sample
        command_2 = -s * st.braking_torque_2
        commands = lambda k: np.where(k < switch, command, command_2)
        motor = _two_level_motor(
            rig, start, power, heating_power(rig, command_2), switch * dt
        )
    if rig.thermal and rig.torque_constant_tempco != 0.0:
        gains = rig.drive_gains
        tempco = rig.torque_constant_tempco

        def u(k: int, count: int) -> np.ndarray:
            """The torques over samples k.. as the magnets warm from the run's start."""
            rows = np.arange(k, k + count)
            if switch is None:
                magnet = advance_motor(rig, start, power, rows * dt)[1]
                return delivered_torque(command, s, thermal_gains(gains, tempco, magnet))
            magnet = motor(rows * dt)[1]
            return delivered_torque(commands(rows), s, thermal_gains(gains, tempco, magnet))

    elif switch is not None:
        gains = rig.drive_gains

        def u(k: int, count: int) -> np.ndarray:
            """The torques over samples k..: the first level, then the second."""
            return delivered_torque(commands(np.arange(k, k + count)), s, gains)

    stop = integrate_to_stop(x0, u, s, p, dt, MAX_BRAKING_TIME)
    if stop is None:
        run = "braking pass" if s > 0 else "backward braking pass"
        raise InputError(
            f"stage {stage}: the {run} does not stop within {MAX_BRAKING_TIME:g} s; "
            "raise braking_torque or lower launch_speed in device.toml"
        )
    t, traj, end_time, end_phi = stop
    temperatures = {}
    if rig.thermal:
        if motor is None:
            motor = lambda h: advance_motor(rig, start, power, h)
        winding, magnet = motor(t)
        end_motor = MotorState(*motor(end_time))
        temperatures = {"winding": winding, "magnet": magnet, "end_motor": end_motor}
    truth = PassTruth(
        t=t,
        phi=traj[:, 0],
        omega=traj[:, 1],
        torque=u(0, len(t)) if callable(u) else np.full(len(t), u),
        end_time=end_time,
        end_phi=end_phi,
        end_omega=0.0,
        **temperatures,
    )
    stream = STREAM_BRAKING if s > 0 else STREAM_BRAKING_BACKWARD
    pair = true_pair(device, stage, virtual)
    truth = jittered(truth, pair, virtual, (stage, stream + STREAM_CLOCK), dt)
    q = device.encoder.quantum
    if switch is None:
        sim = logged(truth, np.full(len(truth.t), command), virtual, (stage, stream), q)
    else:
        sim = logged(truth, commands(np.arange(len(truth.t))), virtual, (stage, stream), q)
        command = command_2  # the drive holds the body with the level it ends on
    sim = held_after_stop(sim, command, virtual, (stage, stream), q, dt, s)
    if rig.thermal:  # the held rows too: the drive holds the body with the same command
        winding = motor(sim.log.t)[0]
        sim = with_temperature(sim, virtual, winding, (stage, stream))
    return sim


def _switch_sample(st: Stage, x0, u: float, s: float, p, dt: float, stage: int) -> int | None:
    """The sample from which a two-level braking holds ``braking_torque_2`` (None: one
    level): the first sample past ``braking_switch_turns`` from the release."""
    if st.braking_torque_2 is None:
        return None
    angle = 2.0 * math.pi * st.braking_switch_turns
    switch = samples_to_angle(x0, u, s, p, dt, angle, MAX_BRAKING_TIME)
    if switch is None:
        raise InputError(
            f"stage {stage}: the braking pass stops before braking_switch_turns = "
            f"{st.braking_switch_turns:g}; lower braking_switch_turns or braking_torque in "
            "device.toml"
        )
    return switch


def _two_level_motor(
    rig, start: MotorState, power_1: float, power_2: float, switch_time: float
):
    """The winding's and the magnets' rises at times t (s) of a two-level braking: heated by
    ``power_1`` from ``start`` (the run's) until ``switch_time``, by ``power_2`` after."""
    at_switch = MotorState(*advance_motor(rig, start, power_1, switch_time))

    def motor(t):
        t = np.asarray(t, dtype=float)
        w1, m1 = advance_motor(rig, start, power_1, np.minimum(t, switch_time))
        w2, m2 = advance_motor(rig, at_switch, power_2, np.maximum(t - switch_time, 0.0))
        before = t < switch_time
        return np.where(before, w1, w2), np.where(before, m1, m2)

    return motor


def simulate_pendulum(device: Device, stage: int, virtual: Virtual, node: int) -> SimulatedPass:
    """Torsion-pendulum run at node ``node`` (0-based) of a stage: motor off, free oscillation.

    Released at rest, ``amplitude_deg`` past the node, and logged for ``duration`` seconds
    (device.toml ``[pendulum]``); each stop (twice a period) is an event with static
    friction, as in every pass. The logged torque is the motor's: zero, plus the log's noise.

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

    Returns
    -------
    SimulatedPass
        The log and the true states.
    """
    params = pendulum_parameters(device, stage, virtual, node)
    pair = (params.vector, pendulum_parameters(device, stage, virtual, node, -1).vector)
    dt = device.encoder.dt
    n = round(device.pendulum.duration / dt) + 1
    x0 = np.array([params.zero_angle + math.radians(device.pendulum.amplitude_deg), 0.0])
    traj = integrate_free(x0, pair, n, dt)
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
    # grid's last sample: resample advances from there).
    clock = (stage, STREAM_PENDULUM + STREAM_CLOCK, node)
    truth = resample(truth, pair, sampling_instants(virtual, clock, n, dt))
    truth = dataclasses.replace(
        truth,
        end_time=float(truth.t[-1]),
        end_phi=float(truth.phi[-1]),
        end_omega=float(truth.omega[-1]),
    )
    seed = (stage, STREAM_PENDULUM, node)
    return logged(truth, np.zeros(len(truth.t)), virtual, seed, device.encoder.quantum)


def free_motion(
    device: Device, stage: int, virtual: Virtual, duration: float, damped: bool
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The body released as for the braking pass but with the motor off (paper Fig. 3).

    Parameters
    ----------
    device : Device
        The gimbal.
    stage : int
        The stage number, from 1.
    virtual : Virtual
        The virtual device's truth.
    duration : float
        s, how long the motion is followed.
    damped : bool
        Keep the friction (free damped motion); otherwise friction is removed too (free
        undamped motion: energy is conserved).

    Returns
    -------
    t, phi, Omega : numpy.ndarray
        The true motion: s, rad, rad/s at each sample.
    """
    pair = true_pair(device, stage, virtual)
    if not damped:
        params = dataclasses.replace(
            true_parameters(device, stage, virtual),
            **FRICTION.model_fields(dict.fromkeys(FRICTION.names, 0.0)),
        )
        pair = (params.vector, params.vector)
    dt = device.encoder.dt
    n = round(duration / dt) + 1
    st = device.stages[stage - 1]
    x0 = np.array([math.radians(release_angle(st, virtual)), st.launch_speed])
    traj = integrate_free(x0, pair, n, dt)
    return np.arange(n) * dt, traj[:, 0], traj[:, 1]


def simulate_pilot(device: Device, stage: int, virtual: Virtual) -> SimulatedPass:
    """A pilot run of stage ``stage`` (1-based): spin-up at a known torque, then a free coast.

    The short run from which the planner estimates the stage's mean reduced inertia and its
    friction before the experiment (``stageN/pilot.csv``, the log format of braking.csv;
    rsp_inertia.design.pilot fits it). Protocol, forward only:

    1. The body starts at rest at the release angle (``virtual.run.release_angle_deg``).
    2. Powered part: the drive commands the constant torque PILOT_TORQUE_FRACTION x
       ``motor.torque_limit`` (forward), held sample by sample, until the first sample at
       which the true speed has reached the stage's ``launch_speed`` (a stage without one:
       the body has turned PILOT_TURNS turns), or has fallen below PILOT_PEAK_FRACTION of
       its highest value so far (a spring wound up against the motor; the within-turn
       exchange with M(phi) moves the speed by a few percent only).
    3. Coast: from that sample on the command is 0 (the motor is off; the log still records
       0 plus the channel's noise) and the body coasts until it comes to rest (the first
       instant the speed reaches zero, an event located inside its sample as in
       :func:`simulate_braking`) or until PILOT_MAX_COAST seconds of coast, whichever
       comes first.

    The log records the command plus ``run.torque_noise``; the body receives h_d x the
    command (``[rig]``: the motor drives it), like every pass. Samples at the encoder rate, t
    from 0; when the body comes to rest the log ends at the last sample before the stop (at
    the stop if it falls on a sample), otherwise at the last sample within PILOT_MAX_COAST of
    the switch-off.
    The command steps at t = 0 and at the switch-off: the drive's torque rate limit is not
    modelled (0.0125 s at the default 20 N m/s for the default 0.25 N m). The noise has its
    own random stream: the run is deterministic for a given seed.

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
    SimulatedPass
        The log and the true states; ``truth.torque`` is the physical torque; ``end_time``
        is the instant of rest (or the log's last sample when the coast was cut),
        ``end_omega`` the speed there.

    Raises
    ------
    InputError
        If the pilot torque cannot turn the body forward from the release angle (friction and
        static torques hold it), or the spin-up does not end within MAX_BRAKING_TIME.
    """
    st = device.stages[stage - 1]
    pair = true_pair(device, stage, virtual)
    p = pair[0]
    dt = device.encoder.dt
    command = PILOT_TORQUE_FRACTION * device.motor.torque_limit
    u = delivered_torque(command, 1.0, virtual.rig.drive_gains)  # the motor drives it forward
    # Powered part, whole blocks at once: states up to the first sample at the launch speed
    # (or PILOT_TURNS turns past the start).
    x = np.array([math.radians(virtual.run.release_angle_deg), 0.0])
    if st.launch_speed is None:
        speed, angle = math.inf, x[0] + 2 * math.pi * PILOT_TURNS
        goal = f"turn the body {PILOT_TURNS:g} turns"
    else:
        speed, angle = st.launch_speed, math.inf
        goal = f"reach the launch speed {st.launch_speed:g} rad/s"
    states = [x[None, :]]
    n = 1
    top_so_far = 0.0
    while True:
        block = step_block(x, u, 1.0, p, dt)  # (BLOCK, 2)
        top = np.maximum.accumulate(np.concatenate([[top_so_far], block[:, 1]]))[1:]
        peaked = block[:, 1] < PILOT_PEAK_FRACTION * top
        reached = np.nonzero((block[:, 1] >= speed) | (block[:, 0] >= angle) | peaked)[0]
        if np.any(block[: reached[0] if reached.size else BLOCK, 1] <= 0.0):
            raise InputError(
                f"stage {stage}: the pilot torque ({command:g} N m) does not turn the body "
                "forward from the release angle: friction and static torques hold it"
            )
        if reached.size:
            states.append(block[: reached[0] + 1])
            n += reached[0] + 1
            break
        states.append(block)
        n += BLOCK
        x = block[-1]
        top_so_far = float(top[-1])
        if n * dt > MAX_BRAKING_TIME:
            raise InputError(
                f"stage {stage}: the pilot torque ({command:g} N m) does not {goal} "
                f"within {MAX_BRAKING_TIME:g} s"
            )
    powered = np.concatenate(states)
    switch = len(powered) - 1  # the first sample of the coast
    # Coast, motor off, until rest or PILOT_MAX_COAST.
    stop = integrate_to_stop(powered[-1], 0.0, 1.0, p, dt, PILOT_MAX_COAST)
    if stop is not None and stop[2] <= PILOT_MAX_COAST:
        _, coast, end_time, end_phi = stop
        end_time, end_omega = switch * dt + end_time, 0.0
    else:  # still moving: no stop within the coast's samples, so no event to handle
        coast = integrate_free(powered[-1], pair, math.floor(PILOT_MAX_COAST / dt + 1e-9) + 1, dt)
        end_phi, end_omega = coast[-1]
        end_time = (switch + len(coast) - 1) * dt
    traj = np.concatenate([powered[:-1], coast])
    t = np.arange(len(traj)) * dt
    commands = np.where(np.arange(len(t)) < switch, command, 0.0)
    truth = PassTruth(
        t=t,
        phi=traj[:, 0],
        omega=traj[:, 1],
        torque=delivered_torque(commands, 1.0, virtual.rig.drive_gains),
        end_time=float(end_time),
        end_phi=float(end_phi),
        end_omega=float(end_omega),
    )
    truth = jittered(truth, pair, virtual, (stage, STREAM_PILOT + STREAM_CLOCK), dt)
    commands = np.where(truth.t < switch * dt, command, 0.0)
    return logged(truth, commands, virtual, (stage, STREAM_PILOT), device.encoder.quantum)
