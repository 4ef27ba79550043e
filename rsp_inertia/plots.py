"""Figures (PNG, matplotlib Agg): what people would rather look at than read.

Every figure the package draws is drawn here; the numbers come from the library. The
functions ending in ``_figure`` return one matplotlib Figure; those ending in ``_figures``
return (file name, Figure) pairs: a command's figures, which its result's ``draw()`` gives
(rsp_inertia.results: the command hands the result the function that draws them). Files are
written by :mod:`rsp_inertia.figure_files` (atomically: a temporary file in the same folder,
then renamed); ``plot_*`` draw and write in one call.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from numpy.typing import ArrayLike

from rsp_inertia.design.mountings import DEFAULT_OPENINGS_DEG, best_cone_opening
from rsp_inertia.estimation.smoothing import smooth_log
from rsp_inertia.figure_files import figure_png, save_figure
from rsp_inertia.plant.experiment import (
    ENCODER_FIGURE,
    PLAN_FIGURE,
    Experiment,
    open_experiment,
)
from rsp_inertia.plant.geometry import design_matrix, icosahedron_design, rcond_curve
from rsp_inertia.plant.logs import read_device_log, read_program
from rsp_inertia.plant.transducers import error_basis, error_slope_basis
from rsp_inertia.virtual.config import Virtual, experiment_virtual, placed_body
from rsp_inertia.virtual.device import free_motion

if TYPE_CHECKING:
    from rsp_inertia.design.plan import Plan
    from rsp_inertia.estimation.calibration import Calibration
    from rsp_inertia.estimation.known_terms import KnownTerms
    from rsp_inertia.estimation.results import Identification
    from rsp_inertia.results import (
        AxisDesignResult,
        CalibrateResult,
        IdentifyResult,
        PlanResult,
    )

__all__ = [
    "AXIS_DESIGN_FIGURE",
    "ERRORS_FIGURE",
    "axis_design_figures",
    "calibrate_figures",
    "cone_conditioning_figure",
    "demo_figures",
    "difference_figure",
    "encoder_error_figure",
    "encoder_figures",
    "errors_figure",
    "experiment_figures",
    "figure_png",
    "identify_figures",
    "motion_figure",
    "plan_figure",
    "plan_figures",
    "plot_cone_conditioning",
    "plot_errors",
    "plot_motion",
    "plot_tracking",
    "save_figure",
    "tracking_figure",
]

ARCSEC = np.degrees(1.0) * 3600.0
"""Arcseconds per radian."""

AXIS_DESIGN_FIGURE = "design.png"
"""The conditioning of the axis design (the paper's Fig. 1), in the experiment folder."""

ERRORS_FIGURE = "errors.png"
"""Each method's relative error per axis against the virtual device's truth."""


def plot_tracking(
    path: str | os.PathLike,
    t: np.ndarray,
    reference: np.ndarray,
    output: np.ndarray,
    title: str,
) -> None:
    """The reverse run's programmed and measured speeds (:func:`tracking_figure`) written to
    ``path``.

    Parameters
    ----------
    path : str or os.PathLike
        The PNG file; its folder must exist.
    t : numpy.ndarray
        s, reverse-pass time.
    reference, output : numpy.ndarray
        rad/s, the mirrored speed and the speed the body had (or its estimate).
    title : str
        The figure's title.
    """
    save_figure(tracking_figure(t, reference, output, title), path)


def tracking_figure(t: np.ndarray, reference: np.ndarray, output: np.ndarray, title: str) -> Figure:
    """The reverse run as the program asked for it and as the body moved (the paper's
    Fig. 4): the programmed speed (the braking mirrored), the measured speed (the smoothed
    log) and their difference.

    Parameters
    ----------
    t : array
        s, reverse-pass time.
    reference, output : arrays
        rad/s, the mirrored speed and the speed the body had (or its estimate).
    title : str
        The figure's title.

    Returns
    -------
    matplotlib.figure.Figure
        The speeds above, their difference below.
    """
    fig = Figure(figsize=(7.0, 5.0), dpi=120)
    FigureCanvasAgg(fig)
    top, bottom = fig.subplots(2, 1, sharex=True, gridspec_kw={"height_ratios": [2, 1]})
    top.plot(t, reference, color="C0", label="programmed speed (the braking mirrored)")
    top.plot(t, output, color="C1", linestyle="--", label="measured speed (smoothed log)")
    top.set_ylabel("speed [rad/s]")
    top.legend(loc="best", fontsize="small")
    top.grid(True, alpha=0.3)
    top.set_title(title)
    bottom.plot(t, output - reference, color="C3", linewidth=0.6,
                label="measured - programmed")
    bottom.set_xlabel("time from the start of the reverse run [s]")
    bottom.set_ylabel("difference [rad/s]")
    bottom.grid(True, alpha=0.3)
    bottom.legend(loc="best", fontsize="small")
    fig.tight_layout()
    return fig


def plot_motion(
    path: str | os.PathLike,
    braking: tuple[np.ndarray, np.ndarray],
    reverse: tuple[np.ndarray, np.ndarray],
    undamped: tuple[np.ndarray, np.ndarray],
    damped: tuple[np.ndarray, np.ndarray],
    title: str,
) -> None:
    """The symmetric semi-program motion (1) against the free undamped (2) and damped (3)
    motions (the paper's Fig. 3): |speed| against time.

    Parameters
    ----------
    path : str or os.PathLike
        The PNG file; its folder must exist.
    braking, reverse, undamped, damped : tuple of numpy.ndarray
        Each (t, Omega), s and rad/s: the braking from the release, the reverse (its time
        shifted to follow the braking), and the two free motions from the same release with
        the motor off. Every speed is drawn as a magnitude, so that the symmetry shows; a
        free motion that swings back (its speed changes sign) is marked where it turns.
    title : str
        The figure's title.
    """
    save_figure(motion_figure(braking, reverse, undamped, damped, title), path)


def motion_figure(braking, reverse, undamped, damped, title: str) -> Figure:
    """:func:`plot_motion`'s figure, its legend below the axes (inside, it covered the
    curves of a long braking). Every curve is |speed|: a damped free motion that can no
    longer pass over the top swings back, and a triangle on the time axis marks each turn
    (with the speed's sign drawn it fell below the axis and vanished until it swung forward).

    Parameters
    ----------
    braking, reverse : tuple of numpy.ndarray
        Each (t, Omega), s and rad/s, as :func:`plot_motion` takes them.
    undamped, damped : tuple of numpy.ndarray, or None
        The free motions; None for none (a real rig's logs have no free motions: only the
        virtual device can release the body with the motor off in a simulation).
    title : str
        The figure's title.

    Returns
    -------
    matplotlib.figure.Figure
        |speed| against time, the reverse dashed after the braking.
    """
    fig = Figure(figsize=(7.0, 4.8), dpi=120, layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    tb, wb = braking
    tr, wr = reverse
    ax.plot(tb, np.abs(wb), color="C0", label="(1) braking, then reverse (semi-program motion)")
    ax.plot(tb[-1] + tr, np.abs(wr), color="C0", linestyle="--")
    if undamped is not None:
        ax.plot(undamped[0], np.abs(undamped[1]), color="C2", linewidth=0.8,
                label="(2) free undamped motion")
    if damped is not None:
        label = "(3) free damped motion"
        turns = _turning_times(*damped)
        if turns.size:  # the body swings back: its |speed| touches 0 at each turn
            label += " (turns back at \u25bc)"
            ax.plot(turns, np.zeros_like(turns), "v", color="C3", markersize=5, clip_on=False)
        ax.plot(damped[0], np.abs(damped[1]), color="C3", linewidth=0.8, label=label)
    ax.axvline(tb[-1], color="grey", linewidth=0.6, alpha=0.6)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("|speed| [rad/s]")
    ax.set_ylim(bottom=0.0)
    ax.grid(True, alpha=0.3)
    fig.legend(loc="outside lower center", fontsize="small", ncol=2)
    ax.set_title(title)
    return fig


def _turning_times(t: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """s, where the speed changes sign: a free motion that no longer passes over the top turns
    back there (its |speed| touches 0 and rises again)."""
    t, omega = np.asarray(t, float), np.asarray(omega, float)
    k = np.flatnonzero(np.sign(omega[:-1]) * np.sign(omega[1:]) < 0)
    return t[k] - omega[k] * (t[k + 1] - t[k]) / (omega[k + 1] - omega[k])


def plot_errors(
    path: str | os.PathLike, labels: list[str], errors: dict[str, np.ndarray], title: str
) -> None:
    """Bar chart of |relative error| per axis for each method (log scale).

    Parameters
    ----------
    path : str or os.PathLike
        The PNG file; its folder must exist.
    labels : list of str
        One per axis.
    errors : dict of str to numpy.ndarray
        Per method, the relative error of each axis.
    title : str
        The figure's title.
    """
    save_figure(errors_figure(labels, errors, title), path)


def errors_figure(
    labels: list[str],
    errors: dict[str, np.ndarray],
    title: str,
    ylabel: str = "|relative error| of J_k",
) -> Figure:
    """:func:`plot_errors`'s figure, its legend below the axes (inside, it covered the
    tallest bars).

    Parameters
    ----------
    labels : list of str
        One per axis.
    errors : dict of str to numpy.ndarray
        Per method, the relative error (or difference) of each axis; the bars show their
        magnitude on a log scale.
    title : str
        The figure's title.
    ylabel : str, optional
        What the bars are (a real rig has no true values: its report shows each method's
        difference from the least squares).

    Returns
    -------
    matplotlib.figure.Figure
        The bar chart.
    """
    fig = Figure(figsize=(7.5, 4.8), dpi=120, layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    width = 0.8 / max(len(errors), 1)
    x = np.arange(len(labels))
    for i, (method, values) in enumerate(errors.items()):
        ax.bar(x + (i - (len(errors) - 1) / 2) * width, np.abs(values), width, label=method)
    ax.set_yscale("log")
    ax.set_xticks(x, labels, fontsize="small")
    ax.set_ylabel(ylabel)
    ax.grid(True, axis="y", alpha=0.3)
    fig.legend(loc="outside lower center", fontsize="small", ncol=3)
    ax.set_title(title)
    return fig


PLOT_POINTS = 20_000
"""At most this many points per curve of :func:`experiment_figures` (a 10 kHz log of ten
minutes has six million rows; the figure cannot show more than its pixels)."""


def experiment_figures(
    exp: Experiment, virtual: Virtual | None = None
) -> list[tuple[str, Figure]]:
    """The figures an experiment folder's logs allow, as (file name, figure), per stage:

    - ``motion_stageN.png`` (the paper's Fig. 3): the forward run's smoothed braking speed, then
      the reverse's, from the logs; with the free undamped and damped motions from the same
      release when ``virtual`` (the virtual device, rsp_inertia.virtual.config.Virtual) is
      given: a simulation can release the body with the motor off, a rig's logs hold no
      such run, and ``report`` never reads virtual.toml;
    - ``tracking_stageN.png`` (the paper's Fig. 4), when the stage has its ``program.csv``: the
      program's reference speed against the reverse log's smoothed speed.

    A stage without its forward braking and reverse logs is left out.
    """
    device = exp.device
    figures = []
    for st in exp.stages():
        if not (exp.braking_path(st).is_file() and exp.reverse_path(st).is_file()):
            continue
        braking = read_device_log(exp.braking_path(st), device, "braking")
        reverse = read_device_log(exp.reverse_path(st), device, "reverse")
        sb = smooth_log(braking, device.encoder.quantum)
        sr = smooth_log(reverse, device.encoder.quantum)
        every_b = max(1, len(sb.t) // PLOT_POINTS)
        every_r = max(1, len(sr.t) // PLOT_POINTS)
        free = (None, None)
        if virtual is not None:
            duration = float(braking.t[-1] + reverse.t[-1])
            free = tuple(
                free_motion(device, st, virtual, duration, damped=damped)[::2]
                for damped in (False, True)
            )
        figures.append((
            f"motion_stage{st}.png",
            motion_figure(
                (sb.t[::every_b], sb.omega[::every_b]),
                (sr.t[::every_r], sr.omega[::every_r]),
                *free,
                f"Stage {st}: speed braking, then reversing"
                + (", and turning freely" if virtual else ""),
            ),
        ))
        if exp.program_path(st).is_file():
            prog = read_program(exp.program_path(st), device.encoder)
            n = min(len(prog.t), len(sr.t))
            figures.append((
                f"tracking_stage{st}.png",
                tracking_figure(
                    prog.t[:n:every_r],
                    prog.omega_ref[:n:every_r],
                    sr.omega[:n:every_r],
                    f"Stage {st}: reverse run, programmed and measured speed",
                ),
            ))
    return figures


def plan_figure(plan: Plan) -> Figure:
    """``rsp-inertia plan``'s trade-off (``plan.png``): predicted worst std against duration
    and launch speed.

    Left: the best predicted worst std of J_k within each total duration (the plan's front),
    the chosen plan and device.toml's protocol before. Right: per stage, the predicted worst
    std of the stage's own J_k against the launch speed (the best braking torque at each,
    other stages as chosen), the chosen speed starred.
    """
    fig = Figure(figsize=(11, 4.5))
    FigureCanvasAgg(fig)
    left, right = fig.subplots(1, 2)
    front = plan.front
    left.step(front[:, 0], front[:, 1], where="post", label="best within the duration")
    left.plot(plan.duration, plan.worst, "o", color="C3", label="plan")
    if plan.current_std is not None:
        now = sum(c.run_time for c in plan.current)
        left.plot(now, plan.current_std, "s", color="C2", label="device.toml before")
    left.axvline(plan.max_duration, color="0.6", ls="--", lw=1, label="budget")
    left.set_xlabel("experiment's motion time, s")
    left.set_ylabel("predicted worst std of J_k, kg m^2")
    left.set_yscale("log")
    left.legend(fontsize=8)
    left.grid(alpha=0.3)
    stages = sorted({row[0] for row in plan.tradeoff})
    for stage in stages:
        rows = [r for r in plan.tradeoff if r[0] == stage and r[2] is not None]
        if not rows:
            continue
        line = right.plot([r[1] for r in rows], [r[3] for r in rows], "o-", label=f"stage {stage}")
        chosen = plan.chosen[stage - 1]
        own = plan.axis_std[plan.axis_stage == stage].max()
        right.plot(chosen.launch_speed, own, "*", ms=14, color=line[0].get_color())
    right.set_xlabel("launch speed, rad/s")
    right.set_ylabel("predicted worst std of the stage's J_k, kg m^2")
    right.set_yscale("log")
    right.legend(fontsize=8)
    right.grid(alpha=0.3)
    fig.tight_layout()
    return fig


def encoder_error_figure(known: KnownTerms, title: str = "") -> Figure:
    """``rsp-inertia calibrate``'s encoder error curve (``encoder_error.png``): what the
    encoder reads beyond the true angle, e(phi), over a turn, with each order's part; below,
    e'(phi), by which the encoder scales every speed (the kinetic energy by 2 e'); at the
    bottom, the 1-std of both, on their own scales (a band of +- 1 std around the curves
    would be thinner than the line: the calibration states e to a fraction of an arcsecond).
    The legends stand beside the axes, clear of the curves.

    ``known``: the calibrated terms (rsp_inertia.estimation.known_terms.KnownTerms) with encoder
    coefficients theta_e and their covariance.
    """
    orders = known.orders
    phi = np.linspace(0.0, 2.0 * np.pi, 721)
    cov = known.cov[known.encoder_slice, known.encoder_slice]
    fig = Figure(figsize=(9.0, 7.0), dpi=110, layout="constrained")
    FigureCanvasAgg(fig)
    top, middle, bottom = fig.subplots(
        3, 1, sharex=True, gridspec_kw={"height_ratios": [3, 2, 1.6]}
    )
    deg = np.degrees(phi)
    stds = []
    for ax, basis, scale, label, name in (
        (top, error_basis(phi, orders), ARCSEC, "reading error e [arcsec]", "e, all orders"),
        (middle, error_slope_basis(phi, orders), 1e6, "speed scale error e' [ppm]", "e'"),
    ):
        value = basis @ known.encoder * scale
        stds.append(np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", basis, cov, basis), 0.0))
                    * scale)
        ax.plot(deg, value, color="C0", lw=2, label=name)
        if ax is top:
            for n in range(orders):
                part = basis[:, 2 * n : 2 * n + 2] @ known.encoder[2 * n : 2 * n + 2] * scale
                ax.plot(deg, part, lw=1, ls="--", color=f"C{n + 1}", label=f"order {n + 1}")
        ax.axhline(0.0, color="0.5", lw=0.8)
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize="small")
    bottom.plot(deg, stds[0], color="C0", lw=1.5, label="std of e [arcsec]")
    scaled = bottom.twinx()
    scaled.plot(deg, stds[1], color="C1", lw=1.5, ls="--", label="std of e' [ppm]")
    bottom.set_ylim(bottom=0.0)
    scaled.set_ylim(bottom=0.0)
    bottom.set_ylabel("std of e [arcsec]")
    scaled.set_ylabel("std of e' [ppm]")
    bottom.grid(True, alpha=0.3)
    lines = bottom.get_lines() + scaled.get_lines()
    bottom.legend(lines, [line.get_label() for line in lines], loc="upper left",
                  bbox_to_anchor=(1.12, 1.0), fontsize="small")
    bottom.set_xlabel("encoder angle phi [deg]")
    bottom.set_xticks(np.arange(0, 361, 45))
    top.set_title(title or "encoder reading error from the calibration")
    return fig


# --- the commands' figures ------------------------------------------------------------------


def cone_conditioning_figure(
    openings_deg: ArrayLike | None = None, best: tuple[float, float] | None = None
) -> Figure:
    """The paper's Fig. 1: 1/cond(V) of the cone-plus-z design against its opening 2 beta.

    The optimum opening is marked and the icosahedron's 1/cond(V) = sqrt(2/5) is drawn as a
    horizontal reference (docs/method.md §5 "Axis designs").

    Parameters
    ----------
    openings_deg : array_like, optional
        Opening angles 2 beta (deg) of the curve, each in [0, 180). Default
        rsp_inertia.design.mountings.DEFAULT_OPENINGS_DEG (10 to 175 deg in 0.25 deg steps).
    best : (float, float), optional
        The optimum ``(opening_deg, cond)``; default
        :func:`rsp_inertia.design.mountings.best_cone_opening`.

    Returns
    -------
    matplotlib.figure.Figure
        The curve, the optimum and the icosahedron's level.
    """
    openings = DEFAULT_OPENINGS_DEG if openings_deg is None else np.asarray(openings_deg, float)
    rcond = rcond_curve(openings)
    best_deg, best_cond = best_cone_opening() if best is None else best
    ico_rcond = 1.0 / icosahedron_design().condition

    fig = Figure(figsize=(6.4, 4.6), dpi=120, layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    ax.plot(openings, rcond, color="C0", label="five axes on a cone + z axis")
    ax.axhline(
        ico_rcond, color="C2", linestyle="--", label=f"icosahedron (two stages): {ico_rcond:.4f}"
    )
    ax.plot(
        [best_deg],
        [1.0 / best_cond],
        "o",
        color="C3",
        label=f"optimum 2\u03b2 = {best_deg:.2f}\u00b0, cond(V) = {best_cond:.4f}",
    )
    ax.axvline(best_deg, color="C3", linewidth=0.8, alpha=0.5)
    ax.set_xlabel("cone opening angle 2\u03b2 [deg]")
    ax.set_ylabel("1 / cond(V)  (1 at best)")
    ax.set_title("Conditioning of the axis design against the cone's opening")
    ax.set_ylim(bottom=0.0)
    ax.grid(True, alpha=0.3)
    fig.legend(loc="outside lower center", fontsize="small", ncol=2)  # clear of the curve
    return fig


def plot_cone_conditioning(
    path: str | os.PathLike[str], openings_deg: ArrayLike | None = None
) -> None:
    """Write the paper's Fig. 1 (:func:`cone_conditioning_figure`) as a PNG, atomically.

    Parameters
    ----------
    path : str or os.PathLike
        Output PNG file; its folder must exist.
    openings_deg : array_like, optional
        Opening angles 2 beta (deg) of the curve (default: 10 to 175 deg in 0.25 deg steps).
    """
    save_figure(cone_conditioning_figure(openings_deg), Path(path))


def demo_figures(exp: Experiment, result: Identification) -> list[tuple[str, Figure]]:
    """The demo's figures of an identified experiment: design.png (Fig. 1), the figures the
    logs allow (:func:`experiment_figures`: per stage Fig. 3, and Fig. 4 where a program was
    run) and, on a virtual device with its [body], the error chart errors.png against the
    truth.

    Parameters
    ----------
    exp : rsp_inertia.plant.experiment.Experiment
        The experiment folder (its logs, and its virtual.toml when there is one).
    result : rsp_inertia.estimation.results.Identification
        What identify found there.

    Returns
    -------
    list of (str, matplotlib.figure.Figure)
        The figures with their file names, in that order.
    """
    virtual = experiment_virtual(exp) if exp.virtual_path.is_file() else None
    figures = [(AXIS_DESIGN_FIGURE, cone_conditioning_figure())]
    figures += experiment_figures(exp, virtual)
    body = None if virtual is None else placed_body(exp.device, virtual)
    if body is None:  # no truth to compare with
        return figures
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
    figures.append((
        ERRORS_FIGURE,
        errors_figure(labels, errors, "Relative error of each axial moment, per method"),
    ))
    return figures


def identify_figures(result: IdentifyResult) -> list[tuple[str, Figure]]:
    """An identify result's figures: :func:`demo_figures` of its experiment folder."""
    return demo_figures(open_experiment(result.experiment), result.identification)


def encoder_figures(calibration: Calibration) -> list[tuple[str, Figure]]:
    """The figure ``calibrate`` draws: the encoder's error curve (:func:`encoder_error_figure`),
    when the calibration has encoder terms (else none)."""
    if not calibration.known.orders:
        return []
    title = f"{calibration.device_name}: encoder reading error from the calibration"
    k = calibration.known
    zero_std = float(k.std[k.zero_slice][0])
    if zero_std > 0:  # the zero offset, measured and taken off with e: a constant, not drawn
        title += (f"\n(and a zero offset of {np.degrees(k.zero) * 3600:+.1f} +- "
                  f"{np.degrees(zero_std) * 3600:.1f} arcsec, not drawn)")
    return [(ENCODER_FIGURE, encoder_error_figure(k, title))]


def calibrate_figures(result: CalibrateResult) -> list[tuple[str, Figure]]:
    """A calibrate result's figures: :func:`encoder_figures` of its calibration."""
    return encoder_figures(result.calibration)


def plan_figures(result: PlanResult) -> list[tuple[str, Figure]]:
    """A plan result's figure: the trade-off ``plan.png`` (:func:`plan_figure`)."""
    return [(PLAN_FIGURE, plan_figure(result.plan))]


def axis_design_figures(result: AxisDesignResult) -> list[tuple[str, Figure]]:
    """An axis-design result's figure: :func:`cone_conditioning_figure` at its optimum, under
    the name of the file ``design`` wrote."""
    best = (result.best_opening_deg, result.best_condition)
    return [(result.figure.name, cone_conditioning_figure(best=best))]


def difference_figure(result: dict) -> Figure:
    """A real rig's error chart (the report's): each method's axial moments against the
    least squares' (no true values on a rig), beside the least squares' own relative std.

    Parameters
    ----------
    result : dict
        result.json's document (its ``axes``, and ``pendulum`` when present).

    Returns
    -------
    matplotlib.figure.Figure
        :func:`errors_figure` of the differences.
    """
    axes = result["axes"]
    J = np.array([a["J"] for a in axes])
    bars = {
        "least squares' relative std": np.array([a["J_std"] for a in axes]) / J,
        "RSP node formula": np.array([a["J_node"] for a in axes]) / J - 1,
    }
    pendulum = (result.get("pendulum") or {}).get("axes") or []
    if len(pendulum) == len(axes):
        bars["pendulum classic"] = np.array([p["J_classic"] for p in pendulum]) / J - 1
        bars["pendulum damped fit"] = np.array([p["J_damped"] for p in pendulum]) / J - 1
    labels = [f"s{a['stage']} {a['phi_deg']:g} deg" for a in axes]
    return errors_figure(
        labels, bars,
        "Each axial moment's difference from the least squares, per method",
        ylabel="|J_k / J_k(least squares) - 1|",
    )
