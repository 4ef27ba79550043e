"""From a braking log to the reverse pass's program (the ``program`` command's library call).

Steps, each in its own module: smoothing (rsp_inertia.estimation.smoothing, the identification's own
smoother), the mirror (rsp_inertia.ocp.reference), the nominal model (rsp_inertia.ocp.nominal), the OCP
(rsp_inertia.ocp.feedforward), the regulator (rsp_inertia.ocp.regulator).
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass

import numpy as np

from rsp_inertia.estimation.smoothing import Smoothed, smooth_log
from rsp_inertia.ocp.feedforward import (
    OcpSolution,
    check_mirror,
    mirror_torque,
    required_torque,
    solve_program_ocp,
)
from rsp_inertia.ocp.nominal import fit_nominal_with_covariance
from rsp_inertia.ocp.reference import Mirror, mirror
from rsp_inertia.ocp.regulator import bandwidth, lqr_gains
from rsp_inertia.plant.config import Device, Stage
from rsp_inertia.plant.direction import Direction
from rsp_inertia.plant.log_files import log_rows
from rsp_inertia.plant.logs import (
    Log,
    Program,
    check_braking_monotone,
    mirror_log,
    mirrored_device,
    switch_row,
    torque_noise,
)
from rsp_inertia.plant.model import ModelParameters, reduced_inertia

__all__ = ["START_FADE_BANDWIDTHS", "TorqueProgram", "make_program", "start_reference"]


@dataclass(frozen=True)
class TorqueProgram:
    """A program and how it was made."""

    program: Program
    """What program.csv holds."""
    mirror: Mirror
    """The reference."""
    nominal: ModelParameters
    """The nominal model fitted to the braking."""
    ocp: OcpSolution
    """The OCP's solution on its grid."""
    smoothed: Smoothed
    """The braking log's smoothed states (of the mirrored log for a backward run)."""
    seconds: float
    """Wall time of the whole generation."""
    warnings: tuple[str, ...] = ()
    """What the program's checks found: the braking log's notes and warnings (rows the reader
    left out after its turning point, rsp_inertia.plant.logs.Log.notes, and glitches,
    rsp_inertia.plant.logs.Log.warnings), a mirror that leaves the
    regulator little of the motor's limits (rsp_inertia.ocp.feedforward.check_mirror)."""


START_FADE_BANDWIDTHS = 3.0
"""Regulator time constants (1 / w, rsp_inertia.ocp.regulator) over which the reference returns from the
OCP's start transient to the mirror."""


def start_reference(
    device: Device, ref: Mirror, sol: OcpSolution, model: ModelParameters
) -> tuple[np.ndarray, np.ndarray]:
    """The regulator's reference (phi, Omega) at the program's samples.

    The mirror, except over the start: there the torque must step from the hold to the
    mirror's first torque at the drive's rate (the OCP's bound), so the body cannot follow the
    mirror, and the OCP's trajectory departs from it. Regulating onto the bare mirror there
    would fight the feedforward. So the reference carries the OCP's departure (linear between
    its grid points) for the step's duration |u'(0) - hold| / torque_rate_limit, then fades
    it out with a half cosine over START_FADE_BANDWIDTHS / w, w the regulator's bandwidth.
    Not beyond: after the start the OCP tracks the mirror only to its cost's tolerance (up to
    6e-4 of the top speed on the default stages), which the regulator removes.

    Parameters
    ----------
    device : Device
        The gimbal: its motor's ``torque_rate_limit`` and the regulator's bandwidth.
    ref : Mirror
        The mirror, on the program's samples.
    sol : OcpSolution
        The OCP's solution on its grid.
    model : ModelParameters
        The nominal model.

    Returns
    -------
    phi_ref, omega_ref : numpy.ndarray
        rad and rad/s at the mirror's samples.
    """
    need = float(required_torque(ref, model)[0])
    step = abs(need - float(sol.torque[0])) / device.motor.torque_rate_limit
    w = bandwidth(device, float(np.max(reduced_inertia(ref.phi, model))))
    fade = START_FADE_BANDWIDTHS / w
    s = np.clip((ref.t - step) / fade, 0.0, 1.0)
    weight = 0.5 * (1.0 + np.cos(np.pi * s))
    phi_dev = np.interp(ref.t, sol.t, sol.phi - np.interp(sol.t, ref.t, ref.phi))
    omega_dev = np.interp(ref.t, sol.t, sol.omega - np.interp(sol.t, ref.t, ref.omega))
    return ref.phi + weight * phi_dev, ref.omega + weight * omega_dev


def _braking_torque_at(braking: Log, sm: Smoothed, ref: Mirror, sigma: float, stage: Stage):
    """The braking's applied torque where the mirror is, N m, and its variance, (N m)^2: the
    log's mean; for a two-level braking (device.toml ``braking_torque_2``) each level's mean
    on its side of the switch, which the log shows
    (rsp_inertia.plant.logs.switch_row).

    Parameters
    ----------
    braking : Log
        The braking log (forward).
    sm : Smoothed
        Its smoothed states.
    ref : Mirror
        The reverse's reference (its angles).
    sigma : float
        N m, the torque log's noise.
    stage : Stage
        The stage: whether its braking holds two levels.

    Returns
    -------
    torque, variance : float or numpy.ndarray
        One number for one level, one per mirror sample for two.
    """
    torque = np.asarray(braking.torque, dtype=float)
    if stage.braking_torque_2 is None:
        return float(np.mean(torque)), sigma**2 / torque.size
    switch = switch_row(torque)
    before = ref.phi < sm.phi[switch]  # the braking's angle rises: the forward coordinate
    levels = (float(np.mean(torque[:switch])), float(np.mean(torque[switch:])))
    rows = (switch, torque.size - switch)
    return (
        np.where(before, *levels),
        np.where(before, sigma**2 / rows[0], sigma**2 / rows[1]),
    )


def make_program(
    device: Device,
    stage: int,
    braking: Log,
    source: str = "braking.csv",
    nominal: ModelParameters | None = None,
    direction: Direction = Direction.FORWARD,
) -> TorqueProgram:
    """The torque program that drives stage ``stage`` back along the mirror of its braking.

    Parameters
    ----------
    device : Device
        The gimbal.
    stage : int
        The stage number, from 1.
    braking : Log
        The stage's braking log.
    source : str, optional
        Names the log in messages.
    nominal : ModelParameters, optional
        Use this nominal model instead of fitting one (tests of robustness perturb it).
    direction : Direction
        A backward braking (phi decreasing) is solved in the mirrored coordinate -phi, where it
        is a forward one (rsp_inertia.plant.logs.mirror_log; the spring's zero angle mirrored
        with it), and its program mirrored back: phi_ref, omega_ref and the feedforward
        change sign, the gains stay.

    Returns
    -------
    TorqueProgram
        The program (what program.csv holds) and how it was made.

    Raises
    ------
    InputError
        A braking log whose speed reverses or does not reach rest, a nominal inertia that is
        not positive, or a mirror the motor cannot drive
        (rsp_inertia.ocp.feedforward.check_mirror).
    """
    if direction is Direction.BACKWARD:
        result = make_program(
            mirrored_device(device),
            stage,
            mirror_log(braking, device.encoder.quantum),
            source,
            nominal,
        )
        prog = result.program
        program = Program(
            t=prog.t,
            phi_ref=-prog.phi_ref,
            omega_ref=-prog.omega_ref,
            torque_ff=-prog.torque_ff,
            k_phi=prog.k_phi,
            k_omega=prog.k_omega,
        )
        return dataclasses.replace(result, program=program)
    start = time.perf_counter()
    check_braking_monotone(braking, log_rows(source, device.log))
    sm = smooth_log(braking, device.encoder.quantum, source)
    ref = mirror(sm, device.encoder.sample_rate, device.encoder.quantum, source)
    friction_cov = None
    if nominal is None:
        model, friction_cov = fit_nominal_with_covariance(device, stage, braking, sm)
    else:
        model = nominal
    # The mirror's need from the braking's mean torque and the nominal friction, with their
    # uncertainty (rsp_inertia.ocp.feedforward.mirror_torque): refused only beyond it.
    sigma = torque_noise(braking)
    u_b, u_b_var = _braking_torque_at(braking, sm, ref, sigma, device.stages[stage - 1])
    need, need_std = mirror_torque(ref, model, u_b, friction_cov, u_b_var)
    # What the reader did to the braking log (its notes and warnings) first, then the
    # mirror's warnings.
    warnings = [
        *braking.notes, *braking.warnings, *check_mirror(device, stage, ref, need, need_std, u_b)
    ]
    sol = solve_program_ocp(device, stage, ref, model)
    torque = np.interp(ref.t, sol.t, sol.torque)  # u is linear between grid points
    phi_ref, omega_ref = start_reference(device, ref, sol, model)
    k_phi, k_omega = lqr_gains(device, ref.t, phi_ref, omega_ref, torque, model)
    program = Program(
        t=ref.t,
        phi_ref=phi_ref,
        omega_ref=omega_ref,
        torque_ff=torque,
        k_phi=k_phi,
        k_omega=k_omega,
    )
    return TorqueProgram(
        program=program,
        mirror=ref,
        nominal=model,
        ocp=sol,
        smoothed=sm,
        seconds=time.perf_counter() - start,
        warnings=tuple(warnings),
    )
