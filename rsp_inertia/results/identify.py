"""``identify``'s (and ``demo``'s) result: a view of the library's record
(rsp_inertia.estimation.results.Identification), and the table the command prints."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from rsp_inertia.figure_files import save_figures
from rsp_inertia.infra.frozen import read_only
from rsp_inertia.plant.experiment import RESULT_FILE
from rsp_inertia.plant.geometry import ENTRY_KEYS, principal, relative_errors, tensor_from_entries
from rsp_inertia.provenance import sealed_json
from rsp_inertia.results.common import Drawer, Drawn

if TYPE_CHECKING:
    from rsp_inertia.estimation.decision import Decision
    from rsp_inertia.estimation.records import Record
    from rsp_inertia.estimation.results import AxisResult, Identification

__all__ = ["IdentifyResult", "format_identification"]


@dataclass(frozen=True, eq=False)
class IdentifyResult(Drawn):
    """The identified inertia tensor and centre of mass, with their standard deviations.

    Returned by :func:`rsp_inertia.identify` and :func:`rsp_inertia.demo`. The headline
    estimate is RSP's weighted least squares over all covered turns; the node formula and,
    when pendulum logs are present, the torsion-pendulum baseline are in ``identification``.
    A view of that record: each field below but ``identification``, ``experiment``,
    ``truth`` and ``drawer`` is computed from it when read, every array a new NumPy array in
    SI units.

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
    expanded_uncertainty : dict
        The GUM statement, as result.json's ``expanded_uncertainty`` (docs/files.md): the
        coverage factor ``k`` (``identify(..., coverage_factor=K)``, default 2), its
        ``coverage_probability``, U = k std of every entry (``tensor``) and centre-of-mass
        coordinate (``com``), the principal moments' Monte Carlo intervals and U, the axes'
        tilts and whether each axis is determined, the linearised values beside them.
    axes : tuple of rsp_inertia.estimation.results.AxisResult
        One per node of every stage: ``stage``, ``phi_deg``, the unit ``direction`` (3,),
        and the axial moment ``J`` (least squares), ``J_node`` (node formula), ``J_plain``
        (the paper's formula), each with its ``_std``, in kg m^2.
    condition_number : float
        cond(V) of the node axes' design matrix (1 is ideal; identify warns above 1e3).
    warnings : tuple of str
        What identify found questionable (no calibration, a non-physical tensor, a failed
        model test, an overdue calibration, ...), the same lines as in result.json; not in
        ``str(result)``: the command line prints them on stderr.
    record : rsp_inertia.estimation.records.Record or None
        The record fields (record.toml, the rig's asset id, the calibration's date and due
        date, the reference's certificate): result.json's ``record``.
    decision : rsp_inertia.estimation.decision.Decision or None
        The decision against spec.toml (each limited quantity's verdict and the part's),
        None without a spec.toml: result.json's ``decision``.
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

    identification: Identification = field(repr=False)
    experiment: Path
    truth: np.ndarray | None = field(default=None, repr=False)
    drawer: Drawer | None = field(default=None, repr=False, compare=False)

    @property
    def tensor(self) -> np.ndarray:
        """kg m^2, (3, 3): the inertia tensor of ``entries``."""
        return read_only(tensor_from_entries(self.identification.entries))

    @property
    def tensor_std(self) -> np.ndarray:
        """kg m^2, (3, 3): the standard deviation of each entry of ``tensor``."""
        return read_only(tensor_from_entries(self.identification.entries_std))

    @property
    def entries(self) -> np.ndarray:
        """kg m^2, (6,): ``[Jx, Jy, Jz, Jxy, Jyz, Jxz]``."""
        return self.identification.entries

    @property
    def entries_std(self) -> np.ndarray:
        """kg m^2, (6,): standard deviations of ``entries``."""
        return read_only(self.identification.entries_std)

    @property
    def covariance(self) -> np.ndarray:
        """(8, 8): joint covariance of ``entries`` and the gravity terms."""
        return self.identification.covariance

    @property
    def entries_cov(self) -> np.ndarray:
        """kg^2 m^4, (6, 6): covariance of ``entries``."""
        return read_only(self.identification.entries_cov)

    @property
    def principal_moments(self) -> np.ndarray:
        """kg m^2, (3,), ascending."""
        return read_only(principal(self.identification.entries)[0])

    @property
    def principal_axes(self) -> np.ndarray:
        """(3, 3): unit principal axes, one per row."""
        return read_only(principal(self.identification.entries)[1])

    @property
    def com(self) -> np.ndarray | None:
        """m, ``[x_c, y_c]``, or None without the body's mass."""
        com = self.identification.com
        return None if com is None else read_only(np.asarray(com, dtype=float))

    @property
    def com_std(self) -> np.ndarray | None:
        """m."""
        std = self.identification.com_std
        return None if std is None else read_only(np.asarray(std, dtype=float))

    @property
    def expanded_uncertainty(self) -> dict:
        """The GUM statement, as result.json's ``expanded_uncertainty``."""
        return self.identification.expanded_uncertainty.to_dict()

    @property
    def axes(self) -> tuple[AxisResult, ...]:
        """One per node of every stage."""
        return tuple(self.identification.axes)

    @property
    def condition_number(self) -> float:
        """cond(V) of the node axes' design matrix."""
        return float(self.identification.condition_number)

    @property
    def warnings(self) -> tuple[str, ...]:
        """What identify found questionable, as in result.json."""
        return tuple(self.identification.warnings)

    @property
    def record(self) -> Record | None:
        """The record fields, as result.json's ``record``."""
        return self.identification.record

    @property
    def decision(self) -> Decision | None:
        """The decision against spec.toml, None without one."""
        return self.identification.decision

    @property
    def path(self) -> Path:
        """The result.json written."""
        return self.experiment / RESULT_FILE

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
            ``node_formula``, ``least_squares``, ``warnings``, ``pendulum``, ...), sealed
            with its ``integrity`` (rsp_inertia.provenance.sealed_json).
        """
        return sealed_json(self.identification.to_dict())

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
        calibration applied, the pendulum baseline, the centre of mass and the part's verdict
        against spec.toml, one line each (no final newline); not the warnings
        (``result.warnings``), which the command line prints on stderr.
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
    if result.warming is not None:
        c, c_std = result.warming
        hottest = int(np.argmax(np.abs(result.warming_drift[:, 0])))
        d, d_std = result.warming_drift[hottest]
        stage, direction = result.runs[hottest]
        lines.append(
            f"warming motor: c = {c:.3e} +- {c_std:.1e} /(N^2 m^2); the torque's scale "
            f"{d:+.1e} +- {d_std:.0e} from the braking to the reverse pass in stage {stage} "
            f"{direction}"
        )
    if result.calibration is not None:
        cal = result.calibration
        (h_d, h_b), (s_d, s_b) = cal.drive_gains, cal.drive_gains_std
        encoder = np.asarray(cal.encoder_error)
        amplitude = np.hypot(encoder[0::2], encoder[1::2])
        lines.append(
            f"calibration applied: drive gains h_d {h_d:.6f} +- {s_d:.1e}, h_b {h_b:.6f} +- "
            f"{s_b:.1e} (round-trip efficiency {cal.round_trip_efficiency:.5f}), "
            "empty-system M0 per stage "
            + ", ".join(f"{row[0]:.6f}" for row in cal.empty_inertia)
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
    lines += result.expanded_uncertainty.lines()
    if result.decision is not None:
        lines.append(str(result.decision))
    # The warnings are not in the table: the command line prints them on stderr.
    return "\n".join(lines)
