"""The result of every command: one class per command, in this module.

Each result is a frozen dataclass returned by :mod:`rsp_inertia.api` (``design``'s by the
command line): ``str`` is the text the command prints, ``to_json()`` a JSON document
(:func:`json_text`), and, where the command draws, ``draw()`` its figures as (file name,
matplotlib Figure) pairs and ``figures(folder)`` the same written as PNG files.

==================  ===========================  ================================
command             result                       records inside it
==================  ===========================  ================================
simulate            :class:`SimulateResult`      :class:`PassSummary`, one per log
program             :class:`ProgramResult`       :class:`ProgramSummary`, one per run
calibrate           :class:`CalibrateResult`
identify, demo      :class:`IdentifyResult`
plan                :class:`PlanResult`
check               :class:`CheckResult`
combine             :class:`CombineResult`
design              :class:`DesignResult`
==================  ===========================  ================================

This module formats; the commands compute (:mod:`rsp_inertia.identifying`,
:mod:`rsp_inertia.planning`, ...). It imports numpy and the light modules of the device
(plant.geometry, plant.toml_writer), never the estimation stack, CasADi or matplotlib: every
command builds its result from here, and ``check`` or ``combine`` must not pay for what they
do not use. So a result does not draw by itself: the command that makes it hands it the
function of :mod:`rsp_inertia.plots` that draws its figures (``drawer``; for
:func:`rsp_inertia.identify`, one that imports matplotlib on first use).
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from rsp_inertia.figure_files import save_figures
from rsp_inertia.infra.toml_writer import document
from rsp_inertia.plant.experiment import CALIBRATION_FILE, ENCODER_FIGURE, RESULT_FILE
from rsp_inertia.plant.geometry import (
    ENTRY_KEYS,
    AxisDesign,
    principal,
    relative_errors,
    tensor_from_entries,
)

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from rsp_inertia.design.candidates import StageModel
    from rsp_inertia.design.plan import Plan
    from rsp_inertia.design.rehearsal import Rehearsal
    from rsp_inertia.estimation.calibration import Calibration
    from rsp_inertia.estimation.combine import Combination
    from rsp_inertia.estimation.results import AxisResult, Identification
    from rsp_inertia.ocp.program import TorqueProgram

__all__ = [
    "LEVELS",
    "CalibrateResult",
    "CheckResult",
    "CombineResult",
    "DesignResult",
    "Drawer",
    "IdentifyResult",
    "PassSummary",
    "PlanResult",
    "ProgramResult",
    "ProgramSummary",
    "SimulateResult",
    "body_json",
    "design_report",
    "format_identification",
    "json_text",
    "mounting_report",
    "result_json",
]

Drawer = Callable[[Any], "list[tuple[str, Figure]]"]
"""What draws a result's figures: called with the result, returns (file name, Figure) pairs
(the functions ``*_figures`` of :mod:`rsp_inertia.plots`)."""

LEVELS = ("error", "missing", "suspicious", "ok")
"""The levels of check's findings, worst first."""


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


class _Drawn:
    """``draw()`` of a result with figures: its ``drawer``, which its command handed it."""

    drawer: Drawer | None

    def draw(self) -> list[tuple[str, Figure]]:
        """The command's figures, drawn and not written.

        Returns
        -------
        list of (str, matplotlib.figure.Figure)
            Each figure with the file name the command gives it.

        Raises
        ------
        TypeError
            The result was made without its drawer (not by its command or the API).
        """
        if self.drawer is None:
            raise TypeError(
                f"this {type(self).__name__} was made without its drawer: make it through "
                "rsp_inertia's API, whose functions hand it rsp_inertia.plots' drawing"
            )
        return self.drawer(self)


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


def result_json(result: Identification) -> str:
    """The text of EXP/result.json: ``result.to_json()`` indented, with a final newline."""
    return json.dumps(result.to_json(), indent=2) + "\n"


def body_json(combination: Combination) -> str:
    """The text of OUT/body.json: ``combination.to_json()`` indented, with a final newline."""
    return json.dumps(combination.to_json(), indent=2) + "\n"


# --- simulate and program -------------------------------------------------------------------


@dataclass(frozen=True)
class PassSummary:
    """What one simulated pass produced: a record of :class:`SimulateResult`."""

    stage: int
    """Stage number, from 1."""
    part: str
    """'braking', 'reverse', 'ideal reverse', 'pilot' or 'pendulum at node K'."""
    path: Path
    """The log written."""
    rows: int
    """Rows of the log."""
    duration: float
    """s, the pass's physical duration."""
    turns: float
    """Turns covered by the pass (encoder angle span / 2 pi)."""
    turns_past_last_node: float | None
    """Braking only: turns after the first passage of the stage's last node."""
    direction: str = "forward"
    """Direction of the stage's run, 'forward' or 'backward' (pendulum runs: 'forward')."""

    def __str__(self) -> str:
        part = self.part if self.direction == "forward" else f"{self.part} {self.direction}"
        text = (
            f"stage {self.stage}: {part}: {self.duration:.2f} s, {self.rows} rows, "
            f"{self.turns:.2f} turns"
        )
        if self.turns_past_last_node is not None:
            text += f" ({self.turns_past_last_node:.2f} past the last node)"
        return f"{text} -> {self.path}"


@dataclass(frozen=True)
class SimulateResult(_Records):
    """The logs the virtual device wrote: one summary per pass, in the order written.

    Returned by :func:`rsp_inertia.simulate`. Iterating, ``len`` and indexing go over ``passes``.

    Attributes
    ----------
    passes : tuple of PassSummary
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
class ProgramSummary:
    """What ``program`` wrote for one run (a stage in one direction): a record of
    :class:`ProgramResult`."""

    stage: int
    """Stage number, from 1."""
    direction: str
    """'forward' or 'backward'."""
    path: Path
    """The program.csv written."""
    details: TorqueProgram
    """How it was made: the program's arrays, the mirror, the nominal model, the OCP's
    solution, the smoothed braking, the wall time (rsp_inertia.ocp.program.TorqueProgram)."""

    def __str__(self) -> str:
        prog = self.details.program
        label = "" if self.direction == "forward" else f" {self.direction}"
        return (
            f"stage {self.stage}{label}: program: {len(prog.t)} rows over {prog.t[-1]:.2f} s, "
            f"peak torque {abs(prog.torque_ff).max():.3f} N m, k_phi "
            f"{prog.k_phi.mean():.3g} N m/rad, k_omega {prog.k_omega.mean():.3g} "
            f"N m s/rad, OCP {self.details.ocp.iterations} iterations; "
            f"{self.details.seconds:.2f} s -> {self.path}"
            + "".join(f"\nwarning: {w}" for w in self.details.warnings)
        )


@dataclass(frozen=True)
class ProgramResult(_Records):
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


# --- calibrate ------------------------------------------------------------------------------


def _interleaved(cos, sin) -> np.ndarray:
    """``[c_1, s_1, c_2, s_2, ...]`` from the cosine and sine coefficients."""
    out = np.empty(2 * len(cos))
    out[0::2], out[1::2] = cos, sin
    return out


@dataclass(frozen=True, eq=False)
class CalibrateResult(_Drawn):
    """The rig's calibration, as written to ``EXP/calibration.toml``.

    Returned by :func:`rsp_inertia.calibrate`; identify applies the file from then on. The
    values are the file's (``calibration.to_file()``, what calibrate writes), so they are
    exactly what identify will use.

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
    drawer : callable or None
        What draws the figures (:meth:`draw`): the function of rsp_inertia.plots its command
        handed it; None for a result made without one.

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
    drawer: Drawer | None = field(default=None, repr=False, compare=False)

    @classmethod
    def _from(
        cls, calibration: Calibration, root: str | Path, drawer: Drawer | None = None
    ) -> CalibrateResult:
        """The result of ``calibration``, written into the experiment folder ``root``."""
        root = Path(root)
        file = calibration.to_file()
        head, drive, encoder, pendulum = file.calibration, file.drive, file.encoder, file.pendulum
        return cls(
            drive_gains=np.array([drive.gain_driving, drive.gain_backdriven]),
            drive_gains_std=np.array([drive.gain_driving_std, drive.gain_backdriven_std]),
            round_trip_efficiency=drive.gain_driving / drive.gain_backdriven,
            round_trip_efficiency_std=file.known_terms().round_trip_std(),
            encoder_error=_interleaved(encoder.error_cos, encoder.error_sin),
            encoder_error_std=_interleaved(encoder.error_cos_std, encoder.error_sin_std),
            reference=head.reference,
            empty_inertia=np.array([s.empty_inertia for s in file.stages]),
            empty_inertia_std=np.array([s.empty_inertia_std for s in file.stages]),
            fixture_gravity=np.array(file.fixture.gravity),
            fixture_gravity_std=np.array(file.fixture.gravity_std),
            stiffness=None if pendulum is None else pendulum.stiffness,
            stiffness_std=None if pendulum is None else pendulum.stiffness_std,
            chi2_dof=head.chi2_dof,
            warnings=tuple(calibration.warnings),
            path=root / CALIBRATION_FILE,
            figure=root / ENCODER_FIGURE if calibration.known.orders else None,
            calibration=calibration,
            drawer=drawer,
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
        doc = document(self.calibration.to_file())
        doc["warnings"] = list(self.calibration.warnings)
        return json_text(doc)

    def figures(self, folder: str | Path | None = None) -> list[Path]:
        """Draw the encoder's error curve ``encoder_error.png`` (calibrate has drawn it into
        EXP already), when the calibration has encoder terms.

        Parameters
        ----------
        folder : str or pathlib.Path, optional
            Where to write it (created if needed). Default: the experiment folder.

        Returns
        -------
        list of pathlib.Path
            ``[folder / "encoder_error.png"]``, or ``[]`` without encoder terms.
        """
        return save_figures(self.draw(), self.path.parent if folder is None else folder)


# --- identify -------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class IdentifyResult(_Drawn):
    """The identified inertia tensor and centre of mass, with their standard deviations.

    Returned by :func:`rsp_inertia.identify` and :func:`rsp_inertia.demo`. The headline
    estimate is RSP's weighted least squares over all covered turns; the node formula and,
    when pendulum logs are present, the torsion-pendulum baseline are in ``identification``.
    Every array is a new NumPy array in SI units.

    Attributes
    ----------
    tensor : numpy.ndarray, shape (3, 3)
        kg m^2, the inertia tensor in the body frame (symmetric; off-diagonal entries are
        the tensor's, Jxy = -integral of x y dm).
    tensor_std : numpy.ndarray, shape (3, 3)
        kg m^2, standard deviation of each entry of ``tensor``.
    entries : numpy.ndarray, shape (6,)
        kg m^2, ``[Jx, Jy, Jz, Jxy, Jyz, Jxz]``, the six independent entries of ``tensor``.
    covariance : numpy.ndarray, shape (8, 8)
        Joint covariance of ``entries`` and the gravity terms [m g x_c, m g y_c] (kg^2 m^4,
        kg m^2 N m, N^2 m^2), as result.json's ``covariance``: what ``combine`` needs.
    entries_cov : numpy.ndarray, shape (6, 6)
        kg^2 m^4, covariance of ``entries``.
    principal_moments : numpy.ndarray, shape (3,)
        kg m^2, ascending.
    principal_axes : numpy.ndarray, shape (3, 3)
        Unit principal axes in the body frame, one per row, in the order of
        ``principal_moments``.
    com : numpy.ndarray, shape (2,), or None
        m, ``[x_c, y_c]`` of the centre of mass, when device.toml gives ``[body] mass``.
    com_std : numpy.ndarray, shape (2,), or None
        m.
    axes : tuple of rsp_inertia.estimation.results.AxisResult
        One per node of every stage: ``stage``, ``phi_deg``, the unit ``direction`` (3,),
        and the axial moment ``J`` (least squares), ``J_node`` (node formula), ``J_plain``
        (the paper's formula), each with its ``_std``, in kg m^2.
    condition_number : float
        cond(V) of the node axes' design matrix (1 is ideal; identify warns above 1e3).
    warnings : tuple of str
        What identify found questionable (no calibration, a non-physical tensor, a failed
        model test, ...), the same lines as in result.json.
    path : pathlib.Path
        The result.json written (``EXP/result.json``).
    experiment : pathlib.Path
        The experiment folder.
    truth : numpy.ndarray, shape (6,), or None
        kg m^2, the virtual device's true entries, set by :func:`rsp_inertia.demo` only
        (then ``str`` shows the errors against it).
    identification : rsp_inertia.estimation.results.Identification
        Everything identify found (node formula, pendulum baseline, uncertainty budget,
        model tests, friction asymmetry, ...).
    drawer : callable or None
        What draws the figures (:meth:`draw`): the function of rsp_inertia.plots its command
        handed it; None for a result made without one.

    Examples
    --------
    >>> result = rsp_inertia.identify("bench-A")             # doctest: +SKIP
    >>> result.tensor[0, 0], result.tensor_std[0, 0]          # doctest: +SKIP
    (0.02500005..., 1.2e-07)
    >>> print(result)                                         # doctest: +SKIP
    """

    tensor: np.ndarray
    tensor_std: np.ndarray
    entries: np.ndarray
    covariance: np.ndarray = field(repr=False)
    entries_cov: np.ndarray = field(repr=False)
    principal_moments: np.ndarray
    principal_axes: np.ndarray = field(repr=False)
    com: np.ndarray | None
    com_std: np.ndarray | None
    axes: tuple[AxisResult, ...] = field(repr=False)
    condition_number: float
    warnings: tuple[str, ...]
    path: Path
    experiment: Path
    truth: np.ndarray | None = field(repr=False)
    identification: Identification = field(repr=False)
    drawer: Drawer | None = field(default=None, repr=False, compare=False)

    @classmethod
    def _from(
        cls,
        identification: Identification,
        root: str | Path,
        truth: np.ndarray | None = None,
        drawer: Drawer | None = None,
    ) -> IdentifyResult:
        """The result of ``identification``, written into the experiment folder ``root``."""
        result = identification
        moments, vectors = principal(result.entries)
        root = Path(root)
        return cls(
            tensor=tensor_from_entries(result.entries),
            tensor_std=tensor_from_entries(result.entries_std),
            entries=np.array(result.entries, dtype=float),
            covariance=np.array(result.covariance, dtype=float),
            entries_cov=np.array(result.entries_cov, dtype=float),
            principal_moments=np.array(moments),
            principal_axes=np.array(vectors),
            com=None if result.com is None else np.array(result.com, dtype=float),
            com_std=None if result.com_std is None else np.array(result.com_std, dtype=float),
            axes=tuple(result.axes),
            condition_number=float(result.condition_number),
            warnings=tuple(result.warnings),
            path=root / RESULT_FILE,
            experiment=root,
            truth=None if truth is None else np.array(truth, dtype=float),
            identification=result,
            drawer=drawer,
        )

    @property
    def entries_std(self) -> np.ndarray:
        """kg m^2, shape (6,): standard deviations of ``entries``."""
        return np.sqrt(np.diag(self.entries_cov))

    def __str__(self) -> str:
        table = format_identification(self.identification, self.truth)
        return f"{table}\nresult -> {self.path}"

    def to_json(self) -> str:
        """The result as JSON: exactly the text identify writes to ``EXP/result.json``.

        Returns
        -------
        str
            The JSON document (keys ``tensor``, ``tensor_std``, ``principal_moments``,
            ``principal_axes``, ``axes``, ``com``, ``com_std``, ``condition_number``,
            ``node_formula``, ``least_squares``, ``warnings``, ``pendulum``, ...).
        """
        return result_json(self.identification)

    def figures(self, folder: str | Path | None = None) -> list[Path]:
        """Draw the demo's figures of this experiment as PNG files.

        ``design.png`` (conditioning of the axis design, the paper's Fig. 1); per stage
        ``motion_stageN.png`` (braking, reverse and the free motions, Fig. 3) and
        ``tracking_stageN.png`` (the program's reference speed against the smoothed reverse,
        Fig. 4); ``errors.png`` (each method's relative error per axis). The free motions of
        Fig. 3 and the error chart need the virtual device's truth (virtual.toml) and Fig. 4
        a ``stageN/program.csv``: each is drawn only where its inputs exist, so a real rig's
        experiment gets ``design.png``, its motions from the logs and its tracking figures.
        ``draw()`` gives them as matplotlib figures, unwritten.

        Parameters
        ----------
        folder : str or pathlib.Path, optional
            Where to write them (created if needed). Default: the experiment folder, where
            ``rsp-inertia demo`` writes them.

        Returns
        -------
        list of pathlib.Path
            The PNG files written, in the order above.

        Raises
        ------
        InputError
            A log or program that cannot be read (for instance changed since identify).
        """
        return save_figures(self.draw(), self.experiment if folder is None else folder)


def format_identification(result: Identification, truth: np.ndarray | None = None) -> str:
    """The table ``rsp-inertia identify`` prints (``demo``: against the true tensor).

    Parameters
    ----------
    result : rsp_inertia.estimation.results.Identification
        What identify found.
    truth : numpy.ndarray, shape (6,), optional
        kg m^2, the true entries ``[Jx, Jy, Jz, Jxy, Jyz, Jxz]``: with them, the table has
        the truth and each method's error relative to the largest principal moment.

    Returns
    -------
    str
        The entries by least squares and by the node formula with their stds, the axes'
        moments, the least sure axis's uncertainty budget, the friction asymmetry, the
        calibration applied, the pendulum baseline, the centre of mass and the warnings, one
        line each (no final newline).
    """
    lines = []
    head = f"{'':5} {'RSP least squares':>26} {'RSP node formula':>26}"
    if truth is not None:
        head += f" {'truth':>12} {'LS error':>10} {'node error':>10}"
        ls_error = relative_errors(result.entries, truth)
        node_error = relative_errors(result.node_entries, truth)
    lines.append(head)
    node_std = np.sqrt(np.diag(result.node_entries_cov))
    for k, name in enumerate(ENTRY_KEYS):
        row = (
            f"{name:5} {result.entries[k]:14.8f} +- {result.entries_std[k]:8.1e}"
            f" {result.node_entries[k]:14.8f} +- {node_std[k]:8.1e}"
        )
        if truth is not None:
            row += f" {truth[k]:12.8f} {ls_error[k]:+10.1e} {node_error[k]:+10.1e}"
        lines.append(row)
    if truth is not None:
        lines.append("(errors relative to the largest principal moment)")
    lines.append(f"axes (cond(V) = {result.condition_number:.4f}):")
    for a in result.axes:
        lines.append(
            f"  stage {a.stage} node {a.phi_deg:6.1f} deg: J = {a.J:.8f} +- {a.J_std:.1e}"
            f"  node formula {a.J_node:.8f} +- {a.J_node_std:.1e}  plain {a.J_plain:.8f}"
        )
    if result.std_budget:
        worst = int(np.argmax([a.J_std / a.J for a in result.axes]))
        a = result.axes[worst]
        shares = ", ".join(
            f"{source} {part['axes'][worst] / a.J:.1e}"
            for source, part in result.std_budget.items()
        )
        lines.append(
            f"uncertainty budget of the least sure axis (stage {a.stage} node {a.phi_deg:g} deg, "
            f"relative std {a.J_std / a.J:.1e}): {shares}"
        )
    if result.friction_asymmetry is not None:
        for k, (e, std) in enumerate(
            zip(result.friction_asymmetry, result.friction_asymmetry_std), 1
        ):
            if np.all(np.isfinite(e)):
                lines.append(
                    f"stage {k}: friction asymmetry D_backward - D_forward = "
                    f"{e[0]:+.2e} +- {std[0]:.0e} N m {e[1]:+.2e} +- {std[1]:.0e} |W| "
                    f"{e[2]:+.2e} +- {std[2]:.0e} W^2"
                )
    if result.calibration is not None:
        cal = result.calibration
        (h_d, h_b), (s_d, s_b) = cal["drive_gains"], cal["drive_gains_std"]
        encoder = np.asarray(cal["encoder_error"])
        amplitude = np.hypot(encoder[0::2], encoder[1::2])
        lines.append(
            f"calibration applied: drive gains h_d {h_d:.6f} +- {s_d:.1e}, h_b {h_b:.6f} +- "
            f"{s_b:.1e} (round-trip efficiency {cal['round_trip_efficiency']:.5f}), "
            "empty-system M0 per stage "
            + ", ".join(f"{row[0]:.6f}" for row in cal["empty_inertia"])
            + " kg m^2"
            + (
                ", encoder error "
                + ", ".join(
                    f"order {n}: {np.degrees(a) * 3600:.2f} arcsec"
                    for n, a in enumerate(amplitude, 1)
                )
                if amplitude.size
                else ""
            )
        )
    if result.pendulum is not None:
        pend = result.pendulum
        lines.append(
            "torsion-pendulum baseline (classic / damped fit; best practice +- std, about the "
            "axis at the oscillation's equilibrium):"
        )
        for i, r in enumerate(pend.runs):
            best = ""
            if pend.J_best is not None and np.isfinite(pend.J_best[i]):
                best = (
                    f"; {pend.J_best[i]:.8f} +- {pend.J_best_std[i]:.1e} at "
                    f"{np.degrees(pend.phi_best[i]):.2f} deg"
                )
            lines.append(
                f"  stage {r.stage} node {r.node_deg:6.1f} deg: tau = {r.period:.5f} s,"
                f" J = {pend.J_classic[i]:.8f} / {pend.J_damped[i]:.8f}{best}"
            )
        if truth is not None and pend.entries_classic is not None:
            err_c = np.abs(relative_errors(pend.entries_classic, truth)).max()
            err_d = np.abs(relative_errors(pend.entries_damped, truth)).max()
            err_ls = np.abs(ls_error).max()
            best = ""
            if pend.entries_best is not None:
                err_b = np.abs(relative_errors(pend.entries_best, truth)).max()
                best = f", pendulum best practice {err_b:.1e}"
            lines.append(
                f"worst tensor error / largest moment: RSP {err_ls:.1e}, pendulum classic "
                f"{err_c:.1e}, pendulum damped fit {err_d:.1e}{best}"
            )
    if result.com is not None:
        lines.append(
            f"centre of mass: x = {result.com[0] * 1e3:.4f} +- {result.com_std[0] * 1e3:.4f} mm,"
            f" y = {result.com[1] * 1e3:.4f} +- {result.com_std[1] * 1e3:.4f} mm"
        )
    lines += [f"warning: {w}" for w in result.warnings]
    return "\n".join(lines)


# --- plan -----------------------------------------------------------------------------------


def _was(value: float | None) -> str:
    """A key's value before the plan, as the plan prints it."""
    return "not stated" if value is None else format(value, "g")


@dataclass(frozen=True, eq=False)
class PlanResult(_Drawn):
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
    plan: Plan = field(repr=False)
    models: tuple[StageModel, ...] = field(repr=False)
    rehearsal: Rehearsal | None = field(repr=False)
    nominal_moment: tuple[float, ...] = field(repr=False)
    limit_fraction: float = field(repr=False)
    closed_loop_notes: tuple[str | None, ...] = field(repr=False)
    seconds: float = field(repr=False)
    drawer: Drawer | None = field(default=None, repr=False, compare=False)

    @property
    def report(self) -> PlanResult:
        """The result itself, the full record (a separate PlanReport before: kept for the
        scripts that read ``result.report.plan``)."""
        return self

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


# --- check ----------------------------------------------------------------------------------


@dataclass(frozen=True)
class CheckResult:
    """What an experiment folder has, lacks or looks wrong, one finding per line.

    Returned by :func:`rsp_inertia.check` (rsp_inertia.checking.check). Not being ready is a
    finding, not an error: :func:`rsp_inertia.check` raises only when device.toml cannot be
    read.

    Attributes
    ----------
    ready : bool
        Whether identify has everything it needs (no 'error' and no 'missing' finding); for
        a calibration folder, calibrate.
    findings : tuple of (str, str)
        ``(level, message)`` in the order found; level is 'error', 'missing', 'suspicious'
        or 'ok' (:data:`LEVELS`).
    experiment : pathlib.Path
        The experiment folder.
    calibration : bool
        Whether the folder was checked as a calibration folder (the empty fixture's or the
        reference body's runs, which calibrate reads).

    Examples
    --------
    >>> status = rsp_inertia.check("bench-A")    # doctest: +SKIP
    >>> status.ready                             # doctest: +SKIP
    False
    """

    ready: bool
    findings: tuple[tuple[str, str], ...]
    experiment: Path
    calibration: bool = False

    @classmethod
    def _from(
        cls, findings: list[tuple[str, str]], experiment: Path, calibration: bool
    ) -> CheckResult:
        """The result of the findings made on ``experiment``."""
        ready = not any(level in ("error", "missing") for level, _ in findings)
        return cls(ready, tuple(findings), experiment, calibration)

    @property
    def report(self) -> CheckResult:
        """The result itself, the full record (a separate CheckReport before: kept for the
        scripts that read ``result.report``)."""
        return self

    def __str__(self) -> str:
        out = [f"{level}: {message}" for level, message in self.findings]
        counts = {level: sum(1 for lv, _ in self.findings if lv == level) for level in LEVELS}
        verdict = "ready for " + ("calibrate" if self.calibration else "identify")
        if not self.ready:
            verdict = "not " + verdict
        out.append(
            f"{self.experiment}: {verdict} ({counts['error']} error(s), {counts['missing']} "
            f"missing, {counts['suspicious']} suspicious)"
        )
        return "\n".join(out)

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
        return body_json(self.combination)


# --- design ---------------------------------------------------------------------------------


def _axes_table(design: AxisDesign) -> list[str]:
    """One line per axis: stage, lambda, cone opening, node, direction."""
    header = (
        f"  {'axis':>4} {'stage':>5} {'lambda':>9} {'2beta[deg]':>10} {'node[deg]':>9}"
        f" {'ex':>9} {'ey':>9} {'ez':>9}"
    )
    lines = [header]
    for k, (stage, lam, phi, e) in enumerate(
        zip(design.stages, design.gear_ratios, design.phis, design.directions, strict=True),
        start=1,
    ):
        opening = 2.0 * np.degrees(np.arctan(abs(lam)))
        lines.append(
            f"  {k:>4d} {stage:>5d} {lam:>9.4f} {opening:>10.3f} {np.degrees(phi):>9.3f}"
            f" {e[0]:>9.5f} {e[1]:>9.5f} {e[2]:>9.5f}"
        )
    return lines


def _angles_table(angles: np.ndarray) -> list[str]:
    """The angle matrix between the axes (deg) and its off-diagonal min/max/mean."""
    n = angles.shape[0]
    header = "  " + " " * 4 + "".join(f"{j:>8d}" for j in range(1, n + 1))
    lines = ["  Angles between the axes [deg]:", header]
    for i in range(n):
        lines.append(f"  {i + 1:>4d}" + "".join(f"{a:>8.2f}" for a in angles[i]))
    if n > 1:
        off = angles[np.triu_indices(n, k=1)]
        lines.append(
            f"  {off.size} angles off the diagonal: min {off.min():.4f}  max {off.max():.4f}"
            f"  mean {off.mean():.4f} deg"
        )
    return lines


def design_report(designs: list[AxisDesign]) -> str:
    """Human-readable report of axis designs (docs/method.md §5 "Axis designs").

    Parameters
    ----------
    designs : list of AxisDesign
        Designs to describe, in order.

    Returns
    -------
    str
        For each design: its name, a table of its axes (stage, gear ratio lambda, cone
        opening 2 beta = 2 arctan lambda, node angle, unit direction), the matrix of angles
        between the axes with the min/max/mean of the off-diagonal ones, and cond(V) to four
        decimals. Ends with a newline.

    Examples
    --------
    >>> from rsp_inertia.plant.geometry import icosahedron_design
    >>> "cond(V) = 1.5811" in design_report([icosahedron_design()])
    True
    """
    blocks = []
    for design in designs:
        stages = np.unique(design.stages)
        lines = [f"Axis design: {design.name}  ({design.n_axes} axes, {stages.size} stages)"]
        lines += _axes_table(design)
        lines += _angles_table(design.angles_deg)
        lines.append(f"  cond(V) = {design.condition:.4f}   (2-norm, V is {design.n_axes}x6)")
        blocks.append("\n".join(lines))
    return "\n\n".join(blocks) + "\n"


def mounting_report(
    names: list[str], rotations: list[np.ndarray], condition: float, gain: np.ndarray
) -> str:
    """The mountings' part of the design report.

    Parameters
    ----------
    names : list of str
        The mountings' experiment folders.
    rotations : list of numpy.ndarray, shape (3, 3) each
        Each mounting's R, body axes -> rig axes (device.toml ``[mounting] rotation``).
    condition : float
        cond(G) of the set (rsp_inertia.design.mountings.mounting_conditioning; infinite when
        a body direction stays on the shaft in every mounting).
    gain : numpy.ndarray, shape (3,)
        The std of x_c, y_c, z_c over one mounting's std of x_c (infinite: not measured).

    Returns
    -------
    str
        Each mounting's body direction on the shaft (which gravity does not see), the gains
        and cond(G), and what to add when the centre of mass is not determined. Ends with a
        newline.
    """
    lines = [f"Mountings for the centre of mass ({len(names)}):"]
    for name, R in zip(names, rotations):
        R = np.asarray(R, dtype=float)
        shaft = R[2]  # the body direction that lies along the shaft (rig z)
        lines.append(
            f"  {name}: body direction on the shaft (not seen by gravity) "
            f"[{', '.join(f'{c:+.3f}' for c in shaft)}]"
        )
    lines.append(
        "  std of x_c, y_c, z_c over one mounting's std of x_c: "
        + ", ".join("not measured" if not math.isfinite(g) else f"{g:.3f}" for g in gain)
        + (f"; cond(G) = {condition:.4f}" if math.isfinite(condition) else "")
    )
    if not math.isfinite(condition):
        lines.append(
            "  the centre of mass is not determined: add a mounting turned 90 deg about the "
            "rig's x axis (rotation = [[1, 0, 0], [0, 0, -1], [0, 1, 0]] from a body as drawn)"
        )
    return "\n".join(lines) + "\n"


@dataclass(frozen=True, eq=False)
class DesignResult(_Drawn):
    """The conditioning of axis designs: the paper's two, and each experiment's.

    Returned by ``rsp-inertia design`` (rsp_inertia.api.axis_designs).

    Attributes
    ----------
    designs : tuple of rsp_inertia.plant.geometry.AxisDesign
        The icosahedron, the cone + z design at its optimum opening, then each experiment's
        device.toml design, in that order.
    best_opening_deg : float
        deg, the cone opening 2 beta of the cone + z design that minimises cond(V)
        (rsp_inertia.design.mountings.best_cone_opening).
    best_condition : float
        cond(V) there.
    mountings : tuple of str
        The experiment folders whose mountings are reported for the centre of mass (several,
        or one with ``[mounting]``); empty otherwise.
    rotations : tuple of numpy.ndarray, shape (3, 3) each
        Each of those mountings' rotation, body axes -> rig axes (the identity without
        ``[mounting]``).
    mounting_condition : float or None
        cond(G) of the mountings for the centre of mass (infinite when a body direction
        stays on the shaft in every mounting); None without mountings.
    mounting_gain : numpy.ndarray, shape (3,), or None
        The std of x_c, y_c, z_c over one mounting's std of x_c; None without mountings.
    figure : pathlib.Path
        The figure written: 1/cond(V) of the cone + z design against its opening (the
        paper's Fig. 1).
    drawer : callable or None
        What draws the figures (:meth:`draw`): the function of rsp_inertia.plots its command
        handed it; None for a result made without one.

    Examples
    --------
    >>> designs = rsp_inertia.api.axis_designs(["bench-A"])    # doctest: +SKIP
    >>> designs.best_opening_deg, designs.best_condition        # doctest: +SKIP
    (141.967..., 1.48925...)
    """

    designs: tuple[AxisDesign, ...]
    best_opening_deg: float
    best_condition: float
    mountings: tuple[str, ...]
    rotations: tuple[np.ndarray, ...] = field(repr=False)
    mounting_condition: float | None
    mounting_gain: np.ndarray | None
    figure: Path
    drawer: Drawer | None = field(default=None, repr=False, compare=False)

    def __str__(self) -> str:
        mountings = ""
        if self.mountings:
            mountings = "\n" + mounting_report(
                list(self.mountings), list(self.rotations), self.mounting_condition,
                self.mounting_gain,
            )
        return (
            design_report(list(self.designs))
            + mountings
            + f"\ncone + z: cond(V) is least at 2beta = {self.best_opening_deg:.3f} deg, "
            f"cond(V) = {self.best_condition:.4f}"
            + " (paper Fig. 1: 140 deg, 1.4899)"
            + f"\nplot of 1/cond(V) against 2beta -> {self.figure}"
        )

    def to_json(self) -> str:
        """The designs as JSON.

        Returns
        -------
        str
            ``{"designs": [{"name", "condition", "axes": [{"stage", "gear_ratio",
            "node_deg", "direction"}, ...]}, ...], "best_opening_deg", "best_condition",
            "mountings": {"folders", "rotations", "condition", "gain"} or null, "figure"}``
            (infinities written as null).
        """
        designs = [
            {
                "name": d.name,
                "condition": d.condition,
                "axes": [
                    {
                        "stage": stage,
                        "gear_ratio": lam,
                        "node_deg": np.degrees(phi),
                        "direction": e,
                    }
                    for stage, lam, phi, e in zip(d.stages, d.gear_ratios, d.phis, d.directions)
                ],
            }
            for d in self.designs
        ]
        mountings = None
        if self.mountings:
            mountings = {
                "folders": self.mountings,
                "rotations": self.rotations,
                "condition": self.mounting_condition,
                "gain": self.mounting_gain,
            }
        return json_text(
            {
                "designs": designs,
                "best_opening_deg": self.best_opening_deg,
                "best_condition": self.best_condition,
                "mountings": mountings,
                "figure": self.figure,
            }
        )

    def figures(self, folder: str | Path | None = None) -> list[Path]:
        """Draw 1/cond(V) of the cone + z design against its opening (design has written it).

        Parameters
        ----------
        folder : str or pathlib.Path, optional
            Where to write it (created if needed), under the name of ``figure``. Default:
            the folder of ``figure``.

        Returns
        -------
        list of pathlib.Path
            ``[folder / figure.name]``.
        """
        return save_figures(self.draw(), self.figure.parent if folder is None else folder)
