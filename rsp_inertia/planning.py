"""``rsp-inertia plan``: device.toml and pilot runs in, each stage's protocol out.

Reads ``EXP/device.toml`` and, per stage, ``stageN/pilot.csv`` when it exists (else the
guesses of ``device.toml [plan]``), chooses every stage's ``launch_speed`` and
``braking_torque`` (rsp_inertia.design.plan), writes them, and the release angle the plan assumed
(``release_angle_deg``, kept when device.toml states one), into ``EXP/device.toml`` (atomically, comments
and key order kept; a key the stage lacked is added), and draws ``EXP/plan.png``. Nothing is
written when a stage has no feasible protocol.

device.toml's stages need not state a protocol (a new rig): the candidates tried come from
the stage's model and the motor's limits alone (rsp_inertia.design.candidates); a protocol
device.toml does state is only evaluated beside the plan, for comparison.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import tomlkit

from rsp_inertia.design.plan import (
    TORQUE_MARGIN,
    Plan,
    StageModel,
    make_plan,
    map_stages,
    planned_release,
)
from rsp_inertia.design.rehearsal import Rehearsal
from rsp_inertia.estimation.balance import harmonic_reach
from rsp_inertia.ocp.regulator import MAX_BANDWIDTH, bandwidth
from rsp_inertia.plant.config import Device
from rsp_inertia.plant.errors import InputError
from rsp_inertia.plant.experiment import open_experiment
from rsp_inertia.plant.files import check_writable, write_atomic
from rsp_inertia.plant.logs import Log, read_device_log
from rsp_inertia.plant.model import ModelParameters

__all__ = ["DEFAULT_MAX_DURATION", "PlanReport", "guess_model", "plan", "stage_models"]

DEFAULT_MAX_DURATION = 120.0
"""s of motion for the whole experiment when neither --max-duration nor [plan] max_duration
says otherwise (the paper's default protocol takes about 90 s)."""

PLAN_FIGURE = "plan.png"
"""The trade-off figure, in the experiment folder."""

def guess_model(device: Device, stage: int) -> tuple[ModelParameters, float]:
    """Nominal model and torque noise of a stage from ``device.toml [plan]`` (no pilot run).

    M0 = M_tare + (1 + lambda^2) J, J the mean of the guessed principal moments (the axis's
    J_e lies between the extreme ones; docs/method.md §2); no M harmonics (their effect on the
    mirror's torque cancels, module docstring of rsp_inertia.design.candidates); gravity m g r from the mass and
    the guessed offset of the centre of mass; friction and spring as given.
    """
    guess = device.plan
    where = f"{device.name}: device.toml"
    if guess is None:
        raise InputError(
            f"{where}: no [plan] table and no stage{stage}/pilot.csv: give the body's "
            "approximate principal moments (plan.inertia or plan.box) and a friction guess, "
            "or record a pilot run"
        )
    mass = device.body.mass if device.body is not None else None
    moments = guess.principal_moments(mass)
    if moments is None:
        raise InputError(
            f"{where}: plan.inertia: missing (or plan.box with [body] mass), and no "
            f"stage{stage}/pilot.csv"
        )
    if guess.torque_noise is None:
        raise InputError(
            f"{where}: plan.torque_noise: missing, and no stage{stage}/pilot.csv to measure it"
        )
    st = device.stages[stage - 1]
    M0 = st.tare_inertia + (1 + st.gear_ratio**2) * float(np.mean(moments))
    weight = (mass or 0.0) * device.gravity * guess.com_offset
    a1, a2, a3 = guess.friction
    model = ModelParameters(
        inertia_harmonics=np.array([M0, 0.0, 0.0, 0.0, 0.0]),
        stiffness=device.spring.stiffness,
        zero_angle=device.spring.zero_angle,
        gravity_sin=weight,
        gravity_cos=0.0,
        coulomb=a1,
        viscous=a2,
        quadratic=a3,
    )
    return model, guess.torque_noise


def stage_models(root: str | Path) -> list[StageModel]:
    """Per stage: the pilot run's fit if ``stageN/pilot.csv`` exists, else device.toml's guess.

    The pilots are read here (a bad log's error comes before any process starts) and fitted
    per stage in parallel (rsp_inertia.design.plan.map_stages).
    """
    exp = open_experiment(root, protocol=False)
    jobs = []
    for stage in exp.stages(None):
        path = exp.pilot_path(stage)
        log = read_device_log(path, exp.device, "pilot") if path.is_file() else None
        jobs.append((exp.device, stage, path, log))
    return map_stages(_stage_model, jobs)


def _stage_model(device: Device, stage: int, path: Path, log: Log | None) -> StageModel:
    """One stage's model: its pilot's fit (``log``, read from ``path``), else device.toml's
    guess."""
    if log is not None:
        from rsp_inertia.design.pilot import fit_pilot

        fit = fit_pilot(device, stage, log, str(path))
        bound = fit.a1 + 2 * fit.a1_std if np.isfinite(fit.a1_std) else fit.a1
        return StageModel(stage, fit.model(), fit.torque_noise, str(path), bound)
    model, noise = guess_model(device, stage)
    return StageModel(stage, model, noise, "device.toml [plan]")


@dataclass(frozen=True)
class PlanReport:
    """What ``plan`` chose, and the text it prints."""

    plan: Plan
    device: Device
    models: list[StageModel]
    old: list[tuple[float | None, float | None, float | None]]
    """Per stage, (launch_speed, braking_torque, release_angle_deg) as device.toml held them
    (None: not stated)."""
    written: Path | None
    """device.toml, when written."""
    figure: Path | None
    seconds: float
    rehearsal: Rehearsal | None = None
    """identify's stds on the plan run in closed loop on the nominal model (rsp_inertia.design.rehearsal);
    None when skipped."""
    rehearsal_error: str | None = None
    """Why the rehearsal could not run (what program or identify refused), if it did not."""

    @property
    def predicted_std(self) -> np.ndarray:
        """kg m^2, J_k std at every node as predicted: the rehearsal's, else the ideal
        reverse's."""
        return self.rehearsal.axis_std if self.rehearsal is not None else self.plan.axis_std

    def __str__(self) -> str:
        return format_plan(self)


CLOSED_LOOP_COST = 1.5
"""A stage whose rehearsed std exceeds its ideal-reverse prediction by this factor is named,
with what its encoder lets the regulator do (:func:`_closed_loop_note`)."""


def _closed_loop_note(device: Device, sm: StageModel, c, cost: float) -> str:
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


def format_plan(report: PlanReport) -> str:
    plan, lines = report.plan, []
    rehearsal = report.rehearsal
    predicted = report.predicted_std
    lines.append(
        f"plan: worst predicted std of J_k {predicted.max():.3g} kg m^2 in "
        f"{plan.duration:.0f} s of motion (budget {plan.max_duration:g} s)"
    )
    if rehearsal is not None:
        scales = ", ".join(
            f"{run} {s:.2g}" for run, s in zip(rehearsal.runs, rehearsal.speed_noise_scale)
        )
        lines.append(
            f"  from a closed-loop rehearsal on the nominal model (ideal reverse: "
            f"{plan.worst:.3g}; speed-noise scales {scales}; drive at a limit on "
            f"{rehearsal.saturated:.2%} of the reverse samples)"
        )
    else:
        why = f": {report.rehearsal_error}" if report.rehearsal_error else ""
        lines.append(f"  for an ideal reverse (no closed-loop rehearsal{why})")
    if plan.current_std is not None:
        now = sum(c.run_time for c in plan.current)
        lines.append(
            f"  device.toml's protocol before (ideal reverse): {plan.current_std:.3g} kg m^2 in "
            f"{now:.0f} s ({plan.current_std / plan.worst:.2f}x the plan's ideal std)"
        )
    for c, sm, (speed, torque, release) in zip(plan.chosen, report.models, report.old):
        stds = predicted[plan.axis_stage == c.stage]
        J = _axial_guess(sm, report.device)
        lines.append(
            f"stage {c.stage} (model: {sm.source}): launch_speed {c.launch_speed:g} rad/s "
            f"(was {_was(speed)}), braking_torque {c.braking_torque:g} N m (was {_was(torque)}), "
            f"release_angle_deg {planned_release(report.device.stages[c.stage - 1]):g} "
            f"(was {_was(release)})"
        )
        lines.append(
            f"  braking {c.braking_time:.1f} s over {c.turns:.1f} turns, {c.loss_first_turn:.0%}"
            f" of the energy lost in the first turn; run {c.run_time:.1f} s (spin-up, braking"
            " and reverse, every direction)"
        )
        lines.append(
            f"  reverse: peak torque {c.peak_torque:.3g} N m, peak rate {c.peak_rate:.3g} N m/s;"
            f" hold {c.hold_torque:.3g} N m (limits used: {1 - TORQUE_MARGIN:g} x the motor's)"
        )
        rel = f" (~{stds.max() / J:.2g} of J_k)" if J > 0 else ""
        lines.append(
            "  predicted std of J_k at the nodes: "
            + ", ".join(f"{s:.3g}" for s in stds)
            + f" kg m^2{rel}"
        )
        if rehearsal is not None:
            ideal = plan.axis_std[plan.axis_stage == c.stage].max()
            cost = stds.max() / ideal
            if cost > CLOSED_LOOP_COST:
                lines.append(_closed_loop_note(report.device, sm, c, cost))
    lines.append(
        "trade-off: per launch speed, the braking torque with the smallest predicted std of the"
        " stage's own J_k (other stages as planned; ideal reverse); stds in kg m^2"
    )
    lines.append("  stage | launch rad/s | braking N m | braking s | run s | stage's worst | all")
    for stage, speed, cand, own, overall in plan.tradeoff:
        if cand is None:
            lines.append(f"  {stage} | {speed:.3g} | infeasible | - | - | - | -")
        else:
            lines.append(
                f"  {stage} | {speed:.3g} | {cand.braking_torque:.3g} | "
                f"{cand.braking_time:.1f} | {cand.run_time:.1f} | {own:.3g} | {overall:.3g}"
            )
    if report.written is not None:
        lines.append(f"protocol -> {report.written}")
    if report.figure is not None:
        lines.append(f"trade-off figure -> {report.figure}")
    return "\n".join(lines)


def _was(value: float | None) -> str:
    """A key's value before the plan, as the report prints it."""
    return "not stated" if value is None else format(value, "g")


def _axial_guess(sm: StageModel, device: Device) -> float:
    """kg m^2, the order of J_k on this stage: its nominal mean reduced inertia as J_e."""
    from rsp_inertia.estimation.identify import axial_moment

    return float(axial_moment(sm.model.inertia_harmonics[0], device.stages[sm.stage - 1]))


def _set_key(table, name: str, value: float, unit: str) -> None:
    """``name = value`` in a ``[[stage]]`` table of device.toml: in place where the key is
    (its comment kept), else added with its unit as a comment."""
    if name in table:
        table[name] = value
    else:
        table[name] = tomlkit.item(value).comment(unit)


def plan(
    root: str | Path,
    max_duration: float | None = None,
    progress: Callable[[str], None] | None = None,
    rehearse: bool = True,
) -> PlanReport:
    """``rsp-inertia plan``: choose, write device.toml and plan.png (module docstring).

    ``rehearse``: run the chosen plan in closed loop on the nominal model and predict with
    identify's stds there (rsp_inertia.design.rehearsal); else the ideal reverse's prediction only.
    """
    import time

    start = time.perf_counter()
    exp = open_experiment(root, protocol=False)
    for output in (exp.root / "device.toml", exp.root / PLAN_FIGURE):
        check_writable(output)
    device = exp.device
    if max_duration is None:
        given = device.plan.max_duration if device.plan is not None else None
        max_duration = given if given is not None else DEFAULT_MAX_DURATION
    if not max_duration > 0:
        raise InputError(f"--max-duration: must be > 0, got {max_duration!r}")
    models = stage_models(root)
    if progress is not None:
        for sm in models:
            m = sm.model
            progress(
                f"stage {sm.stage}: model from {sm.source}: M0 {m.inertia_harmonics[0]:.4g} "
                f"kg m^2, friction a1 {m.coulomb:.3g} N m (up to {sm.coulomb:.3g}), a2 {m.viscous:.3g} N m s, "
                f"a3 {m.quadratic:.3g} N m s^2, torque noise {sm.torque_noise:.3g} N m"
            )
    result = make_plan(device, models, max_duration)
    old = [(st.launch_speed, st.braking_torque, st.release_angle_deg) for st in device.stages]
    path = exp.root / "device.toml"
    text = path.read_text()
    doc = tomlkit.parse(text)
    for c in result.chosen:
        table = doc["stage"][c.stage - 1]
        _set_key(table, "launch_speed", c.launch_speed, "rad/s")
        _set_key(table, "braking_torque", c.braking_torque, "N m")
        table["release_angle_deg"] = planned_release(device.stages[c.stage - 1])
    write_atomic(path, tomlkit.dumps(doc))
    rehearsal, rehearsal_error = None, None
    if rehearse:
        from rsp_inertia.design.rehearsal import rehearse as run_rehearsal

        try:
            rehearsal = run_rehearsal(device, models, result.chosen, progress=progress)
        except InputError as exc:
            rehearsal_error = str(exc)
    from rsp_inertia.plots import plan_figure

    figure = plan_figure(result, exp.root / PLAN_FIGURE)
    return PlanReport(
        plan=result,
        device=device,
        models=models,
        old=old,
        written=path,
        figure=figure,
        seconds=time.perf_counter() - start,
        rehearsal=rehearsal,
        rehearsal_error=rehearsal_error,
    )
