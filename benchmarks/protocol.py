"""A sweep case's protocol: each stage's launch speed and braking torque within the motor.

A scaled friction can make the default protocol impossible: the reverse pass, the time
reversal of the braking, needs the motor to supply the braking torque and twice the friction
(:func:`mirror_torque`). :func:`fit_protocol` lowers the launch speed until that fits in
TORQUE_MARGIN of the motor's limit, and lowers the braking torque while the braking covers
too few turns past the last node. It chooses with the virtual device's TRUE model, as an
operator would from a trial run.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from scipy.optimize import brentq

from benchmarks.experiments import vary, with_stage
from rsp_inertia.checking import MIN_TURNS_PAST_LAST_NODE
from rsp_inertia.infra.errors import InputError
from rsp_inertia.ocp.feedforward import required_torque
from rsp_inertia.ocp.reference import Mirror
from rsp_inertia.plant.experiment import open_experiment
from rsp_inertia.plant.model import ModelParameters, acceleration
from rsp_inertia.simulating import simulate
from rsp_inertia.virtual.config import experiment_virtual
from rsp_inertia.virtual.device import true_parameters

__all__ = ["MAX_PROTOCOL_TRIES", "TORQUE_MARGIN", "fit_protocol", "mirror_torque"]

TORQUE_MARGIN = 0.7
"""Fraction of the motor's torque limit the mirror's reverse torque may need; the rest is the
regulator's headroom (gravity, inertia slope, tracking corrections)."""

MAX_PROTOCOL_TRIES = 8
"""Braking torques tried per stage (the default, then halved each time)."""


def mirror_torque(params: ModelParameters, speed: float, braking_torque: float) -> float:
    """N m the mirror of a braking pass needs where the braking runs at ``speed``.

    The braking state (speed, its acceleration under ``-braking_torque``) mirrored and passed
    to :func:`rsp_inertia.ocp.feedforward.required_torque` with ``params``: the braking obeys
    M eps = -b - D(Omega) + (terms of phi and Omega^2), its time reversal runs at -Omega with
    the same acceleration against the friction, so the motor supplies b + 2 D(Omega) at any
    angle (docs/method.md §4).
    """
    phi = np.zeros(1)
    eps = acceleration(phi, speed, -braking_torque, params, direction=1.0)
    mirror = Mirror(
        t=np.zeros(1), phi=phi, omega=np.full(1, -speed), eps=np.asarray(eps, dtype=float),
        rest_time=0.0, rest_angle=0.0, fitted_from=0.0,
    )
    return -float(required_torque(mirror, params)[0])


def _set_protocol(root: Path, stage: int, launch_speed: float, braking_torque: float) -> None:
    """Write one stage's launch speed and braking torque into device.toml."""
    device, _ = vary(
        root,
        device=lambda d: with_stage(
            d, stage, launch_speed=launch_speed, braking_torque=braking_torque
        ),
    )
    st = device.stages[stage - 1]
    assert (st.launch_speed, st.braking_torque) == (launch_speed, braking_torque)


def fit_protocol(root: Path, stage: int) -> dict:
    """Choose a stage's launch speed and braking torque, and run its braking pass (pipeline).

    Keep the defaults if the mirror's torque (:func:`mirror_torque`) stays within
    TORQUE_MARGIN of the motor's limit; else lower the launch speed until it does. If the
    braking then covers fewer than MIN_TURNS_PAST_LAST_NODE turns past the last node, halve
    the braking torque (which lets the launch speed rise again, up to its default) and retry.
    When no try gets there (high friction on a light stage: the friction then takes most of
    the energy a launch within the torque margin gives), the try with the most turns is kept
    and ``short_protocol_N`` says so; identification then decides whether it is enough.

    Returns
    -------
    dict
        ``launch_speed_N``, ``braking_torque_N``, ``turns_past_last_node_N``,
        ``short_protocol_N`` and ``braking_duration_N`` for the stage N.
    """
    exp = open_experiment(root)
    st = exp.device.stages[stage - 1]
    params = true_parameters(exp.device, stage, experiment_virtual(exp))
    limit = TORQUE_MARGIN * exp.device.motor.torque_limit
    if mirror_torque(params, 1e-9, 0.0) >= limit:
        raise InputError(
            f"stage {stage}: the friction alone needs more than {TORQUE_MARGIN:g} of the "
            "motor's torque limit for the reverse pass"
        )
    braking_torque = st.braking_torque
    tries = []
    for _ in range(MAX_PROTOCOL_TRIES):
        speed = st.launch_speed
        if mirror_torque(params, speed, braking_torque) > limit:
            speed = brentq(
                lambda w, b=braking_torque: mirror_torque(params, w, b) - limit,
                1e-9,
                st.launch_speed,
                xtol=1e-9,
            )
            speed = math.floor(speed * 1e6) / 1e6  # a value a person would type, still within
        _set_protocol(root, stage, speed, braking_torque)
        braking = simulate(root, stage, "braking")[0]
        tries.append((braking.turns_past_last_node, speed, braking_torque, braking))
        if braking.turns_past_last_node >= MIN_TURNS_PAST_LAST_NODE:
            break
        braking_torque /= 2.0
    turns, speed, braking_torque, braking = max(tries, key=lambda t: t[0])
    if braking is not tries[-1][3]:  # leave the chosen protocol's braking log in place
        _set_protocol(root, stage, speed, braking_torque)
        braking = simulate(root, stage, "braking")[0]
    return {
        f"launch_speed_{stage}": speed,
        f"braking_torque_{stage}": braking_torque,
        f"turns_past_last_node_{stage}": turns,
        f"short_protocol_{stage}": turns < MIN_TURNS_PAST_LAST_NODE,
        f"braking_duration_{stage}": braking.duration,
    }
