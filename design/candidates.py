"""A stage's candidate protocols and the limits that admit them, for experiment planning.

A protocol of a stage is its launch speed and braking torque (docs/method.md §4). Each
candidate is simulated on the stage's nominal model (:class:`StageModel`: a pilot run's fit,
or the rough guesses of ``device.toml [plan]``), checked against every limit below and, when
admitted, given its predicted information on the tensor (rsp_inertia.estimation.predict: the
balances and noise model of ``identify``). The plan search over all stages is
rsp_inertia.design.plan.

Limits, each with its reason:

- **Turns.** Both passes must share at least ``MIN_TURNS`` (2) turns at useful speed past
  the release (rsp_inertia.estimation.balance.usable_range): every node then has a whole-turn pair and
  the least squares sees M's pattern repeat. A protocol the balances refuse is infeasible.
- **Energy loss per turn** at least ``MIN_LOSS_PER_TURN`` of the kinetic energy over the
  first turn: below it the node formula's denominator Omega_a^2 - Omega_b^2 (docs/method.md §5)
  is a small difference of two large numbers, and the pass lasts hundreds of turns.
- **Reverse torque.** The mirror needs u' = -(u_b + 2 D(|Omega|)) (subtract the braking's
  equation of motion from the reverse's at the same angle: inertia, spring and gravity
  terms cancel, friction doubles), largest at the launch speed. It must stay within
  (1 - ``TORQUE_MARGIN``) of ``motor.torque_limit``: the regulator needs the rest to absorb
  the nominal model's error (a 30% error in friction moves u' by 0.3 x 2D).
- **Reverse torque rate**, after the first ``RATE_SKIP`` s (the step from the hold to the
  mirror's first torque is the OCP's to smooth): within (1 - TORQUE_MARGIN) of
  ``motor.torque_rate_limit``.
- **Hold.** Where the braking stops, the motor holds the body against the spring and
  gravity (docs/method.md §4, step 3): that static torque within (1 - TORQUE_MARGIN) of the limit,
  and the step from it to the mirror's first torque, taken at the full torque rate, within
  ``START_STEP_SHARE`` of the pass (the drive rides its rate limit meanwhile).
- **Program's nominal model.** ``program`` fits its feedforward model to the braking alone
  (rsp_inertia.ocp.nominal), where Coulomb friction a1 is a constant torque like the braking torque: it
  cannot tell them apart, and its inertia comes out short by a1 over the known torques that
  fix the model's scale (the braking torque, and the spring's mean |c (phi - phi0)|). That
  share must stay within ``NOMINAL_COULOMB_SHARE``: with a braking torque near a1 the
  feedforward lacks most of the mirror's torque and the regulator carries it, with tracking
  errors that cost the balances information.
- **Duration.** Per run: the spin-up (at (1 - TORQUE_MARGIN) x torque_limit against
  friction), the braking and its mirror, once per direction of the stage; summed over the
  stages, within ``max_duration``.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from rsp_inertia.estimation.balance import MIN_SPEED_FRACTION, MIN_TURNS
from rsp_inertia.estimation.predict import PlannedPass, predicted_balance, run_information
from rsp_inertia.estimation.smoothing import hermite
from rsp_inertia.infra.errors import InputError
from rsp_inertia.plant.config import Device, Stage
from rsp_inertia.plant.friction import FRICTION
from rsp_inertia.plant.geometry import turns_past_last_node
from rsp_inertia.plant.model import (
    ModelParameters,
    acceleration,
    dissipation,
    motor_torque,
    reduced_inertia,
    static_torque,
)
from rsp_inertia.virtual.device import MAX_BRAKING_TIME, integrate_to_stop, samples_to_angle

__all__ = [
    "MIN_LOSS_PER_TURN",
    "NOMINAL_COULOMB_SHARE",
    "RATE_SKIP",
    "RELEASE_BEFORE_NODE_DEG",
    "START_STEP_SHARE",
    "TORQUE_MARGIN",
    "Candidate",
    "StageModel",
    "evaluate",
    "planned_release",
    "stage_candidates",
]

TORQUE_MARGIN = 0.2
"""Fraction of the motor's torque and rate limits left to the regulator (module docstring)."""

RATE_SKIP = 0.05
"""s at the start of the reverse whose torque rate is not checked (the step from the hold)."""

START_STEP_SHARE = 0.01
"""Largest share of the pass the reverse may spend at the drive's torque-rate limit going
from the hold torque to the mirror's first torque: at most 1% of the samples at a limit. A
spring wound by a short pass: 0.31 N m at 20 N m/s is 15 ms, 0.76% of a 2.05 s pass at
c = 0.02 N m/rad."""

NOMINAL_COULOMB_SHARE = 0.1
"""Largest a1 over the braking's known torques (module docstring: program's nominal model):
the nominal inertia then within 10%, well inside the 30% the regulator is built to absorb."""

MIN_LOSS_PER_TURN = 0.01
"""Least fraction of the kinetic energy the braking loses over its first turn."""

RELEASE_BEFORE_NODE_DEG = 30.0
"""deg, the planned release when device.toml states none: this far before the stage's first
node (docs/method.md §4, step 1)."""


def planned_release(stage: Stage) -> float:
    """deg, where the plan has a stage's forward braking start: device.toml's
    ``release_angle_deg``, else RELEASE_BEFORE_NODE_DEG before the first node. Where the rest
    falls against the nodes sets the balances' information, so plan writes the release into
    device.toml with the rest of the protocol."""
    if stage.release_angle_deg is not None:
        return stage.release_angle_deg
    return min(stage.nodes_deg) - RELEASE_BEFORE_NODE_DEG

INTEGRATION_STEP = 0.005
"""s, the planner's RK4 step (a whole number of encoder samples): at the 2 Omega harmonic of
a 15 rad/s pass h w = 0.15, a local error ~(h w)^5 / 120 = 6e-7 of the state per step, far
below what a nominal model knows; the encoder's samples come from cubic Hermite
interpolation between steps."""

SPEED_CAP = 100.0
"""rad/s: no launch speed above this, whatever the motor could mirror (a safety bound)."""

N_SPEEDS = 8
"""Launch speeds tried per stage, geometric from 1/8 of the fastest feasible one."""

N_TORQUES = 7
"""Braking torques tried per launch speed: none, then geometric up to the most the motor
can mirror at that speed."""

SIGNIFICANT = 3
"""Significant digits of the protocols tried (and written into device.toml)."""


@dataclass(frozen=True)
class StageModel:
    """What the planner knows of a stage before its runs."""

    stage: int
    """From 1."""
    model: ModelParameters
    """Nominal model of the forward motion (inertia, gravity, spring, friction)."""
    torque_noise: float
    """N m, std of the torque log's noise."""
    source: str
    """Where the model comes from, for the report."""
    coulomb_bound: float | None = None
    """N m, the largest a1 the stage may have, for the limit of program's nominal model
    (module docstring); None: the model's own a1. A pilot's fit pins a1 only loosely (its
    coast spans a narrow speed range), so a pilot's bound is a1 + 2 std."""

    @property
    def coulomb(self) -> float:
        """N m, a1 as the nominal-model limit assumes it."""
        return self.model.coulomb if self.coulomb_bound is None else self.coulomb_bound


@dataclass(frozen=True)
class Candidate:
    """One protocol of one stage, evaluated on its nominal model."""

    stage: int
    launch_speed: float
    """rad/s."""
    braking_torque: float
    """N m, against the motion."""
    braking_time: float = math.nan
    """s, from the release to rest."""
    turns: float = math.nan
    """Turns of the braking pass."""
    loss_first_turn: float = math.nan
    """Fraction of the kinetic energy lost over the first turn."""
    peak_torque: float = math.nan
    """N m, the reverse's largest |u'|."""
    peak_rate: float = math.nan
    """N m/s, the reverse's largest |du'/dt| after RATE_SKIP."""
    hold_torque: float = math.nan
    """N m, the static torque where the braking stops."""
    run_time: float = math.nan
    """s, spin-up + braking + reverse, times the stage's directions."""
    braking_torque_2: float | None = None
    """N m, a two-level braking's torque after ``braking_switch_turns`` (device.toml
    ``braking_torque_2``); None: one level. A two-level candidate's information has each
    run's pass gain marginalised (rsp_inertia.estimation.tensor_fit.pass_gain_unknown)."""
    braking_switch_turns: float | None = None
    """Turns from the release where a two-level braking switches."""
    violations: tuple[str, ...] = ()
    """The limits it breaks, one phrase each (with the numbers)."""
    information: np.ndarray | None = field(default=None, repr=False)
    """(8, 8) information on the tensor and gravity terms (rsp_inertia.estimation.predict), all runs."""

    @property
    def feasible(self) -> bool:
        return not self.violations and self.information is not None


def _friction(model: ModelParameters, omega) -> np.ndarray:
    """D(|Omega|) of the forward motion, N m."""
    return np.asarray(dissipation(np.abs(omega), model, np.ones_like(np.asarray(omega, float)))).ravel()


def _top_speed(device: Device, model: ModelParameters) -> float:
    """The fastest launch whose mirror stays within the torque limit with no braking torque.

    Root of 2 D(Omega) = (1 - TORQUE_MARGIN) torque_limit (module docstring), capped.
    """
    usable = (1 - TORQUE_MARGIN) * device.motor.torque_limit
    root = FRICTION.speed_at(FRICTION.coefficients(model), usable, factor=2)
    return min(root, SPEED_CAP)


def _spin_up_time(device: Device, model: ModelParameters, speed: float) -> float:
    """s to reach ``speed`` from rest at (1 - TORQUE_MARGIN) torque_limit against friction."""
    omega = np.linspace(0.0, speed, 64)
    net = (1 - TORQUE_MARGIN) * device.motor.torque_limit - _friction(model, omega)
    if np.any(net <= 0):
        return math.inf
    M0 = float(model.inertia_harmonics[0])
    return float(np.trapezoid(M0 / net, omega))


def evaluate(
    device: Device,
    sm: StageModel,
    launch_speed: float,
    braking_torque: float,
    max_time: float = MAX_BRAKING_TIME,
    braking_torque_2: float | None = None,
    switch_turns: float | None = None,
) -> Candidate:
    """One protocol of a stage on its nominal model: limits and predicted information.

    Parameters
    ----------
    device : Device
        The gimbal: motor limits, encoder, the stage's nodes and directions.
    sm : StageModel
        What the planner knows of the stage.
    launch_speed : float
        rad/s, the protocol's launch speed.
    braking_torque : float
        N m, the protocol's braking torque, against the motion.
    max_time : float, optional
        s, the longest braking admitted.
    braking_torque_2 : float, optional
        N m: a two-level braking, this torque after ``switch_turns`` turns from the release
        (``braking_torque`` before); its balances fit each run's pass gain (the information
        has it marginalised). None: one level.
    switch_turns : float, optional
        Turns, with ``braking_torque_2``.

    Returns
    -------
    Candidate
        The protocol with its predicted braking, the limits it breaks (``violations``) and,
        when it breaks none, its information on the tensor.
    """
    st = device.stages[sm.stage - 1]
    model = sm.model
    p = model.vector
    usable = (1 - TORQUE_MARGIN) * device.motor.torque_limit
    usable_rate = (1 - TORQUE_MARGIN) * device.motor.torque_rate_limit
    two = braking_torque_2 is not None
    base = Candidate(
        sm.stage, float(launch_speed), float(braking_torque),
        braking_torque_2=float(braking_torque_2) if two else None,
        braking_switch_turns=float(switch_turns) if two else None,
    )
    release = math.radians(planned_release(st))
    dt = device.encoder.dt
    h = dt * max(1, round(INTEGRATION_STEP / dt))
    x0 = np.array([release, launch_speed])
    switch_time = math.inf  # s, when a two-level braking switches (never: one level)
    u_step = -braking_torque
    if two:
        k = samples_to_angle(x0, -braking_torque, 1.0, p, h, 2 * math.pi * switch_turns, max_time)
        if k is None:
            return dataclasses.replace(
                base, violations=(f"the braking stops before its switch at {switch_turns:g} turns",)
            )
        switch_time = k * h

        def u_step(first: int, count: int) -> np.ndarray:
            return np.where(np.arange(first, first + count) < k, -braking_torque, -braking_torque_2)

    stop = integrate_to_stop(x0, u_step, 1.0, p, h, max_time, coarse=True)
    if stop is None:
        return dataclasses.replace(base, violations=(f"the braking lasts more than {max_time:.0f} s",))
    tc, traj, end_time, end_phi = stop
    if end_time < 50 * dt:
        return dataclasses.replace(base, violations=(f"the braking lasts only {end_time:.3f} s",))
    # The encoder's samples from the integrator's steps: cubic Hermite (phi with Omega, Omega
    # with eps), the stop appended as the last knot.
    knots_t = np.append(tc[tc < end_time], end_time)
    knots = np.vstack([traj[: knots_t.size - 1], [end_phi, 0.0]])
    u_c = np.where(knots_t < switch_time, -braking_torque, -(braking_torque_2 or 0.0))
    eps_c = np.asarray(acceleration(knots[:, 0], knots[:, 1], u_c, model, np.ones(knots_t.size))).ravel()
    t = np.arange(math.floor(end_time / dt * (1 - 1e-12)) + 1) * dt
    k = np.clip(np.searchsorted(knots_t, t, side="right") - 1, 0, knots_t.size - 2)
    a, b = knots_t[k], knots_t[k + 1]
    phi = hermite(a, b, knots[k, 0], knots[k, 1], knots[k + 1, 0], knots[k + 1, 1], t)
    omega = hermite(a, b, knots[k, 1], eps_c[k], knots[k + 1, 1], eps_c[k + 1], t)
    u = np.where(t < switch_time, -braking_torque, -(braking_torque_2 or 0.0))
    eps = np.asarray(acceleration(phi, omega, u, model, np.ones_like(omega))).ravel()
    braking = PlannedPass(t, phi, omega, eps, u)
    shape = braking.mirrored(np.zeros(t.size))
    reverse_torque = np.asarray(
        motor_torque(shape.phi, shape.omega, shape.eps, model, -np.ones_like(omega))
    ).ravel()
    reverse = braking.mirrored(reverse_torque)
    turns = (end_phi - phi[0]) / (2 * math.pi)
    one_turn = np.interp(phi[0] + 2 * math.pi, phi, omega, right=0.0)
    loss = 1.0 - (one_turn / launch_speed) ** 2
    peak = float(np.abs(reverse_torque).max())
    skip = min(round(RATE_SKIP / dt), t.size - 2)
    steps = np.abs(np.diff(reverse_torque))
    switch_step = 0.0  # s the reverse spends at the rate limit at a two-level braking's switch
    if two and np.isfinite(switch_time):
        # The mirror steps by the levels' difference where the braking switched: like the
        # step from the hold, the OCP's to smooth, at the drive's full rate (RATE_SKIP about it).
        at = t.size - 1 - int(np.searchsorted(t, switch_time))
        steps[max(at - skip, 0) : at + skip] = 0.0
        switch_step = abs(braking_torque_2 - braking_torque) / device.motor.torque_rate_limit
    rate = float(steps[skip:].max() / dt) if t.size - skip > 2 else 0.0
    hold_signed = float(static_torque(end_phi, model))
    hold = abs(hold_signed)
    # The reverse starts from the hold torque; the mirror's first torque is reached at the
    # drive's full rate (the OCP's bound), a time the drive spends at its rate limit.
    step_time = abs(reverse_torque[0] - hold_signed) / device.motor.torque_rate_limit
    spring = model.stiffness * float(np.mean(np.abs(phi - model.zero_angle)))
    known = max(braking_torque, braking_torque_2 or 0.0) + spring
    directions = len(st.directions)
    run_time = directions * (_spin_up_time(device, model, launch_speed) + 2 * end_time)
    violations = []
    if loss < MIN_LOSS_PER_TURN:
        violations.append(
            f"loses {loss:.2%} of its energy over the first turn (at least "
            f"{MIN_LOSS_PER_TURN:.0%})"
        )
    if peak > usable:
        violations.append(
            f"the reverse needs {peak:.3g} N m, {peak / usable - 1:.0%} over "
            f"{usable:.3g} N m ({1 - TORQUE_MARGIN:g} x motor.torque_limit)"
        )
    if rate > usable_rate:
        violations.append(
            f"the reverse needs {rate:.3g} N m/s, {rate / usable_rate - 1:.0%} over "
            f"{usable_rate:.3g} N m/s ({1 - TORQUE_MARGIN:g} x motor.torque_rate_limit)"
        )
    if step_time > START_STEP_SHARE * end_time:
        violations.append(
            f"the reverse spends {step_time * 1e3:.0f} ms at the torque-rate limit going from "
            f"the hold ({hold_signed:.3g} N m) to the mirror's {reverse_torque[0]:.3g} N m, "
            f"over {START_STEP_SHARE:.2%} of the {end_time:.2f} s pass"
        )
    if switch_step > START_STEP_SHARE * end_time:
        violations.append(
            f"the reverse spends {switch_step * 1e3:.0f} ms at the torque-rate limit where the "
            f"braking switched ({braking_torque:.3g} -> {braking_torque_2:.3g} N m), over "
            f"{START_STEP_SHARE:.2%} of the {end_time:.2f} s pass"
        )
    if sm.coulomb > NOMINAL_COULOMB_SHARE * known:
        violations.append(
            f"a1 (up to {sm.coulomb:.3g} N m) is over {NOMINAL_COULOMB_SHARE:.0%} of the "
            f"braking's known torque {known:.3g} N m (braking torque + spring): program's "
            "nominal model, which cannot tell a1 from it, would put the inertia "
            f"{sm.coulomb / max(known, 1e-300):.0%} short"
        )
    if hold > usable:
        violations.append(
            f"holding the body where it stops takes {hold:.3g} N m, {hold / usable - 1:.0%} "
            f"over {usable:.3g} N m ({1 - TORQUE_MARGIN:g} x motor.torque_limit)"
        )
    info = None
    if not violations:
        try:
            switch = int(np.searchsorted(t, switch_time)) if two else None
            balance = predicted_balance(
                device, sm.stage, braking, reverse, sm.torque_noise, switch
            )
        except InputError:
            past = turns_past_last_node([phi[0], end_phi], st.nodes)
            violations.append(
                f"too few turns: {turns:.2f} in all, {past:.2f} past the last node (the "
                f"balances need {MIN_TURNS:g} shared turns above {MIN_SPEED_FRACTION:.0%} "
                "of the top speed)"
            )
        else:
            inertia = np.asarray(reduced_inertia(balance.phi, model)).ravel()
            info = directions * run_information(device, balance, inertia)
    return dataclasses.replace(
        base,
        braking_time=end_time,
        turns=turns,
        loss_first_turn=loss,
        peak_torque=peak,
        peak_rate=rate,
        hold_torque=hold,
        run_time=run_time,
        violations=tuple(violations),
        information=info,
    )


SWITCH_TURNS = (1.0, 2.0, 4.0, 8.0)
"""Turns from the release after which a two-level candidate switches (``plan --two-level``)."""


def stage_candidates(
    device: Device, sm: StageModel, max_duration: float, two_level: bool = False
) -> list[Candidate]:
    """The grid of protocols of one stage (module docstring), each evaluated.

    Parameters
    ----------
    device : Device
        The gimbal.
    sm : StageModel
        What the planner knows of the stage.
    max_duration : float
        s, the experiment's longest duration: bounds each braking (half of it per direction).
    two_level : bool, optional
        Two-level brakings only (``plan --two-level``, docs/method.md, "A torque scale that
        differs between the passes"): per launch speed, coasting for each of
        :data:`SWITCH_TURNS` turns, then each braking torque of the grid but none; their
        information has each run's pass gain marginalised.

    Returns
    -------
    list of Candidate
        Every protocol tried; a single infeasible one when the mirror cannot be driven at
        any speed.
    """
    top = _top_speed(device, sm.model)
    if top <= 0:
        a1 = sm.model.coulomb
        usable = (1 - TORQUE_MARGIN) * device.motor.torque_limit
        return [
            Candidate(
                sm.stage, 0.0, 0.0,
                violations=(
                    (
                        f"the mirror needs 2 a1 = {2 * a1:.3g} N m at any speed, "
                        f"{2 * a1 / usable - 1:.0%} over {usable:.3g} N m"
                    ),
                ),
            )
        ]
    usable = (1 - TORQUE_MARGIN) * device.motor.torque_limit
    directions = len(device.stages[sm.stage - 1].directions)
    max_time = min(MAX_BRAKING_TIME, max_duration / (2 * directions))
    out = []
    for speed in _rounded(np.geomspace(top / 8, top * 0.98, N_SPEEDS)):
        room = usable - 2 * float(_friction(sm.model, [speed])[0])
        # From none, or from the least that program's nominal model admits (NOMINAL_COULOMB_SHARE).
        low = max(room / 200, sm.coulomb / NOMINAL_COULOMB_SHARE)
        torques = [0.0] + list(np.geomspace(low, room, N_TORQUES - 1)) if room > low else [0.0]
        for torque in dict.fromkeys(_rounded(torques, down=True)):
            if not two_level:
                out.append(evaluate(device, sm, speed, torque, max_time))
                continue
            if torque == 0.0:
                continue
            for turns in SWITCH_TURNS:
                out.append(evaluate(device, sm, speed, 0.0, max_time, torque, turns))
    return out


def _rounded(values, down: bool = False) -> list[float]:
    """Values to SIGNIFICANT digits (what device.toml will hold is what is evaluated);
    ``down``: never above the value (a torque at its limit stays within it)."""
    out = []
    for v in values:
        if v <= 0:
            out.append(0.0)
            continue
        step = 10.0 ** (math.floor(math.log10(v)) - SIGNIFICANT + 1)
        out.append(float(f"{(math.floor(v / step) if down else round(v / step)) * step:.{SIGNIFICANT}g}"))
    return out
