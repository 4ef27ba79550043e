"""Rehearsal of a plan: the chosen experiment run in closed loop on the planner's nominal model.

The planner's prediction (rsp_inertia.estimation.predict) is that of an ideal reverse: the exact mirror
of an exact braking, identify's noise model on it. A closed-loop reverse differs in two ways
that identify sees and the ideal prediction cannot:

- **Tracking mismatch.** identify fits, per run, the two friction slopes of the mismatch
  delta = |Omega'| - |Omega| (rsp_inertia.estimation.balance). Their columns take information from the
  tensor in proportion to how much their shape resembles M's harmonics, whatever their size
  (scaling a column leaves a least squares' covariance unchanged), and the shape is set by
  how the regulator follows a feedforward computed from a nominal model that is a few
  percent off (rsp_inertia.ocp.nominal cannot see Coulomb friction).
- **Closed-loop speed noise.** The regulator's torque steps with every encoder count move
  the body in a way the smoother does not follow; identify measures that as its
  speed-noise scale.

The rehearsal therefore runs what the experiment will run, with the nominal model as the
truth: for every stage and direction the braking of the chosen protocol (encoder
quantization, the torque log's noise of the pilot or the guess; the release where the plan
puts it, rsp_inertia.design.candidates.planned_release), ``program`` from that
braking log (its own nominal fit, blind to a1 as on the rig), the closed-loop reverse on a
drive with the regulator's assumed speed observer (rsp_inertia.ocp.regulator.OBSERVER_BANDWIDTH) and the
motor's limits, and identify's least squares on those logs. Its reported stds are the
prediction. One realisation, seeded: the stds scatter by 3% over four noise seeds (spring
scenario). What the rehearsal cannot know is how far the program's nominal model will be
from the real truth, which sets the mismatch's shape: its truth is the pilot's model, whose
a1 a pilot pins only loosely (benchmarks/results/plan.md).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from rsp_inertia.design.candidates import Candidate, StageModel, planned_release
from rsp_inertia.design.plan import map_stages
from rsp_inertia.estimation.axes import axis_values
from rsp_inertia.estimation.balance import stage_balance
from rsp_inertia.estimation.columns import format_run
from rsp_inertia.estimation.runs import estimate_run
from rsp_inertia.estimation.tensor_fit import fit_tensor
from rsp_inertia.infra.progress import say
from rsp_inertia.ocp.program import make_program
from rsp_inertia.ocp.regulator import OBSERVER_BANDWIDTH
from rsp_inertia.plant.config import Device
from rsp_inertia.plant.geometry import device_design
from rsp_inertia.plant.model import ModelParameters, harmonics_matrix, inertia_harmonics
from rsp_inertia.virtual.config import ControllerSettings, Friction, RunSettings, Virtual
from rsp_inertia.virtual.device import run_program, simulate_braking

__all__ = ["Rehearsal", "consistent_models", "rehearse"]


def consistent_models(device: Device, models: Sequence[StageModel]) -> list[ModelParameters]:
    """The stages' models with M's harmonics and gravity of one body.

    Each stage's pilot is fitted alone, so the stages' harmonics need not come from one tensor,
    nor their gravity terms from one centre of mass; identify fits one of each to all stages
    and would read the difference as a misfit. The harmonics are linear in the tensor
    (rsp_inertia.plant.model.inertia_harmonics, docs/method.md §2): least squares over every stage's
    harmonics gives the tensor, and the harmonics are recomputed from it; Gs and Gc
    (m g x_c, m g y_c, the same for every stage) are averaged. With one stage the model
    stays as it is.
    """
    if len(models) < 2:
        return [sm.model for sm in models]
    rows, rhs = [], []
    for sm in models:
        st = device.stages[sm.stage - 1]
        rows.append(harmonics_matrix(st.gear_ratio))
        rhs.append(sm.model.inertia_harmonics - inertia_harmonics(np.zeros(6), 0.0, st.tare_inertia))
    tensor, *_ = np.linalg.lstsq(np.vstack(rows), np.concatenate(rhs), rcond=None)
    gs = float(np.mean([sm.model.gravity_sin for sm in models]))
    gc = float(np.mean([sm.model.gravity_cos for sm in models]))
    return [
        dataclasses.replace(
            sm.model,
            inertia_harmonics=inertia_harmonics(
                tensor, device.stages[sm.stage - 1].gear_ratio,
                device.stages[sm.stage - 1].tare_inertia,
            ),
            gravity_sin=gs,
            gravity_cos=gc,
        )
        for sm in models
    ]


@dataclass(frozen=True)
class Rehearsal:
    """identify's result on the rehearsed experiment."""

    axis_std: np.ndarray
    """kg m^2, J_k std at every node (device_design order)."""
    speed_noise_scale: list[float]
    """Per run, identify's speed-noise scale."""
    runs: list[str]
    """The runs, e.g. "stage 1 forward"."""
    saturated: float
    """Largest share over the runs of reverse samples at the drive's torque-rate or torque
    limit."""


def rehearse(
    device: Device,
    models: Sequence[StageModel],
    chosen: Sequence[Candidate],
    seed: int = 0,
) -> Rehearsal:
    """Simulate the chosen protocols in closed loop on the models and identify them.

    The stages are independent until the least squares, so they run in parallel processes
    (rsp_inertia.design.plan.map_stages); each stage's noise has its own seeded stream.

    Parameters
    ----------
    device : Device
        The gimbal; the chosen protocols replace its stages' own.
    models : sequence of StageModel
        What the planner knows of each stage: made consistent (:func:`consistent_models`),
        the models are the rehearsal's truth.
    chosen : sequence of Candidate
        The protocol chosen for each stage.
    seed : int, optional
        The noise's random seed.

    Returns
    -------
    Rehearsal
        identify's stds on the rehearsed experiment, its speed-noise scales and the largest
        share of reverse samples at the drive's limits.

    Raises
    ------
    InputError
        What ``program`` or the identification would refuse on this experiment.
    """
    stages = list(device.stages)
    for c in chosen:
        st = stages[c.stage - 1]
        stages[c.stage - 1] = dataclasses.replace(
            st,
            launch_speed=c.launch_speed,
            braking_torque=c.braking_torque,
            braking_torque_2=c.braking_torque_2,
            braking_switch_turns=c.braking_switch_turns,
            release_angle_deg=planned_release(st),
        )
    dev = dataclasses.replace(device, stages=tuple(stages))
    truth = [None] * len(stages)
    for sm, model in zip(models, consistent_models(dev, models)):
        truth[sm.stage - 1] = model
    jobs = [(dev, sm.stage, sm.torque_noise, tuple(truth), seed) for sm in models]
    say(f"rehearsing the plan in closed loop on the nominal model ({len(jobs)} stages)")
    done = map_stages(_rehearse_stage, jobs)
    balances = [b for stage_balances, _, _ in done for b in stage_balances]
    fit = fit_tensor(balances, tests=False)
    design = device_design(dev)
    _, stds = axis_values(fit.entries, fit.entries_cov, design.directions)
    return Rehearsal(
        axis_std=np.asarray(stds),
        speed_noise_scale=[float(s) for s in fit.speed_noise_scale],
        runs=[label for _, labels, _ in done for label in labels],
        saturated=max(sat for _, _, sat in done),
    )


def _rehearse_stage(dev: Device, stage: int, torque_noise: float, truth: tuple, seed: int):
    """One stage's runs (every direction): balances, run labels, largest saturated share."""
    st = dev.stages[stage - 1]
    motor, dt = dev.motor, dev.encoder.dt
    virtual = Virtual(
        body=None,
        friction=Friction(0.0, 0.0, 0.0),
        run=RunSettings(torque_noise=torque_noise, seed=seed),  # the release: dev's stage
        controller=ControllerSettings(speed_observer_bandwidth=OBSERVER_BANDWIDTH),
        models=truth,
    )
    balances, labels, warnings = [], [], []
    saturated = 0.0
    for direction in st.directions:
        braking = simulate_braking(dev, stage, virtual, direction)
        made = make_program(dev, stage, braking.log, direction=direction)
        program = made.program
        start = (braking.truth.end_phi, 0.0)
        reverse = run_program(
            dev, stage, virtual, program, start, direction=direction, coarse=True
        )
        u = reverse.truth.torque  # the drive's command (the rehearsal's rig is exact)
        at_limit = (np.abs(np.diff(u)) >= motor.torque_rate_limit * dt * (1 - 1e-9)) | (
            np.abs(u[1:]) >= motor.torque_limit * (1 - 1e-9)
        )
        saturated = max(saturated, float(np.mean(at_limit)))
        label = format_run((stage, direction))
        b_est, r_est = estimate_run(
            dev, braking.log, reverse.log, direction, warnings,
            f"rehearsed {label} braking", f"rehearsed {label} reverse", made.smoothed,
            two_levels=st.braking_torque_2 is not None,
        )
        balances.append(stage_balance(dev, stage, b_est, r_est, direction.sign))
        labels.append(label)
    return balances, labels, saturated
