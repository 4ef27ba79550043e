"""The result objects of simulate, program, calibrate and check, and what every result shares.

Each result is a frozen dataclass returned by a function of :mod:`rsp_inertia.api`: ``str``
is the text the command prints, ``to_json()`` a JSON document (:func:`json_text`). The
larger results have their own modules: :mod:`rsp_inertia.identify_result` and
:mod:`rsp_inertia.plan_result`. Nothing heavy is imported here (numpy inside the methods).
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar

if TYPE_CHECKING:
    import numpy as np

    from rsp_inertia.checking import CheckReport
    from rsp_inertia.estimation.calibration import Calibration
    from rsp_inertia.estimation.combine import Combination
    from rsp_inertia.pipeline import PassSummary, ProgramSummary

__all__ = [
    "CalibrateResult",
    "CheckResult",
    "CombineResult",
    "ProgramResult",
    "SimulateResult",
    "json_text",
]


class _Records:
    """Iterating, ``len``, indexing and ``str`` of a result over its records (the field
    named by ``_records``), one printed line each."""

    _records: ClassVar[str]

    def __iter__(self) -> Iterator:
        return iter(getattr(self, self._records))

    def __len__(self) -> int:
        return len(getattr(self, self._records))

    def __getitem__(self, index: int):
        return getattr(self, self._records)[index]

    def __str__(self) -> str:
        return "\n".join(str(record) for record in getattr(self, self._records))


def _plain(value: Any) -> Any:
    """``value`` as plain JSON types: arrays and tuples as lists, paths as strings, numpy
    scalars as Python numbers, NaN and infinities as None (JSON has no such numbers)."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, Path):
        return str(value)
    if hasattr(value, "tolist"):  # numpy array or scalar
        return _plain(value.tolist())
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def json_text(document: dict) -> str:
    """The JSON text of a result document: indented, with a final newline (as result.json)."""
    return json.dumps(_plain(document), indent=2) + "\n"


# --- simulate and program -------------------------------------------------------------------


@dataclass(frozen=True)
class SimulateResult(_Records):
    """The logs the virtual device wrote: one summary per pass, in the order written.

    Returned by :func:`rsp_inertia.simulate`. Iterating, ``len`` and indexing go over ``passes``.

    Attributes
    ----------
    passes : tuple of rsp_inertia.pipeline.PassSummary
        One per log written, each with ``stage`` (from 1), ``part`` ('braking', 'reverse',
        'ideal reverse', 'pilot' or 'pendulum at node K'), ``direction``, ``path`` (the CSV
        written), ``rows``, ``duration`` (s), ``turns`` (angle span / 2 pi) and, for a
        braking, ``turns_past_last_node``.
    experiment : pathlib.Path
        The experiment folder.

    Examples
    --------
    >>> passes = rsp_inertia.simulate("bench-A", part="braking")    # doctest: +SKIP
    >>> [p.duration for p in passes]                                 # doctest: +SKIP
    [14.49, 22.09]
    """

    passes: tuple[PassSummary, ...]
    experiment: Path
    _records: ClassVar[str] = "passes"

    def to_json(self) -> str:
        """The passes as JSON.

        Returns
        -------
        str
            ``{"experiment": ..., "passes": [{"stage", "part", "direction", "path", "rows",
            "duration", "turns", "turns_past_last_node"}, ...]}``; durations in s.
        """
        passes = [
            {
                "stage": p.stage,
                "part": p.part,
                "direction": p.direction,
                "path": p.path,
                "rows": p.rows,
                "duration": p.duration,
                "turns": p.turns,
                "turns_past_last_node": p.turns_past_last_node,
            }
            for p in self.passes
        ]
        return json_text({"experiment": self.experiment, "passes": passes})


@dataclass(frozen=True)
class ProgramResult(_Records):
    """The torque programs written, one per run (a stage in one direction).

    Returned by :func:`rsp_inertia.program`. Iterating, ``len`` and indexing go over ``runs``.

    Attributes
    ----------
    runs : tuple of rsp_inertia.pipeline.ProgramSummary
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


# --- calibrate ------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class CalibrateResult:
    """The rig's calibration, as written to ``EXP/calibration.toml``.

    Returned by :func:`rsp_inertia.calibrate`; identify applies the file from then on. The
    values are read back from the file's text, so they are exactly what identify will use.

    Attributes
    ----------
    drive_gains : numpy.ndarray, shape (2,)
        ``[h_d, h_b]``: the torque the body receives per unit of logged torque while the
        motor drives it (eta_d / torque gain) and while the body drives the motor back
        (1 / (eta_b torque gain)); ``[1, 1]`` without a reference experiment.
    drive_gains_std : numpy.ndarray, shape (2,)
        Their standard deviations (0 without a reference experiment: taken as exact).
    round_trip_efficiency, round_trip_efficiency_std : float
        h_d / h_b = eta_d eta_b, the drive's round-trip efficiency, and its std.
    encoder_error : numpy.ndarray, shape (2 orders,)
        rad, ``[c_1, s_1, c_2, s_2, ...]`` of the encoder's reading error
        e(phi) = sum c_n cos(n phi) + s_n sin(n phi).
    encoder_error_std : numpy.ndarray, shape (2 orders,)
        rad.
    reference : bool
        Whether a reference experiment fixed the drive's gains and the encoder's error.
    empty_inertia : numpy.ndarray, shape (stages, 5)
        kg m^2, per stage the empty system's reduced inertia in harmonic form
        ``[M0, Mc2, Ms2, Ms1, Mc1]`` (tare and fixture).
    empty_inertia_std : numpy.ndarray, shape (stages, 5)
        kg m^2.
    fixture_gravity : numpy.ndarray, shape (2,)
        N m, ``[m g x_c, m g y_c]`` of the fixture.
    fixture_gravity_std : numpy.ndarray, shape (2,)
        N m.
    stiffness, stiffness_std : float or None
        N m/rad, the torsion pendulum's stiffness, when both folders have pendulum runs.
    chi2_dof : float
        Residual chi^2 per degree of freedom of the calibration fit.
    warnings : tuple of str
        What the calibration's own checks found.
    path : pathlib.Path
        The calibration.toml written.
    figure : pathlib.Path or None
        The encoder's error curve drawn (``EXP/encoder_error.png``: e(phi) and e'(phi) over a
        turn with their 1-std band), when the calibration has encoder terms.
    calibration : rsp_inertia.estimation.calibration.Calibration
        The full record (the calibrated terms with their covariance, the input files'
        sha256, the model tests).

    Examples
    --------
    >>> cal = rsp_inertia.calibrate("bench-A", "empty", "reference")    # doctest: +SKIP
    >>> cal.drive_gains, cal.round_trip_efficiency                      # doctest: +SKIP
    (array([0.94713..., 1.08697...]), 0.87135...)
    """

    drive_gains: np.ndarray
    drive_gains_std: np.ndarray
    round_trip_efficiency: float
    round_trip_efficiency_std: float
    encoder_error: np.ndarray
    encoder_error_std: np.ndarray
    reference: bool
    empty_inertia: np.ndarray
    empty_inertia_std: np.ndarray
    fixture_gravity: np.ndarray
    fixture_gravity_std: np.ndarray
    stiffness: float | None
    stiffness_std: float | None
    chi2_dof: float
    warnings: tuple[str, ...]
    path: Path
    calibration: Calibration = field(repr=False)
    figure: Path | None = None

    @classmethod
    def _from(cls, calibration: Calibration, root: str | Path) -> CalibrateResult:
        import numpy as np

        file = calibration.to_file()
        head, drive, encoder, pendulum = file.calibration, file.drive, file.encoder, file.pendulum

        def interleaved(cos, sin):
            out = np.empty(2 * len(cos))
            out[0::2], out[1::2] = cos, sin
            return out

        return cls(
            drive_gains=np.array([drive.gain_driving, drive.gain_backdriven]),
            drive_gains_std=np.array([drive.gain_driving_std, drive.gain_backdriven_std]),
            round_trip_efficiency=drive.gain_driving / drive.gain_backdriven,
            round_trip_efficiency_std=file.known_terms().round_trip_std(),
            encoder_error=interleaved(encoder.error_cos, encoder.error_sin),
            encoder_error_std=interleaved(encoder.error_cos_std, encoder.error_sin_std),
            reference=head.reference,
            empty_inertia=np.array([s.empty_inertia for s in file.stages]),
            empty_inertia_std=np.array([s.empty_inertia_std for s in file.stages]),
            fixture_gravity=np.array(file.fixture.gravity),
            fixture_gravity_std=np.array(file.fixture.gravity_std),
            stiffness=None if pendulum is None else pendulum.stiffness,
            stiffness_std=None if pendulum is None else pendulum.stiffness_std,
            chi2_dof=head.chi2_dof,
            warnings=tuple(calibration.warnings),
            path=Path(root) / "calibration.toml",
            figure=(
                Path(root) / "encoder_error.png" if calibration.known.orders else None
            ),
            calibration=calibration,
        )

    def __str__(self) -> str:
        lines = [str(self.calibration), f"calibration -> {self.path}"]
        if self.figure is not None:
            lines.append(f"encoder error curve -> {self.figure}")
        return "\n".join(lines)

    def to_json(self) -> str:
        """The calibration as JSON: calibration.toml's tables and keys, plus ``warnings``.

        Returns
        -------
        str
            ``{"calibration": {"device", "counts_per_rev", "reference", "chi2_dof"},
            "drive": {...}, "encoder": {...}, "fixture": {...}, "stage": [...], "pendulum":
            {...} (when calibrated), "covariance": {...}, "inputs": {...}, "warnings": [...]}``
            (NaN written as null).
        """
        from rsp_inertia.plant.toml_writer import document

        doc = document(self.calibration.to_file())
        doc["warnings"] = list(self.calibration.warnings)
        return json_text(doc)


# --- check ----------------------------------------------------------------------------------


@dataclass(frozen=True)
class CheckResult:
    """What an experiment folder has, lacks or looks wrong, one finding per line.

    Returned by :func:`rsp_inertia.check`. Not being ready is a finding, not an error:
    :func:`rsp_inertia.check` raises only when device.toml cannot be read.

    Attributes
    ----------
    ready : bool
        Whether identify has everything it needs (no 'error' and no 'missing' finding).
    findings : tuple of (str, str)
        ``(level, message)`` in the order found; level is 'error', 'missing', 'suspicious'
        or 'ok'.
    experiment : pathlib.Path
        The experiment folder.
    report : rsp_inertia.checking.CheckReport
        The full record.

    Examples
    --------
    >>> status = rsp_inertia.check("bench-A")    # doctest: +SKIP
    >>> status.ready                             # doctest: +SKIP
    False
    """

    ready: bool
    findings: tuple[tuple[str, str], ...]
    experiment: Path
    report: CheckReport = field(repr=False)

    def __str__(self) -> str:
        return str(self.report)

    def to_json(self) -> str:
        """The findings as JSON.

        Returns
        -------
        str
            ``{"experiment": ..., "ready": ..., "findings": [{"level", "message"}, ...]}``.
        """
        findings = [{"level": level, "message": text} for level, text in self.findings]
        return json_text({"experiment": self.experiment, "ready": self.ready, "findings": findings})


# --- combine --------------------------------------------------------------------------------


@dataclass(frozen=True)
class CombineResult:
    """The body's tensor and whole centre of mass in body axes, from several mountings.

    Returned by :func:`rsp_inertia.combine`.

    Attributes
    ----------
    combination : rsp_inertia.estimation.combine.Combination
        The generalised least squares over the mountings: ``entries`` (6,) kg m^2 about the
        body frame's origin, ``com`` (3,) m, their joint ``cov`` (9, 9), the principal
        moments and axes, each mounting's residuals in stds, the consistency test
        (``chi2``, ``dof``, ``p``) and the ``warnings``.
    path : pathlib.Path
        The body.json written (``OUT/body.json``).

    Examples
    --------
    >>> body = rsp_inertia.combine(["bench-A", "bench-A-x90"], "body")    # doctest: +SKIP
    >>> body.combination.com, body.combination.com_std                     # doctest: +SKIP
    """

    combination: Combination
    path: Path

    def __str__(self) -> str:
        return f"{self.combination}\nbody -> {self.path}"

    def to_json(self) -> str:
        """The text of body.json.

        Returns
        -------
        str
            The document of docs/files.md (body.json): ``tensor``, ``tensor_std``, ``com``,
            ``com_std``, ``covariance``, the principal moments and axes, each mounting's
            residuals, ``consistency`` and ``warnings``.
        """
        from rsp_inertia.pipeline import body_json

        return body_json(self.combination)
