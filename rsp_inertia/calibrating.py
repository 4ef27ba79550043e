"""``rsp-inertia calibrate``: the empty fixture's and the reference body's runs in,
``EXP/calibration.toml`` and the encoder's error curve out.

The calibration itself is rsp_inertia.estimation.reading.calibrate_experiment; here its file
is written (atomically), its figure drawn (rsp_inertia.plots.encoder_figures) and its result
object made (:class:`rsp_inertia.results.CalibrateResult`).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from rsp_inertia.estimation.calibration import Calibration
from rsp_inertia.estimation.calibration_file import write_calibration_file
from rsp_inertia.estimation.reading import calibrate_experiment
from rsp_inertia.figure_files import save_figures
from rsp_inertia.infra.files import check_writable
from rsp_inertia.plant.experiment import CALIBRATION_FILE, open_experiment
from rsp_inertia.plots import calibrate_figures, encoder_figures
from rsp_inertia.provenance import created_now
from rsp_inertia.results.calibrate import CalibrateResult

__all__ = ["calibrate", "calibrate_result"]


def calibrate(
    path: str | Path,
    empty: str | Path,
    reference: str | Path | None = None,
) -> Calibration:
    """The command behind :func:`rsp_inertia.api.calibrate`, documented there; returns the
    library's record (rsp_inertia.estimation.calibration.Calibration), which
    :func:`calibrate_result` views as the API's CalibrateResult."""
    exp = open_experiment(path)
    check_writable(exp.calibration_path)
    result = calibrate_experiment(
        exp,
        open_experiment(empty),
        None if reference is None else open_experiment(reference),
    )
    # The day it was made, in UTC: with the rig's interval, its due date (identify's record).
    result = replace(result, date=created_now()[:10])
    write_calibration_file(exp.calibration_path, result.to_file())
    save_figures(encoder_figures(result), exp.root)
    return result


def calibrate_result(calibration: Calibration, path: str | Path) -> CalibrateResult:
    """The result object of a calibration written into the experiment folder ``path``, with
    the drawing of its figure (rsp_inertia.plots.calibrate_figures)."""
    return CalibrateResult(calibration, Path(path) / CALIBRATION_FILE, drawer=calibrate_figures)
