"""``program``'s result: one per torque program written, each holding the library's record
(rsp_inertia.ocp.program.TorqueProgram)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, ClassVar

from rsp_inertia.plant.direction import Direction
from rsp_inertia.results.common import Records, json_text

if TYPE_CHECKING:
    from rsp_inertia.ocp.program import TorqueProgram

__all__ = ["ProgramResult", "ProgramSummary"]


@dataclass(frozen=True)
class ProgramSummary:
    """What ``program`` wrote for one run (a stage in one direction): a record of
    :class:`ProgramResult`."""

    stage: int
    """Stage number, from 1."""
    direction: Direction
    """The run's direction."""
    path: Path
    """The program.csv written."""
    details: TorqueProgram
    """How it was made: the program's arrays, the mirror, the nominal model, the OCP's
    solution, the smoothed braking, the wall time (rsp_inertia.ocp.program.TorqueProgram)."""

    def __str__(self) -> str:
        prog = self.details.program
        label = "" if self.direction is Direction.FORWARD else f" {self.direction}"
        return (
            f"stage {self.stage}{label}: program: {len(prog.t)} rows over {prog.t[-1]:.2f} s, "
            f"peak torque {abs(prog.torque_ff).max():.3f} N m, k_phi "
            f"{prog.k_phi.mean():.3g} N m/rad, k_omega {prog.k_omega.mean():.3g} "
            f"N m s/rad, OCP {self.details.ocp.iterations} iterations; "
            f"{self.details.seconds:.2f} s -> {self.path}"
            + "".join(f"\nwarning: {w}" for w in self.details.warnings)
        )


@dataclass(frozen=True)
class ProgramResult(Records):
    """The torque programs written, one per run (a stage in one direction).

    Returned by :func:`rsp_inertia.program`. Iterating, ``len`` and indexing go over ``runs``.

    Attributes
    ----------
    runs : tuple of ProgramSummary
        One per program.csv written, each with ``stage``, ``direction``, ``path`` and
        ``details`` (rsp_inertia.ocp.program.TorqueProgram: ``program``, the arrays of
        program.csv, ``t`` s, ``phi_ref`` rad, ``omega_ref`` rad/s, ``torque_ff`` N m,
        ``k_phi`` N m/rad, ``k_omega`` N m s/rad; the ``mirror``, the ``nominal`` model, the
        ``ocp`` solution, the ``smoothed`` braking and the wall time ``seconds``).
    experiment : pathlib.Path
        The experiment folder.

    Examples
    --------
    >>> programs = rsp_inertia.program("bench-A", stage=2)    # doctest: +SKIP
    >>> programs[0].details.program.torque_ff.max()           # doctest: +SKIP
    """

    runs: tuple[ProgramSummary, ...]
    experiment: Path
    _records: ClassVar[str] = "runs"

    def to_json(self) -> str:
        """The programs' summaries as JSON (not their arrays: those are in program.csv).

        Returns
        -------
        str
            ``{"experiment": ..., "programs": [{"stage", "direction", "path", "rows",
            "duration" (s), "peak_torque" (N m), "k_phi" (mean, N m/rad), "k_omega" (mean,
            N m s/rad), "ocp_iterations", "seconds" (wall time)}, ...]}``.
        """
        programs = []
        for run in self.runs:
            prog = run.details.program
            programs.append(
                {
                    "stage": run.stage,
                    "direction": run.direction,
                    "path": run.path,
                    "rows": len(prog.t),
                    "duration": prog.t[-1],
                    "peak_torque": abs(prog.torque_ff).max(),
                    "k_phi": prog.k_phi.mean(),
                    "k_omega": prog.k_omega.mean(),
                    "ocp_iterations": run.details.ocp.iterations,
                    "seconds": run.details.seconds,
                }
            )
        return json_text({"experiment": self.experiment, "programs": programs})
