"""``plan``'s result: a view of the library's record (rsp_inertia.design.plan.Plan) with
what the command added (the rehearsal, device.toml's protocol before), and its text."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from rsp_inertia.figure_files import save_figures
from rsp_inertia.infra.frozen import read_only
from rsp_inertia.results.common import Drawer, Drawn, json_text

if TYPE_CHECKING:
    from rsp_inertia.design.candidates import StageModel
    from rsp_inertia.design.plan import Plan
    from rsp_inertia.design.rehearsal import Rehearsal

__all__ = ["PlanResult"]


def _was(value: float | None) -> str:
    """A key's value before the plan, as the plan prints it."""
    return "not stated" if value is None else format(value, "g")


@dataclass(frozen=True, eq=False)
class PlanResult(Drawn):
    """The protocol ``plan`` chose for every stage, and what it predicts.

    Returned by :func:`rsp_inertia.plan`. The per-stage tuples are in stage order. A view of
    the library's records: ``launch_speed``, ``braking_torque``, the predicted stds,
    ``axis_stage``, the durations and ``rehearsed`` are read from ``plan`` and ``rehearsal``
    when asked for; the other fields are what the command adds.

    Attributes
    ----------
    launch_speed : tuple of float
        rad/s, per stage, as written to device.toml.
    braking_torque : tuple of float
        N m, per stage.
    release_angle_deg : tuple of float
        deg, per stage: where the plan assumes the rig releases the body.
    previous : tuple of (float or None, float or None, float or None)
        Per stage, ``(launch_speed, braking_torque, release_angle_deg)`` as device.toml
        held them before (``None``: not stated).
    predicted_std : numpy.ndarray, shape (nodes,)
        kg m^2, the predicted standard deviation of J_k at every node (stage by stage): the
        closed-loop rehearsal's when it ran, else the ideal reverse's.
    predicted_std_ideal : numpy.ndarray, shape (nodes,)
        kg m^2, the same for an ideal reverse (a closed loop's best case).
    axis_stage : numpy.ndarray, shape (nodes,)
        The stage of each entry of ``predicted_std``.
    duration : float
        s, the experiment's motion time with the plan (spin-up, braking and reverse of
        every stage and direction).
    max_duration : float
        s, the budget it was chosen within.
    rehearsed : bool
        Whether the closed-loop rehearsal ran.
    rehearsal_error : str or None
        Why the rehearsal could not run, if it was asked for and did not.
    path : pathlib.Path
        The device.toml written.
    figure : pathlib.Path
        The trade-off figure plan wrote (``EXP/plan.png``).
    plan : rsp_inertia.design.plan.Plan
        The plan with every candidate tried, the chosen ones, the front of the best std
        within each duration and the trade-off table.
    models : tuple of rsp_inertia.design.candidates.StageModel
        Per stage, the nominal model planned on (a pilot run's fit, or device.toml's
        ``[plan]`` guesses) and its source.
    rehearsal : rsp_inertia.design.rehearsal.Rehearsal or None
        identify's stds on the plan run in closed loop on the nominal model; None when
        skipped or refused.
    nominal_moment : tuple of float
        kg m^2, per stage: the order of its J_k (its nominal mean reduced inertia as J_e),
        against which the predicted std is printed as a fraction.
    limit_fraction : float
        The fraction of the motor's torque and rate limits the plan uses (1 -
        rsp_inertia.design.candidates.TORQUE_MARGIN).
    closed_loop_notes : tuple of (str or None)
        Per stage, why the rehearsed closed loop costs more than the ideal reverse's std
        (the regulator's bandwidth the encoder allows against the braking's speed
        harmonics), where it costs more than rsp_inertia.planning.CLOSED_LOOP_COST times.
    seconds : float
        s, plan's wall time.
    drawer : callable or None
        What draws the figures (:meth:`draw`): the function of rsp_inertia.plots its command
        handed it; None for a result made without one.

    Examples
    --------
    >>> chosen = rsp_inertia.plan("bench-A", max_duration=100)    # doctest: +SKIP
    >>> chosen.launch_speed, chosen.braking_torque                 # doctest: +SKIP
    ((13.8, 4.32), (0.00462, 0.0823))
    """

    plan: Plan = field(repr=False)
    models: tuple[StageModel, ...] = field(repr=False)
    rehearsal: Rehearsal | None = field(repr=False)
    rehearsal_error: str | None
    release_angle_deg: tuple[float, ...]
    previous: tuple[tuple[float | None, float | None, float | None], ...]
    nominal_moment: tuple[float, ...] = field(repr=False)
    limit_fraction: float = field(repr=False)
    closed_loop_notes: tuple[str | None, ...] = field(repr=False)
    path: Path
    figure: Path
    seconds: float = field(repr=False)
    drawer: Drawer | None = field(default=None, repr=False, compare=False)

    @property
    def launch_speed(self) -> tuple[float, ...]:
        """rad/s, per stage: the plan's chosen launch speeds."""
        return tuple(float(c.launch_speed) for c in self.plan.chosen)

    @property
    def braking_torque(self) -> tuple[float, ...]:
        """N m, per stage: the plan's chosen braking torques."""
        return tuple(float(c.braking_torque) for c in self.plan.chosen)

    @property
    def predicted_std(self) -> np.ndarray:
        """kg m^2, per node: the rehearsal's std of J_k when it ran, else the plan's."""
        source = self.plan if self.rehearsal is None else self.rehearsal
        return read_only(np.asarray(source.axis_std, dtype=float))

    @property
    def predicted_std_ideal(self) -> np.ndarray:
        """kg m^2, per node: the plan's std of J_k for an ideal reverse."""
        return read_only(np.asarray(self.plan.axis_std, dtype=float))

    @property
    def axis_stage(self) -> np.ndarray:
        """The stage of each node."""
        return read_only(np.asarray(self.plan.axis_stage))

    @property
    def duration(self) -> float:
        """s, the plan's motion time."""
        return float(self.plan.duration)

    @property
    def max_duration(self) -> float:
        """s, the plan's budget."""
        return float(self.plan.max_duration)

    @property
    def rehearsed(self) -> bool:
        """Whether the closed-loop rehearsal ran."""
        return self.rehearsal is not None

    def __str__(self) -> str:
        plan, lines = self.plan, []
        rehearsal = self.rehearsal
        predicted = self.predicted_std
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
            why = f": {self.rehearsal_error}" if self.rehearsal_error else ""
            lines.append(f"  for an ideal reverse (no closed-loop rehearsal{why})")
        if plan.current_std is not None:
            now = sum(c.run_time for c in plan.current)
            lines.append(
                f"  device.toml's protocol before (ideal reverse): {plan.current_std:.3g} kg m^2 "
                f"in {now:.0f} s ({plan.current_std / plan.worst:.2f}x the plan's ideal std)"
            )
        stages = zip(
            plan.chosen, self.models, self.previous, self.release_angle_deg,
            self.nominal_moment, self.closed_loop_notes,
        )
        for c, sm, (speed, torque, release), angle, J, note in stages:
            stds = predicted[plan.axis_stage == c.stage]
            lines.append(
                f"stage {c.stage} (model: {sm.source}): launch_speed {c.launch_speed:g} rad/s "
                f"(was {_was(speed)}), braking_torque {c.braking_torque:g} N m "
                f"(was {_was(torque)}), release_angle_deg {angle:g} (was {_was(release)})"
                + (
                    ""
                    if c.braking_torque_2 is None
                    else f", braking_torque_2 {c.braking_torque_2:g} N m after "
                    f"braking_switch_turns {c.braking_switch_turns:g}"
                )
            )
            lines.append(
                f"  braking {c.braking_time:.1f} s over {c.turns:.1f} turns, "
                f"{c.loss_first_turn:.0%} of the energy lost in the first turn; run "
                f"{c.run_time:.1f} s (spin-up, braking and reverse, every direction)"
            )
            lines.append(
                f"  reverse: peak torque {c.peak_torque:.3g} N m, peak rate {c.peak_rate:.3g} "
                f"N m/s; hold {c.hold_torque:.3g} N m (limits used: {self.limit_fraction:g} x "
                "the motor's)"
            )
            rel = f" (~{stds.max() / J:.2g} of J_k)" if J > 0 else ""
            lines.append(
                "  predicted std of J_k at the nodes: "
                + ", ".join(f"{s:.3g}" for s in stds)
                + f" kg m^2{rel}"
            )
            if note is not None:
                lines.append(note)
        lines.append(
            "trade-off: per launch speed, the braking torque with the smallest predicted std of "
            "the stage's own J_k (other stages as planned; ideal reverse); stds in kg m^2"
        )
        lines.append(
            "  stage | launch rad/s | braking N m | braking s | run s | stage's worst | all"
        )
        for stage, speed, cand, own, overall in plan.tradeoff:
            if cand is None:
                lines.append(f"  {stage} | {speed:.3g} | infeasible | - | - | - | -")
            else:
                lines.append(
                    f"  {stage} | {speed:.3g} | {cand.braking_torque:.3g} | "
                    f"{cand.braking_time:.1f} | {cand.run_time:.1f} | {own:.3g} | {overall:.3g}"
                )
        lines.append(f"protocol -> {self.path}")
        lines.append(f"trade-off figure -> {self.figure}")
        return "\n".join(lines)

    def to_json(self) -> str:
        """The plan as JSON.

        Returns
        -------
        str
            ``{"stages": [{"stage", "launch_speed" (rad/s), "braking_torque" (N m),
            "release_angle_deg", "previous": {...}, "predicted_std" (kg m^2, per node)}],
            "predicted_std", "predicted_std_ideal", "axis_stage", "duration" (s),
            "max_duration" (s), "rehearsed", "rehearsal_error", "path", "figure"}``.
        """
        stages = [
            {
                "stage": k,
                "launch_speed": speed,
                "braking_torque": torque,
                "release_angle_deg": release,
                "previous": dict(
                    zip(("launch_speed", "braking_torque", "release_angle_deg"), old)
                ),
                "predicted_std": self.predicted_std[self.axis_stage == k],
            }
            for k, (speed, torque, release, old) in enumerate(
                zip(self.launch_speed, self.braking_torque, self.release_angle_deg, self.previous),
                1,
            )
        ]
        return json_text(
            {
                "stages": stages,
                "predicted_std": self.predicted_std,
                "predicted_std_ideal": self.predicted_std_ideal,
                "axis_stage": self.axis_stage,
                "duration": self.duration,
                "max_duration": self.max_duration,
                "rehearsed": self.rehearsed,
                "rehearsal_error": self.rehearsal_error,
                "path": self.path,
                "figure": self.figure,
            }
        )

    def figures(self, folder: str | Path | None = None) -> list[Path]:
        """Draw the trade-off figure ``plan.png`` (plan has already drawn it into EXP).

        Left: the best predicted worst std of J_k within each total duration, the plan and
        device.toml's protocol before; right: per stage, the predicted std against the
        launch speed.

        Parameters
        ----------
        folder : str or pathlib.Path, optional
            Where to write it (created if needed). Default: the experiment folder.

        Returns
        -------
        list of pathlib.Path
            ``[folder / "plan.png"]``.
        """
        return save_figures(self.draw(), self.figure.parent if folder is None else folder)
