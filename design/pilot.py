"""A stage's mean reduced inertia and friction from a pilot run, for experiment planning.

A pilot run (``stageN/pilot.csv``, the log format of braking.csv; the virtual device's
:func:`rsp_inertia.virtual.device.simulate_pilot`) starts at rest, drives the body forward at a constant
known torque up to the stage's launch speed (or until a spring stops the speed rising),
then switches the motor off and lets it coast to rest (or for a while). Its equation of
motion in momentum form, modulated over overlapping windows of the pass (docs/method.md §3),

    - integral w' M Omega dt - integral w F dt = integral w u dt,

is fitted by the same least squares as the nominal model of a braking pass
(:func:`rsp_inertia.estimation.modulated.fit_modulated`). What the pilot adds is a change of
torque: in a braking pass the torque is constant, Coulomb friction a1 is a constant torque too, and
(M, gravity, a2, a3) fit equally well at any common scale (rsp_inertia.ocp.nominal). In a pilot the
powered part's known work sets the scale of the kinetic energy, so M0 comes out absolutely,
and the coast, where only friction works, then separates a1, a2, a3 by how the loss changes
with the speed. A free spin-down alone (motor off throughout) has the braking's problem in
full: every term of the balance is proportional to the unknowns, so M and friction are only
known relative to each other.

The fit gets the friction torque D over the coast's speeds right, its split among a1, a2,
a3 only loosely when the coast spans a narrow speed range.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rsp_inertia.estimation.modulated import MODEL_UNKNOWNS, fit_modulated
from rsp_inertia.estimation.smoothing import smooth_log
from rsp_inertia.infra.errors import InputError
from rsp_inertia.plant.config import Device
from rsp_inertia.plant.friction import FRICTION
from rsp_inertia.plant.geometry import GRAVITY_NAMES, HARMONIC_NAMES
from rsp_inertia.plant.logs import Log, torque_noise
from rsp_inertia.plant.model import ModelParameters

__all__ = ["PILOT_UNKNOWNS", "PilotFit", "fit_pilot"]

PILOT_UNKNOWNS = MODEL_UNKNOWNS
"""Parameters fitted (names of rsp_inertia.plant.model.PARAMETER_NAMES), most important first:
a pilot too short for all of them fits only the first ones
(rsp_inertia.estimation.modulated.fit_modulated). The spring (c, phi0) comes from
device.toml."""

POWERED_SIGMAS = 6.0
"""A row is powered when its logged torque stands out of the log's noise by this many
standard deviations (a pure-noise log of 40,000 rows has such a row once in ~25 logs)."""

MIN_POWERED_ROWS = 10
"""Powered rows a pilot needs at least (the default pilots have 2,700 and 12,500)."""

MIN_COAST_TURNS = 0.5
"""Turns the coast must cover at least, and MIN_PILOT_TURNS the whole pilot: M(phi)'s
harmonics and gravity are unknowns of the fit, but they exchange no net energy only over
whole turns, which is what sets them apart from friction and the mean inertia. A spring
limits the coast (c = 0.02 N m/rad stops the default stage 1 after 0.88 coast turns, 1.84
in all), hence half a turn of coast within at least one turn of motion."""

MIN_PILOT_TURNS = 1.0
"""Turns the whole pilot (powered and coast) must cover at least (MIN_COAST_TURNS)."""


@dataclass(frozen=True)
class PilotFit:
    """What a pilot run tells about a stage (module docstring)."""

    M0: float
    """kg m^2, the mean reduced inertia (tare included) of the stage."""
    M0_std: float
    """kg m^2, std of ``M0`` (least squares, :func:`fit_pilot`)."""
    a1: float
    """N m, Coulomb friction (>= 0)."""
    a1_std: float
    """N m, std of ``a1``."""
    a2: float
    """N m s, viscous friction (>= 0)."""
    a2_std: float
    """N m s, std of ``a2``."""
    a3: float
    """N m s^2, quadratic friction (>= 0)."""
    a3_std: float
    """N m s^2, std of ``a3``."""
    torque_noise: float
    """N m, std of the torque log's noise (rsp_inertia.plant.logs.torque_noise: the median
    absolute deviation of the sample-to-sample changes, which the one step at the switch-off
    does not move)."""
    top_speed: float
    """rad/s, the highest smoothed speed of the pilot (about the launch speed)."""
    coast_turns: float
    """turns covered with the motor off, from the first unpowered row to the log's end."""
    duration: float
    """s, from the log's first row to its last."""
    inertia_harmonics: tuple[float, float, float, float, float]
    """[M0, Mc2, Ms2, Ms1, Mc1], kg m^2: M(phi) in harmonic form (rsp_inertia.plant.model), 0 if not
    fitted."""
    gravity_sin: float
    """Gs = m g x_c, N m (0 if not fitted)."""
    gravity_cos: float
    """Gc = m g y_c, N m (0 if not fitted)."""
    stiffness: float
    """c, N m/rad, device.toml's spring (not fitted)."""
    zero_angle: float
    """phi0, rad, device.toml's spring (not fitted)."""

    def model(self) -> ModelParameters:
        """The fitted model (M's harmonics, gravity, a1-a3, device.toml's spring), usable as
        a nominal model of the stage."""
        return ModelParameters(
            inertia_harmonics=np.array(self.inertia_harmonics),
            stiffness=self.stiffness,
            zero_angle=self.zero_angle,
            gravity_sin=self.gravity_sin,
            gravity_cos=self.gravity_cos,
            **FRICTION.model_fields({name: getattr(self, name) for name in FRICTION.names}),
        )


def fit_pilot(device: Device, stage: int, log: Log, source: str | None = None) -> PilotFit:
    """Mean reduced inertia and friction of stage ``stage`` from its pilot log.

    The log is smoothed (rsp_inertia.estimation.smoothing.smooth_log with the encoder's
    quantum) and the modulated momentum equation fitted over overlapping windows
    (:func:`rsp_inertia.estimation.modulated.fit_modulated`) with the unknowns
    :data:`PILOT_UNKNOWNS`: M0, M's four harmonics, gravity (Gs, Gc) and the friction a1, a2,
    a3, all of them when the log is long enough. M0 and a1-a3 are bounded below by 0. The
    stds are the least squares' from its residuals, with the overlapping windows' correlation
    (Newey-West), plus the torque noise's share exactly (an upper bound); they ignore the
    bounds.

    Parameters
    ----------
    device : Device
        The gimbal (encoder, spring).
    stage : int
        The stage number, from 1.
    log : Log
        The pilot log (rsp_inertia.plant.logs.read_log of ``stageN/pilot.csv``): the powered rows
        first, then the coast's (the protocol of rsp_inertia.virtual.device.simulate_pilot).
    source : str, optional
        The log's name in messages; default ``stageN/pilot.csv``.

    Returns
    -------
    PilotFit
        The fitted mean reduced inertia, harmonics, gravity and friction with their stds.

    Raises
    ------
    InputError
        One line naming the file: the log has no powered part (its torque never stands out
        of its noise: a free spin-down alone cannot tell the scale of M from that of
        friction), its coast covers less than one turn, or the fitted M0 is not positive.
    """
    source = f"stage{stage}/pilot{device.log.extension}" if source is None else source
    torque = np.asarray(log.torque, dtype=float)
    sigma = torque_noise(log)
    powered = np.nonzero(np.abs(torque) > POWERED_SIGMAS * sigma)[0]
    if powered.size < MIN_POWERED_ROWS:
        raise InputError(
            f"{source}: no powered part: the logged torque never stands out of its noise "
            f"({sigma:.3g} N m); a free spin-down alone cannot tell the scale of the inertia "
            "from that of friction: the pilot must start with a known drive torque"
        )
    # The coast starts where the first powered stretch ends (a stray spike later is noise).
    unpowered = np.nonzero(np.abs(torque[powered[0] :]) <= POWERED_SIGMAS * sigma)[0]
    coast_start = int(powered[0] + unpowered[0]) if unpowered.size else len(log)
    turns = (
        float(log.phi[-1] - log.phi[coast_start]) / (2 * math.pi)
        if coast_start < len(log)
        else 0.0
    )
    total = float(log.phi[-1] - log.phi[0]) / (2 * math.pi)
    if turns < MIN_COAST_TURNS or total < MIN_PILOT_TURNS:
        raise InputError(
            f"{source}: the coast (motor off) covers {turns:.2f} turns and the pilot "
            f"{total:.2f}; a pilot needs at least {MIN_COAST_TURNS:g} and {MIN_PILOT_TURNS:g} "
            "to tell friction from the inertia's and gravity's exchange within a turn"
        )
    sm = smooth_log(log, device.encoder.quantum, source)
    values, covariance = fit_modulated(
        device, [(log, sm)], PILOT_UNKNOWNS, source, torque_noise=[sigma]
    )
    std = dict(zip(PILOT_UNKNOWNS, np.sqrt(np.diag(covariance))))
    if values["M0"] <= 0.0:
        raise InputError(
            f"{source}: the fitted mean reduced inertia is not positive "
            f"({values['M0']:.3g} kg m^2): is the drive torque logged with its sign?"
        )
    return PilotFit(
        M0=float(values["M0"]),
        M0_std=float(std["M0"]),
        **{name: float(values[name]) for name in FRICTION.names},
        **{f"{name}_std": float(std[name]) for name in FRICTION.names},
        torque_noise=sigma,
        top_speed=float(sm.omega.max()),
        coast_turns=turns,
        duration=float(log.t[-1] - log.t[0]),
        inertia_harmonics=tuple(float(values[k]) for k in HARMONIC_NAMES),
        gravity_sin=float(values[GRAVITY_NAMES[0]]),
        gravity_cos=float(values[GRAVITY_NAMES[1]]),
        stiffness=device.spring.stiffness,
        zero_angle=device.spring.zero_angle,
    )
