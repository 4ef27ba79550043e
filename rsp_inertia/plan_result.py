"""The result object of plan: the protocol chosen for every stage, and what it predicts."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from rsp_inertia.results import json_text

if TYPE_CHECKING:
    import numpy as np

    from rsp_inertia.planning import PlanReport

__all__ = ["PlanResult"]


@dataclass(frozen=True, eq=False)
class PlanResult:
    """The protocol ``plan`` chose for every stage, and what it predicts.

    Returned by :func:`rsp_inertia.plan`. The per-stage tuples are in stage order.

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
    report : rsp_inertia.planning.PlanReport
        The full record (the plan with every candidate and the trade-off table, the stage
        models, the rehearsal).

    Examples
    --------
    >>> chosen = rsp_inertia.plan("bench-A", max_duration=100)    # doctest: +SKIP
    >>> chosen.launch_speed, chosen.braking_torque                 # doctest: +SKIP
    ((13.8, 4.32), (0.00462, 0.0823))
    """

    launch_speed: tuple[float, ...]
    braking_torque: tuple[float, ...]
    release_angle_deg: tuple[float, ...]
    previous: tuple[tuple[float | None, float | None, float | None], ...]
    predicted_std: np.ndarray
    predicted_std_ideal: np.ndarray
    axis_stage: np.ndarray
    duration: float
    max_duration: float
    rehearsed: bool
    rehearsal_error: str | None
    path: Path
    figure: Path
    report: PlanReport = field(repr=False)

    @classmethod
    def _from(cls, report: PlanReport) -> PlanResult:
        import numpy as np

        from rsp_inertia.design.plan import planned_release

        chosen = report.plan.chosen
        return cls(
            launch_speed=tuple(float(c.launch_speed) for c in chosen),
            braking_torque=tuple(float(c.braking_torque) for c in chosen),
            release_angle_deg=tuple(
                float(planned_release(report.device.stages[c.stage - 1])) for c in chosen
            ),
            previous=tuple(report.old),
            predicted_std=np.array(report.predicted_std, dtype=float),
            predicted_std_ideal=np.array(report.plan.axis_std, dtype=float),
            axis_stage=np.array(report.plan.axis_stage),
            duration=float(report.plan.duration),
            max_duration=float(report.plan.max_duration),
            rehearsed=report.rehearsal is not None,
            rehearsal_error=report.rehearsal_error,
            path=report.written,
            figure=report.figure,
            report=report,
        )

    def __str__(self) -> str:
        return str(self.report)

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
        from rsp_inertia.planning import PLAN_FIGURE
        from rsp_inertia.plots import plan_figure

        out = self.figure.parent if folder is None else Path(folder)
        out.mkdir(parents=True, exist_ok=True)
        return [plan_figure(self.report.plan, out / PLAN_FIGURE)]
