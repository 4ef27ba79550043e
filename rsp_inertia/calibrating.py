"""``rsp-inertia calibrate``: the empty fixture's and the reference body's runs in,
``EXP/calibration.toml`` and the encoder's error curve out.

The calibration itself is rsp_inertia.estimation.reading.calibrate_experiment; here its file
is written (atomically), its figure drawn (rsp_inertia.plots.encoder_figures) and its result
object made (:class:`rsp_inertia.results.CalibrateResult`).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from rsp_inertia.estimation.calibration import Calibration
from rsp_inertia.estimation.calibration_file import write_calibration_file
from rsp_inertia.estimation.reading import calibrate_experiment
from rsp_inertia.figure_files import save_figures
from rsp_inertia.infra.files import check_writable
from rsp_inertia.plant.experiment import open_experiment
from rsp_inertia.plots import calibrate_figures, encoder_figures
from rsp_inertia.results import CalibrateResult

__all__ = ["calibrate", "calibrate_result"]


def calibrate(
    root: str | Path,
    empty: str | Path,
    reference: str | Path | None = None,
    progress: Callable[[str], None] | None = None,
) -> Calibration:
    """``rsp-inertia calibrate``: EMPTY's and REF's logs -> EXP/calibration.toml (atomically),
    and the encoder's error curve EXP/encoder_error.png when the calibration has one.

    Nothing is written when an input is bad (stages that differ from EXP's, a missing or
    unphysical reference.toml, bad logs).

    Parameters
    ----------
    root : str or pathlib.Path
        The experiment folder to calibrate (EXP).
    empty : str or pathlib.Path
        The empty fixture's experiment folder.
    reference : str or pathlib.Path, optional
        The reference body's experiment folder, with reference.toml.
    progress : callable, optional
        Called with each progress line (str).

    Returns
    -------
    rsp_inertia.estimation.calibration.Calibration
        The calibrated terms with their covariance, the input files' sha256, the model tests.
    """
    exp = open_experiment(root)
    check_writable(exp.calibration_path)
    result = calibrate_experiment(
        exp,
        open_experiment(empty),
        None if reference is None else open_experiment(reference),
        progress,
    )
    write_calibration_file(exp.calibration_path, result.to_file())
    save_figures(encoder_figures(result), exp.root)
    return result


def calibrate_result(calibration: Calibration, root: str | Path) -> CalibrateResult:
    """The result object of a calibration written into the experiment folder ``root``, with
    the drawing of its figure (rsp_inertia.plots.calibrate_figures)."""
    return CalibrateResult._from(calibration, root, drawer=calibrate_figures)
