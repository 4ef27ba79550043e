"""The virtual device's drive and its logger: what leaves the device of a simulated pass.

A rig's drive reads the encoder, floor((phi + e(phi))/q) q with the encoder's reading error e
(:func:`rsp_inertia.plant.transducers.encoder_reading`, ``[rig]``), at its sampling instants: one per period of the sample
rate, each off the regular grid by up to
``[logger] time_jitter`` of a period (:func:`sampling_instants`). Its controller estimates
the speed from the encoder alone (:class:`SpeedObserver`). The log records the drive's
command plus the torque channel's noise, less the rows the logger drops
(``[logger] dropped_fraction``); the body receives the command times h_d while the motor drives
it and h_b while it back-drives the motor (``[rig]``: torque gain and the transmission's
efficiencies, rsp_inertia.plant.transducers). The true states are returned beside the log
(:class:`SimulatedPass`) for tests and benchmarks, never written where ``identify`` or
``program`` could read them.

Every pass draws from its own reproducible random streams, numbered per stage: the noise of
its log, the jitter of its instants and the rows its logger drops.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from rsp_inertia.plant.config import Stage
from rsp_inertia.plant.logs import Log, Program
from rsp_inertia.plant.transducers import delivered_torque
from rsp_inertia.virtual.config import Virtual
from rsp_inertia.virtual.integrate import Pair, advance
from rsp_inertia.virtual.thermal import COLD, MotorState, logged_temperature

__all__ = [
    "STREAM_BRAKING",
    "STREAM_BRAKING_BACKWARD",
    "STREAM_CLOCK",
    "STREAM_DROPS",
    "STREAM_HOLD",
    "STREAM_PENDULUM",
    "STREAM_PILOT",
    "STREAM_REVERSE",
    "STREAM_REVERSE_BACKWARD",
    "STREAM_TEMPERATURE",
    "PassTruth",
    "ProgramDrive",
    "SimulatedPass",
    "SpeedObserver",
    "braking_torque",
    "held_after_stop",
    "jittered",
    "logged",
    "resample",
    "sampling_instants",
    "with_temperature",
]

# Seeds of the independent random streams of one stage (numpy SeedSequence entropy words).
STREAM_BRAKING = 0
STREAM_REVERSE = 1
STREAM_PENDULUM = 2
STREAM_BRAKING_BACKWARD = 3
STREAM_REVERSE_BACKWARD = 4
STREAM_PILOT = 5
STREAM_CLOCK = 100
"""Added to a pass's stream for its sampling instants' jitter (``[logger] time_jitter``)."""
STREAM_DROPS = 200
"""Added to a pass's stream for the rows its logger drops (``[logger] dropped_fraction``)."""
STREAM_HOLD = 300
"""Added to a braking's stream for the rows logged while the body is held after the stop
(``[logger] hold_after_stop``: their noise and dither)."""
STREAM_TEMPERATURE = 400
"""Added to a pass's stream for the noise of its logged temperature (``[rig]
temperature_noise``)."""


def braking_torque(stage: Stage, virtual: Virtual, s: float) -> tuple[float, float]:
    """The braking pass's motor torque, N m: (the logged command, the torque the body receives).

    The command is the constant braking torque against the motion, -s braking_torque; the
    body, moving in direction s, back-drives the motor and receives h_b x the command
    (``[rig]``: torque gain and back-driven efficiency,
    :func:`rsp_inertia.plant.transducers.delivered_torque`).

    Parameters
    ----------
    stage : Stage
        The stage; its ``braking_torque``, N m, is the command's magnitude.
    virtual : Virtual
        The virtual device; its ``[rig]`` drive gains give h_b.
    s : float
        Direction of the motion, +1.0 forward, -1.0 backward
        (:attr:`rsp_inertia.plant.direction.Direction.sign`).

    Returns
    -------
    command : float
        N m, the logged command -s braking_torque.
    delivered : float
        N m, the torque the body receives, h_b x the command.
    """
    command = -s * stage.braking_torque
    return command, delivered_torque(command, s, virtual.rig.drive_gains)


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
    winding: np.ndarray | None = None
    """K, the winding's rise above the ambient at t (rsp_inertia.virtual.thermal); None on a
    rig whose motor stays at the ambient."""
    magnet: np.ndarray | None = None
    """K, the magnets' rise above the ambient at t, whose torque constant ``torque`` holds;
    None as ``winding``."""
    end_motor: MotorState = COLD
    """The motor's temperatures at end_time: where the next pass of the run starts."""


@dataclass(frozen=True)
class SimulatedPass:
    """One pass of the virtual device: the log a rig writes, and the truth beside it."""

    log: Log
    """What the rig writes (encoder angle, logged torque)."""
    truth: PassTruth
    """The simulator's true states."""


def sampling_instants(virtual: Virtual, seed: tuple, n: int, dt: float) -> np.ndarray:
    """s, the drive's first ``n`` sampling instants (k + d_k) dt, d_0 = 0 and d_k uniform
    within +-``[logger] time_jitter`` (a fraction of the period); k dt exactly without jitter.

    Parameters
    ----------
    virtual : Virtual
        The virtual device: its ``[logger] time_jitter`` and ``[run] seed``.
    seed : tuple
        Names the pass's random stream (the same instants for the same pass).
    n : int
        How many instants.
    dt : float
        s, the nominal sampling period.

    Returns
    -------
    numpy.ndarray, shape (n,)
        s, the instants, from 0.
    """
    jitter = virtual.logger.time_jitter
    k = np.arange(n, dtype=float)
    if jitter == 0.0 or n == 0:
        return k * dt
    offsets = np.random.default_rng([virtual.run.seed, *seed]).uniform(-jitter, jitter, n)
    offsets[0] = 0.0
    return (k + offsets) * dt


def resample(truth: PassTruth, pair: Pair, instants: np.ndarray) -> PassTruth:
    """The pass ``truth`` at the drive's sampling ``instants``.

    Exact for the passes whose torque is constant between the grid's samples and the
    instants (braking, pendulum: one torque throughout, or on a warming motor one per grid
    sample, held over it, rsp_inertia.virtual.thermal; a pilot's switch-off is a grid
    sample, so its one row around the switch carries the command of the grid sample before
    it). Each state advances from the grid sample before it, stops and static friction
    included (:func:`rsp_inertia.virtual.integrate.advance`).

    Parameters
    ----------
    truth : PassTruth
        The pass: states on the regular grid, the physical torque held over each grid sample.
    pair : Pair
        The true plant the states advance in.
    instants : numpy.ndarray
        s, the drive's sampling instants, from 0; an instant past the grid's last sample
        advances from that sample.

    Returns
    -------
    PassTruth
        The states at ``instants`` (``truth`` itself when the instants are its grid).
    """
    if np.array_equal(instants, truth.t):
        return truth
    g = np.clip(np.searchsorted(truth.t, instants, side="right") - 1, 0, truth.t.size - 1)
    states = np.array(
        [
            advance(np.array([truth.phi[j], truth.omega[j]]), truth.torque[j], h, pair)
            for j, h in zip(g.tolist(), (instants - truth.t[g]).tolist())
        ]
    )
    return dataclasses.replace(
        truth, t=instants, phi=states[:, 0], omega=states[:, 1], torque=truth.torque[g],
        **_rows(truth, g),
    )


def _rows(truth: PassTruth, rows) -> dict:
    """The motor's temperatures of ``truth`` at ``rows`` (indices or a mask), as fields."""
    return {
        name: getattr(truth, name)[rows]
        for name in ("winding", "magnet")
        if getattr(truth, name) is not None
    }


def jittered(
    truth: PassTruth, pair: Pair, virtual: Virtual, seed: tuple, dt: float
) -> PassTruth:
    """``truth`` at the drive's jittered sampling instants before its end_time.

    Parameters
    ----------
    truth : PassTruth
        The pass on the regular grid.
    pair : Pair
        The true plant the states advance in.
    virtual : Virtual
        The virtual device: its ``[logger] time_jitter``.
    seed : tuple
        Names the pass's random stream (:func:`sampling_instants`).
    dt : float
        s, the nominal sampling period.

    Returns
    -------
    PassTruth
        The pass at the jittered instants; ``truth`` itself without jitter.
    """
    if virtual.logger.time_jitter == 0.0:
        return truth
    instants = sampling_instants(virtual, seed, truth.t.size + 2, dt)
    return resample(truth, pair, instants[instants < truth.end_time])


def logged(
    truth: PassTruth, command: np.ndarray, virtual: Virtual, seed: tuple, quantum: float
) -> SimulatedPass:
    """What the logger writes of a pass: encoder readings and the command plus noise at
    every sampling instant, less the rows it drops (``[logger] dropped_fraction``: at random,
    never the first or the last).

    Parameters
    ----------
    truth : PassTruth
        The pass at the drive's sampling instants.
    command : numpy.ndarray
        N m, the drive's command at each instant.
    virtual : Virtual
        The virtual device: ``[run]`` seed and torque noise, ``[rig]`` encoder error,
        ``[logger]`` dropped fraction.
    seed : tuple
        The pass's random stream; the noise is drawn on it, the drops on it plus
        :data:`STREAM_DROPS`.
    quantum : float
        rad, the encoder's step.

    Returns
    -------
    SimulatedPass
        The log and ``truth`` cut to the rows kept.
    """
    rng = np.random.default_rng([virtual.run.seed, *seed])
    noise = virtual.run.torque_noise
    torque = command + (rng.normal(0.0, noise, len(command)) if noise > 0 else 0.0)
    log = Log(
        t=np.asarray(truth.t),
        phi=virtual.rig.reading(truth.phi, quantum),
        torque=np.asarray(torque),
    )
    fraction = virtual.logger.dropped_fraction
    if fraction > 0.0:
        drop_seed = (seed[0], seed[1] + STREAM_DROPS, *seed[2:])
        lost = np.random.default_rng([virtual.run.seed, *drop_seed]).random(len(log)) < fraction
        lost[0] = lost[-1] = False
        keep = ~lost
        log = Log(t=log.t[keep], phi=log.phi[keep], torque=log.torque[keep])
        truth = dataclasses.replace(
            truth, t=truth.t[keep], phi=truth.phi[keep], omega=truth.omega[keep],
            torque=truth.torque[keep], **_rows(truth, keep),
        )
    return SimulatedPass(log=log, truth=truth)


def with_temperature(
    sim: SimulatedPass, virtual: Virtual, winding: np.ndarray, seed: tuple
) -> SimulatedPass:
    """``sim`` whose log records the motor's temperature (device.toml ``[log]
    temperature_column``): the ambient plus the winding's rise at each row, with the sensor's
    noise and resolution (rsp_inertia.virtual.thermal.logged_temperature).

    Parameters
    ----------
    sim : SimulatedPass
        The pass as logged.
    virtual : Virtual
        The virtual device: ``[rig]``'s thermal keys, ``[run] seed``.
    winding : numpy.ndarray
        K, the winding's rise at each row of ``sim.log``.
    seed : tuple
        The pass's random stream; the noise draws on it plus :data:`STREAM_TEMPERATURE`.

    Returns
    -------
    SimulatedPass
        ``sim`` with ``log.temperature`` set.
    """
    stream = [virtual.run.seed, seed[0], seed[1] + STREAM_TEMPERATURE, *seed[2:]]
    temperature = logged_temperature(virtual.rig, winding, stream)
    return dataclasses.replace(sim, log=dataclasses.replace(sim.log, temperature=temperature))


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


def held_after_stop(
    sim: SimulatedPass, command: float, virtual: Virtual, seed: tuple, quantum: float,
    dt: float, s: float,
) -> SimulatedPass:
    """A braking's log going on after the stop, as a real drive's does while it holds the body
    (``[logger] hold_after_stop``, ``hold_dither``, ``backlash_counts``): rows at the sample
    period after the last one for ``hold_after_stop`` seconds, each reading the rest's
    reading (the true rest angle through the encoder), settled back against the braking's
    direction by a count a sample up to ``backlash_counts``, off by a uniform random
    +-``hold_dither`` counts, and the drive's ``command`` plus the torque channel's noise.

    Parameters
    ----------
    sim : SimulatedPass
        The braking up to its stop (the truth stays as it is: the body is at rest after it).
    command : float
        N m, the command the log goes on recording.
    virtual : Virtual
        The virtual device: ``[logger]``, ``[run]`` seed and noise, ``[rig]`` encoder error.
    seed : tuple
        The braking's random stream; the tail draws on it plus :data:`STREAM_HOLD`.
    quantum : float
        rad, the encoder's count.
    dt : float
        s, the sample period.
    s : float
        +1 for a forward braking, -1 for a backward one.

    Returns
    -------
    SimulatedPass
        ``sim`` with the held rows after its log's last (``sim`` itself without a hold).
    """
    logger = virtual.logger
    n = round(logger.hold_after_stop / dt)
    if n == 0:
        return sim
    rng = np.random.default_rng([virtual.run.seed, seed[0], seed[1] + STREAM_HOLD, *seed[2:]])
    rest = virtual.rig.reading(np.array([sim.truth.end_phi]), quantum)[0]
    k = np.arange(1, n + 1)
    counts = -s * np.minimum(k, logger.backlash_counts)
    if logger.hold_dither:
        counts = counts + rng.integers(-logger.hold_dither, logger.hold_dither + 1, n)
    noise = virtual.run.torque_noise
    torque = command + (rng.normal(0.0, noise, n) if noise > 0 else np.zeros(n))
    log = sim.log
    held = Log(
        t=np.concatenate([log.t, log.t[-1] + k * dt]),
        phi=np.concatenate([log.phi, rest + counts * quantum]),
        torque=np.concatenate([log.torque, torque]),
    )
    return dataclasses.replace(sim, log=held)


class ProgramDrive:
    """The drive's regulator executing program.csv (docs/files.md) at its sampling instants:

        u = clip(torque_ff - k_phi (phi - phi_ref) - k_omega (omega - omega_ref), +-torque_limit)

    then the change from the previous command limited to torque_rate_limit times the step;
    phi is the encoder reading, omega the drive's speed estimate (:class:`SpeedObserver`).
    With a wrapping position counter (``span``, its range in rad) phi - phi_ref is taken
    modulo the range. One instance runs one pass: it remembers the last command. The virtual
    device's reverse pass (rsp_inertia.virtual.reverse.run_program) and any other plant that
    executes a program (benchmarks.engine, the MuJoCo rig) use it.

    Parameters
    ----------
    program : Program
        The program.
    instants : numpy.ndarray, shape (n,)
        s, the drive's sampling instants, from 0; the program's columns are interpolated
        there (taken as they are when the instants are its own ``t``).
    torque_limit, torque_rate_limit : float
        N m and N m/s, the motor's limits (``math.inf``: none).
    span : float or None
        rad, the position counter's range; None: it never wraps.
    previous : float
        N m, the command before the program (the one that held the body at rest).
    """

    def __init__(
        self,
        program: Program,
        instants: np.ndarray,
        torque_limit: float,
        torque_rate_limit: float,
        span: float | None,
        previous: float,
    ) -> None:
        names = ("torque_ff", "k_phi", "k_omega", "phi_ref", "omega_ref")
        if np.array_equal(instants, program.t):
            columns = tuple(getattr(program, name) for name in names)
        else:
            columns = tuple(np.interp(instants, program.t, getattr(program, name)) for name in names)
        self.ff, self.kp, self.kw, self.phi_ref, self.omega_ref = columns
        self.torque_limit = torque_limit
        self.torque_rate_limit = torque_rate_limit
        self.span = span
        self.previous = previous

    def command(self, k: int, y: float, omega_hat: float, h: float) -> float:
        """The command of one sample; it becomes the previous command.

        Parameters
        ----------
        k : int
            The sample's index in the program.
        y : float
            rad, the encoder reading.
        omega_hat : float
            rad/s, the drive's speed estimate.
        h : float
            s since the previous command (the rate limit's step).

        Returns
        -------
        float
            N m, the command, held until the next sample.
        """
        error = y - self.phi_ref[k]
        if self.span is not None:  # a counter's position error, modulo its range
            error -= self.span * round(error / self.span)
        u = self.ff[k] - self.kp[k] * error - self.kw[k] * (omega_hat - self.omega_ref[k])
        u = min(max(u, -self.torque_limit), self.torque_limit)
        du_max = self.torque_rate_limit * h
        u = min(max(u, self.previous - du_max), self.previous + du_max)
        self.previous = u
        return u
