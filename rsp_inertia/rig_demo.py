"""The demo: the whole real-rig workflow on the virtual rig (``rsp-inertia demo``).

:func:`demo` builds the rig experiment and its calibration experiments
(:mod:`rsp_inertia.scenarios`), runs the commands' library functions on them and prints the
identification against the virtual device's true tensor, with its figures
(rsp_inertia.plots.demo_figures, which ``IdentifyResult.figures`` draws too). The module is
not named ``demo``: ``rsp_inertia.demo`` is the API's function.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rsp_inertia.calibrating import calibrate
from rsp_inertia.combining import combine
from rsp_inertia.estimation.results import Identification
from rsp_inertia.figure_files import save_figures
from rsp_inertia.identifying import identify
from rsp_inertia.infra.errors import InputError
from rsp_inertia.infra.files import check_writable, write_atomic
from rsp_inertia.infra.progress import drop, lines_to, say
from rsp_inertia.plant.experiment import (
    BODY_FILE,
    CALIBRATION_FILE,
    RESULT_FILE,
    open_experiment,
)
from rsp_inertia.plant.geometry import relative_errors
from rsp_inertia.plots import demo_figures
from rsp_inertia.programming import program
from rsp_inertia.results.identify import format_identification
from rsp_inertia.scenarios import (
    CALIBRATION_FOLDERS,
    SECOND_MOUNTING,
    create_rig_experiment,
    create_second_mounting,
)
from rsp_inertia.simulating import simulate
from rsp_inertia.virtual.config import experiment_virtual, placed_body

__all__ = ["DEFAULT_EXPERIMENT", "demo"]

DEFAULT_EXPERIMENT = Path("demo-experiment")
"""Where ``rsp-inertia demo`` builds its experiment when no folder is given."""


def demo(path: str | Path = DEFAULT_EXPERIMENT) -> Identification:
    """The command behind :func:`rsp_inertia.api.demo`, documented there; returns the
    calibrated identification's library record (the API adds the truth).

    The rig of :func:`rsp_inertia.scenarios.create_rig_experiment`: for the body and for
    both calibration experiments, every stage's braking passes in both directions, their
    torque programs and the closed-loop reverse passes; the torsion-pendulum runs (in the
    calibration folders too: they give the torsion element's stiffness); an identification
    without calibration (its warnings and error shown); ``calibrate``; the identification,
    printed against the virtual device's true tensor, with figures; then the body mounted
    again, turned 90 deg about x, identified on the calibrated rig, and both mountings
    combined. Its lines go to the progress (rsp_inertia.infra.progress.say); those of the
    identification without calibration, of ``calibrate`` and of the second mounting's
    identification do not.
    """
    _check_writable(Path(path))
    root, empty, reference = create_rig_experiment(path)
    say(f"experiment folder: {root}; calibration runs: {empty}, {reference}")
    for folder in (empty, reference, root):
        simulate(folder, part="braking")
        program(folder)
        simulate(folder, part="reverse")
    for folder in (empty, reference, root):  # calibration folders: the torsion element's runs
        if open_experiment(folder).device.pendulum is not None:
            simulate(folder, part="pendulum")
    exp = open_experiment(root)
    truth = placed_body(exp.device, experiment_virtual(exp))
    exp.calibration_path.unlink(missing_ok=True)
    with lines_to(drop):
        raw = identify(root)
    say(
        "without calibration: worst tensor error / largest moment "
        f"{np.abs(relative_errors(raw.entries, truth.inertia)).max():.1e}, warnings:"
    )
    for warning in raw.warnings:
        say(f"  {warning}")
    say(f"rsp-inertia calibrate {root} --empty {empty} --reference {reference}")
    with lines_to(drop):
        calibration = calibrate(root, empty, reference)
    say(str(calibration))
    for warning in calibration.warnings:
        say(f"warning: {warning}")
    result = identify(root)
    say(format_identification(result, truth.inertia))
    for warning in result.warnings:
        say(f"warning: {warning}")
    figures = save_figures(demo_figures(exp, result), exp.root)
    say(f"figures -> {', '.join(str(p) for p in figures)}")
    if result.com is not None:
        say(f"true centre of mass: x = {truth.com[0] * 1e3:.4f} mm, "
            f"y = {truth.com[1] * 1e3:.4f} mm")
    say(f"result -> {exp.result_path}")
    second = create_second_mounting(root)
    say(f"second mounting: {second}, the body turned 90 deg about x, on the calibrated rig")
    write_atomic(second / CALIBRATION_FILE, exp.calibration_path.read_text())
    simulate(second, part="braking")
    program(second)
    simulate(second, part="reverse")
    with lines_to(drop):
        identify(second)
    combination, body = combine([root, second], root / "body")
    say(str(combination))
    for warning in combination.warnings:
        say(f"warning: {warning}")
    true_body = experiment_virtual(exp).body  # body axes, about the body frame's origin
    say(
        "against the true body: worst tensor error / largest moment "
        f"{np.abs(relative_errors(combination.entries, true_body.inertia)).max():.1e}; centre of "
        "mass error x, y, z "
        + ", ".join(f"{e * 1e3:+.4f}" for e in combination.com - true_body.com) + " mm"
    )
    say(f"body -> {body}")
    return result


def _check_writable(root: Path) -> None:
    """Refuse, before anything is built or computed, a demo folder the demo could not write
    into (read-only, or a file in the place of it or of one of its subfolders): one line
    (InputError), not a traceback minutes into the run."""
    body = root / "body"
    folders = {
        root: RESULT_FILE,
        **{root / "calibration" / name: RESULT_FILE for name in CALIBRATION_FOLDERS},
        root / SECOND_MOUNTING: RESULT_FILE,
        body: BODY_FILE,
    }
    existing = root
    while not existing.exists() and existing != existing.parent:
        existing = existing.parent
    for folder in [existing, *folders]:
        if folder.exists() and not folder.is_dir():
            raise InputError(f"{folder}: is a file, not a folder: the demo writes its "
                             "experiment there; nothing was computed")
    if existing != root:  # the folders will be made in the nearest one that exists
        check_writable(existing / root.name)
    for folder, output in folders.items():
        if folder.is_dir():
            check_writable(folder / output)
