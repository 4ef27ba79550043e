"""The stage models a plan starts from: each stage's pilot run's fit, else device.toml's
``[plan]`` guesses (docs/method.md §4).

A plan needs, per stage, a nominal model of the forward motion (inertia, gravity, spring,
friction) and the torque log's noise (rsp_inertia.design.candidates.StageModel). A pilot run
(``stageN/pilot.csv``: spin-up at a known torque, then a coast) is fitted for them
(rsp_inertia.design.pilot); without one, a new rig's ``[plan]`` table states rough guesses.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rsp_inertia.design.candidates import StageModel
from rsp_inertia.design.pilot import fit_pilot
from rsp_inertia.design.plan import map_stages
from rsp_inertia.estimation.reading import read_calibration, tempco_in_use
from rsp_inertia.infra.errors import InputError
from rsp_inertia.infra.progress import say
from rsp_inertia.plant.config import Device
from rsp_inertia.plant.experiment import open_experiment
from rsp_inertia.plant.friction import FRICTION
from rsp_inertia.plant.logs import Log, compensate_temperature, read_device_log
from rsp_inertia.plant.model import ModelParameters, inertia_harmonics

__all__ = ["guess_model", "stage_models"]


def guess_model(device: Device, stage: int) -> tuple[ModelParameters, float]:
    """Nominal model and torque noise of a stage from ``device.toml [plan]`` (no pilot run).

    The inertia harmonics are those of a body whose principal moments all equal J, the mean
    of the guessed ones (rsp_inertia.plant.model.inertia_harmonics: M0 = M_tare +
    (1 + lambda^2) J, the axis's J_e lying between the extreme moments; docs/method.md §2),
    so no M harmonics (their effect on the mirror's torque cancels, module docstring of
    rsp_inertia.design.candidates); gravity m g r from the mass and the guessed offset of the
    centre of mass; friction and spring as given.

    Parameters
    ----------
    device : Device
        The gimbal, with its ``[plan]`` table (and ``[body] mass`` for ``plan.box``).
    stage : int
        The stage, from 1.

    Returns
    -------
    model : rsp_inertia.plant.model.ModelParameters
        The stage's nominal model.
    torque_noise : float
        N m, ``plan.torque_noise``.

    Raises
    ------
    InputError
        No ``[plan]`` table, no ``plan.inertia`` (nor ``plan.box`` with a mass), or no
        ``plan.torque_noise``: each names what is missing.
    """
    guess = device.plan
    where = f"{device.name}: device.toml"
    pilot = f"stage{stage}/pilot{device.log.extension}"
    if guess is None:
        raise InputError(
            f"{where}: no [plan] table and no {pilot}: give the body's "
            "approximate principal moments (plan.inertia or plan.box) and a friction guess, "
            "or record a pilot run"
        )
    mass = device.body.mass if device.body is not None else None
    moments = guess.principal_moments(mass)
    if moments is None:
        raise InputError(
            f"{where}: plan.inertia: missing (or plan.box with [body] mass), and no "
            f"{pilot}"
        )
    if guess.torque_noise is None:
        raise InputError(
            f"{where}: plan.torque_noise: missing, and no {pilot} to measure it"
        )
    st = device.stages[stage - 1]
    J = float(np.mean(moments))
    harmonics = inertia_harmonics([J, J, J, 0.0, 0.0, 0.0], st.gear_ratio, st.tare_inertia)
    weight = (mass or 0.0) * device.gravity * guess.com_offset
    model = ModelParameters(
        inertia_harmonics=harmonics,
        stiffness=device.spring.stiffness,
        zero_angle=device.spring.zero_angle,
        gravity_sin=weight,
        gravity_cos=0.0,
        **FRICTION.model_fields(dict(zip(FRICTION.names, guess.friction))),
    )
    return model, guess.torque_noise


def stage_models(root: str | Path) -> list[StageModel]:
    """Per stage: the pilot run's fit if ``stageN/pilot.csv`` exists, else device.toml's guess.

    The pilots are read here (a bad log's error comes before any process starts) and fitted
    per stage in parallel (rsp_inertia.design.plan.map_stages).

    Parameters
    ----------
    root : str or pathlib.Path
        The experiment folder.

    Returns
    -------
    list of StageModel
        One per stage, in order.
    """
    exp = open_experiment(root, protocol=False)
    tempco = _tempco(exp)
    jobs = []
    for stage in exp.stages(None):
        path = exp.pilot_path(stage)
        log = read_device_log(path, exp.device, "pilot") if path.is_file() else None
        if log is not None:  # its torque at the reference temperature, as identify's
            log = compensate_temperature(log, exp.device.motor, tempco)
        for warning in () if log is None else log.warnings:
            say(f"warning: {warning}")  # a glitch the reader left out
        jobs.append((exp.device, stage, path, log))
    return map_stages(_stage_model, jobs)


def _tempco(exp) -> float | None:
    """The tempco identify compensates with (rsp_inertia.estimation.reading.tempco_in_use:
    calibration.toml's where calibrate measured it, else device.toml's); device.toml's when
    calibration.toml cannot be read (check and identify say why; a plan does not need it)."""
    try:
        calibration = read_calibration(exp)
    except InputError:
        calibration = None
    return tempco_in_use(exp, calibration)[0]


def _stage_model(device: Device, stage: int, path: Path, log: Log | None) -> StageModel:
    """One stage's model: its pilot's fit (``log``, read from ``path``), else device.toml's
    guess."""
    if log is not None:
        fit = fit_pilot(device, stage, log, str(path))
        bound = fit.a1 + 2 * fit.a1_std if np.isfinite(fit.a1_std) else fit.a1
        return StageModel(stage, fit.model(), fit.torque_noise, str(path), bound)
    model, noise = guess_model(device, stage)
    return StageModel(stage, model, noise, "device.toml [plan]")
