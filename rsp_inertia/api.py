"""The Python API of rsp-inertia: the commands as functions, for scripts and notebooks.

Each function does what the command of the same name does (same files read and written,
same checks) and returns a result object instead of printing:

- ``str(result)`` is the text the command prints as its result;
- ``result.to_json()`` is a JSON document of it (for :func:`identify`, the text of
  ``EXP/result.json``);
- ``result.figures(folder)`` draws the command's PNG figures, where it has any;
- the library's full record stays reachable (``result.identification``, ``result.report``,
  ...).

Bad input raises :class:`~rsp_inertia.plant.errors.InputError`, whose message is the line
the command line prints after ``rsp-inertia: error:``. Nothing is printed: what the command
line shows while it works goes to the optional ``progress`` callable, one line (a ``str``)
at a time.

The heavy modules (numpy's stack, CasADi, filterpy, scipy.stats, matplotlib) are imported
inside the functions, so that ``import rsp_inertia`` stays cheap. User documentation:
docs/api.md.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar

from rsp_inertia.plant.errors import InputError

if TYPE_CHECKING:
    import numpy as np

    from rsp_inertia.checking import CheckReport
    from rsp_inertia.estimation.calibration import Calibration
    from rsp_inertia.estimation.results import AxisResult, Identification
    from rsp_inertia.pipeline import PassSummary, ProgramSummary
    from rsp_inertia.planning import PlanReport

__all__ = [
    "CalibrateResult",
    "CheckResult",
    "IdentifyResult",
    "InputError",
    "PlanResult",
    "ProgramResult",
    "SimulateResult",
    "calibrate",
    "check",
    "create_experiment",
    "demo",
    "identify",
    "plan",
    "program",
    "simulate",
    "write_report",
]

Progress = Callable[[str], None]
"""A callable that receives each progress line (str) as the command line would print it."""


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


def _dumps(document: dict) -> str:
    """The JSON text of a result document: indented, with a final newline (as result.json)."""
    return json.dumps(_plain(document), indent=2) + "\n"


def _quiet(progress: Progress | None) -> Progress:
    """The progress callable, or one that drops the lines (a library does not print)."""
    return progress if progress is not None else (lambda _text: None)


# --- identify and demo ----------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class IdentifyResult:
    """The identified inertia tensor and centre of mass, with their standard deviations.

    Returned by :func:`identify` and :func:`demo`. The headline estimate is RSP's weighted
    least squares over all covered turns; the node formula and, when pendulum logs are
    present, the torsion-pendulum baseline are in ``identification``. Every array is a new
    NumPy array in SI units.

    Attributes
    ----------
    tensor : numpy.ndarray, shape (3, 3)
        kg m^2, the inertia tensor in the body frame (symmetric; off-diagonal entries are
        the tensor's, Jxy = -integral of x y dm).
    tensor_std : numpy.ndarray, shape (3, 3)
        kg m^2, standard deviation of each entry of ``tensor``.
    entries : numpy.ndarray, shape (6,)
        kg m^2, ``[Jx, Jy, Jz, Jxy, Jyz, Jxz]``, the six independent entries of ``tensor``.
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
        kg m^2, the virtual device's true entries, set by :func:`demo` only (then ``str``
        shows the errors against it).
    identification : rsp_inertia.estimation.results.Identification
        Everything identify found (node formula, pendulum baseline, uncertainty budget,
        model tests, friction asymmetry, ...).

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

    @classmethod
    def _from(
        cls, identification: Identification, root: str | Path, truth: np.ndarray | None = None
    ) -> IdentifyResult:
        import numpy as np

        from rsp_inertia.estimation.tensor import principal
        from rsp_inertia.plant.geometry import tensor_from_entries

        result = identification
        moments, vectors = principal(result.entries)
        root = Path(root)
        return cls(
            tensor=tensor_from_entries(result.entries),
            tensor_std=tensor_from_entries(result.entries_std),
            entries=np.array(result.entries, dtype=float),
            entries_cov=np.array(result.entries_cov, dtype=float),
            principal_moments=np.array(moments),
            principal_axes=np.array(vectors),
            com=None if result.com is None else np.array(result.com, dtype=float),
            com_std=None if result.com_std is None else np.array(result.com_std, dtype=float),
            axes=tuple(result.axes),
            condition_number=float(result.condition_number),
            warnings=tuple(result.warnings),
            path=root / "result.json",
            experiment=root,
            truth=None if truth is None else np.array(truth, dtype=float),
            identification=result,
        )

    @property
    def entries_std(self) -> np.ndarray:
        """kg m^2, shape (6,): standard deviations of ``entries``."""
        import numpy as np

        return np.sqrt(np.diag(self.entries_cov))

    def __str__(self) -> str:
        from rsp_inertia.pipeline import format_identification

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
        from rsp_inertia.pipeline import result_json

        return result_json(self.identification)

    def figures(self, folder: str | Path | None = None) -> list[Path]:
        """Draw the demo's figures of this experiment as PNG files.

        ``design.png`` (conditioning of the axis design, the paper's Fig. 1); per stage
        ``motion_stageN.png`` (braking, reverse and the free motions, Fig. 3) and
        ``tracking_stageN.png`` (the program's reference speed against the smoothed reverse,
        Fig. 4); ``errors.png`` (each method's relative error per axis). Figures 3 and the
        error chart need the virtual device's truth (virtual.toml) and Fig. 4 a
        ``stageN/program.csv``: each is drawn only where its inputs exist, so a real rig's
        experiment gets ``design.png`` and its tracking figures.

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
        from rsp_inertia.pipeline import demo_figures
        from rsp_inertia.plant.experiment import open_experiment

        return demo_figures(open_experiment(self.experiment), self.identification, folder)


def identify(path: str | Path, *, progress: Progress | None = None) -> IdentifyResult:
    """Identify the inertia tensor and centre of mass (``rsp-inertia identify EXP``).

    Reads ``EXP/device.toml``, every stage's ``braking.csv`` and ``reverse.csv`` (and
    ``calibration.toml`` and the pendulum logs when present) and writes ``EXP/result.json``
    (atomically).

    Parameters
    ----------
    path : str or pathlib.Path
        The experiment folder EXP.
    progress : callable, optional
        Called with each progress line (str) as the command prints it; silent by default.

    Returns
    -------
    IdentifyResult
        The tensor, its standard deviations, the centre of mass, the warnings.

    Raises
    ------
    InputError
        A missing or malformed file, logs that do not overlap, too few turns for a node, a
        braking whose speed reverses, an ill-conditioned axis design, ...

    Examples
    --------
    >>> result = rsp_inertia.identify("bench-A")    # doctest: +SKIP
    >>> print(result.tensor)                         # doctest: +SKIP
    """
    from rsp_inertia.pipeline import identify as run

    return IdentifyResult._from(run(path, progress=_quiet(progress)), path)


def demo(
    path: str | Path = "demo-experiment", *, progress: Progress | None = None
) -> IdentifyResult:
    """The whole real-rig workflow on the virtual rig (``rsp-inertia demo [EXP]``).

    Builds ``EXP``, ``EXP/calibration/empty`` and ``EXP/calibration/reference`` (inputs
    already there are kept), runs every stage of all three both ways (braking, program,
    closed-loop reverse) and the pendulum runs, identifies without calibration, calibrates,
    identifies again and draws the figures. About 3 minutes on 2 cores.

    Parameters
    ----------
    path : str or pathlib.Path, optional
        The experiment folder (default ``demo-experiment``, relative to the working folder).
    progress : callable, optional
        Called with each line the command prints (str); silent by default.

    Returns
    -------
    IdentifyResult
        The calibrated identification, with ``truth`` set to the virtual body's entries:
        ``str(result)`` is the demo's table against the truth.

    Raises
    ------
    InputError
        An edited device.toml or virtual.toml that is not valid.

    Examples
    --------
    >>> result = rsp_inertia.demo("demo-experiment", progress=print)    # doctest: +SKIP
    """
    from rsp_inertia.pipeline import demo as run
    from rsp_inertia.plant.experiment import open_experiment

    result = run(path, progress=_quiet(progress))
    truth = open_experiment(path).load_virtual().body.inertia
    return IdentifyResult._from(result, path, truth)


# --- simulate and program -------------------------------------------------------------------


@dataclass(frozen=True)
class SimulateResult(_Records):
    """The logs the virtual device wrote: one summary per pass, in the order written.

    Returned by :func:`simulate`. Iterating, ``len`` and indexing go over ``passes``.

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
        return _dumps({"experiment": self.experiment, "passes": passes})


def simulate(
    path: str | Path,
    stage: int | None = None,
    part: str = "braking",
    *,
    ideal: bool = False,
    direction: str | None = None,
    progress: Progress | None = None,
) -> SimulateResult:
    """Run the virtual device and write the logs a rig would (``rsp-inertia simulate EXP``).

    Parameters
    ----------
    path : str or pathlib.Path
        The experiment folder, with device.toml and virtual.toml.
    stage : int, optional
        One stage (from 1); every stage by default.
    part : {'braking', 'reverse', 'pendulum', 'pilot'}, optional
        'braking' writes ``stageN/braking.csv``; 'reverse' runs ``stageN/program.csv`` in
        closed loop and writes ``stageN/reverse.csv``; 'pendulum' one torsion-pendulum run
        per node (``stageN/pendulum_kK.csv``); 'pilot' ``stageN/pilot.csv`` (for
        :func:`plan`). Backward runs use the ``_backward`` files.
    ideal : bool, optional
        With ``part='reverse'``: the exact mirror of the braking on an ideal drive (no
        program needed).
    direction : {'forward', 'backward'}, optional
        Braking and reverse: only the runs in this direction; every direction of each
        stage by default.
    progress : callable, optional
        Called with each pass's line (str) as soon as its log is written.

    Returns
    -------
    SimulateResult
        One summary per log written.

    Raises
    ------
    InputError
        A bad ``part`` or ``direction``, ``ideal`` without ``part='reverse'``, no
        virtual.toml, a missing braking or program for the reverse, ...

    Examples
    --------
    >>> rsp_inertia.simulate("bench-A")                              # doctest: +SKIP
    >>> rsp_inertia.simulate("bench-A", part="reverse", ideal=True)  # doctest: +SKIP
    """
    from rsp_inertia.pipeline import simulate as run

    say = _quiet(progress)
    passes = run(
        path, stage, part, ideal=ideal, direction=direction, progress=lambda s: say(str(s))
    )
    return SimulateResult(tuple(passes), Path(path))


@dataclass(frozen=True)
class ProgramResult(_Records):
    """The torque programs written, one per run (a stage in one direction).

    Returned by :func:`program`. Iterating, ``len`` and indexing go over ``runs``.

    Attributes
    ----------
    runs : tuple of rsp_inertia.pipeline.ProgramSummary
        One per program.csv written, each with ``stage``, ``direction``, ``path`` and
        ``details`` (rsp_inertia.ocp.program.ProgramResult: ``program``, the arrays of
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
        return _dumps({"experiment": self.experiment, "programs": programs})


def program(
    path: str | Path, stage: int | None = None, *, progress: Progress | None = None
) -> ProgramResult:
    """Make the reverse pass's torque program from the braking (``rsp-inertia program EXP``).

    Reads ``device.toml`` and ``stageN/braking.csv``; writes ``stageN/program.csv``
    (atomically): reference, feedforward torque and regulator gains at the encoder's rate.

    Parameters
    ----------
    path : str or pathlib.Path
        The experiment folder.
    stage : int, optional
        One stage (from 1); every stage (and each of its directions) by default.
    progress : callable, optional
        Called with each run's line (str) as soon as its program is written.

    Returns
    -------
    ProgramResult
        One summary per program written.

    Raises
    ------
    InputError
        A missing or malformed braking log, or a mirror the motor cannot drive (the message
        says how much torque it needs, and where); nothing is written for that stage.

    Examples
    --------
    >>> print(rsp_inertia.program("bench-A"))    # doctest: +SKIP
    """
    from rsp_inertia.pipeline import program_summaries

    runs = program_summaries(path, stage, progress=_quiet(progress))
    return ProgramResult(tuple(runs), Path(path))


# --- calibrate ------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class CalibrateResult:
    """The rig's calibration, as written to ``EXP/calibration.toml``.

    Returned by :func:`calibrate`; identify applies the file from then on. The values are
    read back from the file's text, so they are exactly what identify will use.

    Attributes
    ----------
    torque_gain : float
        Logged torque / applied torque (1 without a reference experiment).
    torque_gain_std : float
        Its standard deviation (0 without a reference experiment: taken as exact).
    reference : bool
        Whether a reference experiment fixed the torque gain.
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
    calibration : rsp_inertia.estimation.calibration.Calibration
        The full record (the calibrated terms with their covariance, the input files'
        sha256, the model tests).

    Examples
    --------
    >>> cal = rsp_inertia.calibrate("bench-A", "empty", "reference")    # doctest: +SKIP
    >>> cal.torque_gain, cal.torque_gain_std                            # doctest: +SKIP
    (1.002999..., 4.5e-06)
    """

    torque_gain: float
    torque_gain_std: float
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

    @classmethod
    def _from(cls, calibration: Calibration, root: str | Path) -> CalibrateResult:
        import numpy as np

        doc = _calibration_document(calibration)
        head, stages, pendulum = doc["calibration"], doc["stage"], doc.get("pendulum")
        return cls(
            torque_gain=head["torque_gain"],
            torque_gain_std=head["torque_gain_std"],
            reference=head["reference"],
            empty_inertia=np.array([s["empty_inertia"] for s in stages]),
            empty_inertia_std=np.array([s["empty_inertia_std"] for s in stages]),
            fixture_gravity=np.array(doc["fixture"]["gravity"]),
            fixture_gravity_std=np.array(doc["fixture"]["gravity_std"]),
            stiffness=None if pendulum is None else pendulum["stiffness"],
            stiffness_std=None if pendulum is None else pendulum["stiffness_std"],
            chi2_dof=head["chi2_dof"],
            warnings=tuple(calibration.warnings),
            path=Path(root) / "calibration.toml",
            calibration=calibration,
        )

    def __str__(self) -> str:
        return f"{self.calibration}\ncalibration -> {self.path}"

    def to_json(self) -> str:
        """The calibration as JSON: calibration.toml's tables and keys, plus ``warnings``.

        Returns
        -------
        str
            ``{"calibration": {"device", "counts_per_rev", "reference", "torque_gain",
            "torque_gain_std", "chi2_dof"}, "fixture": {...}, "stage": [...], "pendulum":
            {...} (when calibrated), "covariance": {...}, "inputs": {...}, "warnings": [...]}``
            (NaN written as null).
        """
        doc = _calibration_document(self.calibration)
        doc["warnings"] = list(self.calibration.warnings)
        return _dumps(doc)


def _calibration_document(calibration: Calibration) -> dict:
    """calibration.toml's content, parsed from the text calibrate writes (one source)."""
    import tomllib

    return tomllib.loads(calibration.to_toml())


def calibrate(
    path: str | Path,
    empty: str | Path,
    reference: str | Path | None = None,
    *,
    progress: Progress | None = None,
) -> CalibrateResult:
    """Calibrate the rig from empty-fixture and reference-body runs (``rsp-inertia calibrate``).

    Fits the empty system's reduced inertia per stage, the fixture's gravity terms and the
    torque gain (and, from pendulum runs in both folders, the torsion stiffness) in one
    generalised least squares, and writes ``EXP/calibration.toml`` (atomically).

    Parameters
    ----------
    path : str or pathlib.Path
        The experiment folder to calibrate (EXP).
    empty : str or pathlib.Path
        The experiment folder of the empty fixture (same stages as EXP), with its logs.
    reference : str or pathlib.Path, optional
        The experiment folder of the reference body, with ``reference.toml`` (same stages);
        without it the torque gain is taken as 1.
    progress : callable, optional
        Called with each progress line (str); silent by default.

    Returns
    -------
    CalibrateResult
        The torque gain, the empty system's inertia, the fixture's gravity terms, with
        their standard deviations.

    Raises
    ------
    InputError
        Folders whose stages differ from EXP's, a missing or unphysical reference.toml, bad
        logs; nothing is written then.

    Examples
    --------
    >>> rsp_inertia.calibrate("bench-A", "bench-A-empty", "bench-A-ref")    # doctest: +SKIP
    """
    from rsp_inertia.pipeline import calibrate as run

    result = run(path, empty, reference, progress=_quiet(progress))
    return CalibrateResult._from(result, path)


# --- plan -----------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class PlanResult:
    """The protocol ``plan`` chose for every stage, and what it predicts.

    Returned by :func:`plan`. The per-stage tuples are in stage order.

    Attributes
    ----------
    launch_speed : tuple of float
        rad/s, per stage, as written to device.toml.
    braking_torque : tuple of float
        N m, per stage.
    release_angle_deg : tuple of float
        deg, per stage: where the plan assumes the rig releases the body.
    previous : tuple of (float, float, float or None)
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
    previous: tuple[tuple[float, float, float | None], ...]
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

        from rsp_inertia.ocp.plan import planned_release

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
        return _dumps(
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


def plan(
    path: str | Path,
    max_duration: float | None = None,
    *,
    rehearse: bool = True,
    progress: Progress | None = None,
) -> PlanResult:
    """Choose every stage's launch speed and braking torque (``rsp-inertia plan EXP``).

    From each stage's pilot run ``stageN/pilot.csv`` (else the guesses of device.toml's
    ``[plan]`` table), tries launch speeds and braking torques, keeps those within the
    motor's limits and the duration, and chooses the combination with the smallest
    predicted worst std of J_k. Writes them (and the release angle) into
    ``EXP/device.toml`` (atomically, comments kept) and draws ``EXP/plan.png``.

    Parameters
    ----------
    path : str or pathlib.Path
        The experiment folder.
    max_duration : float, optional
        s of motion for the whole experiment (default: device.toml ``[plan] max_duration``,
        else 120).
    rehearse : bool, optional
        Rehearse the chosen plan in closed loop on the nominal model (about 15 s) and
        predict the stds there (default); False: the ideal reverse's prediction only.
    progress : callable, optional
        Called with each progress line (str); silent by default.

    Returns
    -------
    PlanResult
        The protocol chosen per stage and the predicted stds.

    Raises
    ------
    InputError
        ``max_duration`` not > 0, no pilot run and no ``[plan]`` guess, a bad pilot log, or
        a stage that no protocol admits (the message names the binding limit); nothing is
        written then.

    Examples
    --------
    >>> rsp_inertia.plan("bench-A", max_duration=100, rehearse=False)    # doctest: +SKIP
    """
    from rsp_inertia.planning import plan as run

    if max_duration is not None:
        max_duration = float(max_duration)  # as the command line parses it
    report = run(path, max_duration, progress=_quiet(progress), rehearse=rehearse)
    return PlanResult._from(report)


# --- check, report, create_experiment -------------------------------------------------------


@dataclass(frozen=True)
class CheckResult:
    """What an experiment folder has, lacks or looks wrong, one finding per line.

    Returned by :func:`check`. Not being ready is a finding, not an error: :func:`check`
    raises only when device.toml cannot be read.

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
        return _dumps({"experiment": self.experiment, "ready": self.ready, "findings": findings})


def check(path: str | Path) -> CheckResult:
    """Check an experiment folder before a run (``rsp-inertia check EXP``).

    Reads what a rig produces (device.toml, the logs, calibration.toml, reference.toml;
    never virtual.toml), without stopping at the first problem.

    Parameters
    ----------
    path : str or pathlib.Path
        The experiment folder.

    Returns
    -------
    CheckResult
        Every finding, and whether the folder is ready for identify (the command's exit
        status 0 or 1).

    Raises
    ------
    InputError
        The folder or its device.toml is missing or malformed.

    Examples
    --------
    >>> print(rsp_inertia.check("bench-A"))    # doctest: +SKIP
    """
    from rsp_inertia.checking import check as run

    report = run(path)
    return CheckResult(report.ready, tuple(report.lines), report.root, report)


def write_report(path: str | Path) -> Path:
    """Write ``EXP/report.html`` from an identified experiment (``rsp-inertia report EXP``).

    One self-contained file (figures inlined, no network): the tensor, the centre of mass
    and the axial moments with their stds, the uncertainty budget, the warnings, the
    calibration, each stage's protocol, the sha256 of every input file and the package
    versions. (Named ``write_report``, not ``report``: ``rsp_inertia.report`` is the module
    that writes it.)

    Parameters
    ----------
    path : str or pathlib.Path
        The experiment folder, with the result.json of :func:`identify`.

    Returns
    -------
    pathlib.Path
        The report.html written.

    Raises
    ------
    InputError
        No result.json (run identify first), or one that identify did not write.

    Examples
    --------
    >>> rsp_inertia.write_report("bench-A")    # doctest: +SKIP
    PosixPath('bench-A/report.html')
    """
    from rsp_inertia.report import write_report as run

    return run(path)


def create_experiment(path: str | Path) -> Path:
    """Create a virtual experiment: the paper's scenario (what ``rsp-inertia demo`` starts from).

    Writes ``device.toml`` (two stages of three nodes each, a 16-bit encoder at 1 kHz, a
    2 kg body) and ``virtual.toml`` (the true body, friction and noise of the virtual
    device) into ``path``. Files already there are kept, so an edited experiment is never
    overwritten.

    Parameters
    ----------
    path : str or pathlib.Path
        The experiment folder (created if needed).

    Returns
    -------
    pathlib.Path
        The experiment folder.

    Examples
    --------
    >>> exp = rsp_inertia.create_experiment("virtual-bench")    # doctest: +SKIP
    >>> rsp_inertia.simulate(exp)                               # doctest: +SKIP
    """
    from rsp_inertia.pipeline import create_default_experiment

    return create_default_experiment(path)
