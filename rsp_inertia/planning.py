"""``rsp-inertia plan``: device.toml and pilot runs in, each stage's protocol out.

Reads ``EXP/device.toml`` and, per stage, ``stageN/pilot.csv`` when it exists (else the
guesses of ``device.toml [plan]``: rsp_inertia.design.models), chooses every stage's
``launch_speed`` and ``braking_torque`` (rsp_inertia.design.plan), writes them, and the
release angle the plan assumed (``release_angle_deg``, kept when device.toml states one),
into ``EXP/device.toml`` (rsp_inertia.design.device_edit: atomically, comments and key order
kept; a key the stage lacked is added), and draws ``EXP/plan.png``. Nothing is written when a
stage has no feasible protocol. Its result object is :class:`rsp_inertia.results.PlanResult`.

device.toml's stages need not state a protocol (a new rig): the candidates tried come from
the stage's model and the motor's limits alone (rsp_inertia.design.candidates); a protocol
device.toml does state is only evaluated beside the plan, for comparison.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from rsp_inertia.design.candidates import TORQUE_MARGIN, Candidate, StageModel, planned_release
from rsp_inertia.design.device_edit import write_protocols
from rsp_inertia.design.models import stage_models
from rsp_inertia.design.plan import Plan, make_plan
from rsp_inertia.design.rehearsal import Rehearsal
from rsp_inertia.design.rehearsal import rehearse as run_rehearsal
from rsp_inertia.estimation.balance import harmonic_reach
from rsp_inertia.estimation.identify import axial_moment
from rsp_inertia.figure_files import save_figure
from rsp_inertia.infra.errors import InputError
from rsp_inertia.infra.files import check_writable
from rsp_inertia.infra.progress import say
from rsp_inertia.ocp.regulator import MAX_BANDWIDTH, bandwidth
from rsp_inertia.plant.config import Device
from rsp_inertia.plant.experiment import open_experiment
from rsp_inertia.plots import plan_figure, plan_figures
from rsp_inertia.results.plan import PlanResult

__all__ = ["CLOSED_LOOP_COST", "DEFAULT_MAX_DURATION", "plan"]

DEFAULT_MAX_DURATION = 120.0
"""s of motion for the whole experiment when neither --max-duration nor [plan] max_duration
says otherwise (the paper's default protocol takes about 90 s)."""

CLOSED_LOOP_COST = 1.5
"""A stage whose rehearsed std exceeds its ideal-reverse prediction by this factor is named,
with what its encoder lets the regulator do (:func:`_closed_loop_note`)."""


def _closed_loop_note(device: Device, sm: StageModel, c: Candidate, cost: float) -> str:
    """Why a stage's closed loop costs ``cost`` x the ideal reverse's std: the regulator's
    bandwidth that the encoder's count allows (rsp_inertia.ocp.regulator.bandwidth) against the
    braking's speed harmonics at the balances' slowest speed, and the encoder's counts per
    sample there."""
    M0 = float(sm.model.inertia_harmonics[0])
    w = bandwidth(device, M0)
    head = f"  closed loop: {cost:.1f}x the ideal reverse's std (rehearsed): "
    if w >= MAX_BANDWIDTH:
        return head + (
            f"the regulator runs at its ceiling of {w:.2g} rad/s, so the encoder is not what "
            "limits it: the tracking mismatch the nominal model's errors leave costs the "
            "information (a pilot run sharpens the model)"
        )
    reach = harmonic_reach(device, w, c.launch_speed)
    follows = (
        "follows the mirror's speed harmonics"
        if reach.follows
        else f"cannot follow the speed's harmonics (2 Omega >= {2 * reach.slowest:.2g} rad/s over "
        "the balances), so the reverse tracks the mirror on the feedforward alone and "
        "identify's tracking-mismatch terms take information"
    )
    return head + (
        f"the encoder's count holds the regulator to {w:.2g} rad/s, which {follows}; "
        f"{reach.counts:.2g} counts per sample at the balances' slowest speed (a finer encoder, "
        "or a faster launch, helps)"
    )


def _closed_loop_notes(
    device: Device,
    models: list[StageModel],
    made: Plan,
    predicted: np.ndarray,
    rehearsal: Rehearsal | None,
) -> tuple[str | None, ...]:
    """Per stage, :func:`_closed_loop_note` where the rehearsed std exceeds the ideal
    reverse's by more than CLOSED_LOOP_COST, else None (all None without a rehearsal)."""
    notes = []
    for c, sm in zip(made.chosen, models):
        note = None
        if rehearsal is not None:
            stds = predicted[made.axis_stage == c.stage]
            ideal = made.axis_std[made.axis_stage == c.stage].max()
            cost = stds.max() / ideal
            if cost > CLOSED_LOOP_COST:
                note = _closed_loop_note(device, sm, c, cost)
        notes.append(note)
    return tuple(notes)


def _axial_guess(sm: StageModel, device: Device) -> float:
    """kg m^2, the order of J_k on this stage: its nominal mean reduced inertia as J_e."""
    return float(axial_moment(sm.model.inertia_harmonics[0], device.stages[sm.stage - 1]))


def plan(
    path: str | Path,
    max_duration: float | None = None,
    rehearse: bool = True,
    two_level: bool = False,
) -> PlanResult:
    """The command behind :func:`rsp_inertia.api.plan`, documented there (and in this
    module's docstring); ``max_duration`` None falls back to device.toml's, then to
    DEFAULT_MAX_DURATION. Its progress lines are each stage's model and the rehearsal's
    runs."""
    start = time.perf_counter()
    exp = open_experiment(path, protocol=False)
    for output in (exp.device_path, exp.plan_figure_path):
        check_writable(output)
    device = exp.device
    if max_duration is None:
        given = device.plan.max_duration if device.plan is not None else None
        max_duration = given if given is not None else DEFAULT_MAX_DURATION
    if not max_duration > 0:
        raise InputError(f"--max-duration: must be > 0, got {max_duration!r}")
    models = stage_models(path)
    for sm in models:
        m = sm.model
        say(
            f"stage {sm.stage}: model from {sm.source}: M0 {m.inertia_harmonics[0]:.4g} "
            f"kg m^2, friction a1 {m.coulomb:.3g} N m (up to {sm.coulomb:.3g}), a2 "
            f"{m.viscous:.3g} N m s, a3 {m.quadratic:.3g} N m s^2, torque noise "
            f"{sm.torque_noise:.3g} N m"
        )
    made = make_plan(device, models, max_duration, two_level)
    old = [(st.launch_speed, st.braking_torque, st.release_angle_deg) for st in device.stages]
    write_protocols(exp.device_path, device, made.chosen)
    rehearsal, rehearsal_error = None, None
    if rehearse:
        try:
            rehearsal = run_rehearsal(device, models, made.chosen)
        except InputError as exc:
            rehearsal_error = str(exc)
    predicted = rehearsal.axis_std if rehearsal is not None else made.axis_std
    save_figure(plan_figure(made), exp.plan_figure_path)
    return PlanResult(
        plan=made,
        models=tuple(models),
        rehearsal=rehearsal,
        rehearsal_error=rehearsal_error,
        release_angle_deg=tuple(
            float(planned_release(device.stages[c.stage - 1])) for c in made.chosen
        ),
        previous=tuple(old),
        nominal_moment=tuple(_axial_guess(sm, device) for sm in models),
        limit_fraction=1 - TORQUE_MARGIN,
        closed_loop_notes=_closed_loop_notes(device, models, made, predicted, rehearsal),
        path=exp.device_path,
        figure=exp.plan_figure_path,
        seconds=time.perf_counter() - start,
        drawer=plan_figures,
    )
