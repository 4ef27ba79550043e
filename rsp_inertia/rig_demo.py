"""The demo: the whole real-rig workflow on the virtual rig (``rsp-inertia demo``).

:func:`demo` builds the rig experiment and its calibration experiments, runs the pipeline's
commands on them (:mod:`rsp_inertia.pipeline`) and prints the identification against the
virtual device's true tensor; :func:`demo_figures` draws its figures (also
``IdentifyResult.figures``). The module is not named ``demo``: ``rsp_inertia.demo`` is the
API's function.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from rsp_inertia.identify_result import format_identification
from rsp_inertia.pipeline import (
    calibrate,
    combine,
    create_rig_experiment,
    create_second_mounting,
    identify,
    program,
    simulate,
)
from rsp_inertia.plant.config import placed_body
from rsp_inertia.plant.experiment import Experiment, open_experiment
from rsp_inertia.plant.files import write_atomic

if TYPE_CHECKING:
    from rsp_inertia.estimation.results import Identification

__all__ = ["DEFAULT_EXPERIMENT", "demo", "demo_figures"]

DEFAULT_EXPERIMENT = Path("demo-experiment")
"""Where ``rsp-inertia demo`` builds its experiment when no folder is given."""


def demo_figures(
    exp: Experiment, result: Identification, folder: str | Path | None = None
) -> list[Path]:
    """The demo's PNG figures: design.png (Fig. 1), the figures the logs allow
    (rsp_inertia.plots.experiment_figures: per stage Fig. 3, and Fig. 4 where a program was
    run) and, on a virtual device with its [body], the error chart against the truth.

    Written into ``folder`` (created if needed; default: the experiment folder); returns
    the paths written, in that order.
    """
    # Imported here: only the demo draws, and matplotlib costs the other commands a second.
    from rsp_inertia.design.mountings import plot_cone_conditioning
    from rsp_inertia.plant.geometry import design_matrix
    from rsp_inertia.plots import experiment_figures, plot_errors, save_figure

    out = exp.root if folder is None else Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    virtual = exp.load_virtual() if exp.virtual_path.is_file() else None
    paths = [out / "design.png"]
    plot_cone_conditioning(paths[0])
    for name, figure in experiment_figures(exp, virtual):
        paths.append(out / name)
        save_figure(figure, paths[-1])
    body = None if virtual is None else placed_body(exp.device, virtual)
    if body is None:  # no truth to compare with
        return paths
    # The true moments about the axes (rig axes, as identify's): J_k = V_k . J
    # (docs/method.md §5).
    J_true = design_matrix(np.array([a.direction for a in result.axes])) @ body.inertia
    errors = {
        "RSP least squares": np.array([a.J for a in result.axes]) / J_true - 1,
        "RSP node formula": np.array([a.J_node for a in result.axes]) / J_true - 1,
    }
    if result.pendulum is not None and len(result.pendulum.runs) == len(result.axes):
        errors["pendulum classic"] = result.pendulum.J_classic / J_true - 1
        errors["pendulum damped fit"] = result.pendulum.J_damped / J_true - 1
        pend = result.pendulum
        if pend.J_best is not None:
            # About the axis at each run's equilibrium, where the best practice measures.
            J_best_true = design_matrix(pend.best_axes(exp.device)) @ body.inertia
            errors["pendulum best practice"] = pend.J_best / J_best_true - 1
    labels = [f"s{a.stage} {a.phi_deg:g} deg" for a in result.axes]
    paths.append(out / "errors.png")
    plot_errors(paths[-1], labels, errors, "Relative error of each axial moment, per method")
    return paths


def demo(
    root: str | Path = DEFAULT_EXPERIMENT, progress: Callable[[str], None] | None = None
) -> Identification:
    """``rsp-inertia demo``: the whole real-rig workflow on the virtual device.

    The rig of :func:`rsp_inertia.pipeline.create_rig_experiment`: for the body and for
    both calibration experiments, every stage's braking passes in both directions, their
    torque programs and the closed-loop reverse passes; the torsion-pendulum runs (in the
    calibration folders too: they give the torsion element's stiffness); an identification
    without calibration (its warnings and error shown); ``calibrate``; the identification,
    printed against the virtual device's true tensor, with figures.
    """
    from rsp_inertia.plant.experiment import CALIBRATION_FILE
    from rsp_inertia.plant.geometry import relative_errors

    say = progress or (lambda _text: None)
    root, empty, reference = create_rig_experiment(root)
    say(f"experiment folder: {root}; calibration runs: {empty}, {reference}")
    for folder in (empty, reference, root):
        simulate(folder, part="braking", progress=lambda s: say(str(s)))
        program(folder, progress=say)
        simulate(folder, part="reverse", progress=lambda s: say(str(s)))
    for folder in (empty, reference, root):  # calibration folders: the torsion element's runs
        if open_experiment(folder).device.pendulum is not None:
            simulate(folder, part="pendulum", progress=lambda s: say(str(s)))
    exp = open_experiment(root)
    truth = placed_body(exp.device, exp.load_virtual())
    (root / CALIBRATION_FILE).unlink(missing_ok=True)
    raw = identify(root)
    say(
        "without calibration: worst tensor error / largest moment "
        f"{np.abs(relative_errors(raw.entries, truth.inertia)).max():.1e}, warnings:"
    )
    for warning in raw.warnings:
        say(f"  {warning}")
    say(f"rsp-inertia calibrate {root} --empty {empty} --reference {reference}")
    say(str(calibrate(root, empty, reference)))
    result = identify(root, progress=say)
    say(format_identification(result, truth.inertia))
    say(f"figures -> {', '.join(str(p) for p in demo_figures(exp, result))}")
    if result.com is not None:
        say(f"true centre of mass: x = {truth.com[0] * 1e3:.4f} mm, "
            f"y = {truth.com[1] * 1e3:.4f} mm")
    say(f"result -> {root / 'result.json'}")
    second = create_second_mounting(root)
    say(f"second mounting: {second}, the body turned 90 deg about x, on the calibrated rig")
    write_atomic(second / CALIBRATION_FILE, (root / CALIBRATION_FILE).read_text())
    simulate(second, part="braking", progress=lambda s: say(str(s)))
    program(second, progress=say)
    simulate(second, part="reverse", progress=lambda s: say(str(s)))
    identify(second)
    combination, path = combine([root, second], root / "body")
    say(str(combination))
    body = exp.load_virtual().body  # body axes, about the body frame's origin
    say(
        "against the true body: worst tensor error / largest moment "
        f"{np.abs(relative_errors(combination.entries, body.inertia)).max():.1e}; centre of "
        "mass error x, y, z "
        + ", ".join(f"{e * 1e3:+.4f}" for e in combination.com - body.com) + " mm"
    )
    say(f"body -> {path}")
    return result
